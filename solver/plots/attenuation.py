"""The Rayleigh-to-diffusive figure: attenuation gamma(k) of the L and TR waves and its local
exponent (``analysis.attenuation``), from ``io.results.fits``.

Never imports petsc4py or mpi4py.  Writes ``<stem>.png`` and ``<stem>.pdf`` and returns their
paths ([] when it has nothing to draw).  Not collective.  Units: k in 1/d0, gamma in 1/t0.
"""

from __future__ import annotations

import numpy as np

from ..analysis import attenuation
from .common import legend, log_ticks, plt, rho_label, save

_STYLE = {("L", 0): ("tab:blue", "o"), ("TR", 0): ("tab:red", "s"),
          ("L", 1): ("navy", "o"), ("TR", 1): ("darkred", "s")}


def plot_attenuation_regimes(fits: dict, stem: str, dim: int = 2) -> list[str]:
    """Left: gamma(k) of L and TR for every rho, filled where the run resolves the decay (gamma
    t_end >= 1), open where it does not (an upper bound of the early loss); the level gamma =
    1 / t_end dashed; guides ~ k^(d+1) (Rayleigh) and ~ k^2 (diffusive) from the first resolved
    point of the first curve; Ioffe-Regel k (omega = 2 pi gamma) as a star.  Right: the local exponent
    d ln gamma / d ln k between neighbouring resolved points, with d + 1 and 2 marked, on a range
    holding them and every exponent."""
    acoustic = sorted((rho, mode) for rho, mode in fits if mode in ("L", "TR"))
    if not acoustic:
        return []
    rhos = sorted({rho for rho, _ in acoustic})
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.4))
    resolved_k, exponents = [], [1.0, dim + 2.0]
    for rho, mode in acoustic:
        fit = fits[(rho, mode)]
        k, gamma, omega, t_end = fit["k"], fit["gamma"], fit["omega"], float(fit["t_end"])
        color, marker = _STYLE[(mode, min(rhos.index(rho), 1))]
        ls = "-" if rho == rhos[-1] else ":"
        label = f"{mode}, {rho_label(rho)}"
        resolved = attenuation.resolved(gamma, t_end)
        with np.errstate(invalid="ignore"):
            early = np.isfinite(gamma) & (gamma > 0) & ~resolved
        ax.loglog(k[resolved], gamma[resolved], marker + ls, color=color, ms=4, lw=0.8, label=label)
        ax.loglog(k[early], gamma[early], marker, color=color, ms=4, mfc="none", lw=0)
        k_ir, omega_ir = attenuation.ioffe_regel(k, omega, gamma)
        if np.isfinite(k_ir):
            ax.loglog([k_ir], [omega_ir / (2 * np.pi)], "*", color=color, ms=11,
                      mec="k", mew=0.5)
        if resolved.sum() >= 2:
            k_mid, p = attenuation.local_exponents(k[resolved], gamma[resolved])
            bx.semilogx(k_mid, p, marker + ls, color=color, ms=4, lw=0.8, label=label)
            exponents += list(p[np.isfinite(p)])
            resolved_k.append((k[resolved], gamma[resolved]))
        ax.axhline(1.0 / t_end, color="0.6", ls="--", lw=0.6)
    for k_r, g_r in resolved_k[:1]:  # slopes from the first resolved point of one curve, over a factor 4 in k
        guide = np.geomspace(k_r[0], 4 * k_r[0], 8)
        ax.loglog(guide, g_r[0] * (guide / k_r[0])**(dim + 1), "k-", lw=2, alpha=0.25,
                  label=rf"$\propto k^{dim + 1}$ (Rayleigh)")
        ax.loglog(guide, g_r[0] * (guide / k_r[0])**2, "k--", lw=2, alpha=0.25, label=r"$\propto k^2$ (diffusive)")
    ax.set(xlabel=r"$k\,d_0$", ylabel=r"$\gamma\,t_0$",
           title=r"attenuation (open: $\gamma\,t_{end} < 1$, not resolved; $\star$: Ioffe-Regel)")
    legend(ax, ncol=2)
    for level, text in ((dim + 1, f"$d + 1$ = {dim + 1}"), (2, "2")):
        bx.axhline(level, color="0.5", lw=0.6)
        bx.annotate(text, (0.01, level), xycoords=("axes fraction", "data"), fontsize=7, va="bottom")
    margin = 0.05 * (max(exponents) - min(exponents))
    bx.set(xlabel=r"$k\,d_0$", ylabel=r"$d \ln\gamma\,/\,d \ln k$", title="local exponent (resolved points)",
           ylim=(min(exponents) - margin, max(exponents) + margin))
    for axis in (ax.xaxis, ax.yaxis, bx.xaxis):
        log_ticks(axis)
    legend(bx)
    fig.tight_layout()
    return save(fig, stem)
