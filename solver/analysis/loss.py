"""Scattering against loss (issue 29 item 5): how much of a standing wave's attenuation is the
disorder's scattering and how much the dashpots' loss.

For each mode (L, TR, RT; R in 3D) and wave number k of two runs on the same packings, one
without dashpots and one with them:
    gamma_s(k)   the decay rate of the undamped VAF (scattering alone, the paper's gamma),
    gamma(k)     the decay rate of the damped VAF,
    <sigma>(w)   the damping rate of the damped modes at the wave's frequency w = omega(k), their
                 Gaussian-weighted mean (width ``width``) over the modes lambda = -sigma + i omega_d
                 of the damped spectrum (``spectrum.method: pep``).
Where damping is weak the two losses add: the wave is a packet of modes near omega(k), each of
which decays at its sigma on top of the dephasing that scattering causes, so
gamma ~ gamma_s + <sigma>(omega(k)); ``additivity`` tabulates the three and the relative
deviation (gamma - gamma_s - <sigma>) / gamma, which shows where it breaks.

numpy only (no PETSc).  Not collective.  Units: omega, gamma, sigma in 1/t0; k in 1/d0.
"""

from __future__ import annotations

import numpy as np


def mean_rate(lam: np.ndarray, omega: float, width: float) -> tuple[float, float]:
    """(<sigma>, effective number of modes): the mean of sigma = -Re lambda over the underdamped
    modes ``lam`` (Im > 0), weighted by exp(-(omega_d - omega)^2 / 2 width^2), and
    (sum w)^2 / sum w^2 of those weights; (NaN, 0) when no mode is within 5 widths."""
    under = lam[lam.imag > 0]
    weight = np.exp(-0.5 * ((under.imag - omega) / width) ** 2)
    weight[np.abs(under.imag - omega) > 5 * width] = 0.0
    total = weight.sum()
    if total == 0.0:
        return float("nan"), 0.0
    return float((weight * -under.real).sum() / total), float(total**2 / (weight**2).sum())


def additivity(damped: dict, undamped: dict, lam: dict, width: float) -> list[dict]:
    """Rows (mode, rho, k, omega, gamma, gamma_s, sigma, sum, deviation, modes) for every
    (rho, mode) fitted in both ``damped`` and ``undamped`` (``io.results.fits``: per (rho, mode)
    arrays k, omega, gamma) whose rho has damped modes in ``lam`` ({rho: lambda}); the k of the
    damped run, matched to the undamped run's same k (both runs use the same n, box and axes)."""
    rows = []
    for (rho, mode), fit in sorted(damped.items()):
        if (rho, mode) not in undamped or rho not in lam:
            continue
        ref = undamped[(rho, mode)]
        for i, k in enumerate(fit["k"]):
            j = int(np.argmin(np.abs(ref["k"] - k)))
            if not np.isclose(ref["k"][j], k, rtol=1e-9, atol=0.0):
                continue
            sigma, count = mean_rate(lam[rho], float(fit["omega"][i]), width)
            gamma, gamma_s = float(fit["gamma"][i]), float(ref["gamma"][j])
            total = gamma_s + sigma
            rows.append({"mode": mode, "rho": rho, "k": float(k), "omega": float(fit["omega"][i]), "gamma": gamma,
                         "gamma_s": gamma_s, "sigma": sigma, "sum": total,
                         "deviation": (gamma - total) / gamma if gamma else float("nan"), "modes": count})
    return rows
