"""Figures of how far the modes carry energy, from ``io.results``: the Allen-Feldman diffusivity
d(omega) of every mode and its mean on the vDOS's bins (the scene's ``transport`` section;
docs/diffusivity.md).

Never imports petsc4py or mpi4py.  Each function writes ``<stem>.png`` and ``<stem>.pdf`` and
returns their paths ([] when it has nothing to draw).  Not collective.  Units: omega in 1/t0,
d in d0^2/t0.
"""

from __future__ import annotations

import numpy as np

from .common import legend, log_ticks, plt, rho_label, save, series_colour


def plot_diffusivity(diffusivity: dict, stem: str) -> list[str]:
    """d(omega) for every rho of ``diffusivity`` ({rho: results.Diffusivity}): each mode's d_n as a
    dot (exact), the bin means as a line with their standard error as a band (kpm), on a log scale
    of d; eta in the title (exact)."""
    if not any(np.isfinite(g.d_binned).any() for g in diffusivity.values()):
        return []
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for index, rho in enumerate(sorted(diffusivity)):
        g = diffusivity[rho]
        colour = "k" if rho == 0 else series_colour(index, len(diffusivity))
        ax.plot(g.omega, g.d, ".", ms=2, alpha=0.35, color=colour)
        centres = 0.5 * (g.edges[1:] + g.edges[:-1])
        ax.plot(centres, g.d_binned, "-", color=colour, label=rho_label(rho))
        if np.isfinite(g.d_err).any():
            ax.fill_between(centres, g.d_binned - g.d_err, g.d_binned + g.d_err, color=colour, alpha=0.25, lw=0)
    etas = sorted({g.eta for g in diffusivity.values() if np.isfinite(g.eta)})
    how = (rf"$\eta$ = {', '.join(f'{e:g}' for e in etas)}/$t_0$; dots: modes, lines: bin means" if etas
           else "kpm: bin means, bands: standard error")
    ax.set(xlabel=r"$\omega\,t_0$", ylabel=r"$d(\omega)\;[d_0^2/t_0]$", xlim=(0, None), yscale="log")
    ax.set_title(f"Allen-Feldman diffusivity\n{how}", fontsize=11)
    legend(ax, fontsize=8)
    log_ticks(ax.yaxis)
    fig.tight_layout()
    return save(fig, stem)
