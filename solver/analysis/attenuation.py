"""Regimes of the acoustic attenuation gamma(k) of L and TR waves: which fitted points a run
resolves, the local exponent, and the Ioffe-Regel wave number.

* A point is resolved when its fitted decay is visible in the run: gamma t_end >= 1 (``dispersion``'s
  power law uses this rule).  Below that the damped-cosine fit sees at most the first
  few per cent of the decay, where the loss of a plane wave to the other modes is not yet
  exponential: such gamma are an upper bound of the early loss, not an attenuation.
* Local exponent p(k) = d ln gamma / d ln k between neighbouring resolved k: d + 1 for Rayleigh
  scattering by elastic disorder (gamma ~ omega^(d+1), 3 for disks), 2 in the diffusive regime.
* Ioffe-Regel: omega = pi Gamma with Gamma = 2 gamma the full width at half maximum of the
  Lorentzian S(k, omega) (Shintani & Tanaka, Nat. Mater. 7, 870 (2008)), i.e. omega / (2 pi gamma)
  falls to 1: the wave's amplitude decays by 1/e within one period.
Pure numpy, no MPI.  Units: k in 1/d0, omega and gamma in 1/t0, t_end in t0.
"""

from __future__ import annotations

import numpy as np


def resolved(gamma: np.ndarray, t_end: float) -> np.ndarray:
    """(K,) bool: finite positive gamma with gamma t_end >= 1."""
    gamma = np.asarray(gamma, dtype=float)
    with np.errstate(invalid="ignore"):
        return np.isfinite(gamma) & (gamma > 0) & (gamma * t_end >= 1.0)


def local_exponents(k: np.ndarray, gamma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k_mid (K-1,), p (K-1,)): d ln gamma / d ln k between consecutive points of increasing k
    (k > 0, gamma > 0), at the geometric mean of each pair's k."""
    k, gamma = np.asarray(k, dtype=float), np.asarray(gamma, dtype=float)
    if k.size != gamma.size or np.any(np.diff(k) <= 0) or np.any(k <= 0) or np.any(gamma <= 0):
        raise ValueError("local_exponents needs increasing k > 0 and gamma > 0 of the same length")
    lk, lg = np.log(k), np.log(gamma)
    return np.exp(0.5 * (lk[1:] + lk[:-1])), np.diff(lg) / np.diff(lk)


def ioffe_regel(k: np.ndarray, omega: np.ndarray, gamma: np.ndarray) -> tuple[float, float]:
    """(k_IR, omega_IR): the first k (increasing) at which omega / (2 pi gamma) falls to 1,
    interpolated linearly in ln k and ln of that ratio between the bracketing points, and omega
    there, linear in ln k and ln omega between the same points; (NaN, NaN) when no consecutive pair
    brackets it (the ratio stays above 1, or starts below).  Points with a non-finite or
    non-positive omega or gamma are skipped."""
    k, omega, gamma = (np.asarray(a, dtype=float) for a in (k, omega, gamma))
    with np.errstate(invalid="ignore"):
        keep = np.isfinite(omega) & np.isfinite(gamma) & (omega > 0) & (gamma > 0)
    k, omega, ratio = k[keep], omega[keep], omega[keep] / (2 * np.pi * gamma[keep])
    crossing = np.nonzero((ratio[:-1] > 1.0) & (ratio[1:] <= 1.0))[0]
    if crossing.size == 0:
        return float("nan"), float("nan")
    i = crossing[0]
    a, b = np.log(ratio[i]), np.log(ratio[i + 1])
    share = a / (a - b)
    return (float(np.exp(np.log(k[i]) + (np.log(k[i + 1]) - np.log(k[i])) * share)),
            float(np.exp(np.log(omega[i]) + (np.log(omega[i + 1]) - np.log(omega[i])) * share)))
