"""Figures from results files only (never imports petsc4py or mpi4py). Not collective."""

from __future__ import annotations

import os

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import EllipseCollection  # noqa: E402

from .errors import InputError  # noqa: E402


def _save(fig, stem: str) -> list[str]:
    paths = [f"{stem}.png", f"{stem}.pdf"]
    for path in paths:
        fig.savefig(path, dpi=150)
    plt.close(fig)
    return paths


def plot_packing(group, stem: str) -> list[str]:
    """Disks of one configuration, rattlers in red; units of d0."""
    pos, diam = group["positions"][()], group["diameters"][()]
    rattler, box = group["rattler"][()], float(group.attrs["box_length"])
    fig, ax = plt.subplots(figsize=(6, 6))
    colors = np.where(rattler, "tab:red", np.where(diam > diam.mean(), "0.55", "0.8"))
    ax.add_collection(EllipseCollection(diam, diam, np.zeros_like(diam), offsets=pos,
                                        units="xy", offset_transform=ax.transData,
                                        facecolors=colors, edgecolors="k", linewidths=0.2))
    ax.set(xlim=(0, box), ylim=(0, box), aspect="equal", xlabel="x / d0", ylabel="y / d0",
           title=f"N = {diam.size}, phi = {group.attrs['phi']:.3f}, z = {group.attrs['z']:.2f}, "
                 f"rattlers in red ({int(rattler.sum())})")
    return _save(fig, stem)


def _groups(f, name):
    return [f[name][k] for k in sorted(f[name])] if name in f else []


def plot_vdos(f, stem: str) -> list[str]:
    """Fig. 1: g(omega) for every rho, rho = 0 dotted, omega_c marked."""
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    groups = sorted(_groups(f, "vdos"), key=lambda g: g.attrs["rho"])
    cmap = plt.get_cmap("viridis")
    for index, g in enumerate(groups):
        edges, density, rho = g["edges"][()], g["density"][()], float(g.attrs["rho"])
        centres = 0.5 * (edges[1:] + edges[:-1])
        style = {"ls": ":", "color": "k"} if rho == 0 else {"color": cmap(0.8 * index / max(1, len(groups) - 1))}
        ax.plot(centres, density, label=f"rho = {rho:g}", **style)
        ax.annotate("", xy=(g.attrs["omega_c"], 0), xytext=(g.attrs["omega_c"], 0.08 * density.max()),
                    arrowprops={"arrowstyle": "->", "color": style["color"], "lw": 0.8})
    ax.set(xlabel="omega t0", ylabel="g(omega) t0", xlim=(0, None), ylim=(0, None),
           title="vibrational density of states (arrows: omega_c)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, stem)


def plot_energies(f, stem: str, rhos=None) -> list[str]:
    """Fig. 6: bin-averaged K (blue dotted) and Q (red) with g(omega) x 5e-3 (dashed), per rho
    (every rho > 0 of the file, or those of ``rhos`` it has, in that order)."""
    spectra = [g for g in _groups(f, "spectra") if "K" in g]
    have = sorted({float(g.attrs["rho"]) for g in spectra if g.attrs["rho"] > 0})
    rhos = have if rhos is None else [r for r in rhos if r in have]
    if not rhos:
        return []
    fig, axes = plt.subplots(1, len(rhos), figsize=(4.2 * len(rhos), 3.8), squeeze=False)
    vdos = {float(g.attrs["rho"]): g for g in _groups(f, "vdos")}
    from .spectrum.modes import bin_average

    for ax, rho in zip(axes[0], rhos):
        mine = [g for g in spectra if float(g.attrs["rho"]) == rho]
        edges = vdos[rho]["edges"][()]
        centres = 0.5 * (edges[1:] + edges[:-1])
        for key, style in (("K", {"color": "tab:blue", "ls": ":"}), ("Q", {"color": "tab:red"})):
            x = centres
            if "omega" in mine[0]:  # per mode (slicing): average over the modes of each bin
                omega = np.concatenate([g["omega"][()] for g in mine])
                curve = bin_average(omega, np.concatenate([g[key][()] for g in mine]), edges)
            else:  # kpm: already bin averages; weight each configuration by its modes in the bin
                size = min(g[key].shape[0] for g in mine)
                w = np.array([g["density"][:size] for g in mine])
                with np.errstate(invalid="ignore"):
                    curve = np.nansum(w * np.array([g[key][:size] for g in mine]), axis=0) / w.sum(axis=0)
                x = 0.5 * (mine[0]["edges"][1:size + 1] + mine[0]["edges"][:size])
            ax.semilogy(x, curve, label=key, **style)
        ax.semilogy(centres, 5e-3 * vdos[rho]["density"][()], "k--", lw=0.8, label="g(omega) x 5e-3")
        ax.set(xlabel="omega t0", ylabel="K, Q (m d0^2 / t0^2)", title=f"rho = {rho:g}")
        ax.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, stem)


def _pooled(groups, key):
    """Runs (R, K, S) of all configurations of groups sharing rho and mode."""
    return np.concatenate([g[key][()] for g in groups], axis=0)


def _pooled_spectrum(groups):
    """(k (K,), omega (W,), S (K, W)) of waves groups sharing rho and mode, runs pooled."""
    from .analysis.correlations import power_spectrum

    ks, t = groups[0]["k"][()], groups[0]["t"][()]
    z = _pooled(groups, "z")
    rows = [power_spectrum(z[:, i], t[1] - t[0]) for i in range(len(ks))]
    return ks, rows[0][0], np.array([r[1] for r in rows])


def plot_vafs(f, stem: str, kd0: float = 0.38 * np.pi, rhos=None) -> list[str]:
    """Fig. 2: C_l, C_t, C_r at the k nearest k d0 = 0.38 pi, per rho (rho = 0 dotted); every
    rho of the file or only those in ``rhos``."""
    from .analysis.correlations import vaf

    groups = _groups(f, "waves")
    if not groups:
        return []
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    for ax, mode, label in zip(axes, ("L", "TR", "RT"), ("C_l", "C_t", "C_r")):
        mine = [g for g in groups if g.attrs["mode"] == mode]
        for rho in sorted({float(g.attrs["rho"]) for g in mine}):
            if rhos is not None and rho not in rhos:
                continue
            sel = [g for g in mine if float(g.attrs["rho"]) == rho]
            ks = sel[0]["k"][()]
            i = int(np.argmin(np.abs(ks - kd0)))
            c = vaf(_pooled(sel, "z")[:, i])
            ax.plot(sel[0]["t"][()], c, ":" if rho == 0 else "-", lw=1,
                    label=f"rho = {rho:g}, k d0 = {ks[i]:.3f}")
        ax.axhline(0, color="0.7", lw=0.5)
        ax.set(xlabel="t / t0", ylabel=label, title=f"{mode} mode")
        ax.legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, stem)


def plot_spectra(f, stem: str, rhos=None) -> list[str]:
    """Fig. 3: log10 S_alpha(k, omega) maps (L, TR, RT) for each rho (or each in ``rhos``)."""
    groups = _groups(f, "waves")
    written: list[str] = []
    for rho in sorted({float(g.attrs["rho"]) for g in groups}):
        if rhos is not None and rho not in rhos:
            continue
        mine = [g for g in groups if float(g.attrs["rho"]) == rho]
        modes_here = [m for m in ("L", "TR", "RT") if any(g.attrs["mode"] == m for g in mine)]
        fig, axes = plt.subplots(1, len(modes_here), figsize=(4.2 * len(modes_here), 3.8), squeeze=False)
        for ax, mode in zip(axes[0], modes_here):
            sel = [g for g in mine if g.attrs["mode"] == mode]
            ks, omega, power = _pooled_spectrum(sel)
            top = min(omega[-1], 1.15 * float(sel[0].attrs["omega_max"]))
            keep = omega <= top
            mesh = ax.pcolormesh(ks, omega[keep], np.log10(power[:, keep].T + 1e-30), shading="nearest",
                                 cmap="Greys", vmin=np.log10(power.max()) - 6)
            fig.colorbar(mesh, ax=ax, label="log10 S")
            ax.set(xlabel="k d0", ylabel="omega t0", title=f"{mode}, rho = {rho:g}")
        fig.tight_layout()
        written += _save(fig, f"{stem}_rho{rho:g}")
    return written


def plot_vdos_compare(paths: list[str], stem: str) -> list[str]:
    """Fig. S1: g(omega) of several results files (e.g. different phi) overlaid, one panel per rho."""
    curves: dict[float, list] = {}
    for path in paths:
        with h5py.File(path, "r") as f:
            phi = float(f["packings"][sorted(f["packings"])[0]].attrs["phi"]) if "packings" in f else float("nan")
            n = int(f["packings"][sorted(f["packings"])[0]]["diameters"].shape[0]) if "packings" in f else 0
            for g in _groups(f, "vdos"):
                curves.setdefault(float(g.attrs["rho"]), []).append(
                    (phi, n, g["edges"][()], g["density"][()], float(g.attrs["omega_c"])))
    if not curves:
        return []
    rhos = sorted(curves)
    fig, axes = plt.subplots(1, len(rhos), figsize=(4.2 * len(rhos), 3.6), squeeze=False)
    for ax, rho in zip(axes[0], rhos):
        for phi, n, edges, density, omega_c in sorted(curves[rho], key=lambda c: c[0]):
            ax.plot(0.5 * (edges[1:] + edges[:-1]), density, lw=1, label=f"phi = {phi:.3f} (N = {n})")
        ax.set(xlabel="omega t0", ylabel="g(omega) t0", title=f"rho = {rho:g}", ylim=(0, None))
        ax.legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, stem)


def analysis_groups(f, mode=None):
    """Analysis groups of ``f`` (fits per rho and mode), sorted by rho."""
    if "analysis" not in f:
        return []
    groups = [f["analysis"][k] for k in f["analysis"] if "mode" in f["analysis"][k].attrs]
    return sorted((g for g in groups if mode is None or g.attrs["mode"] == mode),
                  key=lambda g: float(g.attrs["rho"]))


def _lattice(f):
    return dict(f["analysis/lattice"].attrs) if "analysis/lattice" in f else None


def plot_dispersion_rt(f, stem: str) -> list[str]:
    """Fig. 4: fitted omega_r(k) (symbols) for every rho > 0 with the lattice model (lines)."""
    groups = [g for g in analysis_groups(f, "RT") if g.attrs["rho"] > 0]
    lattice = _lattice(f)
    if not groups or lattice is None:
        return []
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    cmap = plt.get_cmap("viridis")
    k_line = np.linspace(0, lattice["k_max"], 200)
    for index, g in enumerate(groups):
        rho, color = float(g.attrs["rho"]), cmap(0.9 * index / max(1, len(groups) - 1))
        ax.plot(g["k"][()], g["omega"][()], "o", ms=3.5, mfc="none", color=color, label=f"rho = {rho:g}")
        ax.plot(k_line, lattice_curve(k_line, rho, lattice)[1], "-", lw=0.9, color=color)
    ax.axvline(lattice["kd0_max_used"], color="0.6", ls=":", lw=0.8)
    ax.set(xlabel="k d0", ylabel="omega_r t0", title=f"RT dispersion; lines: lattice model, a_r = "
           f"{lattice['a_r']:.3f}/t0, l = {lattice['l']:.3f} d0 (fit left of the dotted line)")
    ax.title.set_fontsize(8)
    ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    return _save(fig, stem)


def lattice_curve(k, rho, lattice, edge: bool = False):
    """(omega_t, omega_r) of the lattice model with the fitted parameters of ``lattice``; with
    ``edge``, omega_t uses a_t_edge (fitted beyond k_c) when the run found one."""
    from .analysis.fits import lattice_omega

    a_t = lattice["a_t_edge"] if edge and np.isfinite(lattice.get("a_t_edge", np.nan)) else lattice["a_t"]
    return lattice_omega(k, rho, lattice["l"], a_t, lattice["a_r"])


def plot_transition(f, stem: str, rho: float = 0.2) -> list[str]:
    """Fig. 5: (a) log10 S_r(k, omega) with k_c, (b) fitted omega_t and omega_r with both model
    branches, at the analysed rho nearest ``rho``."""
    rt = analysis_groups(f, "RT")
    lattice = _lattice(f)
    if not rt or lattice is None:
        return []
    g_rt = min(rt, key=lambda g: abs(float(g.attrs["rho"]) - rho))
    rho = float(g_rt.attrs["rho"])
    g_tr = next((g for g in analysis_groups(f, "TR") if float(g.attrs["rho"]) == rho), None)
    k, omega, power = _pooled_spectrum([g for g in _groups(f, "waves")
                                        if float(g.attrs["rho"]) == rho and g.attrs["mode"] == "RT"])
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4))
    top = 1.1 * np.nanmax(g_rt["omega"][()]) + 1
    keep = omega <= top
    mesh = ax.pcolormesh(k, omega[keep], np.log10(power[:, keep].T + 1e-30), shading="nearest", cmap="Greys",
                         vmin=np.log10(power.max()) - 5)
    fig.colorbar(mesh, ax=ax, label="log10 S_r")
    k_c = float(g_rt.attrs["k_c"])
    if np.isfinite(k_c):
        ax.annotate("k_c", xy=(k_c, 0.02 * top), xytext=(k_c, 0.25 * top), color="tab:red",
                    arrowprops={"arrowstyle": "->", "color": "tab:red"}, ha="center")
    ax.set(xlabel="k d0", ylabel="omega t0", title=f"(a) log10 S_r(k, omega), rho = {rho:g}")
    k_line = np.linspace(0, lattice["k_max"], 200)
    w_t, w_r = lattice_curve(k_line, rho, lattice)
    if np.isfinite(lattice.get("a_t_edge", np.nan)):
        bx.plot(k_line, lattice_curve(k_line, rho, lattice, edge=True)[0], ":", color="tab:purple",
                label=f"model omega_t, a_t = {lattice['a_t_edge']:.2f} (fit beyond k_c)")
    if g_tr is not None:
        bx.plot(g_tr["k"][()], g_tr["omega"][()], "+", color="tab:blue", label="omega_t (TR fit)")
    bx.plot(g_rt["k"][()], g_rt["omega"][()], "s", mfc="none", color="tab:red", label="omega_r (RT fit)")
    bx.plot(k_line, w_t, ":", color="tab:blue", label=f"model omega_t, a_t = {lattice['a_t']:.2f} (TR fit)")
    bx.plot(k_line, w_r, "-", color="tab:red", label="model omega_r")
    if np.isfinite(k_c):
        bx.axvline(k_c, color="0.5", lw=0.8, ls="--")
    bx.set(xlabel="k d0", ylabel="omega t0", title=f"(b) fitted dispersion, rho = {rho:g}"
           + (f", k_c d0 = {k_c:.2f}" if np.isfinite(k_c) else ", no k_c detected"))
    bx.legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, stem)


def plot_bands(f, stem: str, omega_c: dict | None = None) -> list[str]:
    """Fig. 7: RT band limits against rho (data symbols, model lines and shaded band), omega_c
    (crosses; ``omega_c`` maps rho -> value, else the file's own), log-log inset."""
    lattice = _lattice(f)
    if lattice is None or "analysis/bands" not in f:
        return []
    b = {key: f["analysis/bands"][key][()] for key in f["analysis/bands"]}
    rho_line = np.linspace(1e-3, max(2.0, b["rho"].max()), 300)
    a_r = lattice["a_r"]
    a_t = lattice["a_t_edge"] if np.isfinite(lattice.get("a_t_edge", np.nan)) else lattice["a_t"]
    r0, rk, tk = a_r * np.sqrt(40 * rho_line), 2 * a_r * np.sqrt(3 * rho_line + 1), a_t * np.sqrt(10 * rho_line)
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    inset = ax.inset_axes([0.62, 0.1, 0.35, 0.35])
    cross = omega_c if omega_c is not None else dict(zip(b["rho"], b["omega_c"]))
    for axis in (ax, inset):
        axis.fill_between(rho_line, np.minimum(r0, rk), np.maximum(r0, rk), color="0.9")
        axis.plot(rho_line, r0, "-", color="tab:red", label="model omega_r(0) = a_r sqrt(40 rho)")
        axis.plot(rho_line, rk, ":", color="tab:blue", label="model omega_r(k_max) = 2 a_r sqrt(3 rho + 1)")
        axis.plot(rho_line, tk, "--", color="tab:green", label=f"model omega_t(k_max) = a_t sqrt(10 rho), a_t = {a_t:.2f}")
        axis.plot(b["rho"], b["omega_r0"], "o", mfc="none", color="tab:red", label="omega_r(0), data")
        axis.plot(b["rho"], b["omega_r_kmax"], "s", mfc="none", color="tab:blue", label="omega_r(k_max), data")
        axis.plot(b["rho"], b["omega_t_kmax"], "^", mfc="none", color="tab:green", label="omega_t(k_max), data")
        rc = sorted((r, w) for r, w in cross.items() if r > 0 and np.isfinite(w))
        if rc:
            axis.plot(*zip(*rc), "x", color="k", label="omega_c (vDOS)")
    inset.set(xscale="log", yscale="log")
    inset.tick_params(labelsize=6)
    ax.set(xlabel="rho = kt / kn", ylabel="omega t0", title="RT frequency band (shaded: model)")
    ax.legend(fontsize=6, loc="upper left")
    fig.tight_layout()
    return _save(fig, stem)


def plot_speeds_attenuation(f, stem: str) -> list[str]:
    """Figs. S2 and S3: phase speeds c = omega/k and attenuation gamma(k) (log-log, k^3 guide) of
    L and TR, per rho."""
    groups = [g for g in analysis_groups(f) if g.attrs["mode"] in ("L", "TR")]
    if not groups:
        return []
    fig, axes = plt.subplots(2, 2, figsize=(10, 7))
    cmap = plt.get_cmap("viridis")
    rhos = sorted({float(g.attrs["rho"]) for g in groups})
    for col, mode in enumerate(("L", "TR")):
        for g in (g for g in groups if g.attrs["mode"] == mode):
            rho = float(g.attrs["rho"])
            color = "k" if rho == 0 else cmap(0.9 * rhos.index(rho) / max(1, len(rhos) - 1))
            k, gamma = g["k"][()], g["gamma"][()]
            axes[0, col].plot(k, g["c"][()], "o-" if rho else "o:", ms=2.5, lw=0.7, color=color, label=f"rho = {rho:g}")
            good = gamma > 0
            axes[1, col].loglog(k[good], gamma[good], "o-" if rho else "o:", ms=2.5, lw=0.7, color=color,
                                label=f"rho = {rho:g}, p = {g.attrs['power_law_p']:.2f}")
        k_guide = np.array([0.2, 1.0])
        axes[1, col].loglog(k_guide, 0.05 * k_guide**3, "k-", lw=2, alpha=0.4, label="~ k^3")
        axes[0, col].set(xlabel="k d0", ylabel=f"c_{mode.lower()[0]} (d0 / t0)", title=f"phase speed, {mode}")
        axes[1, col].set(xlabel="k d0", ylabel=f"gamma_{mode.lower()[0]} t0", title=f"attenuation, {mode}")
        for ax in axes[:, col]:
            ax.legend(fontsize=5, ncol=2)
    fig.tight_layout()
    return _save(fig, stem)


def plot_results(path: str) -> list[str]:
    """Write every figure the results file has data for, next to it; return the paths."""
    if not os.path.isfile(path):
        raise InputError(f"results file {path}: not found (run the scene first)")
    stem = os.path.splitext(path)[0]
    written: list[str] = []
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"results file {path}: not a readable HDF5 file ({exc})") from None
    with f:
        if "packings" in f and len(f["packings"]):
            first = sorted(f["packings"])[0]
            written += plot_packing(f["packings"][first], f"{stem}_packing")
        if "vdos" in f:
            written += plot_vdos(f, f"{stem}_vdos")
            written += plot_energies(f, f"{stem}_energies")
        if "waves" in f:
            written += plot_vafs(f, f"{stem}_vaf")
            written += plot_spectra(f, f"{stem}_spectrum")
        if "analysis" in f:
            written += plot_dispersion_rt(f, f"{stem}_dispersion_rt")
            written += plot_transition(f, f"{stem}_transition")
            written += plot_bands(f, f"{stem}_bands")
            written += plot_speeds_attenuation(f, f"{stem}_speeds_attenuation")
    return written
