"""The stored tangential forces of a packing made with friction (docs/stressed_contacts.md): per
contact (i, j), i < j, the tangential force on i from j that the DEM code's spring history holds
at rest.  A packing without them (``Packing.tangential`` None) has unstressed springs.

Units kn d0 (rotsound's).  Not collective.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import contact_law
from ..errors import InputError
from . import geometry

NORMAL_PART_TOL = 1e-6  # largest |f_t . n| / |f_t| accepted: a stored force lies in the tangent plane
NORMAL_PART_FLOOR = 1e-14  # kn d0, allowed on top: a contact LAMMPS left at an overlap of 1e-12 carried
                           # |f_t| = 1.4e-13 with a normal part of 2.7e-19, 2e-6 of it (round-off)
COULOMB_SLACK = 1e-9    # relative: |f_t| <= mu f_n (1 + slack) + COULOMB_FLOOR; at or above mu f_n (1 - slack): mobilised
COULOMB_FLOOR = 1e-10   # kn d0: LAMMPS caps |f_t| by mu times the normal force with its damping, at the last step's
                        # positions; at rest (forces below 1e-10, frictional packings' force_tol) that leaves
                        # excesses of this size, which on a contact of tiny overlap are large relative to f_n


@dataclass(frozen=True)
class TangentialForces:
    """pairs : (C, 2) int64 particle indices, i < j, sorted by (i, j), each pair once;
    force : (C, D) float64 the tangential force on i from j (kn d0), perpendicular to the contact
    normal (r_i - r_j)/r_ij; friction : the Coulomb coefficient mu the packing was made with, or
    None when unknown (then no contact is classed as mobilised)."""

    pairs: np.ndarray
    force: np.ndarray
    friction: float | None = None

    def __len__(self) -> int:
        return int(self.pairs.shape[0])

    def on(self, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """Stored force (len(i), D) on each contact (i, j) (i < j) of a contact list: zero for a
        contact with no stored force (a pair that touched only at the end, or a file that lists
        only the loaded contacts).  ``build`` has checked that every stored pair touches."""
        n = int(max(self.pairs.max(initial=-1), i.max(initial=-1), j.max(initial=-1))) + 1
        return stored_at(self.pairs[:, 0] * n + self.pairs[:, 1], self.force, i.astype(np.int64) * n + j)

    def nonzero(self) -> bool:
        """Whether any stored force is not zero (then the matrix is not symmetric)."""
        return bool(np.any(self.force != 0.0))


def stored_at(keys: np.ndarray, force: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """The rows of ``force`` (K, D) whose sorted integer ``keys`` (K,) are ``wanted`` (W,), zero rows
    where a wanted key is not among them: (W, D).  The stored forces' lookup by contact."""
    at = np.searchsorted(keys, wanted)
    hit = at < keys.size
    hit[hit] = keys[at[hit]] == wanted[hit]
    out = np.zeros((wanted.size, force.shape[1]))
    out[hit] = force[at[hit]]
    return out


def build(pairs: np.ndarray, force: np.ndarray, positions: np.ndarray, diameters: np.ndarray, box,
          law: str, friction: float | None, where: str, cap: float = 0.0) -> TangentialForces:
    """Check stored forces against their packing and return them in canonical form.

    pairs (C, 2) particle indices (any order within a pair: a pair given as (j, i) has its force
    negated, so it acts on the lower index); force (C, D); f_n of each pair under the normal
    ``law`` and ``friction`` (mu, or None) make the Coulomb check.
    InputError naming ``where`` for: an index out of range, a pair listed twice or with itself, a
    pair that does not touch (overlap <= 0) but carries a force, a force with a normal part
    (|f . n| > 1e-6 |f| + 1e-14), a force above mu f_n (1 + 1e-9) + 1e-10.  Pairs apart at
    exactly zero force are dropped (LAMMPS's dump local lists every pair within the neighbour
    cutoff); the tiny normal part allowed is projected away.  A force above mu f_n by at most
    ``cap`` (kn d0) is put back on the cone, |f_t| = mu f_n: a packing engine passes its rest
    tolerance, since LAMMPS caps |f_t| by mu times the normal force with the damping of the last
    step's velocities, which the rest check bounds (measured: 1.1e-10 above at force_tol 1e-9).
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    force = np.asarray(force, dtype=float).reshape(pairs.shape[0], -1)
    n, dim = positions.shape
    if force.shape[1] != dim:
        raise InputError(f"{where}: the tangential forces have {force.shape[1]} components, the packing is {dim}D")
    if not np.all(np.isfinite(force)):
        raise InputError(f"{where}: a tangential force is NaN or infinite")
    bad = np.flatnonzero((pairs < 0).any(axis=1) | (pairs >= n).any(axis=1))
    if bad.size:
        raise InputError(f"{where}: contact {bad[0]} names particle index {pairs[bad[0]].tolist()}, not among the "
                         f"packing's {n} particles")
    if np.any(pairs[:, 0] == pairs[:, 1]):
        self_pair = pairs[pairs[:, 0] == pairs[:, 1]][0, 0]
        raise InputError(f"{where}: a contact pairs a particle with itself (index {self_pair})")
    flip = pairs[:, 0] > pairs[:, 1]
    pairs = np.sort(pairs, axis=1)
    force = np.where(flip[:, None], -force, force)
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))
    pairs, force = pairs[order], force[order]
    twice = np.flatnonzero(np.all(pairs[1:] == pairs[:-1], axis=1))
    if twice.size:
        raise InputError(f"{where}: the pair {pairs[twice[0]].tolist()} (0-based indices) is listed more than once")
    normal, _, overlap = geometry.pair_geometry(positions, diameters, box, pairs)
    keep = (overlap > 0.0) | np.any(force != 0.0, axis=1)  # LAMMPS also lists near pairs, at zero force
    pairs, force, normal, overlap = pairs[keep], force[keep], normal[keep], overlap[keep]
    apart = np.flatnonzero(overlap <= 0.0)
    if apart.size:
        k = apart[0]
        raise InputError(f"{where}: {apart.size} listed pair(s) carry a force but do not touch in the packing "
                         f"(first: particles {pairs[k].tolist()}, 0-based, at overlap {overlap[k]:.3e} d0 <= 0); a "
                         f"stored force needs a contact: the contact file and the packing file must be written at the "
                         f"same step (a wet packing's bridges are pairs apart too: LIGGGHTS lists them; read it with "
                         f"model.cohesion)")
    along = np.einsum("cd,cd->c", force, normal)
    size = np.linalg.norm(force, axis=1)
    tilted = np.flatnonzero(np.abs(along) > NORMAL_PART_TOL * size + NORMAL_PART_FLOOR)
    if tilted.size:
        k = tilted[0]
        raise InputError(f"{where}: the stored force of pair {pairs[k].tolist()} is not tangential: its part along the "
                         f"contact normal is {abs(along[k]) / size[k]:.2e} of it (> {NORMAL_PART_TOL:g}); the file "
                         f"must hold the tangential force alone")
    force = force - along[:, None] * normal
    if friction is not None:
        fn = _normal_force(pairs, overlap, diameters, law)
        limit = friction * fn
        onto = (size > limit) & (size - limit <= cap)
        force[onto] *= (limit[onto] / size[onto])[:, None]
        size[onto] = limit[onto]
        over = np.flatnonzero(size > friction * fn * (1.0 + COULOMB_SLACK) + COULOMB_FLOOR)
        if over.size:
            k = over[0]
            raise InputError(f"{where}: {over.size} contact(s) carry a tangential force above the Coulomb limit "
                             f"mu f_n with mu = packing.friction = {friction:g} (first: pair {pairs[k].tolist()}, "
                             f"|f_t| / f_n = {size[k] / fn[k]:.6g}, {size[k] / (friction * fn[k]) - 1:.2e} above the limit, "
                             f"|f_t| - mu f_n = {size[k] - friction * fn[k]:.2e} kn d0); give the mu the packing was "
                             f"made with")
    return TangentialForces(pairs, force, friction)


def _normal_force(pairs: np.ndarray, overlap: np.ndarray, diameters: np.ndarray, law: str) -> np.ndarray:
    """f_n (C,) of pairs (C, 2) at their overlaps under ``law``."""
    reduced = contact_law.reduced_radius(diameters[pairs[:, 0]], diameters[pairs[:, 1]])
    return contact_law.normal_force(np.maximum(overlap, 0.0), law, reduced)


def at_limit(force: np.ndarray, pairs: np.ndarray, overlap: np.ndarray, diameters: np.ndarray, law: str,
             friction: float | None) -> np.ndarray:
    """(C,) bool: contacts (pairs (C, 2), overlaps (C,)) whose tangential force (C, D) is at the
    Coulomb limit, |f_t| >= mu f_n (1 - 1e-9) under the normal ``law``; none when mu is None, and
    never a contact with no stored force (at mu = 0 every contact carries none: it has no slip
    direction to slide along, and the packing is frictionless)."""
    if friction is None:
        return np.zeros(pairs.shape[0], dtype=bool)
    fn = _normal_force(pairs, overlap, diameters, law)
    size = np.linalg.norm(force, axis=1)
    return (size > 0.0) & (size >= friction * fn * (1.0 - COULOMB_SLACK))


def mobilised(stored: TangentialForces, positions: np.ndarray, diameters: np.ndarray, box,
              law: str) -> np.ndarray:
    """(C,) bool: the stored contacts at the Coulomb limit (:func:`at_limit`)."""
    _, _, overlap = geometry.pair_geometry(positions, diameters, box, stored.pairs)
    return at_limit(stored.force, stored.pairs, overlap, diameters, law, stored.friction)
