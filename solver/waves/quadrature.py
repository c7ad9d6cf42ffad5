"""The autocorrelation of a standing wave's start, C_a(t) = <v(0), v(t)>_M / <v(0), v(0)>_M =
a^T cos(sqrt(A) t) a / |a|^2 (a = M^1/2 v(0), A = M^-1/2 D M^-1/2), by Gauss quadrature from
Lanczos: a quadratic form, exact to polynomial degree 2m - 1 after m steps, so about half the
steps of the bilinear z(t) of ``spectral``.  It is the part of the paper's C(k, t) along the
start only: docs/waves_theory.md, "Gauss quadrature and what the waves read", says what the
rest is and why the waves unit's outputs (z, C, S) keep the bilinear path.
Collective on the matrix's communicator.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.operators import largest_omega
from .lanczos import Recurrences, cos_sqrt, operator, refuse_unstable, scaled_starts, tridiagonal_eigen
from .spectral import BATCH


@dataclass
class StartCorrelation:
    """One wave's C_a at the times t (S,) (C_a(0) = 1), its weight |a|^2 = v(0)^T M v(0) for pooling
    runs (pooled C_a = sum_r |a_r|^2 C_a,r / sum_r |a_r|^2), the Lanczos steps taken and the error
    estimate (absolute, i.e. relative to C_a(0) = 1; 0 for a closed Krylov space)."""

    t: np.ndarray
    c: np.ndarray
    weight: float
    steps: int
    error_estimate: float


def start_correlations(dm, positions, waves: list[tuple[str, int, float]], *, amplitude: float, times: np.ndarray,
                       tol: float = 1e-8, omega_max: float | None = None) -> list[StartCorrelation]:
    """C_a of every wave (mode, run of ``excitation.runs(mode, dm.dim)``, k), in chunks of
    ``spectral.BATCH`` side by side (:func:`_side_by_side`).  ``times`` (S,) t0, ascending.
    Symmetric matrices without dashpots only (the caller checks).  Collective."""
    if omega_max is None:
        omega_max = largest_omega(dm)
    times = np.asarray(times, dtype=float)
    return [c for i in range(0, len(waves), BATCH)
            for c in _side_by_side(dm, positions, waves[i:i + BATCH], amplitude=amplitude, times=times, tol=tol,
                                   omega_max=omega_max)]


def gauss_steps(omega_max: float, t_end: float) -> int:
    """The first step count tried: degree 2m - 1 must reach n* = omega_max t_end / 2 + 4 (omega_max
    t_end)^(1/3), past which the Chebyshev coefficients 2 (-1)^n J_2n(omega_max t) of cos(t sqrt(lambda))
    on [0, omega_max^2] are below ~1e-9 (J_nu(x) falls like an Airy tail past nu = x), plus the 10
    steps the estimate drops (docs/waves_theory.md).  Measured smallest counts at tol 1e-8:
    omega_max t_end / 4 + 6, + 10, + 19 for omega_max t_end = 922, 1393, 1405 (N = 256, 512, 2048)."""
    degree = omega_max * t_end
    return int(np.ceil(0.25 * degree + 2.0 * np.cbrt(degree))) + 10


def _side_by_side(dm, positions, waves, *, amplitude: float, times: np.ndarray, tol: float,
                  omega_max: float) -> list[StartCorrelation]:
    """C_a of up to ``BATCH`` waves from one set of recurrences (``lanczos.Recurrences``): from
    :func:`gauss_steps`, steps grow by a fifth until every wave's C_a from T_m and from its leading
    (m - 10) block agree to ``tol`` (the estimate reported), or its Krylov space has closed (T
    exact: estimate 0).  Rank 0 evaluates and broadcasts.  Collective."""
    mpi = dm.D.getComm().tompi4py()
    a, norm_a = scaled_starts(dm, positions, waves, amplitude, mpi)
    recurrences = Recurrences(operator(dm), a / norm_a, (), 1e-13 * omega_max**2)  # floor: ``spectral``'s
    del a

    def evaluate(alphas, betas, _, sizes, closed):
        return [gauss_correlation(alphas[:sizes[i], i], betas[:sizes[i] - 1, i], times, closed[i])
                for i in range(len(waves))]

    try:
        results, sizes = recurrences.converge(gauss_steps(omega_max, times[-1]), tol, evaluate)
    finally:
        recurrences.destroy()
    return [StartCorrelation(times, c, float(norm_a[i]**2), sizes[i], float(estimate))
            for i, (c, estimate) in enumerate(results)]


def gauss_correlation(alpha, beta, times: np.ndarray, exact: bool = False) -> tuple[np.ndarray, float]:
    """(C (S,), estimate): the Gauss quadrature e_1^T cos(sqrt(T) t) e_1 = sum_i s_i0^2
    cos(sqrt(theta_i) t) of the m x m tridiagonal T (diagonal ``alpha`` (m,), off-diagonal
    ``beta`` (m - 1,); eigenpairs (theta_i, s_i)) at ``times`` (S,), and max_t |C_m - C_(m-10)|,
    the change from dropping the last 10 steps (0 when ``exact``: T of a closed Krylov space;
    inf for m <= 20).  Not collective."""
    def c_of(m):
        theta, S = tridiagonal_eigen(alpha[:m], beta[:m - 1])
        weights = S[0] ** 2
        return np.concatenate([weights @ cos_sqrt(theta, times[start:start + 1024])
                               for start in range(0, len(times), 1024)])  # (m, 1024) cosines at a time

    m = len(alpha)
    refuse_unstable(alpha, beta[:m - 1], float(np.max(times)))
    c = c_of(m)
    if exact:
        return c, 0.0
    return c, (float(np.abs(c - c_of(m - 10)).max()) if m > 20 else np.inf)
