"""FIRE's compiled vector updates (``packing.fire_steps``) and its force engine's compiled Verlet-list
check (``pair_forces.largest_squared_move``) against the numpy expressions they replace, bit for
bit (FIRE's packings must not change), in 2D and 3D."""

import numpy as np
import pytest

from solver.packing import fire_steps, pair_forces

pytestmark = pytest.mark.serial_only  # arrays only, no communicator


@pytest.mark.parametrize("dim", [2, 3])
def test_each_update_equals_its_numpy_expression_bit_for_bit(dim):
    rng = np.random.default_rng(dim)
    x, v, f = (rng.normal(size=(1001, dim)) * scale for scale in (10.0, 1e-3, 1e-5))
    dt, keep, push = 0.37, 1.0 - 0.0834, 0.0834 * 1.7
    assert fire_steps.largest_squared_force(f) == np.max(np.sum(f * f, axis=1))

    expected = v + dt * f
    got = v.copy()
    fire_steps.kick(got, f, dt)
    assert np.array_equal(got, expected)

    expected_v = keep * v + push * f
    expected_x = x + dt * expected_v
    got_x, got_v = x.copy(), v.copy()
    fire_steps.mix_and_move(got_x, got_v, f, keep, push, dt)
    assert np.array_equal(got_v, expected_v) and np.array_equal(got_x, expected_x)

    got_x = x.copy()
    fire_steps.move(got_x, v, dt)
    assert np.array_equal(got_x, x + dt * v)
    assert not np.array_equal(got_x, x)  # the arrays moved: the comparison could fail


@pytest.mark.parametrize("dim", [2, 3])
def test_the_list_check_equals_its_numpy_expression_bit_for_bit(dim):
    rng = np.random.default_rng(10 + dim)
    reference = rng.uniform(0.0, 50.0, size=(2001, dim))
    x = reference + rng.normal(scale=0.05, size=reference.shape)
    x[1234] += 0.4  # the largest move, in the middle of the array
    step = x - reference
    moved = np.einsum("nd,nd->n", step, step)
    assert moved.argmax() == 1234  # the comparison below sees the largest move, not a tie
    assert pair_forces.largest_squared_move(x, reference) == moved.max()


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("row", [0, 600, 1000])
def test_a_nan_gives_nan_as_the_numpy_expressions(dim, row):
    """A NaN component anywhere, also after larger rows (the compiled ``max`` kept the finite
    rows' largest), gives NaN as numpy's max does; so does a position moved from inf to inf."""
    rng = np.random.default_rng(20 + dim)
    f = rng.normal(size=(1001, dim))
    f[row, dim - 1] = np.nan
    assert np.isnan(np.max(np.sum(f * f, axis=1)))  # the expression the kernel promises
    assert np.isnan(fire_steps.largest_squared_force(f))

    reference = rng.uniform(0.0, 50.0, size=(1001, dim))
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
    assert fire_steps.largest_squared_force(f) == np.max(np.sum(f * f, axis=1)) == np.inf


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
    from conftest import jammed_packing

    from solver.packing import fire, mechanics

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
    from solver.packing import fire, mechanics

    forces = mechanics.FrictionlessForces(np.ones(2), np.array([20.0, 20.0]))
    x = np.array([[2.0, 2.0], [12.0, 12.0]])
    f, energy = forces(x)
    assert np.array_equal(f, np.zeros_like(x)) and energy == 0.0  # the construction: no pair
    x[1] = np.nan
    f, energy = forces(x)
    assert np.isnan(f).all() and np.isnan(energy)
    result = fire.minimize(x, forces, force_tol=1e-12, max_steps=1000)
    assert not result.converged and np.isnan(result.max_force) and result.steps == 0
