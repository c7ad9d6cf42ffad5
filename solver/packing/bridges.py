"""The capillary bridges of a wet packing across a gap: which pairs that no longer touch still
carry one.  That is history, not geometry: a bridge forms when two particles touch and breaks at
its rupture distance s_c (docs/capillary_bridges.md section 4), so a wet packing carries the list
of its bridged pairs apart, (B, 2) int64 particle indices, i < j, sorted by (i, j), each once.
Every contact carries a bridge by that rule and is not listed.  Units d0.  Not collective.
"""

from __future__ import annotations

import numpy as np

from .. import capillary
from ..errors import InputError
from . import geometry


def build(pairs: np.ndarray, positions: np.ndarray, diameters: np.ndarray, box, cohesion: capillary.Cohesion,
          where: str) -> np.ndarray:
    """The bridged pairs across a gap (B, 2), canonical (module docstring), from ``pairs`` (any
    order within a pair).  Pairs that touch are dropped (they carry a bridge as contacts).
    InputError naming ``where`` for an index out of range, a particle paired with itself, a pair
    listed twice, or a pair at or beyond its rupture distance under ``cohesion`` (whose bridge
    would have broken)."""
    pairs = np.sort(np.asarray(pairs, dtype=np.int64).reshape(-1, 2), axis=1)
    n = positions.shape[0]
    bad = np.flatnonzero((pairs < 0).any(axis=1) | (pairs >= n).any(axis=1))
    if bad.size:
        raise InputError(f"{where}: bridge {bad[0]} names particle index {pairs[bad[0]].tolist()}, not among the "
                         f"packing's {n} particles")
    if np.any(pairs[:, 0] == pairs[:, 1]):
        raise InputError(f"{where}: a bridge pairs particle {pairs[pairs[:, 0] == pairs[:, 1]][0, 0]} with itself")
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    twice = np.flatnonzero(np.all(pairs[1:] == pairs[:-1], axis=1))
    if twice.size:
        raise InputError(f"{where}: the bridge {pairs[twice[0]].tolist()} (0-based indices) is listed more than once")
    _, _, overlap = geometry.pair_geometry(positions, diameters, box, pairs)
    gap = -overlap
    radius = 0.5 * diameters
    rupture = capillary.rupture_distance(radius[pairs[:, 0]], radius[pairs[:, 1]], cohesion)
    broken = np.flatnonzero(gap >= rupture)
    if broken.size:
        k = broken[0]
        raise InputError(f"{where}: {broken.size} bridge(s) span a gap at or beyond the rupture distance (first: "
                         f"particles {pairs[k].tolist()}, 0-based, gap {gap[k]:.4g} d0 >= s_c = {rupture[k]:.4g} d0 "
                         f"under cohesion law {cohesion.law}): such a bridge has broken; the bridges must be written "
                         f"with the packing, under the same cohesion")
    return pairs[gap > 0]


def rank_share(pairs: np.ndarray, owned: np.ndarray, active: np.ndarray) -> np.ndarray:
    """(B,) bool: the bridges between two ``active`` particles with an end in ``owned`` (both (N,)
    bool): a rank's share, as ``geometry.find_contacts_touching`` takes it."""
    i, j = pairs[:, 0], pairs[:, 1]
    return active[i] & active[j] & (owned[i] | owned[j])


def pull_forces(positions: np.ndarray, diameters: np.ndarray, box, pairs: np.ndarray,
                cohesion: capillary.Cohesion) -> np.ndarray:
    """The bridges' force on i from j (B, D) (kn d0) of ``pairs`` (B, 2): the pull F(s) towards j."""
    normal, _, overlap = geometry.pair_geometry(positions, diameters, box, pairs)
    radius = 0.5 * diameters
    pull = capillary.bridge_force(-overlap, radius[pairs[:, 0]], radius[pairs[:, 1]], cohesion)
    return -pull[:, None] * normal


def cohesion_record(cohesion: capillary.Cohesion) -> dict:
    """The bridges' law as flat attributes of a packing's ``info`` (for its unit and the results
    file; :func:`cohesion_of` reads them back)."""
    return {"cohesion_law": cohesion.law, "surface_tension": cohesion.surface_tension,
            "contact_angle": cohesion.contact_angle, "bridge_volume": cohesion.volume,
            "liquid_content": cohesion.liquid_content}


def cohesion_of(info: dict) -> capillary.Cohesion | None:
    """The bridges' law :func:`cohesion_record` wrote into ``info``, or None (dry)."""
    if "cohesion_law" not in info:
        return None
    return capillary.Cohesion(str(info["cohesion_law"]), float(info["surface_tension"]),
                              float(info["contact_angle"]), float(info["bridge_volume"]),
                              float(info["liquid_content"]))
