"""Figures: one function per figure of the paper, drawing arrays that ``io.results`` read from a
results file; :func:`plot_results` draws every figure a file has data for.

Never imports petsc4py or mpi4py; the correlations come from ``waves.correlations.pooled`` and
the model curves from ``analysis.lattice`` (eq:omega_t(k), eq:omega_r(k), fig:band_RT).  Each
function writes ``<stem>.png`` and ``<stem>.pdf`` and returns their paths ([] when it has nothing
to draw).  Not collective.  Symbols in labels, legends and titles are mathtext
(omega, rho, ...); rho is written to 3 significant figures (:func:`rho_label`).
"""

from __future__ import annotations

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import EllipseCollection  # noqa: E402
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter  # noqa: E402

from .waves import correlations  # noqa: E402
from .errors import InputError  # noqa: E402
from .analysis import lattice  # noqa: E402
from .io import results  # noqa: E402
from .spectrum.modes import bin_average  # noqa: E402


MODES = ("L", "TR", "RT", "R")  # R: angular velocity along k, 3D only


def _save(fig, stem: str) -> list[str]:
    """Write ``fig`` as PNG and PDF at ``stem``; a folder that cannot take them is bad input."""
    paths = [f"{stem}.png", f"{stem}.pdf"]
    try:
        for path in paths:
            fig.savefig(path, dpi=150)
    except OSError as exc:
        raise InputError(f"figure {path}: cannot write ({exc})") from None
    finally:
        plt.close(fig)
    return paths


def rho_label(rho: float) -> str:
    """rho for a legend or a title, to 3 significant figures (2/7: 0.286)."""
    return rf"$\rho$ = {rho:.3g}"


def rho_list(rhos) -> str:
    """Several rho for a title, each to 3 significant figures; more than 4 as their range."""
    rhos = sorted(rhos)
    if len(rhos) > 4:
        return rf"$\rho$ = {rhos[0]:.3g} to {rhos[-1]:.3g} ({len(rhos)} values)"
    return r"$\rho$ = " + ", ".join(f"{rho:.3g}" for rho in rhos)


def legend(ax, **style) -> None:
    """``ax.legend(**style)`` when ``ax`` has labelled artists (else matplotlib logs a warning)."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(**style)


def _log_label(value: float, _position=None) -> str:
    """A log tick's label: plain from 1e-3 to 1e4, else m x 10^e in mathtext."""
    if 1e-3 <= value < 1e4:
        return f"{value:g}"
    exponent = int(np.floor(np.log10(value) + 1e-9))  # 1e-7 is not 9.99...e-8
    mantissa = round(value / 10.0**exponent, 6)
    return rf"${mantissa:g}\times10^{{{exponent}}}$" if mantissa != 1 else rf"$10^{{{exponent}}}$"


def log_ticks(axis) -> None:
    """At least two labelled ticks on the log ``axis`` (``ax.xaxis`` or ``ax.yaxis``), whose limits
    are final.  matplotlib labels the powers of ten, so one on a range of a decade or two: then
    ticks at 1, 2 and 5 times them, labelled plainly (on a range too short to hold two of those,
    matplotlib's LogLocator gives evenly spaced ticks itself).  A linear axis is left alone."""
    if axis.get_scale() != "log":
        return
    low, high = sorted(axis.get_view_interval())
    decades = LogLocator().tick_values(low, high)
    if np.count_nonzero((decades >= low) & (decades <= high)) >= 2:
        return
    axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(_log_label))
    axis.set_minor_formatter(NullFormatter())


def section(positions: np.ndarray, diameters: np.ndarray, box: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(which (N,) bool, diameters (n,)) of the particles drawn in a plane picture: every disk in 2D;
    for spheres (positions (N, 3)) those cut by the plane z = L_z/2, as disks of diameter
    2 sqrt(R^2 - dz^2) (dz the periodic distance of the centre from the plane)."""
    if positions.shape[1] == 2:
        return np.ones(len(diameters), dtype=bool), diameters
    dz = positions[:, 2] - 0.5 * box[2]
    dz -= box[2] * np.rint(dz / box[2])
    cut = np.abs(dz) < 0.5 * diameters
    return cut, 2.0 * np.sqrt(0.25 * diameters[cut] ** 2 - dz[cut] ** 2)


def disks(ax, centres: np.ndarray, diameters: np.ndarray, **style) -> EllipseCollection:
    """Add disks of ``diameters`` at ``centres`` (n, 2) to ``ax`` as one collection, to scale (data
    units); ``style``: the collection's facecolors, edgecolors, cmap, ... Returns it."""
    collection = EllipseCollection(diameters, diameters, np.zeros_like(diameters), offsets=centres, units="xy",
                                   offset_transform=ax.transData, **style)
    ax.add_collection(collection)
    return collection


def plot_packing(packing: dict, stem: str) -> list[str]:
    """Disks of one configuration (``results.first_packing``), rattlers in red; units of d0.
    Spheres: their sections by the plane z = L_z/2 (:func:`section`)."""
    pos, diam = packing["positions"], packing["diameters"]
    rattler, box = packing["rattler"], packing["box"]
    colors = np.where(rattler, "tab:red", np.where(diam > diam.mean(), "0.55", "0.8"))
    cut, diam = section(pos, diam, box)
    pos, colors = pos[cut, :2], colors[cut]
    plane = ", section $z = L_z/2$" if box.size == 3 else ""
    fig, ax = plt.subplots(figsize=(6, 6))
    disks(ax, pos, diam, facecolors=colors, edgecolors="k", linewidths=0.2)
    ax.set(xlim=(0, box[0]), ylim=(0, box[1]), aspect="equal", xlabel=r"$x\,/\,d_0$", ylabel=r"$y\,/\,d_0$",
           title=rf"$N$ = {packing['diameters'].size}, $\phi$ = {packing['phi']:.3f}, $z$ = {packing['z']:.2f}, "
                 f"rattlers in red ({int(packing['rattler'].sum())}){plane}")
    return _save(fig, stem)


def _centres(edges):
    return 0.5 * (edges[1:] + edges[:-1])


def plot_vdos(vdos: dict, stem: str, damped: bool = False) -> list[str]:
    """Fig. 1: g(omega) for every rho of ``vdos`` ({rho: results.Vdos}), rho = 0 dotted, omega_c
    marked; ``damped``: the file's vDOS is that of the damped frequencies omega_d (spectrum.method
    pep), and the title and axes say so."""
    if not vdos:
        return []
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    cmap = plt.get_cmap("viridis")
    for index, rho in enumerate(sorted(vdos)):
        v = vdos[rho]
        style = {"ls": ":", "color": "k"} if rho == 0 else {"color": cmap(0.8 * index / max(1, len(vdos) - 1))}
        ax.plot(_centres(v.edges), v.density, label=rho_label(rho), **style)
        ax.annotate("", xy=(v.omega_c, 0), xytext=(v.omega_c, 0.08 * v.density.max()),
                    arrowprops={"arrowstyle": "->", "color": style["color"], "lw": 0.8})
    w = r"\omega_d" if damped else r"\omega"
    what = r"vDOS of the damped frequencies $\omega_d$" if damped else "vibrational density of states"
    ax.set(xlabel=rf"${w}\,t_0$", ylabel=rf"$g({w})\,t_0$", xlim=(0, None), ylim=(0, None),
           title=rf"{what} (arrows: $\omega_c$)")
    legend(ax, fontsize=8)
    fig.tight_layout()
    return _save(fig, stem)


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
        ax.semilogy(_centres(edges), 5e-3 * vdos[rho].density, "k--", lw=0.8,
                    label=r"$g(\omega)\,t_0 \times 5\cdot10^{-3}$")
        ax.set(xlabel=r"$\omega\,t_0$", ylabel=r"$K$, $Q$ ($m\,d_0^2/t_0^2$)", title=rho_label(rho))
        log_ticks(ax.yaxis)
        legend(ax, fontsize=8)
    fig.tight_layout()
    return _save(fig, stem)


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
    return _save(fig, stem)


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
        written += _save(fig, f"{stem}_rho{rho:g}")
    return written


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
    return _save(fig, stem)


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
    return _save(fig, stem)


def plot_dispersion_rt(fits: dict, lattice_fit: dict | None, stem: str) -> list[str]:
    """Fig. 4: fitted omega_r(k) (symbols) for every rho > 0 with the lattice model (lines).
    ``fits``: {(rho, mode): fit} (``results.fits``)."""
    rt = [(rho, fit) for rho, fit in _of_mode(fits, "RT") if rho > 0]
    if not rt or lattice_fit is None:
        return []
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    cmap = plt.get_cmap("viridis")
    k_line = np.linspace(0, lattice_fit["k_max"], 200)
    for index, (rho, fit) in enumerate(rt):
        color = cmap(0.9 * index / max(1, len(rt) - 1))
        ax.plot(fit["k"], fit["omega"], "o", ms=3.5, mfc="none", color=color, label=rho_label(rho))
        ax.plot(k_line, lattice_curve(k_line, rho, lattice_fit)[1], "-", lw=0.9, color=color)
    ax.axvline(lattice_fit["kd0_max_used"], color="0.6", ls=":", lw=0.8)
    ax.set(xlabel=r"$k\,d_0$", ylabel=r"$\omega_r\,t_0$", title=rf"RT dispersion; lines: lattice model, $a_r$ = "
           rf"{lattice_fit['a_r']:.3f}$/t_0$, $l$ = {lattice_fit['l']:.3f} $d_0$ (fit left of the dotted line)")
    ax.title.set_fontsize(8)
    legend(ax, fontsize=6, ncol=2)
    fig.tight_layout()
    return _save(fig, stem)


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
    return _save(fig, stem)


def plot_bands(lattice_fit: dict | None, bands: dict | None, stem: str, omega_c: dict | None = None) -> list[str]:
    """Fig. 7: RT band limits against rho (data symbols; model lines omega_r(0), omega_r(k_max),
    omega_t(k_max) of ``analysis.lattice`` and the shaded band), omega_c (crosses; ``omega_c`` maps rho ->
    value, else the bands' own), log-log inset.  ``bands``: ``results.bands``."""
    if lattice_fit is None or bands is None:
        return []
    b = bands
    rho_line = np.linspace(1e-3, max(2.0, b["rho"].max()), 300)
    a_t = lattice.edge_a_t(lattice_fit)
    r0 = lattice.omega_r_zero(rho_line, lattice_fit["a_r"])
    rk = lattice.omega_r_kmax(rho_line, lattice_fit["a_r"])
    tk = lattice.omega_t_kmax(rho_line, a_t)
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    inset = ax.inset_axes([0.62, 0.1, 0.35, 0.35])
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
    inset.set(xscale="log", yscale="log")
    inset.tick_params(labelsize=6)
    log_ticks(inset.xaxis)
    log_ticks(inset.yaxis)
    ax.set(xlabel=r"$\rho = k_t / k_n$", ylabel=r"$\omega\,t_0$", title="RT frequency band (shaded: model)")
    legend(ax, fontsize=6, loc="upper left")
    fig.tight_layout()
    return _save(fig, stem)


def plot_speeds_attenuation(fits: dict, stem: str) -> list[str]:
    """Figs. S2 and S3: phase speeds c = omega/k and attenuation gamma(k) (log-log, k^3 guide) of
    L and TR (a column each, of those run), per rho."""
    modes = [m for m in ("L", "TR") if any(mode == m for _, mode in fits)]
    if not modes:
        return []
    fig, axes = plt.subplots(2, len(modes), figsize=(5 * len(modes), 7), squeeze=False)
    cmap = plt.get_cmap("viridis")
    rhos = sorted({rho for rho, mode in fits if mode in modes})
    for col, mode in enumerate(modes):
        for rho, fit in _of_mode(fits, mode):
            color = "k" if rho == 0 else cmap(0.9 * rhos.index(rho) / max(1, len(rhos) - 1))
            k, gamma = fit["k"], fit["gamma"]
            axes[0, col].plot(k, fit["c"], "o-" if rho else "o:", ms=2.5, lw=0.7, color=color, label=rho_label(rho))
            good = gamma > 0
            axes[1, col].loglog(k[good], gamma[good], "o-" if rho else "o:", ms=2.5, lw=0.7, color=color,
                                label=f"{rho_label(rho)}, $p$ = {fit['power_law_p']:.2f}")
        k_guide = np.array([0.2, 1.0])
        axes[1, col].loglog(k_guide, 0.05 * k_guide**3, "k-", lw=2, alpha=0.4, label=r"$\propto k^3$")
        axes[0, col].set(xlabel=r"$k\,d_0$", ylabel=rf"$c_{mode.lower()[0]}$ ($d_0/t_0$)", title=f"phase speed, {mode}")
        axes[1, col].set(xlabel=r"$k\,d_0$", ylabel=rf"$\gamma_{mode.lower()[0]}\,t_0$", title=f"attenuation, {mode}")
        log_ticks(axes[1, col].xaxis)
        log_ticks(axes[1, col].yaxis)
        for ax in axes[:, col]:
            legend(ax, fontsize=5, ncol=2)
    fig.tight_layout()
    return _save(fig, stem)


def report_figures(data, folder: str) -> list[tuple[str, str]]:
    """Draw the reproduction report's figures into ``folder`` from the files that ``data``
    (``analysis.claims.Data``, filled by ``report.gather``) names; return (caption, png path) pairs."""
    os.makedirs(folder, exist_ok=True)
    out: list[tuple[str, str]] = []

    def keep(caption, paths):
        pngs = [p for p in paths if p.endswith(".png")]
        out.extend((caption if len(pngs) == 1 else f"{caption} ({os.path.basename(p)})", p) for p in pngs)

    if data.vdos_file:
        keep("Fig. 1: vDOS for every rho (rho = 0 dotted), arrows at omega_c", plot_vdos(data.vdos, f"{folder}/fig1_vdos"))
    energies = data.energies_file.get(1.0) or data.energies_file.get(0.4)
    if energies:
        with results.open_results(energies) as f:
            keep("Fig. 6: K (blue dotted), Q (red) and g x 5e-3 (dashed), rho = 1 and 0.4",
                 plot_energies(results.vdos(f), results.mode_energies(f), results.binned_energies(f), f"{folder}/fig6_energies",
                               rhos=(1.0, 0.4)))
    if data.waves_file:
        fits, lattice_fit = data.fits, data.lattice
        rt = [rho for rho, mode in fits if mode == "RT"]
        transition = [min(rt, key=lambda r: abs(r - 0.2))] if rt else []
        with results.open_results(data.waves_file) as f:  # only the rho drawn: the runs are the bulk of a file
            waves = results.waves(f, rhos={0.0, 1.0, *transition})
        keep("Fig. 2: VAFs at k d0 nearest 0.38 pi", plot_vafs(waves, f"{folder}/fig2_vaf", rhos=(0.0, 1.0)))
        keep("Fig. 3: log10 S(k, omega), rho = 1", plot_spectra(waves, f"{folder}/fig3_spectrum", rhos=(1.0,)))
        keep("Fig. 4: RT dispersion with the lattice model", plot_dispersion_rt(fits, lattice_fit, f"{folder}/fig4_dispersion_rt"))
        keep("Fig. 5: the RT transition at rho = 0.2", plot_transition(fits, lattice_fit, waves, f"{folder}/fig5_transition"))
        omega_c = {rho: v[2] for rho, v in data.vdos.items()}
        keep("Fig. 7: RT band limits against rho", plot_bands(lattice_fit, data.bands, f"{folder}/fig7_bands", omega_c or None))
        keep("Figs. S2, S3: phase speeds and attenuation of L and TR", plot_speeds_attenuation(fits, f"{folder}/figS2_S3"))
    with_vdos = [(path, phi) for path, phi, _, what in data.sources if "vdos" in what]
    if len({round(phi, 4) for _, phi in with_vdos}) >= 2:
        keep("Fig. S1: vDOS at several phi", plot_vdos_compare([p for p, _ in with_vdos], f"{folder}/figS1_vdos_phi"))
    return out


def plot_results(path: str) -> list[str]:
    """Write every figure the results file has data for, next to it; return the paths."""
    stem = os.path.splitext(path)[0]
    written: list[str] = []
    with results.open_results(path) as f:
        packing = results.first_packing(f)
        if packing is not None:
            written += plot_packing(packing, f"{stem}_packing")
            from . import plots_packing  # its figure imports this module's helpers
            from .io import hdf5

            law = results.contact_law(f)
            first = hdf5.read_packings(path, count=1, check_equilibrium=False, law=law)[0]
            written += plots_packing.plot_force_network(first, law, f"{stem}_forces")
        vdos = results.vdos(f)
        damped = results.damped_modes(f)
        written += plot_vdos(vdos, f"{stem}_vdos", damped=bool(damped))
        written += plot_energies(vdos, results.mode_energies(f), results.binned_energies(f), f"{stem}_energies")
        waves = results.waves(f)
        written += plot_vafs(waves, f"{stem}_vaf")
        written += plot_spectra(waves, f"{stem}_spectrum")
        fits, lattice_fit = results.fits(f), results.lattice(f)
        written += plot_dispersion(fits, f"{stem}_dispersion")
        written += plot_dispersion_rt(fits, lattice_fit, f"{stem}_dispersion_rt")
        written += plot_transition(fits, lattice_fit, waves, f"{stem}_transition")
        written += plot_bands(lattice_fit, results.bands(f), f"{stem}_bands")
        written += plot_speeds_attenuation(fits, f"{stem}_speeds_attenuation")
        from . import plots_attenuation  # its figure imports this module's helpers

        dim = packing["positions"].shape[1] if packing is not None else 2
        written += plots_attenuation.plot_attenuation_regimes(fits, f"{stem}_attenuation", dim=dim)
        shapes = results.mode_shapes(f)
        per_mode_participation = results.participation(f)
        snapshots = results.wave_snapshots(f)
        pictured = {i: results.packing(f, i) for i in {g.packing for g in shapes} | {w.packing for w in snapshots}}
    if shapes or per_mode_participation or snapshots:
        from . import plots_modes  # its figures import this module's helpers

        written += plots_modes.plot_participation(per_mode_participation, shapes, f"{stem}_participation")
        written += plots_modes.plot_mode_shapes(pictured, shapes, stem)
        written += plots_modes.plot_wave_snapshots(pictured, snapshots, stem)
    if damped:
        from . import plots_damped  # its figures import this module's _save

        written += plots_damped.plot_damped_modes(damped, f"{stem}_damped_modes")
        written += plots_damped.plot_damped_vdos(damped, float(np.diff(vdos[next(iter(vdos))].edges[:2])[0]),
                                                 f"{stem}_damped_vdos")
    return written
