"""Dispersion fits: damped cosine (eq:damped), Lorentzian, power laws, the lattice model's
(a_r, l) fit, k_c (where the RT and TR branches exchange).

numpy/scipy only (no PETSc).  Units: omega, gamma in 1/t0; k in 1/d0.  The lattice model itself
(eq:omega_t(k), eq:omega_r(k)) is in ``lattice``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, signal

from . import lattice


@dataclass(frozen=True)
class DampedFit:
    """C(t) = exp(-gamma t) cos(omega t): values, 1-sigma errors, rms residual, fit window."""

    omega: float
    gamma: float
    omega_err: float
    gamma_err: float
    rms: float
    t_max: float


def _peak_guess(t, c):
    dt = t[1] - t[0]
    spectrum = np.abs(np.fft.rfft(c * np.hanning(c.size), n=8 * c.size))
    omega = 2 * np.pi * np.fft.rfftfreq(8 * c.size, d=dt)
    return float(omega[np.argmax(spectrum[1:]) + 1])


def fit_damped_cosine(t: np.ndarray, c: np.ndarray, decay_window: float = 3.0) -> DampedFit:
    """Least-squares fit of exp(-gamma t) cos(omega t) to C(t) (scipy.optimize.curve_fit).

    The fit uses t <= decay_window / gamma (C decayed to about e^-3, PHYSICS.md section 5), found
    by fitting twice; parameter errors are the square roots of the covariance diagonal.
    """
    def model(x, omega, gamma):
        return np.exp(-gamma * x) * np.cos(omega * x)

    omega0 = _peak_guess(t, c)
    envelope = np.abs(c)
    tail = np.nonzero(envelope > np.exp(-1))[0]
    gamma0 = 1.0 / max(t[tail[-1]] if tail.size else t[-1], t[1])
    params, cov, mask = (omega0, gamma0), None, t <= t[-1]
    for _ in range(2):
        t_max = min(t[-1], decay_window / max(params[1], 1e-12))
        mask = t <= t_max
        if mask.sum() < 8:
            mask = np.arange(t.size) < 8
        params, cov = optimize.curve_fit(model, t[mask], c[mask], p0=params, maxfev=20000)
        params = (abs(params[0]), params[1])
    residual = c[mask] - model(t[mask], *params)
    err = np.sqrt(np.clip(np.diag(cov), 0, None))
    return DampedFit(float(params[0]), float(params[1]), float(err[0]), float(err[1]),
                     float(np.sqrt(np.mean(residual**2))), float(t[mask][-1]))


def fit_lorentzian(omega: np.ndarray, power: np.ndarray, width: float = 5.0) -> tuple[float, float]:
    """(omega_0, gamma) of A gamma / ((w - w0)^2 + gamma^2) fitted around the peak of S(w).

    The starting gamma is the half width at half maximum of the highest peak
    (``scipy.signal.peak_widths`` at half its height above zero), fitted over
    |w - w_peak| <= ``width`` x that half width.  ``omega`` (W,) evenly spaced, ``power`` (W,).
    """
    i = int(np.argmax(power))
    step = omega[1] - omega[0]
    # prominence = the peak's height above 0 and bases at the ends: the width is taken at power[i] / 2
    above_zero = (np.array([power[i]]), np.array([0]), np.array([power.size - 1]))
    full = signal.peak_widths(power, [i], rel_height=0.5, prominence_data=above_zero)[0][0]  # in samples
    gamma0 = max(0.5 * full * step, step)
    window = np.abs(omega - omega[i]) <= width * gamma0

    def model(w, w0, gamma, amp):
        return amp * gamma / ((w - w0) ** 2 + gamma**2)

    params, _ = optimize.curve_fit(model, omega[window], power[window],
                                   p0=(omega[i], gamma0, power[i] * gamma0), maxfev=20000)
    return float(params[0]), float(abs(params[1]))


def power_law(k: np.ndarray, gamma: np.ndarray) -> tuple[float, float]:
    """Exponent p and its 1-sigma error of gamma = b k^p (straight-line fit in log-log)."""
    (p, _), cov = np.polyfit(np.log(k), np.log(gamma), 1, cov=True) if k.size > 2 else \
        (np.polyfit(np.log(k), np.log(gamma), 1), np.full((2, 2), np.nan))
    return float(p), float(np.sqrt(cov[0, 0]))


def exchange_k(k_rt: np.ndarray, omega_rt: np.ndarray, k_tr: np.ndarray, omega_tr: np.ndarray) -> float:
    """k_c (1/d0): where the RT and TR branches exchange; NaN if they do not.  Not collective.

    The paper (Fig. 5 text): at k_c the RT frequency drops from branch (iv) to (ii) while the TR
    frequency jumps from (i) to (iii), so RT lies above TR for k < k_c and below it beyond.  With
    d(k) = omega_rt - omega_tr on the k where both are finite, k_c is the zero of d linearly
    interpolated between the last k with d >= 0 and the next one; d < 0 at every larger k, so a
    noisy point that dips below TR before the exchange cannot make an earlier k_c.  NaN if d >= 0
    at the largest k (no exchange: rho >= 1), if d < 0 from the first k, or with no finite pair.
    No threshold and no step size enter, so k_c does not depend on the k spacing beyond the linear
    interpolation of d.  k (K,) ascending, omega (K,) in 1/t0; RT and TR must be sampled on the
    same k (one scene excites every mode at the same k), else ValueError.
    """
    k = np.asarray(k_rt, float)
    if k.shape != np.shape(k_tr) or not np.array_equal(k, np.asarray(k_tr, float)):
        raise ValueError(f"RT and TR sampled on different k ({np.size(k_rt)} and {np.size(k_tr)} values): "
                         "the branch exchange needs one k grid")
    d = np.asarray(omega_rt, float) - np.asarray(omega_tr, float)
    finite = np.isfinite(d)
    k, d = k[finite], d[finite]
    above = np.nonzero(d >= 0)[0]
    if above.size == 0 or above[-1] == d.size - 1:
        return np.nan
    i = int(above[-1])
    return float(k[i] + d[i] / (d[i] - d[i + 1]) * (k[i + 1] - k[i]))


def fit_lattice(data: list[tuple[float, np.ndarray, np.ndarray]], k_max: float = np.pi / 2,
                guess: tuple[float, float] = (0.7, 0.45)) -> tuple[float, float, float, float]:
    """Joint fit of (a_r, l) of omega_r over all rho on the long-wave part k d0 <= k_max.

    data: (rho, k (K,), omega_r (K,)) per rho.  Returns (a_r, a_r_err, l, l_err).
    """
    rows = [(rho, k[k <= k_max], w[k <= k_max]) for rho, k, w in data]

    def residual(params):
        a_r, l = params
        return np.concatenate([lattice.lattice_omega(k, rho, l, 1.0, a_r)[1] - w for rho, k, w in rows])

    result = optimize.least_squares(residual, guess, bounds=([0.01, 0.05], [10.0, 2.0]))
    dof = max(1, result.fun.size - 2)
    cov = np.linalg.pinv(result.jac.T @ result.jac) * np.sum(result.fun**2) / dof
    err = np.sqrt(np.diag(cov))
    return float(result.x[0]), float(err[0]), float(result.x[1]), float(err[1])
