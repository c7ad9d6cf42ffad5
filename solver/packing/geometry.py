"""Periodic orthogonal box geometry (rectangle in 2D, rectangular cuboid in 3D, origin at 0) and contact detection (units: d0 = 1).

Every function works in D = 2 or 3 dimensions, read from the shape of ``positions`` (N, D).
``box`` is the (D,) side lengths (L_x, L_y[, L_z]) of the box, or one float for a square or cubic one.

Neighbours come from ``scipy.spatial.cKDTree`` with ``boxsize=L`` (periodic), never from a
Python loop over particles.  Not collective.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree


def wrap(positions: np.ndarray, box: float) -> np.ndarray:
    """Return ``positions`` (N, D) folded into the box, ``[0, L_a)`` along each axis a."""
    wrapped = np.mod(positions, box)
    wrapped[wrapped >= box] = 0.0  # np.mod can round -tiny up to exactly L_a
    return wrapped


def minimum_image(delta: np.ndarray, box: float) -> np.ndarray:
    """Return separation vectors ``delta`` (..., D) mapped to their nearest periodic image."""
    return delta - box * np.rint(delta / box)


def candidate_pairs(positions: np.ndarray, box: float, cutoff: float) -> np.ndarray:
    """Return all pairs (P, 2), ``i < j``, closer than ``cutoff`` under periodic images, sorted
    by i, then j.  (An unbalanced tree and one argsort of i N + j: measured 1.5x faster than a
    balanced tree and a lexsort at N = 32768 in 3D, where FIRE rebuilds its list ~100 times.)"""
    tree = cKDTree(wrap(positions, box), boxsize=box, balanced_tree=False, compact_nodes=False)
    pairs = tree.query_pairs(r=cutoff, output_type="ndarray")
    return pairs[np.argsort(pairs[:, 0] * positions.shape[0] + pairs[:, 1])]


@dataclass(frozen=True)
class Contacts:
    """Overlapping pairs of a configuration.

    i, j : (C,) int      particle indices, i < j
    normal : (C, D)      unit vector n = (r_i - r_j) / r_ij (minimum image)
    distance : (C,)      r_ij
    overlap : (C,)       xi_ij = (d_i + d_j)/2 - r_ij > 0
    """

    i: np.ndarray
    j: np.ndarray
    normal: np.ndarray
    distance: np.ndarray
    overlap: np.ndarray

    def __len__(self) -> int:
        return int(self.i.size)

    def count_per_particle(self, n: int) -> np.ndarray:
        """Number of contacts (N,) of each of ``n`` particles."""
        return np.bincount(self.i, minlength=n) + np.bincount(self.j, minlength=n)


def cells_around(positions: np.ndarray, box, cutoff: float, owned: np.ndarray) -> np.ndarray:
    """Particles (N,) bool in the periodic cells of side >= ``cutoff`` that hold an ``owned``
    ((N,) bool) particle or touch such a cell (3^D of them around each): every particle closer than
    ``cutoff`` to an owned one is among them.  All particles when the box is less than three
    cells wide along an axis."""
    n, dim = positions.shape
    box = np.broadcast_to(np.asarray(box, dtype=float), (dim,))
    per_side = np.floor(box / cutoff).astype(int)
    if np.any(per_side < 3):
        return np.ones(n, dtype=bool)
    cell = np.minimum((wrap(positions, box) / box * per_side).astype(int), per_side - 1)
    flat = np.ravel_multi_index(tuple(cell.T), tuple(per_side))
    grid = np.zeros(tuple(per_side), dtype=bool)
    grid.flat[flat[owned]] = True
    for axis in range(dim):
        grid = grid | np.roll(grid, 1, axis) | np.roll(grid, -1, axis)
    return grid.ravel()[flat]


def find_contacts_touching(positions: np.ndarray, diameters: np.ndarray, box, owned: np.ndarray,
                           active: np.ndarray | None = None) -> Contacts:
    """The contacts of :func:`find_contacts` (same order, same orientation) that have at least one
    end in ``owned`` ((N,) bool), found among the particles of :func:`cells_around` only: a rank's
    share of the contact search, in memory and time proportional to its own particles and their
    halo rather than to N."""
    cutoff = float(np.max(diameters))
    near = cells_around(positions, box, cutoff, owned)
    if active is not None:
        near &= active
    subset = np.flatnonzero(near)  # increasing, so the pairs keep find_contacts' order and i < j
    if subset.size < 2:
        pairs = np.zeros((0, 2), dtype=np.int64)
    else:
        pairs = subset[candidate_pairs(positions[subset], box, cutoff)]
    pairs = pairs[owned[pairs[:, 0]] | owned[pairs[:, 1]]]
    normal, distance, overlap = pair_geometry(positions, diameters, box, pairs)
    touching = overlap > 0.0
    return Contacts(pairs[touching, 0], pairs[touching, 1], normal[touching],
                    distance[touching], overlap[touching])


def pair_geometry(positions, diameters, box, pairs):
    """Return (normal (P, D), distance (P,), overlap (P,)) of the given pairs (P, 2)."""
    i, j = pairs[:, 0], pairs[:, 1]
    delta = minimum_image(positions[i] - positions[j], box)
    distance = np.sqrt(np.einsum("pd,pd->p", delta, delta))
    overlap = 0.5 * (diameters[i] + diameters[j]) - distance
    return delta / distance[:, None], distance, overlap


def find_contacts(positions: np.ndarray, diameters: np.ndarray, box: float,
                  active: np.ndarray | None = None) -> Contacts:
    """Return the contacts (overlap > 0) among ``active`` particles (all when None).

    Requires every side > 2 max(diameters), so that a pair touches through one image only.
    """
    pairs = candidate_pairs(positions, box, float(np.max(diameters)))
    if active is not None:
        pairs = pairs[active[pairs[:, 0]] & active[pairs[:, 1]]]
    normal, distance, overlap = pair_geometry(positions, diameters, box, pairs)
    touching = overlap > 0.0
    return Contacts(pairs[touching, 0], pairs[touching, 1], normal[touching],
                    distance[touching], overlap[touching])
