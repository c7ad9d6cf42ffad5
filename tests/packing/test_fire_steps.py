"""FIRE's compiled, threaded vector updates and reductions (``packing.fire_steps``) and its force
engine's compiled pair forces and Verlet-list check (``pair_forces``): against the numpy
expressions they replace (the elementwise updates and maxima bit for bit, sums to round-off),
NaN handling, and the same packing bit for bit on 1, 2 and 3 threads, in 2D and 3D."""

import json
import os
import subprocess
import sys

import numba
import numpy as np
import pytest
from conftest import REPO, jammed_packing

from solver.packing import fire_steps, mechanics, pair_forces

pytestmark = pytest.mark.serial_only  # arrays only, no communicator; the thread counts spawn processes


@pytest.mark.parametrize("dim", [2, 3])
def test_each_update_equals_its_numpy_expression(dim):
    """Elementwise updates and the largest |f_i|^2 bit for bit; the sums to 1e-13 relative (their
    order is chunked, not numpy's pairwise one).  5001 rows: three chunks, the last one short."""
    rng = np.random.default_rng(dim)
    x, v, f = (rng.normal(size=(5001, dim)) * scale for scale in (10.0, 1e-3, 1e-5))
    dt, keep, push = 0.37, 1.0 - 0.0834, 0.0834 * 1.7
    largest, power, total = fire_steps.force_measures(f, v)
    assert largest == np.max(np.sum(f * f, axis=1))
    np.testing.assert_allclose([power, total], [np.vdot(f, v), np.vdot(f, f)], rtol=1e-13, atol=0.0)

    expected = v + dt * f
    got = v.copy()
    squared = fire_steps.kick(got, f, dt)
    assert np.array_equal(got, expected)
    np.testing.assert_allclose(squared, np.vdot(expected, expected), rtol=1e-13, atol=0.0)

    expected_v = keep * v + push * f
    expected_x = x + dt * expected_v
    got_x, got_v = x.copy(), v.copy()
    fire_steps.mix_and_move(got_x, got_v, f, keep, push, dt)
    assert np.array_equal(got_v, expected_v) and np.array_equal(got_x, expected_x)

    got_x = x.copy()
    fire_steps.move(got_x, v, dt)
    assert np.array_equal(got_x, x + dt * v)
    assert not np.array_equal(got_x, x)  # the arrays moved: the comparison could fail


def _scatter(x, forces):
    """Net forces (N, D) and energy over ``forces``' pair list the way the code did before the
    gather (issue 60): each pair's harmonic or Hertz force added to i and subtracted from j
    (``np.bincount``, list order), energies summed once per pair."""
    s = x[forces.i] - x[forces.j] + forces.shift
    distance = np.sqrt(np.sum(s * s, axis=1))
    overlap = np.maximum(forces.contact - distance, 0.0)
    growth = np.sqrt(forces.reduced * overlap) if forces.hertz else np.ones_like(overlap)
    pair = (growth * overlap / distance)[:, None] * s
    energy = np.sum((0.4 if forces.hertz else 0.5) * growth * overlap**2)
    n = x.shape[0]
    net = np.stack([np.bincount(forces.i, pair[:, d], minlength=n) - np.bincount(forces.j, pair[:, d], minlength=n)
                    for d in range(x.shape[1])], axis=1)
    return net, energy


@pytest.mark.parametrize("dim, law", [(2, "harmonic"), (2, "hertz"), (3, "harmonic"), (3, "hertz")])
def test_the_gathered_forces_equal_the_scattered_ones(dim, law):
    """Each particle's force summed over its own neighbour table equals the pair list scattered to
    i and j, to round-off (the order of the sums changed): contact forces are ~1e-2 kn d0 and
    sums of ~6 of them round at ~1e-17, hence atol 1e-15 kn d0; the energy to rtol 1e-13.
    A shaken jammed packing, so that most listed pairs overlap."""
    p = jammed_packing(256, 0.9, 7) if dim == 2 else jammed_packing(128, 0.7, 3, dim=3)
    x = p.positions + np.random.default_rng(5).uniform(-0.02, 0.02, size=p.positions.shape)
    forces = mechanics.FrictionlessForces(p.diameters, p.box, law=law)
    got, energy = forces(x)
    expected, expected_energy = _scatter(x, forces)
    assert np.abs(expected).max() > 1e-3  # forces there to compare
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(energy, expected_energy, rtol=1e-13, atol=0.0)


def test_the_forces_and_sums_are_the_same_bits_on_1_and_2_threads():
    """In this process: numba.set_num_threads(1), then 2 (needs a pool of 2: NUMBA_NUM_THREADS is 2
    on this 2-core machine run alone; skipped otherwise).  8192 particles: four chunks."""
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has one thread here (NUMBA_NUM_THREADS = 1)")
    rng = np.random.default_rng(3)
    p = jammed_packing(256, 0.9, 7)
    tiles = np.array([(i, j) for i in range(4) for j in range(8)], dtype=float) * p.box  # 32 tiles: 8192 disks
    x = (p.positions[None] + tiles[:, None]).reshape(-1, 2) + rng.uniform(-0.02, 0.02, size=(8192, 2))
    box = p.box * np.array([4.0, 8.0])
    v = rng.normal(size=x.shape)
    got = {}
    try:
        for threads in (1, 2):
            numba.set_num_threads(threads)
            f, energy = mechanics.FrictionlessForces(np.tile(p.diameters, 32), box)(x)
            w = v.copy()
            got[threads] = (f, energy, fire_steps.force_measures(f, v), fire_steps.kick(w, f, 0.1), w)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    (f1, e1, m1, k1, w1), (f2, e2, m2, k2, w2) = got[1], got[2]
    assert np.array_equal(f1, f2) and e1 == e2 and m1 == m2 and k1 == k2 and np.array_equal(w1, w2)


def test_a_single_chunk_runs_on_one_thread_and_the_count_comes_back():
    """fire.minimize runs small packings (one chunk) on one thread, larger ones on all; either way
    numba's count is restored after it, also on an error."""
    before = numba.get_num_threads()
    with fire_steps.threads_for(fire_steps.CHUNK):
        assert numba.get_num_threads() == 1
    with fire_steps.threads_for(fire_steps.CHUNK + 1):
        assert numba.get_num_threads() == before
    with pytest.raises(ZeroDivisionError), fire_steps.threads_for(10):
        1 / 0
    assert numba.get_num_threads() == before


FIRE_STEPS = """
import sys, json, hashlib, numba, numpy as np
from solver.packing import fire, jammed, mechanics
n, phi, dim, law = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
rng = np.random.default_rng(4)
diameters = rng.permutation(jammed.bidisperse_diameters(n))
box = np.full(dim, jammed.box_length_for(diameters, phi, dim))
forces = mechanics.FrictionlessForces(diameters, box, law=law)
result = fire.minimize(rng.uniform(0.0, box[0], size=(n, dim)), forces, 0.0, 400)
print(json.dumps({"threads": numba.get_num_threads(), "lists": [forces.rebuilds, forces.refreshes],
                  "positions": hashlib.sha256(result.x.tobytes()).hexdigest(), "energy": result.energy}))
"""


@pytest.mark.parametrize("n, phi, dim, law", [(4096, 0.9, 2, "harmonic"), (2560, 0.7, 3, "hertz")])
def test_fire_moves_the_same_bits_on_1_2_and_3_threads(n, phi, dim, law):
    """400 FIRE steps from a random start (the list remade on the way, as in
    jammed.generate's first steps) in three processes, NUMBA_NUM_THREADS = 1, 2 and 3 (3 threads on
    2 cores: chunks dealt unevenly): the positions (SHA-256) and the energy the same.  A reduction
    summed per thread (numba's own ``prange`` reductions) or forces scattered from two threads
    round differently with the thread count, and the steps carry the difference into the
    positions.  (Fixed steps rather than a whole packing: 5 min on this shared machine.)"""
    ends = []
    for threads in (1, 2, 3):
        env = {**os.environ, "NUMBA_NUM_THREADS": str(threads)}
        out = subprocess.run([sys.executable, "-c", FIRE_STEPS, str(n), str(phi), str(dim), law], cwd=REPO,
                             env=env, capture_output=True, text=True, timeout=600, check=True)
        ends.append(json.loads(out.stdout.splitlines()[-1]))
    assert [end["threads"] for end in ends] == [1, 2, 3]
    assert ends[0]["lists"][0] > 1  # the list remade (compiled, threaded: cell_list) on the way
    assert all(end == {**ends[0], "threads": end["threads"]} for end in ends), ends


@pytest.mark.parametrize("dim", [2, 3])
def test_the_list_check_equals_its_numpy_expression_bit_for_bit(dim):
    rng = np.random.default_rng(10 + dim)
    reference = rng.uniform(0.0, 50.0, size=(5001, dim))
    x = reference + rng.normal(scale=0.05, size=reference.shape)
    x[3234] += 0.4  # the largest move, in the second chunk
    step = x - reference
    moved = np.einsum("nd,nd->n", step, step)
    assert moved.argmax() == 3234  # the comparison below sees the largest move, not a tie
    assert pair_forces.largest_squared_move(x, reference) == moved.max()


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("row", [0, 2600, 5000])
def test_a_nan_gives_nan_as_the_numpy_expressions(dim, row):
    """A NaN component anywhere, also after larger rows (the compiled ``max`` kept the finite
    rows' largest), gives NaN as numpy's max does; so does a position moved from inf to inf."""
    rng = np.random.default_rng(20 + dim)
    f = rng.normal(size=(5001, dim))
    f[row, dim - 1] = np.nan
    assert np.isnan(np.max(np.sum(f * f, axis=1)))  # the expression the kernel promises
    assert np.isnan(fire_steps.force_measures(f, np.zeros_like(f))[0])

    reference = rng.uniform(0.0, 50.0, size=(5001, dim))
    for bad in (np.nan, np.inf):
        x = reference + rng.normal(scale=0.05, size=reference.shape)
        x[row, 0] = bad
        if bad == np.inf:
            reference = reference.copy()
            reference[row, 0] = np.inf  # inf - inf: NaN
        with np.errstate(invalid="ignore"):  # inf - inf
            step = x - reference
        assert np.isnan(np.einsum("nd,nd->n", step, step).max())
        assert np.isnan(pair_forces.largest_squared_move(x, reference))


def test_an_inf_force_stays_inf():
    f = np.zeros((7, 2))
    f[3, 1] = np.inf
    assert fire_steps.force_measures(f, np.zeros_like(f))[0] == np.max(np.sum(f * f, axis=1)) == np.inf


def test_fire_does_not_report_nan_forces_as_converged():
    """Forces zero but one NaN: not converged, max_force NaN (it reported convergence with
    max_force = 0)."""
    from solver.packing import fire

    def forces(x):
        f = np.zeros_like(x)
        f[5, 0] = np.nan
        return f, 0.0

    result = fire.minimize(np.zeros((16, 2)), forces, force_tol=1e-12, max_steps=1000)
    assert not result.converged and np.isnan(result.max_force)
    assert result.steps == 0  # stopped at the first NaN force: no step can mend it


def test_fire_through_the_verlet_list_does_not_converge_on_a_nan_position():
    """A packing at its minimum, its Verlet list built, then one disk at NaN: the forces of that
    disk's listed pairs are NaN and FIRE does not converge (it reported convergence at step 0 from
    the others' forces, all below the tolerance chosen here)."""
    from solver.packing import fire

    p = jammed_packing(32, 0.9, 7)
    forces = mechanics.FrictionlessForces(p.diameters, p.box)
    f, _ = forces(p.positions)  # the list, built on finite positions
    tol = 2.0 * np.sqrt(np.max(np.sum(f * f, axis=1)))  # every finite force below it
    x = p.positions.copy()
    x[5] = np.nan
    result = fire.minimize(x, forces, force_tol=tol, max_steps=3)
    assert not result.converged and np.isnan(result.max_force)


def test_the_verlet_list_gives_nan_forces_for_a_nan_position_with_no_listed_pair():
    """Two disks far apart (no pair within the list's reach), the list built, then one of them at
    NaN: its force is unknown, so every force is NaN (the stale list gave zeros, FIRE converged)."""
    from solver.packing import fire

    forces = mechanics.FrictionlessForces(np.ones(2), np.array([20.0, 20.0]))
    x = np.array([[2.0, 2.0], [12.0, 12.0]])
    f, energy = forces(x)
    assert np.array_equal(f, np.zeros_like(x)) and energy == 0.0  # the construction: no pair
    x[1] = np.nan
    f, energy = forces(x)
    assert np.isnan(f).all() and np.isnan(energy)
    result = fire.minimize(x, forces, force_tol=1e-12, max_steps=1000)
    assert not result.converged and np.isnan(result.max_force) and result.steps == 0
