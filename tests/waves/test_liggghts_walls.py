"""LIGGGHTS 3.8.0 as a referee of rotsound's walls and gravity (issue 59, "LIGGGHTS where its file
format differs"): a frictional packing that LIGGGHTS settled under gravity between two primitive
walls in z (``fix wall/gran ... primitive type 1 zplane``), periodic in x and y, read at rest, and
LIGGGHTS's own L standing wave about it against rotsound's exact wave on its matrix with the wall
contacts' blocks.

Committed files (tests/data/dem/README.md; ``liggghts_3d_walls.in`` says how each was made):

- ``liggghts_3d_walls.data``, ``.dump`` (the same packing; the dump's ``BOX BOUNDS pp pp ff``),
  ``.contacts`` (``compute pair/gran/local``, as ``liggghts_3d_friction.contacts``) and ``.walls``:
  the wall contacts as a one-frame ``dump custom`` of id, wall index (0 lower, 1 upper) and the
  force on the particle from the wall (``fix wall/gran ... store_force yes``), which
  ``solver/io/wall_files.py`` reads as it is;
- ``liggghts_3d_walls.l``: LIGGGHTS's L wave (v_x, k = 2 pi / lx along x, amplitude 1e-7 on every
  sphere), dt = 1e-4 with contact damping off, walls and gravity on: 51 frames every 0.4 over t = 20.

LIGGGHTS's law: hooke/stiffness kn = 1, kt = 2/7, mu = 0.5, the tangential force acting at
R - xi/2 from the centre, at the particles' contacts and at the walls alike (its surface model's
contact radius ``cr = radi - deltan/2``): rotsound's ``model.lever: contact``, which the walls follow
(``contact_law.wall_arm``).
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
from solver.packing import walls as walling
from solver.references import first_order_flow
from solver.waves import excitation, exponential

DATA = REPO / "tests" / "data" / "dem"
STEM = "liggghts_3d_walls"
SAMPLE, FRAMES = 0.4, 51  # the wave's dump interval (LIGGGHTS time) and frames
AMPLITUDE = 1e-7          # its start's amplitude (LIGGGHTS's units)
KT = 2 / 7                # kt / kn of liggghts_3d_walls.in, particles and walls alike
FRICTION = 0.5
GRAVITY = [0.0, 0.0, -0.002]  # fix gravity 0.002 vector 0 0 -1: force m g with the file's masses
LIGGGHTS = ContactModel(lever="contact")

# dense exp(tJ) of 900 DOF, the same on every rank: one rank is enough
pytestmark = pytest.mark.serial_only


def upper_wall() -> float:
    """The upper wall's z: the data file's zhi (liggghts_3d_walls.in puts the box's bound on it)."""
    return float(re.search(r"^\S+ (\S+) zlo zhi$", (DATA / f"{STEM}.data").read_text(), re.M).group(1))


def read(model=LIGGGHTS, wall_contacts: bool = True, gravity: bool = True, suffix: str = "data",
         walls: bool = True, check_equilibrium: bool = True):
    """rotsound's Packing of the committed files, with or without each part of the walls' load;
    ``walls`` False leaves the walls to the file (a dump's f bounds; none in a data file)."""
    return hdf5.read_packings(
        str(DATA / f"{STEM}.{suffix}"), check_equilibrium=check_equilibrium,
        contacts=str(DATA / f"{STEM}.contacts"), contacts_format="liggghts-local", model=model, friction=FRICTION,
        walls=[{"axis": "z", "position": 0.0}, {"axis": "z", "position": upper_wall()}] if walls else None,
        wall_contacts=str(DATA / f"{STEM}.walls") if wall_contacts else None,
        gravity=GRAVITY if gravity else None)[0]


@pytest.fixture(scope="module")
def packing():
    return read()


def liggghts_frames(n: int) -> np.ndarray:
    """(S, N, 6): the wave file's velocities and angular velocities, every frame sorted by id 1..N."""
    return wave_frames(DATA / f"{STEM}.l", n)


def misses(p, model, comm) -> tuple[float, float]:
    """(trajectory, C): max |v_LIGGGHTS - v| over the run, spheres and components, over the
    amplitude, and max |C_LIGGGHTS - C| (C(0) = 1), v = exp(tJ) of rotsound's matrix of ``p`` under
    ``model`` from LIGGGHTS's own start.  Collective."""
    t0 = np.sqrt(p.masses.mean())  # rotsound's time unit in LIGGGHTS's (kn = 1, d0 = 1 in both)
    k = 2 * np.pi / float(p.box[0])
    lig = liggghts_frames(p.n)[:, ~p.rattler] * t0
    dm = dynmat.assemble(p, model, comm, mass_rule="density")
    try:
        exact = first_order_flow(dm, lig[0], SAMPLE / t0, FRAMES)[:, 1]
    finally:
        dm.destroy()
    x = p.positions[~p.rattler]

    def pooled(v):
        return pooled_c([v[:, :, 0] @ np.exp(-1j * k * x[:, 0])], SAMPLE)

    return (float(np.abs(lig - exact).max() / (AMPLITUDE * t0)), float(np.abs(pooled(lig) - pooled(exact)).max()))


def test_liggghts_packing_between_walls_reads_at_rest(packing):
    """The positive control: 150 spheres, none a rattler, 417 pair contacts with their stored
    tangential forces and 29 wall contacts (19 on the lower wall, 10 on the upper), at rest under
    the contacts, the walls (their tangential forces at LIGGGHTS's lever R - xi/2) and m g."""
    p = packing
    assert p.n == 150 and not p.rattler.any() and p.info["n_stored"] == 417, (p.n, p.rattler.sum(), p.info)
    assert np.array_equal(p.walls.axis, [2, 2]) and np.array_equal(p.walls.facing, [1.0, -1.0]), p.walls
    assert len(p.wall_contacts) == 29 and np.bincount(p.wall_contacts.wall).tolist() == [19, 10], p.wall_contacts
    net, torque = mechanics.net_load(p)
    assert np.abs(net).max() < 1e-12 and np.abs(torque).max() < 1e-12, (np.abs(net).max(), np.abs(torque).max())


@pytest.mark.parametrize("left_out", [{"gravity": False}, {"wall_contacts": False},
                                      {"model": ContactModel(lever="radius")}],
                         ids=["gravity", "wall_contacts", "lever_R"])
def test_liggghts_packing_without_its_load_is_not_at_rest(left_out):
    """The negative controls of the rest check, each refused when read: without gravity (m g:
    5.4e-4 to 1.8e-3 kn d0 per sphere) or without the wall contact file (the walls' stored
    tangential forces), and with LAMMPS's lever R in place of LIGGGHTS's R - xi/2 (at the walls and
    the pairs)."""
    with pytest.raises(InputError, match="not at rest"):
        read(**left_out)


def test_liggghts_walls_turn_at_their_lever(packing):
    """The walls' lever alone: with the pairs' torques at R - xi/2 as before, the walls' stored
    forces turned at R in place of R - xi/2 leave a net torque of 3.1e-4 kn d0 on a sphere touching a
    wall (the rest check's tolerance is 1e-4), against 1.9e-15 at LIGGGHTS's lever."""
    p = packing
    _, torque = mechanics.net_load(p)
    touch, _, at_radius = walling.loads(p.positions, p.diameters, p.walls, p.wall_contacts, "harmonic", ~p.rattler,
                                        "radius")
    _, _, at_contact = walling.loads(p.positions, p.diameters, p.walls, p.wall_contacts, "harmonic", ~p.rattler,
                                     "contact")
    wrong = torque.copy()
    np.add.at(wrong, touch.particle, at_radius - at_contact)
    assert np.abs(torque).max() < 1e-12 and np.abs(wrong).max() > mechanics.EQUILIBRIUM_TOL, np.abs(wrong).max()


def test_the_dump_bounds_read_as_walls_to_six_digits(packing):
    """The dump's BOX BOUNDS pp pp ff imply walls at z = 0 and z = zhi without packing.walls (the
    same particles and stored forces as the data file), but LIGGGHTS 3.8.0 writes a dump's box
    bounds with %g (6.22783 for the data file's 6.2278294014942901): the upper wall is 5.9e-7 off and
    the packing read from the dump rests to 6.0e-7 kn d0 only (within the rest check's 1e-4), not to
    round-off as from the data file with packing.walls."""
    p = read(suffix="dump", walls=False)
    assert np.array_equal(p.walls.axis, [2, 2]) and np.array_equal(p.walls.facing, [1.0, -1.0]), p.walls
    assert p.walls.position[1] == pytest.approx(6.22783 / p.info["length_unit"], rel=1e-15), p.walls
    assert not p.cell.periodic[2] and p.cell.periodic[:2].all()
    assert np.array_equal(p.positions, packing.positions) and len(p.wall_contacts) == len(packing.wall_contacts)
    net, _ = mechanics.net_load(p)
    assert 1e-8 < np.abs(net).max() < mechanics.EQUILIBRIUM_TOL, np.abs(net).max()


def test_liggghts_l_wave_between_walls(packing, comm):
    """LIGGGHTS's L wave follows exp(tJ) of rotsound's stressed matrix with the walls' blocks (lever
    R - xi/2) to 1e-4 of the amplitude over t = 20 (about 26 t0), C(k, t) to 1e-6: measured 1.3e-5,
    C 1.1e-7.  The matrix without the walls misses by 6.3 (C by 0.096; nothing holds the packing
    up), with LAMMPS's lever R at the pairs and the walls by 1.3 (C by 0.010).  rotsound's own run of
    the wave (its start: every sphere, no zero mode projected out between frictional walls; the MFN
    of ``waves/exponential.py``) gives LIGGGHTS's z_fixed(t) to 2.4e-7 of |z(0)|."""
    p = packing
    start = liggghts_frames(p.n)[0]
    given = np.zeros_like(start)
    given[:, 0] = np.sin(2 * np.pi / float(p.box[0]) * p.positions[:, 0])
    # LIGGGHTS's start is 1e-7 sin(k x) to its dump's ten digits, on every sphere (no mean removed)
    assert_close(start / AMPLITUDE, given, rtol=0.0, atol=1e-9, what="LIGGGHTS's start / amplitude")
    model = ContactModel(KT, lever="contact")
    trajectory, c = misses(p, model, comm)
    assert_close(trajectory, 0.0, rtol=0.0, atol=1e-4, what="trajectory / amplitude")
    assert_close(c, 0.0, rtol=0.0, atol=1e-6, what="C(k, t)")
    for wrong, wrong_model in ((dataclasses.replace(p, walls=None, wall_contacts=None), model), (p, ContactModel(KT))):
        missed, missed_c = misses(wrong, wrong_model, comm)
        assert missed > 1.0 and missed_c > 1e-3, (wrong_model, len(wrong.walls or ()), missed, missed_c)
    # rotsound's own run of the wave (its start, excitation.start_velocity; the MFN path of
    # waves/exponential.py) against LIGGGHTS's z_fixed(t) = sum_i v_x,i(t) exp(-i k x_i(0))
    t0, k = np.sqrt(p.masses.mean()), 2 * np.pi / float(p.box[0])
    dm = dynmat.assemble(p, model, comm, mass_rule="density")
    try:
        (series,) = exponential.exponential_all(dm, p.positions, [("L", excitation.runs("L", p.dim).index((0, 0)), k)],
                                                amplitude=AMPLITUDE * t0, times=np.arange(FRAMES) * SAMPLE / t0,
                                                tol=1e-10)
    finally:
        dm.destroy()
    lig_z = liggghts_frames(p.n)[:, :, 0] @ np.exp(-1j * k * p.positions[:, 0])
    assert_close(np.abs(series.z_fixed / t0 - lig_z).max() / np.abs(lig_z[0]), 0.0, rtol=0.0, atol=1e-6,
                 what="z_fixed(t) of waves/exponential.py against LIGGGHTS's, over |z(0)|")


def test_a_scene_on_the_liggghts_walls_files_makes_the_same_packing(packing, tmp_path):
    """The same files through a scene's keys (packing.file, contacts, contacts_format, friction, walls,
    wall_contacts, gravity, model.lever; schema, scene rules, pipeline.make_packings) give the packing
    read above; the scene without model.lever: contact is refused (a LIGGGHTS contact file)."""
    from conftest import COMM

    from solver import pipeline
    from solver.io import coerce, scene_rules, schema

    def scene(model):
        return coerce.build(schema.Scene, {
            "packing": {"file": str(DATA / f"{STEM}.data"), "contacts": str(DATA / f"{STEM}.contacts"),
                        "contacts_format": "liggghts-local", "friction": FRICTION,
                        "walls": [{"axis": "z", "position": 0.0}, {"axis": "z", "position": upper_wall()}],
                        "wall_contacts": str(DATA / f"{STEM}.walls"), "gravity": GRAVITY},
            "model": model, "waves": {"modes": ["L"], "axes": ["x"], "n": [1], "method": "exponential"},
            "output": str(tmp_path / "out.h5")})

    right = scene({"rho": KT, "lever": "contact"})
    scene_rules.check_scene(right)
    p, = pipeline.make_packings(right, COMM)
    assert np.array_equal(p.positions, packing.positions) and np.array_equal(p.gravity, packing.gravity)
    assert np.array_equal(p.walls.position, packing.walls.position) and not p.rattler.any()
    assert np.array_equal(p.wall_contacts.force, packing.wall_contacts.force)
    assert np.array_equal(p.tangential.force, packing.tangential.force) and p.model.lever == "contact"
    with pytest.raises(InputError, match="model.lever: contact"):
        scene_rules.check_scene(scene({"rho": KT}))
