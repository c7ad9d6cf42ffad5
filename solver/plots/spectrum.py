"""Figures of the spectrum against omega, from ``io.results``: the vDOS g(omega) (Fig. 1), the
kinetic and potential energies K and Q of the modes (Fig. 6), the participation ratio of every
mode (localisation), and the vDOS of several results files overlaid (Fig. S1).

Never imports petsc4py or mpi4py.  Each function writes ``<stem>.png`` and ``<stem>.pdf`` and
returns their paths ([] when it has nothing to draw).  Not collective.  Units: 1/t0, m d0^2/t0^2.
"""

from __future__ import annotations

import numpy as np

from ..io import results
from ..spectrum.modes import bin_average
from .common import legend, log_ticks, plt, rho_label, save, series_colour


def _centres(edges):
    return 0.5 * (edges[1:] + edges[:-1])


def plot_vdos(vdos: dict, stem: str, damped: bool = False) -> list[str]:
    """Fig. 1: g(omega) for every rho of ``vdos`` ({rho: results.Vdos}), rho = 0 dotted, omega_c
    marked by an arrow down to just above the axis (the axis reaching past every omega_c); empty
    bins left blank, not drawn as g = 0 (a bin between two empty ones as a dot); ``damped``: the file's vDOS is that of the damped
    frequencies omega_d (spectrum.method pep), and the title and axes say so.  A rho whose
    spectrum holds no modes (an empty ``spectrum.window``: omega_c NaN) is left out."""
    vdos = {rho: v for rho, v in vdos.items() if np.isfinite(v.omega_c)}
    if not vdos:
        return []
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for index, rho in enumerate(sorted(vdos)):
        v = vdos[rho]
        style = {"ls": ":", "color": "k"} if rho == 0 else {"color": series_colour(index, len(vdos))}
        held = v.density > 0
        ax.plot(_centres(v.edges), np.where(held, v.density, np.nan), label=rho_label(rho), **style)
        alone = held & ~np.r_[False, held[:-1]] & ~np.r_[held[1:], False]  # no segment to show them
        ax.plot(_centres(v.edges)[alone], v.density[alone], ".", ms=3, color=style["color"])
        ax.annotate("", xy=(v.omega_c, 0.03), xytext=(v.omega_c, 0.15), xycoords=("data", "axes fraction"),
                    arrowprops={"arrowstyle": "->", "color": style["color"], "lw": 0.8})
    top = max(max(v.edges[-1], v.omega_c) for v in vdos.values())
    w = r"\omega_d" if damped else r"\omega"
    what = r"vDOS of the damped frequencies $\omega_d$" if damped else "vibrational density of states"
    ax.set(xlabel=rf"${w}\,t_0$", ylabel=rf"$g({w})\,t_0$", xlim=(0, 1.03 * top), ylim=(0, None),
           title=rf"{what} (arrows: $\omega_c$; gaps: empty bins)")
    legend(ax, fontsize=8)
    fig.tight_layout()
    return save(fig, stem)


def plot_energies(vdos: dict, per_mode: dict, binned: dict, stem: str, rhos=None) -> list[str]:
    """Fig. 6: bin-averaged K (blue dotted) and Q (red) with g(omega) x 5e-3 (dashed), per rho
    (every rho > 0 with energies, or those of ``rhos`` in that order).  ``per_mode``: {rho: (omega,
    K, Q)} (``results.mode_energies``), averaged over the vDOS bins; ``binned``: {rho:
    results.BinnedEnergies} (KPM), each configuration weighted by its modes in the bin."""
    have = sorted(r for r in {*per_mode, *binned} if r > 0 and r in vdos)
    rhos = have if rhos is None else [r for r in rhos if r in have]
    if not rhos:
        return []
    fig, axes = plt.subplots(1, len(rhos), figsize=(4.2 * len(rhos), 3.8), squeeze=False)
    for ax, rho in zip(axes[0], rhos):
        edges = vdos[rho].edges
        for index, (key, style) in enumerate((("K", {"color": "tab:blue", "ls": ":"}), ("Q", {"color": "tab:red"}))):
            if rho in per_mode:
                x, curve = _centres(edges), bin_average(per_mode[rho][0], per_mode[rho][1 + index], edges)
            else:
                b = binned[rho]
                with np.errstate(invalid="ignore"):
                    curve = np.nansum(b.density * b[2 + index], axis=0) / b.density.sum(axis=0)
                x = _centres(b.edges)
            ax.semilogy(x, curve, label=f"${key}$", **style)
        density = vdos[rho].density
        ax.semilogy(_centres(edges), 5e-3 * np.where(density > 0, density, np.nan), "k--", lw=0.8,  # empty bins: gaps
                    label=r"$g(\omega)\,t_0 \times 5\cdot10^{-3}$")
        ax.set(xlabel=r"$\omega\,t_0$", ylabel=r"$K$, $Q$ ($m\,d_0^2/t_0^2$)", title=rho_label(rho))
        log_ticks(ax.yaxis)
        legend(ax, fontsize=8)
    fig.tight_layout()
    return save(fig, stem)


def plot_participation(per_mode: dict[float, tuple[np.ndarray, np.ndarray]], kept: list[results.ModeShapes], stem: str,
                       bin_width: float = 0.1) -> list[str]:
    """Participation ratio P of every mode against omega (``results.participation``), one colour
    per rho, with its mean per ``bin_width`` bin as a line; the modes kept whole (``kept``,
    ``results.mode_shapes``) circled.  Log P axis: 1 for a mode spread evenly over every particle,
    ~1/N on one particle.  A rho with no modes (an empty ``spectrum.window``) is left out."""
    per_mode = {rho: values for rho, values in per_mode.items() if values[0].size}
    if not per_mode:
        return []
    fig, ax = plt.subplots(figsize=(7, 4.5), layout="constrained")
    colours = plt.cm.viridis(np.linspace(0, 0.85, len(per_mode)))
    for colour, (rho, (omega, p)) in zip(colours, sorted(per_mode.items())):
        ax.scatter(omega, p, s=2, color=colour, alpha=0.25, linewidths=0, rasterized=True)
        edges = np.arange(0.0, omega.max() + bin_width, bin_width)
        ax.plot(0.5 * (edges[1:] + edges[:-1]), bin_average(omega, p, edges), color=colour, lw=1.5,
                label=f"{rho_label(rho)} ({omega.size} modes)")
    for g in kept:
        ax.scatter(g.omega, g.participation, s=60, facecolors="none", edgecolors="tab:red", linewidths=1.2)
    ax.set(yscale="log", xlabel=r"$\omega\,t_0$", ylabel=r"participation ratio $P$",
           title="localisation: $P$ of every mode (dots), bin means (lines)" + (",\nmodes kept whole circled" if kept
                                                                                  else ""))
    log_ticks(ax.yaxis)
    legend(ax, fontsize=8)
    return save(fig, stem)


def plot_vdos_compare(paths: list[str], stem: str) -> list[str]:
    """Fig. S1: g(omega) of several results files (e.g. different phi, or frictional packings of
    different mu) overlaid, one panel per rho."""
    curves: dict[float, list] = {}
    for path in paths:
        with results.open_results(path) as f:
            phi, n = results.packing_summary(f)
            mu = results.packing_friction(f)
            for rho, v in results.vdos(f).items():
                curves.setdefault(rho, []).append((phi, n, mu, v.edges, v.density))
    if not curves:
        return []
    rhos = sorted(curves)
    fig, axes = plt.subplots(1, len(rhos), figsize=(4.2 * len(rhos), 3.6), squeeze=False)
    for ax, rho in zip(axes[0], rhos):
        for phi, n, mu, edges, density in sorted(curves[rho], key=lambda c: (c[0], -1 if c[2] is None else c[2])):
            ax.plot(_centres(edges), density, lw=1,
                    label=rf"$\phi$ = {phi:.3f} ($N$ = {n})" + ("" if mu is None else rf", $\mu$ = {mu:g}"))
        ax.set(xlabel=r"$\omega\,t_0$", ylabel=r"$g(\omega)\,t_0$", title=rho_label(rho), ylim=(0, None))
        legend(ax, fontsize=7)
    fig.tight_layout()
    return save(fig, stem)
