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
