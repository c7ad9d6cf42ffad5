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


def plot_energies(f, stem: str) -> list[str]:
    """Fig. 6: bin-averaged K (blue dotted) and Q (red) with g(omega) x 5e-3 (dashed), per rho."""
    spectra = [g for g in _groups(f, "spectra") if "K" in g]
    rhos = sorted({float(g.attrs["rho"]) for g in spectra if g.attrs["rho"] > 0})
    if not rhos:
        return []
    fig, axes = plt.subplots(1, len(rhos), figsize=(4.2 * len(rhos), 3.8), squeeze=False)
    vdos = {float(g.attrs["rho"]): g for g in _groups(f, "vdos")}
    for ax, rho in zip(axes[0], rhos):
        mine = [g for g in spectra if float(g.attrs["rho"]) == rho]
        omega = np.concatenate([g["omega"][()] for g in mine])
        edges = vdos[rho]["edges"][()]
        centres = 0.5 * (edges[1:] + edges[:-1])
        from .modes import bin_average

        for key, style in (("K", {"color": "tab:blue", "ls": ":"}), ("Q", {"color": "tab:red"})):
            values = np.concatenate([g[key][()] for g in mine])
            ax.semilogy(centres, bin_average(omega, values, edges), label=key, **style)
        ax.semilogy(centres, 5e-3 * vdos[rho]["density"][()], "k--", lw=0.8, label="g(omega) x 5e-3")
        ax.set(xlabel="omega t0", ylabel="K, Q (m d0^2 / t0^2)", title=f"rho = {rho:g}")
        ax.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, stem)


def _pooled(groups, key):
    """Runs (R, K, S) of all configurations of groups sharing rho and mode."""
    return np.concatenate([g[key][()] for g in groups], axis=0)


def plot_vafs(f, stem: str, kd0: float = 0.38 * np.pi) -> list[str]:
    """Fig. 2: C_l, C_t, C_r at the k nearest k d0 = 0.38 pi, per rho (rho = 0 dotted)."""
    from .correlations import vaf

    groups = _groups(f, "waves")
    if not groups:
        return []
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    for ax, mode, label in zip(axes, ("L", "TR", "RT"), ("C_l", "C_t", "C_r")):
        mine = [g for g in groups if g.attrs["mode"] == mode]
        for rho in sorted({float(g.attrs["rho"]) for g in mine}):
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


def plot_spectra(f, stem: str) -> list[str]:
    """Fig. 3: log10 S_alpha(k, omega) maps (L, TR, RT) for each rho."""
    from .correlations import power_spectrum

    groups = _groups(f, "waves")
    written: list[str] = []
    for rho in sorted({float(g.attrs["rho"]) for g in groups}):
        mine = [g for g in groups if float(g.attrs["rho"]) == rho]
        modes_here = [m for m in ("L", "TR", "RT") if any(g.attrs["mode"] == m for g in mine)]
        fig, axes = plt.subplots(1, len(modes_here), figsize=(4.2 * len(modes_here), 3.8), squeeze=False)
        for ax, mode in zip(axes[0], modes_here):
            sel = [g for g in mine if g.attrs["mode"] == mode]
            ks, t = sel[0]["k"][()], sel[0]["t"][()]
            z = _pooled(sel, "z")
            rows = [power_spectrum(z[:, i], t[1] - t[0]) for i in range(len(ks))]
            omega = rows[0][0]
            power = np.array([r[1] for r in rows])
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
    return written
