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

from ..errors import InputError
from ..model import contact_law
from .. import profiling
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
        separation = np.stack((px[self.i] - px[self.j] + self.shift_x,
                               py[self.i] - py[self.j] + self.shift_y), axis=1)
        pair_force, energy = contact_law.normal_pair(separation, self.contact)  # eq:eij, rho = 0
        n = x.shape[0]
        force = np.empty_like(x)
        for axis in range(2):
            f = pair_force[:, axis]
            force[:, axis] = np.bincount(self.i, f, minlength=n) - np.bincount(self.j, f, minlength=n)
        return force, float(energy.sum())


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
        "energy": float(np.sum(contact_law.normal_energy(found.overlap))),
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


@profiling.logged("rsPackingFIRE")
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


PHI_JAMMING = 0.84
"""Where this mixture jams (O'Hern et al., PRE 68, 011306 (2003)); finite packings scatter around
it (measured: at N = 256, 2 of 4 seeds jam at phi = 0.84, all at 0.845; at N = 16, 19 of 20 at 0.85)."""


def jamming_failure(packing: Packing) -> str | None:
    """Why the dynamical matrix cannot be built on ``packing``, or None if it can. Not collective.

    Decision: refused when no disk is left after removing rattlers (FIRE relaxed every overlap
    to ``force_tol``: the packing did not jam; its matrix has 0 DOF and the solvers die), or when
    the N' non-rattlers share fewer than 2N' - 1 contacts.  A rigid contact network in a periodic
    box needs 2(N' - 1) contacts for its 2N' DOF less the two translations, plus one to carry a
    positive pressure (the isostatic count; Goodrich, Liu & Nagel, PRL 109, 095704 (2012)); fewer
    means a floppy cluster held only by FIRE's residual overlaps, whose matrix has zero modes
    besides the two translations that the spectrum and KPM take as the only ones.  That count is
    the minimum of non-rattlers, rather than a fixed number: it needs at least 5 disks (4 disks
    make at most 6 < 7 contacts), and every packing measured that jammed passes it (N = 16 to
    1024, phi = 0.83 to 0.9, 90 seeds; the smallest margin was 1 contact).
    """
    stats = describe(packing.positions, packing.diameters, packing.box_length, packing.rattler)
    n_active = packing.n - int(packing.rattler.sum())
    if n_active == 0:
        return f"all {packing.n} disks are rattlers (pressure {stats['pressure']:.1e})"
    if stats["n_contacts"] < 2 * n_active - 1:
        return (f"only {n_active} of {packing.n} disks are not rattlers and they share "
                f"{stats['n_contacts']} contacts, fewer than the 2N' - 1 = {2 * n_active - 1} of a "
                f"rigid packing (pressure {stats['pressure']:.1e})")
    return None


def require_jammed(packings: list[Packing], phi: float) -> None:
    """Raise InputError naming ``packing.phi`` if any generated configuration did not jam
    (:func:`jamming_failure`). Not collective (the same verdict on every rank)."""
    failures = [(index, why) for index, p in enumerate(packings) if (why := jamming_failure(p))]
    if not failures:
        return
    index, why = failures[0]
    what = (f"configuration {index} did not jam: {why}" if len(failures) == 1 else
            f"configurations {', '.join(str(i) for i, _ in failures)} of {len(packings)} did not jam "
            f"(configuration {index}: {why})")
    raise InputError(f"packing.phi = {phi}: {what}; this mixture jams near phi = {PHI_JAMMING} and "
                     f"small packings scatter around it: choose a larger packing.phi (the paper's is 0.9)")
