"""Figures of the damped modes (``spectrum.method: pep``), from ``io.results.damped_modes``:
the damping rate sigma against the damped frequency omega_d coloured by K/Q, the quality factor
Q(omega_d), and the damped vDOS beside the undamped one when a file of the same packings is given.

Never imports petsc4py or mpi4py.  Each function writes ``<stem>.png`` and ``<stem>.pdf`` and
returns their paths ([] when it has nothing to draw).  Not collective.  Units: 1/t0.
"""

from __future__ import annotations

import numpy as np

from ..io.results import DampedModes
from .common import legend, log_ticks, plt, rho_label, rho_list, save


def plot_damped_modes(modes: dict[float, DampedModes], stem: str) -> list[str]:
    """Two panels per file: sigma(omega_d) of every underdamped mode (coloured by log10 K/Q when
    the file has energies; overdamped roots at omega_d = 0 as crosses), and Q(omega_d) = omega_d
    / 2 sigma on log axes, every rho in one figure."""
    if not modes:
        return []
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4))
    colours = plt.cm.viridis(np.linspace(0, 0.85, len(modes)))
    scatter = None
    for colour, (rho, m) in zip(colours, sorted(modes.items())):
        under = m.lam.imag > 0
        omega, sigma = m.lam.imag[under], -m.lam.real[under]
        if m.K is not None and len(modes) == 1:
            ratio = np.log10(np.maximum(m.K[under], 1e-300) / np.maximum(m.Q[under], 1e-300))
            scatter = ax.scatter(omega, sigma, c=ratio, s=3, cmap="coolwarm", vmin=-2, vmax=2, lw=0)
        else:
            ax.plot(omega, sigma, ".", ms=2, color=colour, label=rho_label(rho))
        over = ~under
        if over.any():
            ax.plot(np.zeros(over.sum()), -m.lam.real[over], "x", ms=4, color="tab:red",
                    label=f"overdamped roots ({over.sum()})" if len(modes) == 1 else None)
        bx.loglog(omega, omega / (2 * sigma), ".", ms=2, color=colour, label=rho_label(rho))
    if scatter is not None:
        fig.colorbar(scatter, ax=ax, label=r"$\log_{10} K/Q$")
    ax.set(xlabel=r"$\omega_d\,t_0$", ylabel=r"$\sigma\,t_0$",
           title=rf"damping rate $\sigma$ of each mode, {rho_list(modes)}")
    bx.set(xlabel=r"$\omega_d\,t_0$", ylabel=r"$Q = \omega_d / 2\sigma$",
           title=rf"quality factor $Q(\omega_d)$, {rho_list(modes)}")
    log_ticks(bx.xaxis)
    log_ticks(bx.yaxis)
    for axis in (ax, bx):
        legend(axis, fontsize=7)
    fig.tight_layout()
    return save(fig, stem)


def plot_damped_vdos(modes: dict[float, DampedModes], bin_width: float, stem: str,
                     undamped: dict[float, np.ndarray] | None = None) -> list[str]:
    """The damped vDOS (histogram of omega_d of the underdamped modes, unit area) of each rho, the
    undamped g(omega) of the same rho dashed when ``undamped`` ({rho: omega}) is given."""
    if not modes:
        return []
    fig, ax = plt.subplots(figsize=(6, 4))
    colours = plt.cm.viridis(np.linspace(0, 0.85, len(modes)))
    for colour, (rho, m) in zip(colours, sorted(modes.items())):
        omega = m.lam.imag[m.lam.imag > 0]
        edges = np.arange(0.0, omega.max(initial=bin_width) + 2 * bin_width, bin_width)
        ax.stairs(np.histogram(omega, edges, density=True)[0], edges, color=colour, label=f"damped, {rho_label(rho)}")
        if undamped and rho in undamped:
            ax.stairs(np.histogram(undamped[rho], edges, density=True)[0], edges, color=colour, ls="--",
                      label=f"undamped, {rho_label(rho)}")
    both = ", undamped dashed" if undamped else ""
    ax.set(xlabel=r"$\omega_d\,t_0$", ylabel=r"$g(\omega_d)\,t_0$",
           title=rf"damped vDOS: $\omega_d$ of the underdamped modes{both}, {rho_list(modes)}")
    legend(ax, fontsize=7)
    fig.tight_layout()
    return save(fig, stem)
