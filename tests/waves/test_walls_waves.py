"""LAMMPS as the referee of rotsound's walls and gravity (issue 59, referee 6(b)): a frictional packing
that LAMMPS settled under gravity between two walls in z, periodic in x and y, read at rest, and
LAMMPS's own standing waves about it against rotsound's exact waves on its matrix with the wall
contacts' blocks.

Committed files (tests/data/dem/README.md; the inputs say how each was made):

- ``lammps_3d_walls.data``, ``.contacts``, ``.walls``: 150 spheres (diameters 0.8 and 1.2, density 1)
  between the walls z = 0 and z = zhi (the data file's z bounds; ``fix wall/gran hooke/history
  zplane``, the particles' law: kn = 1, kt = 2/7, mu = 0.5, no dashpots), gravity 0.002 along -z,
  at rest; the pair contact file (tangential force on patom1) and the wall contact file (id, wall,
  the force on the particle from the wall: ``fix wall/gran ... contacts``);
- ``lammps_3d_walls.l``, ``lammps_3d_walls.t``: LAMMPS's L (v_x) and T (v_z, across the walls)
  standing waves, k = 2 pi / lx along x, amplitude 1e-7 (LAMMPS's units), from the packing at rest
  (its restart, histories included), dt = 1e-4, walls and gravity on: 51 frames every 0.4 over
  t = 20 of every sphere's velocities and angular velocities.

rotsound's reference: X(t) = exp(tJ) X(0) (``references.first_order_flow``: the exact solution the
stressed wave path, ``waves/exponential.py``, is measured against; that path itself is compared
through z_fixed(t)) on its matrix with the files' masses (``mass_rule="density"``: its unit of mass
is the mean mass m0, its time unit sqrt(m0 / kn) = sqrt(m0) of LAMMPS's; d0 = 1 in both), from
LAMMPS's own start (frame 0, which is checked to be 1e-7 sin(k x) in the excited component on
every sphere).  The negative controls: the same packing
without its walls (or without its upper wall) in the matrix misses by far more, and without gravity
(or without the walls) it is not at rest and is refused when read.
"""

import dataclasses
import re

import numpy as np
import pytest
from conftest import REPO, assert_close, wave_frames

from scripts.crosschecks.harness import pooled_c
from solver.contact_law import ContactModel
from solver.errors import InputError
from solver.io import hdf5
from solver.model import dynmat
from solver.packing import mechanics
from solver.references import first_order_flow
from solver.waves import excitation, exponential

DATA = REPO / "tests" / "data" / "dem"
STEM = "lammps_3d_walls"
SAMPLE, FRAMES = 0.4, 51  # lammps_3d_walls_waves.in's dump interval (LAMMPS time) and frames
AMPLITUDE = 1e-7          # its starts' amplitude (LAMMPS's units)
KT = 2 / 7                # kt / kn of lammps_3d_walls.in, particles and walls alike
FRICTION = 0.5
GRAVITY = [0.0, 0.0, -0.002]  # fix gravity 0.002 vector 0 0 -1: force m g with the file's masses
RUNS = {"l": (0, 0), "t": (2, 0)}  # wave file -> (excited component, axis of k): v_x, v_z; k || x
MODES = {"l": "L", "t": "TR"}     # wave file -> rotsound's mode of that run (excitation.RUNS)

# dense exp(tJ) of 900 DOF, the same on every rank: one rank is enough
pytestmark = pytest.mark.serial_only


def upper_wall() -> float:
    """The upper wall's z: the data file's zhi (lammps_3d_walls.in puts the box's bound on it)."""
    return float(re.search(r"^0 (\S+) zlo zhi$", (DATA / f"{STEM}.data").read_text(), re.M).group(1))


def read(walls: bool = True, wall_contacts: bool = True, gravity: bool = True):
    """rotsound's Packing of the committed files, with or without each part of the walls' load."""
    return hdf5.read_packings(
        str(DATA / f"{STEM}.data"), contacts=str(DATA / f"{STEM}.contacts"), contacts_format="lammps-local",
        model=ContactModel(), friction=FRICTION,
        walls=[{"axis": "z", "position": 0.0}, {"axis": "z", "position": upper_wall()}] if walls else None,
        wall_contacts=str(DATA / f"{STEM}.walls") if wall_contacts else None,
        gravity=GRAVITY if gravity else None)[0]


@pytest.fixture(scope="module")
def packing():
    return read()


def lammps_frames(suffix: str, n: int) -> np.ndarray:
    """(S, N, 6): the wave file's velocities and angular velocities, every frame sorted by id 1..N."""
    return wave_frames(DATA / f"{STEM}.{suffix}", n)


def misses(p, suffix: str, comm) -> tuple[float, float]:
    """(trajectory, C): max |v_LAMMPS - v| over the run, spheres and components, over the amplitude,
    and max |C_LAMMPS - C| (C(0) = 1), v = exp(tJ) of rotsound's matrix of ``p`` from LAMMPS's own
    start.  Collective."""
    t0 = np.sqrt(p.masses.mean())  # rotsound's time unit in LAMMPS's
    component, axis = RUNS[suffix]
    k = 2 * np.pi / float(p.box[axis])
    lammps = lammps_frames(suffix, p.n)[:, ~p.rattler] * t0  # rotsound's units (d0 = 1 in both)
    dm = dynmat.assemble(p, ContactModel(KT), comm, mass_rule="density")
    try:
        exact = first_order_flow(dm, lammps[0], SAMPLE / t0, FRAMES)[:, 1]
    finally:
        dm.destroy()
    x = p.positions[~p.rattler]

    def pooled(v):
        return pooled_c([v[:, :, component] @ np.exp(-1j * k * x[:, axis])], SAMPLE)

    return (float(np.abs(lammps - exact).max() / (AMPLITUDE * t0)),
            float(np.abs(pooled(lammps) - pooled(exact)).max()))


def pipeline_z(p, suffix: str, comm) -> np.ndarray:
    """z_fixed (S,) = sum_i v_i,c(t) exp(-i k x_i(0)) of rotsound's own wave run (its start,
    ``excitation.start_velocity``, and its stressed wave path, ``exponential.exponential_all``) at
    LAMMPS's frame times, in LAMMPS's velocity units.  Collective."""
    t0 = np.sqrt(p.masses.mean())
    component, axis = RUNS[suffix]
    run = excitation.runs(MODES[suffix], p.dim).index((component, axis))
    dm = dynmat.assemble(p, ContactModel(KT), comm, mass_rule="density")
    try:
        (series,) = exponential.exponential_all(dm, p.positions, [(MODES[suffix], run, 2 * np.pi / float(p.box[axis]))],
                                                amplitude=AMPLITUDE * t0, times=np.arange(FRAMES) * SAMPLE / t0,
                                                tol=1e-10)
    finally:
        dm.destroy()
    return series.z_fixed / t0


def test_lammps_packing_between_walls_reads_at_rest(packing):
    """The walls' and gravity's positive control: 150 spheres, none a rattler, 415 pair contacts with
    their stored tangential forces and 28 wall contacts (22 on the lower wall, 6 on the upper), at
    rest under the contacts, the walls and m g: largest net force 4.3e-14 and torque 2.3e-14 (a
    numpy sum over the files' forces, LAMMPS's lever R), against weights m g of 5.4e-4 to 1.8e-3."""
    p = packing
    assert p.n == 150 and not p.rattler.any() and p.info["n_stored"] == 415, (p.n, p.rattler.sum(), p.info)
    assert p.info["length_unit"] == pytest.approx(1.0, rel=1e-15), "d0 = 1 in LAMMPS's units"
    assert np.array_equal(p.walls.axis, [2, 2]) and np.array_equal(p.walls.facing, [1.0, -1.0]), p.walls
    assert len(p.wall_contacts) == 28 and np.bincount(p.wall_contacts.wall).tolist() == [22, 6], p.wall_contacts
    net, torque = mechanics.net_load(p)
    assert np.abs(net).max() < 1e-12 and np.abs(torque).max() < 1e-12, (np.abs(net).max(), np.abs(torque).max())


@pytest.mark.parametrize("left_out", [{"gravity": False}, {"wall_contacts": False},
                                      {"walls": False, "wall_contacts": False, "gravity": False}],
                         ids=["gravity", "wall_contacts", "walls"])
def test_lammps_packing_without_its_load_is_not_at_rest(left_out):
    """The negative controls of the rest check, each refused when read: without gravity the walls and
    contacts leave each sphere's weight unbalanced (m g: 5.4e-4 to 1.8e-3 kn d0), without the wall
    contact file the walls' stored tangential forces, without the walls (nor their contacts and
    gravity) the walls' forces."""
    with pytest.raises(InputError, match="not at rest"):
        read(**left_out)


@pytest.mark.parametrize("suffix", sorted(RUNS))
def test_lammps_waves_between_walls(packing, suffix, comm):
    """LAMMPS's L and T waves follow exp(tJ) of rotsound's stressed matrix with the walls' blocks to
    1e-4 of the amplitude over t = 20 (about 26 t0), C(k, t) to 1e-6: measured 1.4e-5 (L) and 1.7e-5
    (T), C 1.1e-7 (the same with the flat wall's blocks built by hand, kn n n^T + kt A^T A with
    A = P [I, R [n]x], on rotsound's pair matrix).  That is LAMMPS's record, not the matrix: its part
    that is not proportional to the amplitude (the residual forces at rest, 4e-14, and the round-off
    of positions of order 5 moved by 1e-11 a step) -- at amplitude 2e-7 the miss is 6e-6 of it, at
    dt = 5e-5 (twice the steps) 3.2e-5.  The matrix without the walls misses by 32 and 29 (C by
    0.15, 0.30; nothing holds the packing up), without the upper wall (6 contacts) by 20 and 5.5
    (C by 0.03, 0.12).  The walls' stored tangential forces add no stiffness (a flat wall's normal
    does not turn): dropping them changes nothing (not asserted).  rotsound's own run of the wave
    (its start: no zero mode is projected out between frictional walls; the MFN of
    ``waves/exponential.py``) gives LAMMPS's z_fixed(t) to 1.6e-7 (L) and 1.8e-7 (T) of |z(0)|."""
    p = packing
    component, axis = RUNS[suffix]
    start = lammps_frames(suffix, p.n)[0]
    given = np.zeros_like(start)
    given[:, component] = np.sin(2 * np.pi / float(p.box[axis]) * p.positions[:, axis])
    # LAMMPS's start is 1e-7 sin(k x) to its dump's ten digits, on every sphere (no mean removed)
    assert_close(start / AMPLITUDE, given, rtol=0.0, atol=1e-9, what="LAMMPS's start / amplitude")
    trajectory, c = misses(p, suffix, comm)
    assert_close(trajectory, 0.0, rtol=0.0, atol=1e-4, what="trajectory / amplitude")
    assert_close(c, 0.0, rtol=0.0, atol=1e-6, what="C(k, t)")
    # rotsound's own run (its start, no zero mode projected out between walls; the MFN path)
    lammps_z = lammps_frames(suffix, p.n)[:, :, component] @ np.exp(-1j * 2 * np.pi / float(p.box[axis])
                                                                    * p.positions[:, axis])
    ours = pipeline_z(p, suffix, comm)
    assert_close(np.abs(ours - lammps_z).max() / np.abs(lammps_z[0]), 0.0, rtol=0.0, atol=1e-6,
                 what="z_fixed(t) of waves/exponential.py against LAMMPS's, over |z(0)|")
    lower = p.wall_contacts.wall == 0
    for wrong in (dataclasses.replace(p, walls=None, wall_contacts=None),
                  dataclasses.replace(p, walls=dataclasses.replace(p.walls, axis=p.walls.axis[:1],
                                                                   position=p.walls.position[:1],
                                                                   facing=p.walls.facing[:1]),
                                      wall_contacts=dataclasses.replace(
                                          p.wall_contacts, particle=p.wall_contacts.particle[lower],
                                          wall=p.wall_contacts.wall[lower], force=p.wall_contacts.force[lower]))):
        missed, _ = misses(wrong, suffix, comm)
        assert missed > 1.0, (len(wrong.walls or ()), missed)


def test_a_scene_on_the_lammps_walls_files_makes_the_same_packing(packing, tmp_path):
    """The same files through a scene's keys (packing.file, contacts, friction, walls, wall_contacts,
    gravity; schema, scene rules, pipeline.make_packings) give the packing read above: the same
    positions, walls, stored pair and wall forces and gravity."""
    from conftest import COMM

    from solver import pipeline
    from solver.io import coerce, scene_rules, schema

    scene = coerce.build(schema.Scene, {
        "packing": {"file": str(DATA / f"{STEM}.data"), "contacts": str(DATA / f"{STEM}.contacts"),
                    "friction": FRICTION, "walls": [{"axis": "z", "position": 0.0}, {"axis": "z", "position": upper_wall()}],
                    "wall_contacts": str(DATA / f"{STEM}.walls"), "gravity": GRAVITY},
        "model": {"rho": KT}, "waves": {"modes": ["L", "TR"], "axes": ["x"], "n": [1], "method": "exponential"}, "output": str(tmp_path / "out.h5")})
    scene_rules.check_scene(scene)
    p, = pipeline.make_packings(scene, COMM)
    assert np.array_equal(p.positions, packing.positions) and np.array_equal(p.gravity, packing.gravity)
    assert np.array_equal(p.walls.position, packing.walls.position) and not p.rattler.any()
    assert np.array_equal(p.wall_contacts.force, packing.wall_contacts.force)
    assert np.array_equal(p.tangential.force, packing.tangential.force)
