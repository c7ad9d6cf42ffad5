"""Periodic square (2D) or cubic (3D) box geometry and contact detection (units: d0 = 1).

Every function works in D = 2 or 3 dimensions, read from the shape of ``positions`` (N, D).

Neighbours come from ``scipy.spatial.cKDTree`` with ``boxsize=L`` (periodic), never from a
Python loop over particles.  Not collective.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree


def wrap(positions: np.ndarray, box_length: float) -> np.ndarray:
    """Return ``positions`` (N, D) folded into ``[0, L)``."""
    wrapped = np.mod(positions, box_length)
    wrapped[wrapped >= box_length] = 0.0  # np.mod can round -tiny up to exactly L
    return wrapped


def minimum_image(delta: np.ndarray, box_length: float) -> np.ndarray:
    """Return separation vectors ``delta`` (..., D) mapped to their nearest periodic image."""
    return delta - box_length * np.rint(delta / box_length)


def candidate_pairs(positions: np.ndarray, box_length: float, cutoff: float) -> np.ndarray:
    """Return all pairs (P, 2), ``i < j``, closer than ``cutoff`` under periodic images, sorted
    by i, then j.  (An unbalanced tree and one argsort of i N + j: measured 1.5x faster than a
    balanced tree and a lexsort at N = 32768 in 3D, where FIRE rebuilds its list ~100 times.)"""
    tree = cKDTree(wrap(positions, box_length), boxsize=box_length, balanced_tree=False, compact_nodes=False)
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


def pair_geometry(positions, diameters, box_length, pairs):
    """Return (normal (P, D), distance (P,), overlap (P,)) of the given pairs (P, 2)."""
    i, j = pairs[:, 0], pairs[:, 1]
    delta = minimum_image(positions[i] - positions[j], box_length)
    distance = np.sqrt(np.einsum("pd,pd->p", delta, delta))
    overlap = 0.5 * (diameters[i] + diameters[j]) - distance
    return delta / distance[:, None], distance, overlap


def find_contacts(positions: np.ndarray, diameters: np.ndarray, box_length: float,
                  active: np.ndarray | None = None) -> Contacts:
    """Return the contacts (overlap > 0) among ``active`` particles (all when None).

    Requires ``box_length > 2 max(diameters)`` so that a pair touches through one image only.
    """
    pairs = candidate_pairs(positions, box_length, float(np.max(diameters)))
    if active is not None:
        pairs = pairs[active[pairs[:, 0]] & active[pairs[:, 1]]]
    normal, distance, overlap = pair_geometry(positions, diameters, box_length, pairs)
    touching = overlap > 0.0
    return Contacts(pairs[touching, 0], pairs[touching, 1], normal[touching],
                    distance[touching], overlap[touching])
