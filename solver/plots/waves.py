"""Figures of the standing waves and their analysis, from ``io.results``: the velocity
autocorrelations C(k, t) (Fig. 2), the spectra S(k, omega) (Fig. 3), the fitted dispersion of
every mode and of RT with the lattice model (Fig. 4), the RT transition (Fig. 5), the RT band
against rho (Fig. 7), phase speeds and attenuation of L and TR (Figs. S2, S3).

Never imports petsc4py or mpi4py; the correlations come from ``waves.correlations.pooled`` and
the model curves from ``analysis.lattice`` (eq:omega_t(k), eq:omega_r(k), fig:band_RT).  Each
function writes ``<stem>.png`` and ``<stem>.pdf`` and returns their paths ([] when it has nothing
to draw).  Not collective.  Units: k in 1/d0, omega and gamma in 1/t0.
"""

from __future__ import annotations

import numpy as np

from ..analysis import lattice
from ..waves import correlations
from .common import legend, log_ticks, plt, rho_label, save, series_colour

MODES = ("L", "TR", "RT", "R")  # R: angular velocity along k, 3D only


def plot_vafs(waves: dict, stem: str, kd0: float = 0.38 * np.pi, rhos=None) -> list[str]:
    """Fig. 2: C_l, C_t, C_r (and C_R of the 3D twist mode R, when run) at the k nearest
    k d0 = 0.38 pi, per rho (rho = 0 dotted); every rho of ``waves`` ({(rho, mode): results.Waves}) or only those in ``rhos``."""
    if not waves:
        return []
    present = [(m, label) for m, label in zip(MODES, ("$C_l$", "$C_t$", "$C_r$", "$C_R$"))
               if any(w == m for _, w in waves)]
    fig, axes = plt.subplots(1, len(present), figsize=(4 * len(present), 3.6), squeeze=False)
    for ax, (mode, label) in zip(axes[0], present):
        for rho in sorted(r for r, m in waves if m == mode and (rhos is None or r in rhos)):
            w = waves[(rho, mode)]
            i = int(np.argmin(np.abs(w.k - kd0)))
            c = correlations.pooled(w.z[:, [i]], w.t[1] - w.t[0])[0][0]
            ax.plot(w.t, c, ":" if rho == 0 else "-", lw=1, label=rf"{rho_label(rho)}, $k\,d_0$ = {w.k[i]:.3f}")
        ax.axhline(0, color="0.7", lw=0.5)
        ax.set(xlabel=r"$t\,/\,t_0$", ylabel=label, title=f"{mode} mode")
        legend(ax, fontsize=7)
    fig.tight_layout()
    return save(fig, stem)


def _spectrum(w):
    """omega (W,) and S (K, W) of one (rho, mode) (results.Waves), runs pooled, each record
    tapered so that its cut at t_end does not stripe the map (``correlations`` module)."""
    _, omega, power = correlations.pooled(w.z, w.t[1] - w.t[0], taper=True)
    return omega, power


def plot_spectra(waves: dict, stem: str, rhos=None) -> list[str]:
    """Fig. 3: log10 S_alpha(k, omega) maps (L, TR, RT, and R in 3D) for each rho of ``waves`` (or each in ``rhos``),
    of the tapered records (:func:`_spectrum`); one file ``<stem>_rho<rho>`` per rho."""
    written: list[str] = []
    for rho in sorted({r for r, _ in waves if rhos is None or r in rhos}):
        modes_here = [m for m in MODES if (rho, m) in waves]
        fig, axes = plt.subplots(1, len(modes_here), figsize=(4.2 * len(modes_here), 3.8), squeeze=False)
        for ax, mode in zip(axes[0], modes_here):
            w = waves[(rho, mode)]
            omega, power = _spectrum(w)
            top = min(omega[-1], 1.15 * w.omega_max)
            keep = omega <= top
            mesh = ax.pcolormesh(w.k, omega[keep], np.log10(power[:, keep].T + 1e-30), shading="nearest",
                                 cmap="Greys", vmin=np.log10(power.max()) - 6)
            fig.colorbar(mesh, ax=ax, label=r"$\log_{10} S$ (record tapered, $\cos^2$)")
            ax.set(xlabel=r"$k\,d_0$", ylabel=r"$\omega\,t_0$", title=f"{mode}, {rho_label(rho)}")
        fig.tight_layout()
        written += save(fig, f"{stem}_rho{rho:g}")
    return written


def _of_mode(fits: dict, mode: str) -> list[tuple[float, dict]]:
    """(rho, fit) of one mode, by rho."""
    return sorted(((rho, fit) for (rho, m), fit in fits.items() if m == mode), key=lambda item: item[0])


def lattice_curve(k, rho, lattice_fit: dict, edge: bool = False):
    """(omega_t, omega_r) of the lattice model (eq:omega_t(k), eq:omega_r(k)) with the fitted
    parameters ``lattice_fit`` (``results.lattice``); with ``edge``, omega_t uses ``analysis.lattice.edge_a_t``."""
    a_t = lattice.edge_a_t(lattice_fit) if edge else lattice_fit["a_t"]
    return lattice.lattice_omega(k, rho, lattice_fit["l"], a_t, lattice_fit["a_r"])


def plot_dispersion(fits: dict, stem: str) -> list[str]:
    """Fitted omega(k) of every mode run (L, TR, RT and, in 3D, R), one panel per rho; drawn
    when the file has more than the paper's RT to show (``fits``: {(rho, mode): fit})."""
    rhos = sorted({rho for rho, _ in fits})
    if not rhos or {mode for _, mode in fits} <= {"RT"}:
        return []
    fig, axes = plt.subplots(1, len(rhos), figsize=(3.6 * len(rhos), 3.6), squeeze=False, sharey=True)
    for ax, rho in zip(axes[0], rhos):
        for mode, marker, color in zip(MODES, "os^D", ("tab:blue", "tab:green", "tab:red", "tab:purple")):
            if (rho, mode) in fits:
                fit = fits[(rho, mode)]
                ax.plot(fit["k"], fit["omega"], marker, ms=3.5, mfc="none", color=color, label=mode)
        ax.set(xlabel=r"$k\,d_0$", title=rho_label(rho))
        legend(ax, fontsize=7)
    axes[0][0].set(ylabel=r"$\omega\,t_0$ (fit of $C(k, t)$)")
    fig.tight_layout()
    return save(fig, stem)


def plot_dispersion_rt(fits: dict, lattice_fit: dict | None, stem: str) -> list[str]:
    """Fig. 4: fitted omega_r(k) (symbols) for every rho > 0 with the lattice model (lines).
    ``fits``: {(rho, mode): fit} (``results.fits``)."""
    rt = [(rho, fit) for rho, fit in _of_mode(fits, "RT") if rho > 0]
    if not rt or lattice_fit is None:
        return []
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    k_line = np.linspace(0, lattice_fit["k_max"], 200)
    for index, (rho, fit) in enumerate(rt):
        color = series_colour(index, len(rt))
        ax.plot(fit["k"], fit["omega"], "o", ms=3.5, mfc="none", color=color, label=rho_label(rho))
        ax.plot(k_line, lattice_curve(k_line, rho, lattice_fit)[1], "-", lw=0.9, color=color)
    ax.axvline(lattice_fit["kd0_max_used"], color="0.6", ls=":", lw=0.8)
    ax.set(xlabel=r"$k\,d_0$", ylabel=r"$\omega_r\,t_0$", title=rf"RT dispersion; lines: lattice model, $a_r$ = "
           rf"{lattice_fit['a_r']:.3f}$/t_0$, $l$ = {lattice_fit['l']:.3f} $d_0$ (fit left of the dotted line)")
    ax.title.set_fontsize(8)
    legend(ax, ncol=2)
    fig.tight_layout()
    return save(fig, stem)


def plot_transition(fits: dict, lattice_fit: dict | None, waves: dict, stem: str, rho: float = 0.2) -> list[str]:
    """Fig. 5: (a) log10 S_r(k, omega) with k_c, (b) fitted omega_t and omega_r with both model
    branches, at the analysed rho nearest ``rho``.  ``waves``: {(rho, mode): results.Waves}."""
    rt = dict(_of_mode(fits, "RT"))
    if not rt or lattice_fit is None:
        return []
    rho = min(rt, key=lambda r: abs(r - rho))
    if (rho, "RT") not in waves:
        return []
    fit_rt, fit_tr = rt[rho], fits.get((rho, "TR"))
    w = waves[(rho, "RT")]
    omega, power = _spectrum(w)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4))
    top = 1.1 * np.nanmax(fit_rt["omega"]) + 1
    keep = omega <= top
    mesh = ax.pcolormesh(w.k, omega[keep], np.log10(power[:, keep].T + 1e-30), shading="nearest", cmap="Greys",
                         vmin=np.log10(power.max()) - 5)
    fig.colorbar(mesh, ax=ax, label=r"$\log_{10} S_r$ (record tapered, $\cos^2$)")
    k_c = float(fit_rt["k_c"])
    if np.isfinite(k_c):
        ax.annotate("$k_c$", xy=(k_c, 0.02 * top), xytext=(k_c, 0.25 * top), color="tab:red",
                    arrowprops={"arrowstyle": "->", "color": "tab:red"}, ha="center")
    ax.set(xlabel=r"$k\,d_0$", ylabel=r"$\omega\,t_0$", title=rf"(a) $\log_{{10}} S_r(k, \omega)$, {rho_label(rho)}")
    k_line = np.linspace(0, lattice_fit["k_max"], 200)
    w_t, w_r = lattice_curve(k_line, rho, lattice_fit)
    if np.isfinite(lattice_fit.get("a_t_edge", np.nan)):
        bx.plot(k_line, lattice_curve(k_line, rho, lattice_fit, edge=True)[0], ":", color="tab:purple",
                label=rf"model $\omega_t$, $a_t$ = {lattice_fit['a_t_edge']:.2f} (fit beyond $k_c$)")
    if fit_tr is not None:
        bx.plot(fit_tr["k"], fit_tr["omega"], "+", color="tab:blue", label=r"$\omega_t$ (TR fit)")
    bx.plot(fit_rt["k"], fit_rt["omega"], "s", mfc="none", color="tab:red", label=r"$\omega_r$ (RT fit)")
    bx.plot(k_line, w_t, ":", color="tab:blue", label=rf"model $\omega_t$, $a_t$ = {lattice_fit['a_t']:.2f} (TR fit)")
    bx.plot(k_line, w_r, "-", color="tab:red", label=r"model $\omega_r$")
    if np.isfinite(k_c):
        bx.axvline(k_c, color="0.5", lw=0.8, ls="--")
    bx.set(xlabel=r"$k\,d_0$", ylabel=r"$\omega\,t_0$", title=f"(b) fitted dispersion, {rho_label(rho)}"
           + (rf", $k_c\,d_0$ = {k_c:.2f}" if np.isfinite(k_c) else r", no $k_c$ detected"))
    legend(bx, fontsize=7)
    fig.tight_layout()
    return save(fig, stem)


def plot_bands(lattice_fit: dict | None, bands: dict | None, stem: str, omega_c: dict | None = None) -> list[str]:
    """Fig. 7: RT band limits against rho (data symbols; model lines omega_r(0), omega_r(k_max),
    omega_t(k_max) of ``analysis.lattice`` and the shaded band), omega_c (crosses; ``omega_c`` maps rho ->
    value, else the bands' own); the same on log-log axes beside (an inset would hide curves).
    ``bands``: ``results.bands``."""
    if lattice_fit is None or bands is None:
        return []
    b = bands
    rho_line = np.linspace(1e-3, max(2.0, b["rho"].max()), 300)
    a_t = lattice.edge_a_t(lattice_fit)
    r0 = lattice.omega_r_zero(rho_line, lattice_fit["a_r"])
    rk = lattice.omega_r_kmax(rho_line, lattice_fit["a_r"])
    tk = lattice.omega_t_kmax(rho_line, a_t)
    fig, (ax, inset) = plt.subplots(1, 2, figsize=(10, 4.6), gridspec_kw={"width_ratios": [3, 2]})
    cross = omega_c if omega_c is not None else dict(zip(b["rho"], b["omega_c"]))
    for axis in (ax, inset):
        axis.fill_between(rho_line, np.minimum(r0, rk), np.maximum(r0, rk), color="0.9")
        axis.plot(rho_line, r0, "-", color="tab:red", label=r"model $\omega_r(0) = a_r\sqrt{40\rho}$")
        axis.plot(rho_line, rk, ":", color="tab:blue", label=r"model $\omega_r(k_{max}) = 2 a_r\sqrt{3\rho + 1}$")
        axis.plot(rho_line, tk, "--", color="tab:green",
                  label=rf"model $\omega_t(k_{{max}}) = a_t\sqrt{{10\rho}}$, $a_t$ = {a_t:.2f}")
        axis.plot(b["rho"], b["omega_r0"], "o", mfc="none", color="tab:red", label=r"$\omega_r(0)$, data")
        axis.plot(b["rho"], b["omega_r_kmax"], "s", mfc="none", color="tab:blue", label=r"$\omega_r(k_{max})$, data")
        axis.plot(b["rho"], b["omega_t_kmax"], "^", mfc="none", color="tab:green", label=r"$\omega_t(k_{max})$, data")
        rc = sorted((r, w) for r, w in cross.items() if r > 0 and np.isfinite(w))
        if rc:
            axis.plot(*zip(*rc), "x", color="k", label=r"$\omega_c$ (vDOS)")
    inset.set(xscale="log", yscale="log", xlabel=r"$\rho$", ylabel=r"$\omega\,t_0$", title="the same, log-log")
    log_ticks(inset.xaxis)
    log_ticks(inset.yaxis)
    ax.set(xlabel=r"$\rho = k_t / k_n$", ylabel=r"$\omega\,t_0$", title="RT frequency band (shaded: model)")
    legend(ax, loc="upper left")
    fig.tight_layout()
    return save(fig, stem)


def plot_speeds_attenuation(fits: dict, stem: str) -> list[str]:
    """Figs. S2 and S3: phase speeds c = omega/k and attenuation gamma(k) (log-log, k^3 guide) of
    L and TR (a column each, of those run), per rho."""
    modes = [m for m in ("L", "TR") if any(mode == m for _, mode in fits)]
    if not modes:
        return []
    fig, axes = plt.subplots(2, len(modes), figsize=(5 * len(modes), 7), squeeze=False)
    rhos = sorted({rho for rho, mode in fits if mode in modes})
    for col, mode in enumerate(modes):
        for rho, fit in _of_mode(fits, mode):
            color = "k" if rho == 0 else series_colour(rhos.index(rho), len(rhos))
            k, gamma = fit["k"], fit["gamma"]
            axes[0, col].plot(k, fit["c"], "o-" if rho else "o:", ms=2.5, lw=0.7, color=color, label=rho_label(rho))
            good = gamma > 0
            p = float(fit["power_law_p"])
            axes[1, col].loglog(k[good], gamma[good], "o-" if rho else "o:", ms=2.5, lw=0.7, color=color,
                                label=rho_label(rho) + (f", $p$ = {p:.2f}" if np.isfinite(p) else ", no power law"))
        k_guide = np.array([0.2, 1.0])
        axes[1, col].loglog(k_guide, 0.05 * k_guide**3, "k-", lw=2, alpha=0.4, label=r"$\propto k^3$")
        axes[0, col].set(xlabel=r"$k\,d_0$", ylabel=rf"$c_{mode.lower()[0]}$ ($d_0/t_0$)", title=f"phase speed, {mode}")
        axes[1, col].set(xlabel=r"$k\,d_0$", ylabel=rf"$\gamma_{mode.lower()[0]}\,t_0$", title=f"attenuation, {mode}")
        log_ticks(axes[1, col].xaxis)
        log_ticks(axes[1, col].yaxis)
        for ax in axes[:, col]:
            legend(ax, ncol=2)
    fig.tight_layout()
    return save(fig, stem)
