"""FIRE's compiled Verlet list (``packing.cell_list``): every pair within reach and no other, by
brute force, in the list's order with its neighbour table (``pair_forces.neighbour_table``'s), in
boxes of 3 cells or more a side and of fewer, the same on 1 and 2 threads; and FIRE's forces
independent of the list's reach and the same as with the cKDTree list."""

import numpy as np
import pytest

from solver.contact_law import reduced_radius
from solver.packing import cell_list, fire, geometry, jammed, mechanics, pair_forces

pytestmark = pytest.mark.serial_only  # arrays only, no communicator


def brute_force(x, diameters, sides, reach):
    """(i, j, shift) of every pair i < j closer than (d_i + d_j)/2 + reach under minimum images,
    sorted by (i, j), shift = -L rint(delta / L): all pairs, no search."""
    i, j = np.triu_indices(len(x), k=1)
    delta = x[i] - x[j]
    shift = -(sides * np.rint(delta / sides))
    separation = delta + shift
    near = np.einsum("pd,pd->p", separation, separation) < (0.5 * (diameters[i] + diameters[j]) + reach) ** 2
    return i[near], j[near], shift[near]


@pytest.mark.parametrize("dim, n, phi, reach", [
    (2, 3000, 0.9, 0.3),   # 2D, many cells
    (3, 2000, 0.64, 0.3),  # 3D, many cells
    (2, 40, 0.9, 0.3),     # 5.9 wide: 4 cells of 1.47 a side
    (3, 20, 0.6, 0.05),    # 2.6 wide: 2 cells a side, minimum images
    (2, 16, 0.5, 0.2),     # 4.6 wide: 3 cells
])
def test_the_list_is_every_pair_within_reach_and_its_table(dim, n, phi, reach):
    """Random positions (a random whole number of sides off the box: FIRE's are not folded)."""
    rng = np.random.default_rng(n)
    diameters = rng.permutation(jammed.bidisperse_diameters(n))
    sides = np.full(dim, jammed.box_length_for(diameters, phi, dim))
    assert sides[0] > 2 * (diameters.max() + reach)
    x = rng.uniform(0.0, sides[0], size=(n, dim)) + sides * rng.integers(-3, 4, size=(n, dim))
    (i, j, shift, contact, reduced), table, _ = cell_list.verlet_list(x, diameters, sides, reach)
    bi, bj, bshift = brute_force(x, diameters, sides, reach)
    assert len(bi) > n // 4  # pairs there to find
    assert np.array_equal(i, bi) and np.array_equal(j, bj)
    assert np.array_equal(shift, bshift)
    assert np.array_equal(contact, 0.5 * (diameters[i] + diameters[j]))
    assert np.array_equal(reduced, reduced_radius(diameters[i], diameters[j]))
    expected = (np.empty(n + 1, dtype=np.int64), np.empty(2 * len(i), dtype=np.int64), np.empty((2 * len(i), dim)),
                np.empty(2 * len(i)), np.empty(2 * len(i)))
    pair_forces.neighbour_table(n, i, j, shift, contact, reduced, *expected)
    assert len(table[1]) == 2 * len(i)
    assert all(np.array_equal(got, want) for got, want in zip(table, expected))


def test_fire_does_not_depend_on_the_lists_reach():
    """300 FIRE steps from a random start (1024 disks at phi = 0.9, the list remade every few steps)
    with skins 0.15, 0.3 and 0.45: the same positions bit for bit, the lists remade a different
    number of times.  Each image shift is a whole number of sides, so a pair's force is the same
    bits whenever it was listed, and a listed pair apart adds +-0."""
    rng = np.random.default_rng(9)
    diameters = rng.permutation(jammed.bidisperse_diameters(1024))
    box = np.full(2, jammed.box_length_for(diameters, 0.9, 2))
    start = rng.uniform(0.0, box[0], size=(1024, 2))
    ends, lists = [], []
    for skin in (0.15, 0.3, 0.45):
        forces = mechanics.FrictionlessForces(diameters, box, skin=skin)
        ends.append(fire.minimize(start, forces, 0.0, 300).x)
        lists.append(forces.rebuilds + forces.refreshes)
    assert len(set(lists)) == 3, lists
    assert all(np.array_equal(end, ends[0]) for end in ends[1:])
    assert not np.array_equal(ends[0], start)


@pytest.mark.parametrize("n, phi, dim, law, steps", [(2048, 0.9, 2, "harmonic", 1500), (1024, 0.7, 3, "hertz", 800)])
def test_fire_moves_the_same_bits_as_with_the_searched_list(n, phi, dim, law, steps):
    """FIRE from a random start with the compiled list against the list of before (the tree
    search and its partial refreshes, which tilted and walled cells keep): the same positions bit
    for bit, so the packings did not change (the same pairs in the same order, each shift the same
    whole number of sides)."""
    rng = np.random.default_rng(4)
    diameters = rng.permutation(jammed.bidisperse_diameters(n))
    box = np.full(dim, jammed.box_length_for(diameters, phi, dim))
    start = rng.uniform(0.0, box[0], size=(n, dim))
    compiled = mechanics.FrictionlessForces(diameters, box, law=law)
    searched = mechanics.FrictionlessForces(diameters, box, law=law)
    searched._compiled_sides = lambda dim: None  # the search of tilted and walled cells
    ends = [fire.minimize(start, forces, 0.0, steps).x for forces in (compiled, searched)]
    assert compiled.refreshes == 0 and searched.refreshes > 0 and compiled.rebuilds > 1
    assert np.array_equal(ends[0], ends[1])


def test_the_list_is_the_same_on_1_and_2_threads():
    """verlet_list with numba.set_num_threads(1), then 2 (needs a pool of 2, skipped otherwise): every
    array the same bit for bit.  20000 disks: about 80 chunks of cells."""
    import numba

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has one thread here (NUMBA_NUM_THREADS = 1)")
    rng = np.random.default_rng(11)
    diameters = rng.permutation(jammed.bidisperse_diameters(20000))
    sides = np.full(2, jammed.box_length_for(diameters, 0.9, 2))
    x = rng.uniform(0.0, sides[0], size=(20000, 2))
    got = []
    try:
        for threads in (1, 2):
            numba.set_num_threads(threads)
            listed, table, _ = cell_list.verlet_list(x, diameters, sides, 0.3)
            got.append([array.copy() for array in (*listed, *table)])
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert all(np.array_equal(one, two) for one, two in zip(*got))
