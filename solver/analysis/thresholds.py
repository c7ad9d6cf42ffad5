"""Where a standing wave's contacts stop being linear springs (issue 46 point 4;
docs/finite_amplitude.md section 5): the amplitude at which each contact would open or slide,
predicted from the packing alone, and the crossover amplitude A* measured on a sweep.

Predicted, per contact c of the packing (unit normal n, branch length |b| = r_ij, overlap xi,
normal force f_n, stored tangential force f_t):
    opening slack  xi                                      (the overlap)
    sliding slack  s = (mu f_n - |f_t|) / k_t              (k_t = rho kn for the linear spring;
                                                            rho kn sqrt(a' xi) for hertz: the
                                                            Mindlin stiffness as LAMMPS's
                                                            gran/hertz/history has it)
The standing wave v_c(0) = A sin(k r_a) (eq:initial) of phase speed c_k = omega(k)/k has strain
amplitude eps = A / c_k.  Affinely [choice], with the particles turning with the medium (the
Cosserat long-wave limit: the shear's rotation moves no contact point), the relative
displacement of a contact is eps |b| E n, E the symmetric strain of unit amplitude
(L: e_a e_a; TR: (e_c e_a + e_a e_c)/2), so its normal and tangential parts reach
    delta_n = eps |b| |n.E.n|,   delta_t = eps |b| |E n - (n.E.n) n|
and the contact opens at A_open = c_k xi / (|b| |n.E.n|), slides at A_slide = c_k s / (|b| |E n -
(n.E.n) n|).  As A grows, contacts that opened lose their normal and tangential springs and
sliding ones their tangential spring; the share of the affine modulus sum_c |b|^2 (k_n (n.E.n)^2 +
k_t |E n - (n.E.n) n|^2) so lost (``lost_share``) makes omega ~ sqrt(modulus) fall by 1 % at a
share of 2 %: the predicted A*.  An estimate: the real displacements are not affine (larger near
jamming), and a contact opens or slides for part of each cycle only.

Measured (``crossover``): the smallest amplitude at which omega(k) or gamma(k) of a sweep departs
from its linear value (rotsound's linear waves of the same packing, or the sweep's smallest
amplitude) by ``tol`` (1 %) and by more than twice the fits' combined error, interpolated in
log A.

numpy only.  Not collective.  Units: d0 = m = kn = 1; A in d0/t0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import contact_law
from ..packing import mechanics

STRAIN_MODES = ("L", "TR")  # the modes with a strain at long wavelength (RT and R drive rotations)
OMEGA_SHARE = 0.02  # the share of the affine modulus lost for a 1 % fall of omega ~ sqrt(modulus)


@dataclass(frozen=True)
class Slacks:
    """Per contact (C,) of a packing's non-rattlers: ``normal`` (C, D), branch ``length`` r_ij,
    ``opening`` (the overlap xi) and ``sliding`` ((mu f_n - |f_t|)/k_t, 0 where already at the
    Coulomb limit) slacks (d0), and the stiffnesses (kn) ``kn`` of the normal spring (its tangent,
    df_n/dxi) and ``kt`` of the tangential one."""

    normal: np.ndarray
    length: np.ndarray
    opening: np.ndarray
    sliding: np.ndarray
    kn: np.ndarray
    kt: np.ndarray


def slacks(packing, rho: float, friction: float) -> Slacks:
    """The contacts' slacks of ``packing`` (``Packing``, its law ``packing.model.law``) under
    tangential springs k_t = ``rho`` kn (times sqrt(a' xi) under hertz) and Coulomb ``friction``
    (mu > 0, rho > 0).  Not collective."""
    if not (rho > 0.0 and friction > 0.0):
        raise ValueError(f"rho = {rho} and mu = {friction} must be positive: no tangential spring, nothing slides")
    found, f_n, f_t = mechanics.force_magnitudes(packing)
    d, law = packing.diameters, packing.model.law
    reduced = contact_law.reduced_radius(d[found.i], d[found.j])
    kt = rho * contact_law.spring_scale(found.overlap, law, reduced)
    kn = contact_law.normal_stiffness(found.overlap, law, reduced)
    sliding = np.maximum(friction * f_n - f_t, 0.0) / kt
    return Slacks(found.normal, found.distance, found.overlap, sliding, kn, kt)


def unit_strain(mode: str, component: int, axis: int, dim: int) -> np.ndarray:
    """E (D, D): the symmetric strain of unit amplitude of ``mode``'s run exciting velocity
    ``component`` with k along ``axis`` (``excitation.runs``).  ValueError for RT and R."""
    if mode not in STRAIN_MODES:
        raise ValueError(f"mode {mode}: the thresholds are those of the strain modes {STRAIN_MODES}")
    polar, along = np.eye(dim)[component], np.eye(dim)[axis]
    return 0.5 * (np.outer(polar, along) + np.outer(along, polar))


def _parts(s: Slacks, strain: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """|n.E.n| and |E n - (n.E.n) n| (C,) per contact: the normal and tangential relative
    displacement per unit strain and branch length."""
    stretch = s.normal @ strain
    normal = np.einsum("cd,cd->c", stretch, s.normal)
    return np.abs(normal), np.linalg.norm(stretch - normal[:, None] * s.normal, axis=1)


def affine_amplitudes(s: Slacks, strain: np.ndarray, speed: float) -> tuple[np.ndarray, np.ndarray]:
    """(A_open, A_slide) (C,) d0/t0: the velocity amplitude at which a standing wave of phase
    speed ``speed`` (omega/k, d0/t0) and unit strain ``strain`` (D, D) would open, and slide,
    each contact, affinely (module docstring); inf where its strain part vanishes."""
    normal, tangential = _parts(s, strain)
    with np.errstate(divide="ignore"):
        return (speed * s.opening / (s.length * normal), speed * s.sliding / (s.length * tangential))


def _losses(s: Slacks, strain: np.ndarray, speed: float) -> tuple[np.ndarray, np.ndarray]:
    """(amplitudes, cumulative share) of the affine modulus lost: sorted amplitudes at which a
    term goes (a contact's tangential term at the first of its opening and sliding, its normal
    term at its opening) and the share gone by each.  O(C log C)."""
    normal, tangential = _parts(s, strain)
    w_n, w_t = s.length**2 * s.kn * normal**2, s.length**2 * s.kt * tangential**2
    a_open, a_slide = affine_amplitudes(s, strain, speed)
    at = np.concatenate((np.minimum(a_open, a_slide), a_open))
    weight = np.concatenate((w_t, w_n))
    order = np.argsort(at, kind="stable")
    return at[order], np.cumsum(weight[order]) / (w_n + w_t).sum()


def lost_share(s: Slacks, strain: np.ndarray, speed: float, amplitudes: np.ndarray) -> np.ndarray:
    """(A,) share of the affine modulus lost at each of ``amplitudes``: the normal and tangential
    terms of contacts opened by then and the tangential terms of those sliding (module
    docstring).  Not collective."""
    at, lost = _losses(s, strain, speed)
    index = np.searchsorted(at, np.asarray(amplitudes, dtype=float), side="right")
    return np.where(index > 0, lost[np.maximum(index - 1, 0)], 0.0)


def predicted_crossover(s: Slacks, strain: np.ndarray, speed: float, share: float = OMEGA_SHARE) -> float:
    """The amplitude (d0/t0) at which :func:`lost_share` reaches ``share``: the predicted A*."""
    at, lost = _losses(s, strain, speed)
    reached = np.flatnonzero((lost >= share) & np.isfinite(at))
    return float(at[reached[0]]) if reached.size else float("inf")


def crossover(amplitude: np.ndarray, value: np.ndarray, error: np.ndarray, tol: float = 0.01,
              reference: np.ndarray | None = None, reference_error: np.ndarray | None = None) -> np.ndarray:
    """Measured A* per k (K,): the smallest amplitude where |value/value_0 - 1| reaches ``tol``
    and exceeds twice the combined 1-sigma error of the two fits; value_0 is the linear value
    ``reference`` (K,) with its ``reference_error`` (rotsound's linear waves of the same packing)
    or, without one, the first (smallest) amplitude's.  Log-linear between the two sweep points
    that straddle it; 0 where the smallest amplitude already departs (A* is below the sweep); NaN
    where it never does (or value_0 is not finite).  ``amplitude`` (A,) ascending, ``value``,
    ``error`` (A, K) (``results.Sweep``: omega or gamma and their errors)."""
    ref = value[0] if reference is None else np.asarray(reference, dtype=float)
    ref_err = error[0] if reference is None else np.asarray(reference_error, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        departure = np.abs(value / ref - 1.0)
        noise = 2.0 * np.hypot(error, ref_err) / np.abs(ref)
    out = np.full(value.shape[1], np.nan)
    for kk in range(value.shape[1]):  # K wave numbers: a handful
        over = np.flatnonzero((departure[:, kk] >= tol) & (departure[:, kk] > noise[:, kk]))
        if over.size == 0 or not np.isfinite(ref[kk]):
            continue
        i = over[0]
        if i == 0:
            out[kk] = 0.0 if reference is not None else np.nan
            continue
        lo, hi = np.log(amplitude[i - 1]), np.log(amplitude[i])
        d_lo, d_hi = departure[i - 1, kk], departure[i, kk]
        frac = 1.0 if not np.isfinite(d_lo) or d_hi == d_lo else np.clip((tol - d_lo) / (d_hi - d_lo), 0.0, 1.0)
        out[kk] = float(np.exp(lo + frac * (hi - lo)))
    return out


def from_linear_run(amplitude: float, opening: np.ndarray, coulomb: np.ndarray) -> tuple[float, float]:
    """(A_open, A_slide) d0/t0 at which the first contact opens and slides, scaled from a run at
    ``amplitude`` in the linear regime with its largest ratios over its samples (``Contacts``
    ``opening`` = (xi_0 - xi)/xi_0 and ``coulomb`` = |f_t|/(mu |f_n|), (S,)): both grow in
    proportion to A (for a packing without stored tangential forces; the coulomb ratio only to
    O(delta_n / xi), as f_n moves too).  NaN where the run already reached 1 (it is not
    linear).  Not collective."""
    out = []
    for ratio in (np.max(opening), np.max(coulomb)):
        out.append(float(amplitude / ratio) if 0.0 < ratio < 1.0 else float("nan"))
    return out[0], out[1]
