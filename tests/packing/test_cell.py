"""Tilted (triclinic) cells and axes with walls (geometry.Cell): wrapping, the minimum image, the
contact search and the grid of a rank's share, each against brute force over explicit images."""

import itertools

import numpy as np
import pytest
from conftest import assert_close

from solver.packing import geometry

pytestmark = pytest.mark.serial_only  # geometry on arrays: no communicator


def tilted_cell(dim, tilt_fraction=0.45, periodic=None):
    sides = np.array([9.0, 8.0, 7.5][:dim])
    tilt = {2: [tilt_fraction * sides[0]],
            3: [tilt_fraction * sides[0], -0.3 * sides[0], 0.4 * sides[1]]}[dim]
    return geometry.Cell(sides, np.array(tilt), np.ones(dim, bool) if periodic is None else np.array(periodic))


def brute_image(delta, cell, reach=2):
    """The shortest of delta + H n over every n with |n_a| <= reach on periodic axes."""
    h = cell.matrix
    best = np.array(delta, dtype=float)
    for n in itertools.product(*[range(-reach, reach + 1) if p else [0] for p in cell.periodic]):
        moved = delta + np.asarray(n, dtype=float) @ h.T
        shorter = np.sum(moved**2, axis=-1) < np.sum(best**2, axis=-1)
        best[shorter] = moved[shorter]
    return best


def brute_pairs(positions, cell, cutoff):
    """Every pair i < j with some image closer than cutoff (no tree, no reduction)."""
    delta = positions[:, None, :] - positions[None, :, :]
    nearest = brute_image(delta.reshape(-1, cell.dim), cell, reach=1).reshape(delta.shape)  # heights > 2 cutoff
    close = np.sqrt(np.sum(nearest**2, axis=-1)) < cutoff
    i, j = np.nonzero(np.triu(close, k=1))
    return np.stack((i, j), axis=1)


def points_in(cell, n, seed):
    return np.random.default_rng(seed).random((n, cell.dim)) @ cell.matrix.T


@pytest.mark.parametrize("dim", [2, 3])
def test_the_matrix_volume_heights_and_reciprocal_vectors_of_a_tilted_cell(dim):
    cell = tilted_cell(dim)
    h = cell.matrix
    assert np.allclose(np.tril(h, -1), 0.0, rtol=0, atol=0) and np.array_equal(np.diag(h), cell.sides)
    assert_close(cell.volume, abs(np.linalg.det(h)), rtol=1e-13, atol=0, what="det H")
    assert_close(cell.reciprocal() @ h, 2 * np.pi * np.eye(dim), rtol=0, atol=1e-13, what="b_a . a_b")
    # the height across axis a: the component of edge a along the unit normal of the other edges' face
    for axis in range(dim):
        normal = cell.reciprocal()[axis] / np.linalg.norm(cell.reciprocal()[axis])
        assert_close(cell.heights[axis], abs(h[:, axis] @ normal), rtol=1e-13, atol=0, what="height")
    assert np.all(cell.heights < cell.sides + 1e-12) and np.any(cell.heights < cell.sides - 0.1)


@pytest.mark.parametrize("dim", [2, 3])
def test_wrapping_in_a_tilted_cell_moves_by_lattice_vectors_into_the_unit_cell(dim):
    cell = tilted_cell(dim)
    positions = points_in(cell, 200, 1) * 3.0 - 5.0  # far outside the cell
    wrapped = geometry.wrap(positions, cell)
    s = np.linalg.solve(cell.matrix, wrapped.T).T
    assert np.all((s >= 0.0) & (s < 1.0))
    n = np.linalg.solve(cell.matrix, (positions - wrapped).T).T
    assert_close(n, np.rint(n), rtol=0, atol=1e-9, what="whole lattice vectors")


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("tilt_fraction", [0.0, 0.2, -0.5])
def test_minimum_image_in_a_tilted_cell_is_the_shortest_image(dim, tilt_fraction):
    cell = tilted_cell(dim, tilt_fraction)
    if tilt_fraction == 0.0:
        cell = geometry.Cell(cell.sides, np.zeros_like(cell.tilt), cell.periodic)
    direction = np.random.default_rng(2).normal(size=(500, dim))
    length = np.random.default_rng(1).random(500) * 0.499 * cell.heights.min()  # shorter than any image
    short = direction / np.linalg.norm(direction, axis=1)[:, None] * length[:, None]
    far = short + np.random.default_rng(3).integers(-3, 4, (500, dim)) @ cell.matrix.T
    reduced = geometry.minimum_image(far, cell)
    assert_close(reduced, short, rtol=0, atol=1e-12, what="image of a short separation")
    assert_close(reduced, brute_image(far, cell, reach=4), rtol=0, atol=1e-12, what="brute force")


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("periodic", ["all", "last walled"])
def test_candidate_pairs_in_a_tilted_cell_are_brute_forces(dim, periodic):
    axes = np.ones(dim, bool)
    if periodic == "last walled":
        axes[-1] = False
    cell = tilted_cell(dim, periodic=axes)
    if periodic == "last walled" and dim == 3:  # xz, yz shear across z: not allowed with walls in z
        cell = geometry.Cell(cell.sides, np.array([cell.tilt[0], 0.0, 0.0]), axes)
    positions = points_in(cell, 400 if dim == 2 else 600, 4)
    cutoff = 1.3
    assert np.all(cell.heights > 2 * cutoff)
    found = geometry.candidate_pairs(positions, cell, cutoff)
    expected = brute_pairs(positions, cell, cutoff)
    assert len(expected) > 100
    assert np.array_equal(found, expected)


def test_an_axis_with_walls_has_no_images():
    cell = geometry.Cell(np.array([6.0, 6.0]), np.zeros(1), np.array([True, False]))
    positions = np.array([[1.0, 0.2], [1.0, 5.9], [5.9, 3.0], [0.1, 3.0]])
    pairs = geometry.candidate_pairs(positions, cell, 0.5)
    assert pairs.tolist() == [[2, 3]]  # across x's images, not across the walls in y
    assert_close(geometry.minimum_image(np.array([[5.8, 5.7]]), cell), np.array([[-0.2, 5.7]]),
                 rtol=0, atol=1e-12, what="no image along y")
    assert_close(geometry.wrap(np.array([[7.0, -0.5]]), cell), np.array([[1.0, -0.5]]),
                 rtol=0, atol=1e-12, what="not folded along y")


@pytest.mark.parametrize("dim", [2, 3])
def test_cells_around_an_owned_slab_of_a_tilted_cell_hold_its_neighbours(dim):
    cell = tilted_cell(dim)
    cell = geometry.Cell(cell.sides * 2.5, cell.tilt * 2.5, cell.periodic)
    positions = points_in(cell, 1500, 5)
    owned = cell.fractional(positions)[:, -1] < 0.2
    cutoff = 1.2
    near = geometry.cells_around(positions, cell, cutoff, owned)
    pairs = geometry.candidate_pairs(positions, cell, cutoff)  # brute force's (test above)
    touching = owned[pairs[:, 0]] | owned[pairs[:, 1]]
    assert np.all(near[pairs[touching].ravel()])
    assert near.sum() < 0.9 * len(positions)  # a share, not everything


@pytest.mark.parametrize("dim", [2, 3])
def test_a_tilt_beyond_half_a_side_is_named(dim):
    cell = tilted_cell(dim, 0.51)
    assert "tilt xy" in cell.tilt_problem() and "beyond half the side L_x" in cell.tilt_problem()
    assert tilted_cell(dim, 0.5).tilt_problem() is None
    if dim == 3:
        walled = geometry.Cell(cell.sides, np.array([0.0, 0.0, 1.0]), np.array([True, True, False]))
        assert "yz" in walled.tilt_problem() and "walls" in walled.tilt_problem()
