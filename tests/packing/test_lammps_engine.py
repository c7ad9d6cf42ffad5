"""LAMMPS's FIRE as a packing engine (solver/packing/lammps_engine.py): LAMMPS's contact forces
are rotsound's to round-off, its minimised packings meet force_tol under rotsound's own force
evaluation, on 1 rank and on 2, and a missing LAMMPS or a FIRE that does not converge stops with
one clear error.  Skipped, with the reason, where Debian's python3-lammps is not installed."""

import sys

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close

from solver.errors import InputError
from solver.packing import jammed
from solver.packing import mechanics
from solver.packing import lammps_engine


def recipe_start(n: int, phi: float, dim: int, seed: int):
    """The recipe's start: (positions (n, dim) uniform in the box, bidisperse diameters, box (dim,))."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0]))
    diameters = rng.permutation(jammed.bidisperse_diameters(n))
    box = np.full(dim, jammed.box_length_for(diameters, phi, dim))
    return rng.uniform(0.0, box[0], size=(n, dim)), diameters, box


def rotsound_max_force(positions, diameters, box) -> float:
    force, _ = mechanics.FrictionlessForces(diameters, box)(positions)
    return float(np.sqrt(np.max(np.sum(force**2, axis=1))))


@pytest.mark.parametrize("law", ["harmonic", "hertz"])
@pytest.mark.parametrize("dim, stretch", [(2, (0.8, 1.25)), (3, (1.0, 0.8, 1.25))])
def test_lammps_forces_and_virial_are_rotsounds(lammps_present, dim, stretch, law):
    """At a random start of 64 particles (every particle overlapping several others, overlaps up
    to a diameter) in a rectangular box, LAMMPS's net forces equal
    mechanics.FrictionlessForces's and its virial pressure mechanics.describe's.  The virial sums
    f_c r_c over contacts, so it checks each contact force, not only their sums per particle.
    Granular pair styles tally no energy; equal forces everywhere make LAMMPS's energy
    rotsound's E = sum xi^2 / 2 up to a constant.  Tolerances: each pair force (size <= 1) is the
    same formula rounded differently (kn (R_i + R_j - r) (1/r) against xi / r, and LAMMPS's ghost
    copies at x +- L_a add a rounding of eps L_a ~ 1e-15 to a separation), and a particle sums
    up to ~20 of them in another order: atol 1e-13 (~20 x eps L_a; measured 6e-16); the pressure
    is a sum of positive terms, rtol 1e-13 (measured equal).  Radii 1e-12 too large already fail
    (error / bound 50); a radius taken as d, kn != 1 or particles out of order differ by O(1).
    Hertz: LAMMPS's gran/hertz/history, kn sqrt(a' xi) xi with a' = R_i R_j/(R_i + R_j), is
    contact_law's law (a' as the diameter product over 4 c, or sqrt(xi) misplaced, differ by O(1))."""
    x, d, cube = recipe_start(64, 0.9 if dim == 2 else 0.7, dim, seed=5)
    box = cube * np.array(stretch)
    x = x * np.array(stretch)
    force, pressure = lammps_engine.forces(x, d, box, COMM, law=law)
    expected, _ = mechanics.FrictionlessForces(d, box, law=law)(x)
    assert_all(np.abs(expected).max() > 0.1, "the start should be far from force balance")
    assert_close(force, expected, rtol=0.0, atol=1e-13, what=f"{dim}D forces")
    stats = mechanics.describe(x, d, box, np.zeros(d.size, dtype=bool), law)
    assert_close(pressure, stats["pressure"], rtol=1e-13, what=f"{dim}D virial pressure")


@pytest.mark.parametrize("dim, phi", [(2, 0.9), (3, 0.7)])
def test_lammps_packing_meets_force_tol_under_rotsounds_forces(lammps_present, dim, phi):
    """128 particles minimised by LAMMPS on every rank of COMM: rotsound's own force evaluation
    of the returned positions finds max_i |F_i| below force_tol and equal to the max force LAMMPS
    reports (its criterion is the per-particle force length, ``min_modify norm max``; stopped on
    the largest component instead, ``norm inf``, it left max |F_i| = 1.1e-6 in 2D and 1.3e-6 in
    3D here), the same on every rank.  rtol 1e-9: the net force ~1e-6 is a cancellation of
    contact forces ~1e-2 each rounded differently at ~1e-18, measured 1e-12 apart."""
    x, d, box = recipe_start(128, phi, dim, seed=1)
    tol = 1e-6
    positions, steps, max_force = lammps_engine.minimize(x, d, box, tol, 100_000, COMM)
    ours = rotsound_max_force(positions, d, box)
    assert_all(ours < tol, f"{dim}D: rotsound's max |F| = {ours:.3e} >= {tol}")
    assert_close(ours, max_force, rtol=1e-9, what=f"{dim}D max force, rotsound's vs LAMMPS's")
    assert_all(np.all((positions >= 0) & (positions < box)), "positions folded into the box")
    copies = COMM.allgather((positions.tobytes(), steps, max_force))
    assert_all(all(c == copies[0] for c in copies), "the result differs between ranks")
    assert_all(steps > 10 and np.abs(positions - x).max() > 0.01, f"{dim}D: FIRE took {steps} steps")


def lammps_variant_of_rotsounds_fire(x0, forces, force_tol: float, max_steps: int):
    """fire.minimize with the three changes lammps_engine's docstring lists: the mixing takes |v|
    before the velocity update and alpha before its decrease, and after the half step back the
    forces are evaluated again at the corrected positions.  Returns (x, steps)."""
    from solver.packing import fire

    p = fire.FireParameters()
    x, v = np.array(x0, dtype=float), np.zeros_like(x0)
    dt, alpha, positive = p.dt_start, p.alpha_start, 0
    f, _ = forces(x)
    for step in range(max_steps + 1):
        if np.sqrt(np.max(np.sum(f * f, axis=1))) < force_tol:
            return x, step
        power, speed, mixing = np.vdot(f, v), np.sqrt(np.vdot(v, v)), alpha
        if power > 0.0:
            positive += 1
            if positive > p.n_min:
                dt, alpha = min(dt * p.f_inc, p.dt_max), alpha * p.f_alpha
        else:
            positive, dt, alpha = 0, dt * p.f_dec, p.alpha_start
            x -= 0.5 * dt * v
            v[:] = 0.0
            f, _ = forces(x)
        v += dt * f
        if power > 0.0:
            v = (1.0 - mixing) * v + mixing * (speed / np.sqrt(np.vdot(f, f))) * f
        x += dt * v
        f, _ = forces(x)
    raise AssertionError(f"the variant did not converge in {max_steps} steps")


@pytest.mark.parametrize("dim, phi", [(2, 0.9), (3, 0.7)])
def test_lammps_fire_is_rotsounds_with_the_documented_changes(lammps_present, dim, phi):
    """The module docstring's list of what LAMMPS's FIRE does differently is complete: rotsound's
    FIRE with exactly those three changes, on rotsound's forces, takes LAMMPS's number of steps
    and ends where LAMMPS ends (128 particles).  atol 1e-6: round-off alone (other rounding of
    the forces, other summation orders) moved the end by 4e-9 at N = 512, and perturbing
    rotsound's start by 1e-15 moved its end by at most 4e-8; leaving out any one of the three
    changes, or any two, ends in another minimum 0.9 to 1.6 diameters away (N = 512, 2D and 3D).
    Equal step counts were measured in every case (N = 512 in 2D and 3D, 2048 in 2D)."""
    x, d, box = recipe_start(128, phi, dim, seed=1)
    positions, steps, _ = lammps_engine.minimize(x, d, box, 1e-6, 100_000, COMM)
    expected, expected_steps = lammps_variant_of_rotsounds_fire(x, mechanics.FrictionlessForces(d, box), 1e-6, 100_000)
    assert_all(steps == expected_steps, f"{dim}D: LAMMPS took {steps} steps, the variant {expected_steps}")
    delta = positions - expected
    delta -= box * np.rint(delta / box)
    assert_close(delta, np.zeros_like(delta), rtol=0.0, atol=1e-6, what=f"{dim}D end positions, LAMMPS vs variant")


@pytest.mark.mpi
def test_lammps_on_one_rank_and_on_two_both_converge(lammps_present):
    """The same start minimised on COMM (2 ranks: LAMMPS splits the box) and on COMM_SELF (one
    rank): both reach force_tol under rotsound's forces.  They need not be the same packing:
    the force sums and reductions are ordered per rank, and FIRE amplifies the round-off."""
    from mpi4py import MPI

    x, d, box = recipe_start(256, 0.9, 2, seed=2)
    tol = 1e-6
    for comm in (COMM, MPI.COMM_SELF):
        positions, steps, max_force = lammps_engine.minimize(x, d, box, tol, 100_000, comm)
        ours = rotsound_max_force(positions, d, box)
        assert_all(ours < tol, f"{comm.size} rank(s): rotsound's max |F| = {ours:.3e} after {steps} steps")


def test_lammps_fire_that_does_not_converge_raises_on_every_rank(lammps_present):
    """Five FIRE steps from a random start leave max |F| ~ 1: RuntimeError on every rank with the
    force reached and the steps, not a LAMMPS exit or a hang."""
    x, d, box = recipe_start(64, 0.9, 2, seed=3)
    with pytest.raises(RuntimeError, match=r"did not converge: max \|F\| = .* after 5 steps"):
        lammps_engine.minimize(x, d, box, 1e-6, 5, COMM)


def test_missing_lammps_is_one_input_error_naming_the_installer(monkeypatch):
    """Without LAMMPS's Python module: InputError on every rank naming packing.engine and
    scripts/tools/setup_dem.sh (runs whether or not LAMMPS is installed)."""
    monkeypatch.setitem(sys.modules, "lammps", None)  # import lammps now raises ImportError
    x, d, box = recipe_start(16, 0.9, 2, seed=0)
    with pytest.raises(InputError, match=r"packing\.engine: lammps .*scripts/tools/setup_dem\.sh"):
        lammps_engine.minimize(x, d, box, 1e-6, 10, COMM)


def test_scene_with_engine_lammps_makes_jammed_packings_on_all_ranks(lammps_present, tmp_path):
    """packing.engine: lammps through the pipeline: every configuration minimised by LAMMPS on all
    ranks, jammed, to force_tol under rotsound's forces, the same on every rank; its unit key
    differs from the FIRE recipe's (a cache never mixes the two)."""
    from solver import pipeline
    from solver.io import coerce, schema, unit_keys

    out = COMM.bcast(str(tmp_path / "out.h5"), root=0)
    spec = {"packing": {"n": 64, "phi": 0.9, "count": 2, "engine": "lammps"}, "output": out}
    scene = coerce.build(schema.Scene, spec)
    made = pipeline.make_packings(scene, COMM)
    for p in made:
        assert_all(p.info["engine"] == "lammps" and mechanics.jamming_failure(p) is None, "not jammed")
        assert_all(rotsound_max_force(p.positions, p.diameters, p.box) < 1e-6, "force_tol not met")
        assert_all(COMM.allgather(p.positions.tobytes()).count(p.positions.tobytes()) == COMM.size,
                   "ranks differ")
    fire_scene = coerce.build(schema.Scene, {**spec, "packing": {**spec["packing"], "engine": "fire"}})
    assert_all(unit_keys.packing_key(scene, 0) != unit_keys.packing_key(fire_scene, 0), "same unit key")
