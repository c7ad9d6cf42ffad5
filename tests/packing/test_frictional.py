"""Frictional packings as DEM codes leave them (issue 25): made by LAMMPS
(``packing.friction`` with ``packing.engine: lammps``), at rest on their stored tangential forces,
the stressed rattler rule, and scenes that use them or refuse what needs a symmetric matrix."""

import functools

import h5py
import numpy as np
import pytest
from conftest import COMM, assert_all, scene_of

from solver import contact_law, pipeline
from solver.errors import InputError
from solver.packing import configuration, geometry, jammed, mechanics


@functools.lru_cache(maxsize=None)
def frictional(dim: int, phi: float, mu: float, n: int = 128, seed: int = 1):
    """A frictional packing made by LAMMPS on COMM_WORLD (once per session)."""
    return jammed.generate(n, phi, np.random.SeedSequence([seed, 0]), force_tol=1e-10, dim=dim, engine="lammps",
                           comm=COMM, friction=mu)


@pytest.mark.parametrize("dim, phi, mu", [(2, 0.82, 1.0), (3, 0.62, 1.0)])
def test_lammps_makes_frictional_packings_at_rest_on_their_tangential_forces(lammps_present, dim, phi, mu):
    p = frictional(dim, phi, mu)
    net, torque = mechanics.net_load(p)
    active = ~p.rattler
    # LAMMPS stopped with every force and torque component below 1e-10 kn d0; rotsound recomputes
    # them from the same state (a few components per particle: 1e-9 bounds their sum)
    assert_all(p.stressed and np.abs(net[active]).max() < 1e-9 and np.abs(torque[active]).max() < 1e-9,
               f"net {np.abs(net[active]).max():.1e}, torque {np.abs(torque[active]).max():.1e}")
    bare, _ = mechanics.net_load(configuration.Packing(p.positions, p.diameters, p.box, p.rattler))
    assert_all(np.abs(bare[active]).max() > 1e-3, "the normal forces alone balance: not a frictional packing")
    found = geometry.find_contacts(p.positions, p.diameters, p.box)
    reduced = contact_law.reduced_radius(p.diameters[found.i], p.diameters[found.j])
    ratio = np.linalg.norm(p.tangential.on(found.i, found.j), axis=1) / contact_law.normal_force(
        found.overlap, "harmonic", reduced)
    assert_all(ratio.max() <= mu * (1 + 1e-9), f"|f_t| / f_n up to {ratio.max()} > mu = {mu}")
    assert_all(mechanics.jamming_failure(p) is None, str(mechanics.jamming_failure(p)))
    # frictional packings jam looser: z below the frictionless isostatic 2D (4) or 6 (3D)
    assert_all(p.info["z"] < 2 * dim, f"z = {p.info['z']}")


# LAMMPS on 2 ranks is the 2D case's in the MPI pass; 3D varies the dimension, not the layout
@pytest.mark.parametrize("dim, phi", [(2, 0.82), pytest.param(3, 0.6, marks=pytest.mark.serial_only)])
def test_lammps_holds_frictional_packings_at_a_pressure(lammps_present, dim, phi):
    """packing.pressure: LAMMPS's barostat brings packings made with mu = 0 and mu = 1 to the same
    pressure (rotsound's, recomputed from the positions: within 2e-3 of the target, the barostat's
    1e-3 plus the settling in the fixed box after it); at that pressure the frictional one is looser
    (lower phi, lower z); at mu = 0 no force is stored and no contact counts as mobilised."""
    target = 1e-2
    made = {mu: jammed.generate(128, phi, np.random.SeedSequence([2, 0]), force_tol=1e-10, dim=dim, engine="lammps",
                                comm=COMM, friction=mu, pressure=target) for mu in (0.0, 1.0)}
    for mu, p in made.items():
        assert_all(abs(p.info["pressure"] / target - 1.0) < 2e-3 and p.info["target_pressure"] == target,
                   f"mu = {mu}: pressure {p.info['pressure']}")
    assert_all(not made[0.0].stressed and made[0.0].info["n_mobilised"] == 0 and made[1.0].stressed)
    assert_all(made[1.0].phi < made[0.0].phi and made[1.0].info["z"] < made[0.0].info["z"],
               f"phi {made[1.0].phi}, {made[0.0].phi}; z {made[1.0].info['z']}, {made[0.0].info['z']}")


def test_stressed_rattler_rule_keeps_load_bearing_particles_on_few_contacts(lammps_present):
    """In the 2D mu = 1 packing some disks carry load on 2 contacts (their forces balance and they
    are not rattlers), which the frictionless count (fewer than 3) would cut; every rattler
    carries together less than the equilibrium tolerance."""
    p = frictional(2, 0.82, 1.0)
    found = geometry.find_contacts(p.positions, p.diameters, p.box)
    count = found.count_per_particle(p.n)
    two = np.flatnonzero((count == 2) & ~p.rattler)
    assert_all(two.size > 0, "no load-bearing disk on 2 contacts in this packing: the test needs one")
    counted = mechanics.find_rattlers(p.positions, p.diameters, p.box)  # the frictionless count rule
    assert_all(np.all(counted[two]), "the count rule should cut disks on 2 contacts")
    reduced = contact_law.reduced_radius(p.diameters[found.i], p.diameters[found.j])
    force = (contact_law.normal_force(found.overlap, "harmonic", reduced)[:, None] * found.normal
             + p.tangential.on(found.i, found.j))
    carried = np.linalg.norm(force, axis=1)
    load = np.bincount(found.i, carried, minlength=p.n) + np.bincount(found.j, carried, minlength=p.n)
    assert_all(np.all(load[p.rattler] < mechanics.EQUILIBRIUM_TOL) and np.all(load[two] > 1e-3),
               f"rattler loads {load[p.rattler]}, 2-contact loads {load[two]}")


def test_a_frictional_scene_runs_its_waves_and_keeps_the_stored_forces(lammps_present, shared_tmp):
    """packing.friction with engine lammps, TS waves: the results file holds each packing's
    stored forces, and a second run resumes every unit (no new packing, the same numbers)."""
    sections = dict(cache="off", packing={"n": 64, "phi": 0.82, "engine": "lammps", "friction": 0.5,
                                          "force_tol": 1e-10},
                    model={"rho": 1.0}, waves={"modes": ["TR"], "n": [1], "t_end": 4.0, "dt": 0.01,
                                                "sample_every": 10})
    scene = scene_of(shared_tmp / "frictional.h5", **sections)
    first = pipeline.run(scene, COMM, [])["units"]
    with h5py.File(shared_tmp / "frictional.h5", "r") as f:
        group = f["packings/0000"]
        assert_all("tangential" in group and group["tangential/force"].shape[1] == 2
                   and float(group["tangential"].attrs["friction"]) == 0.5, "stored forces not in the results file")
    second = pipeline.run(scene_of(shared_tmp / "frictional.h5", **sections), COMM, [])["units"]
    name = next(n for n in first if n.startswith("waves/"))
    assert_all(np.array_equal(first[name][0]["C"], second[name][0]["C"]), "the resumed waves differ")


def test_exact_waves_on_a_frictional_scene_agree_with_verlet(lammps_present, shared_tmp):
    """waves.method exponential on LAMMPS's stressed packing (a non-symmetric matrix): the same C as
    Verlet at dt = 0.01 to Verlet's step error (bounded by 1e-4 of C(0) = 1; measured 1.4e-5, as
    Verlet's error against exp(tJ) in tests/run/test_crosscheck_stressed.py), and an error
    estimate stored."""
    base = dict(cache="off", packing={"n": 64, "phi": 0.82, "engine": "lammps", "friction": 0.5, "force_tol": 1e-10},
                model={"rho": 1.0})
    waves = {"modes": ["TR"], "n": [1], "t_end": 4.0, "dt": 0.01, "sample_every": 10}
    c = {}
    for method in ("ts", "exponential"):
        scene = scene_of(shared_tmp / f"{method}.h5", **base, waves={**waves, "method": method})
        units = pipeline.run(scene, COMM, [])["units"]
        name = next(n for n in units if n.startswith("waves/"))
        datasets, attrs = units[name]
        c[method] = datasets["C"]
    assert_all("error_estimate" in datasets and attrs["integrator"] == "exponential (SLEPc MFN)", str(attrs))
    assert_all(np.abs(c["ts"] - c["exponential"]).max() < 1e-4, f"{np.abs(c['ts'] - c['exponential']).max()}")


@pytest.mark.serial_only
@pytest.mark.parametrize("sections, match", [
    ({"packing": {"n": 64, "phi": 0.82, "engine": "lammps", "friction": 0.5}, "spectrum": {"method": "counting"}},
     "not symmetric"),
    ({"packing": {"n": 64, "phi": 0.82, "engine": "lammps", "friction": 0.5},
      "waves": {"modes": ["L"], "n": [1], "method": "spectral"}}, "waves.method = 'spectral'"),
    ({"packing": {"n": 64, "phi": 0.82, "engine": "lammps", "friction": 0.5}, "model": {"rho": [0.0, 1.0]},
      "waves": {"modes": ["L"], "n": [1]}}, "model.rho contains 0"),
    ({"packing": {"n": 64, "phi": 0.82, "friction": 0.5}}, "packing.friction = 0.5"),
    ({"packing": {"n": 64, "phi": 0.82, "contacts": "c.dump"}}, "packing.contacts"),
    ({"packing": {"file": "p.data", "contacts": "c.dump", "relax": True}}, "packing.relax"),
])
def test_scenes_refuse_what_stressed_packings_cannot_give(tmp_path, sections, match):
    with pytest.raises(InputError, match=match):
        scene_of(tmp_path / "x.h5", **sections)
