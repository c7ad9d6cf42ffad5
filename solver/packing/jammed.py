"""Jammed 50:50 bidisperse disk packings (the paper's Materials and Methods).

Diameters d_S = 2/2.4 and d_L = 1.4 d_S (mean d0 = 1), equal masses m = 1, periodic square box
with area fraction phi, uniform random start from a seed, FIRE on the frictionless harmonic
energy E_n = sum kn xi^2 / 2 until max_i |F_i| / m < force_tol (default 1e-6 kn d0 / m).

Rattlers [choice]: a disk with fewer than 3 contacts among the remaining non-rattlers is a
rattler; the rule is applied repeatedly until no new rattler appears.  Rattlers stay in the
packing (flagged) and are excluded from the dynamical matrix.  After minimisation disks are
renumbered in horizontal strips (by y, then x) so that contiguous rank blocks are compact in
space; the renumbering depends only on the packing, never on the number of ranks.
Not collective.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..model import contact_law
from . import fire
from . import geometry as contacts

SIZE_RATIO = 1.4
D_SMALL = 2.0 / (1.0 + SIZE_RATIO)
D_LARGE = SIZE_RATIO * D_SMALL
MIN_CONTACTS = 3


@dataclass(frozen=True)
class Packing:
    """One configuration (units d0 = m = kn = 1).

    positions : (N, 2) float64 in [0, L);  diameters : (N,) float64;  box_length : L;
    rattler : (N,) bool;  info : provenance and statistics (energy, pressure, z, ...).
    """

    positions: np.ndarray
    diameters: np.ndarray
    box_length: float
    rattler: np.ndarray
    info: dict = field(default_factory=dict)

    @property
    def n(self) -> int:
        return int(self.diameters.size)

    @property
    def phi(self) -> float:
        return float(np.pi * np.sum(self.diameters**2) / 4.0 / self.box_length**2)


def bidisperse_diameters(n: int) -> np.ndarray:
    """Diameters (n,): first n//2 small, the rest large."""
    d = np.full(n, D_LARGE)
    d[: n // 2] = D_SMALL
    return d


def box_length_for(diameters: np.ndarray, phi: float) -> float:
    """Side L of the square box in which ``diameters`` fill area fraction ``phi``."""
    return float(np.sqrt(np.pi * np.sum(diameters**2) / 4.0 / phi))


class _FrictionlessForces:
    """Harmonic normal forces with a Verlet list (skin) rebuilt after large moves.

    Positions are not wrapped during minimisation, so each listed pair keeps the periodic
    image shift found when the list was built; per step only gathers and bincounts remain.
    """

    def __init__(self, diameters: np.ndarray, box_length: float, skin: float = 0.3):
        self.diameters, self.box_length, self.skin = diameters, box_length, skin
        self.reference: np.ndarray | None = None
        self.rebuilds = 0

    def _rebuild(self, x: np.ndarray) -> None:
        pairs = contacts.candidate_pairs(x, self.box_length, float(self.diameters.max()) + self.skin)
        self.i, self.j = pairs[:, 0].copy(), pairs[:, 1].copy()
        delta = x[self.i] - x[self.j]
        shift = contacts.minimum_image(delta, self.box_length) - delta
        self.shift_x, self.shift_y = shift[:, 0].copy(), shift[:, 1].copy()
        self.contact = 0.5 * (self.diameters[self.i] + self.diameters[self.j])
        self.reference = x.copy()
        self.rebuilds += 1

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, float]:
        if self.reference is None or np.max(np.sum((x - self.reference) ** 2, axis=1)) > (0.5 * self.skin) ** 2:
            self._rebuild(x)
        px, py = x[:, 0], x[:, 1]
        dx = px[self.i] - px[self.j] + self.shift_x
        dy = py[self.i] - py[self.j] + self.shift_y
        distance = np.hypot(dx, dy)
        overlap = np.maximum(self.contact - distance, 0.0)
        scale = contact_law.normal_force(overlap) / distance
        n = x.shape[0]
        force = np.empty_like(x)
        for axis, d in ((0, dx), (1, dy)):
            f = scale * d
            force[:, axis] = np.bincount(self.i, f, minlength=n) - np.bincount(self.j, f, minlength=n)
        return force, 0.5 * contact_law.KN * float(np.dot(overlap, overlap))


def find_rattlers(positions: np.ndarray, diameters: np.ndarray, box_length: float) -> np.ndarray:
    """Rattler mask (N,): iteratively, disks with fewer than 3 contacts among non-rattlers."""
    found = contacts.find_contacts(positions, diameters, box_length)
    rattler = np.zeros(diameters.size, dtype=bool)
    while True:
        keep = ~rattler[found.i] & ~rattler[found.j]
        count = (np.bincount(found.i[keep], minlength=rattler.size)
                 + np.bincount(found.j[keep], minlength=rattler.size))
        new = ~rattler & (count < MIN_CONTACTS)
        if not new.any():
            return rattler
        rattler |= new


def describe(positions: np.ndarray, diameters: np.ndarray, box_length: float,
             rattler: np.ndarray) -> dict:
    """Energy, pressure (2D virial), mean contact number z and rattler fraction of a packing."""
    found = contacts.find_contacts(positions, diameters, box_length)
    fn = contact_law.normal_force(found.overlap)
    active = ~rattler
    keep = active[found.i] & active[found.j]
    n_active = int(active.sum())
    return {
        "energy": float(0.5 * np.sum(found.overlap**2) * contact_law.KN),
        "pressure": float(np.sum(fn * found.distance) / (2.0 * box_length**2)),
        "z": float(2.0 * keep.sum() / n_active) if n_active else 0.0,
        "rattler_fraction": float(rattler.mean()),
        "n_contacts": int(keep.sum()),
        "mean_overlap": float(found.overlap.mean()) if len(found) else 0.0,
    }


def strip_order(positions: np.ndarray, box_length: float, n: int) -> np.ndarray:
    """Permutation sorting disks into ~sqrt(n) horizontal strips, by x inside a strip."""
    strips = max(1, int(np.sqrt(n)))
    row = np.minimum((positions[:, 1] / box_length * strips).astype(int), strips - 1)
    return np.lexsort((positions[:, 0], row))


def generate(n: int, phi: float, seed: np.random.SeedSequence, force_tol: float = 1e-6,
             max_steps: int = 2_000_000) -> Packing:
    """Make one jammed packing of ``n`` disks at area fraction ``phi``. Not collective.

    Raises RuntimeError if FIRE does not reach ``force_tol`` within ``max_steps``.
    """
    rng = np.random.default_rng(seed)
    diameters = rng.permutation(bidisperse_diameters(n))  # mixed, so the sort below is safe
    box_length = box_length_for(diameters, phi)
    forces = _FrictionlessForces(diameters, box_length)
    start = rng.uniform(0.0, box_length, size=(n, 2))
    start = start[strip_order(start, box_length, n)]  # spatial order: cache-friendly gathers
    result = fire.minimize(start, forces, force_tol, max_steps)
    if not result.converged:
        raise RuntimeError(f"FIRE did not converge: max |F| = {result.max_force:.3e} > "
                           f"{force_tol:.1e} after {result.steps} steps (n={n}, phi={phi})")
    positions = contacts.wrap(result.x, box_length)
    order = strip_order(positions, box_length, n)
    positions, diameters = positions[order], diameters[order]
    rattler = find_rattlers(positions, diameters, box_length)
    info = describe(positions, diameters, box_length, rattler)
    info.update(fire_steps=result.steps, max_force=result.max_force, force_tol=force_tol,
                neighbour_rebuilds=forces.rebuilds)
    return Packing(positions, diameters, box_length, rattler, info)


def from_arrays(positions: np.ndarray, diameters: np.ndarray, box_length: float,
                rattler: np.ndarray | None = None, info: dict | None = None) -> Packing:
    """Build a :class:`Packing` from user arrays (e.g. another code's packing).

    Rattlers are computed with the iterative rule when ``rattler`` is None.
    """
    positions = contacts.wrap(np.asarray(positions, dtype=float), box_length)
    diameters = np.asarray(diameters, dtype=float)
    if rattler is None:
        rattler = find_rattlers(positions, diameters, box_length)
    stats = describe(positions, diameters, box_length, rattler)
    stats.update(info or {})
    return Packing(positions, diameters, float(box_length), np.asarray(rattler, dtype=bool), stats)
