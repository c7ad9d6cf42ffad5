"""The finite-amplitude findings (issue 46 point 5; docs/finite_amplitude.md section 5) from the
sweep scene's results files (configs/finite_amplitude.yaml): the measured crossover A* against
mu and pressure with the thresholds predicted from each packing, the softening and loss against
A, and whether the softening follows the contacts opened or those sliding.

    .venv/bin/python -m scripts.tools.finite_amplitude_findings [results/finite_amplitude_*.h5 ...]

Writes docs/finite_amplitude_{softening,crossover,loss,contacts}.png and prints the tables the
documentation quotes (markdown).  Reads only what ``rotsound run`` wrote; not collective.
"""

from __future__ import annotations

import argparse
import glob
import os

import numpy as np

from solver.analysis import thresholds
from solver.io import hdf5, results
from solver.plots.common import legend, log_ticks, plt, save
from solver.plots.sweeps import predictions

DOCS = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "docs")


def linear_fits(paths: list[str]) -> list[tuple[np.ndarray, dict]]:
    """[(first packing's positions, {mode: fits})] of the files holding linear waves (no sweep)."""
    out = []
    for path in paths:
        with results.open_results(path) as f:
            if not results.sweeps(f) and results.fits(f):
                out.append((results.first_packing(f)["positions"], {m: fit for (_, m), fit in results.fits(f).items()}))
    return out


def case(path: str, linear: list) -> dict:
    """One sweep's results file: its packing's phi, pressure, z, dimension and mu, its sweeps per
    mode, the linear fits of the same packing (from ``linear``, matched by positions; None
    without), the contacts' number and the predicted thresholds per mode."""
    with results.open_results(path) as f:
        sweeps = {mode: s for (rho, mode), s in results.sweeps(f).items()}
        mu = results.sweep_friction(f)
        first = results.first_packing(f)
        positions = first["positions"]
        packing = hdf5.read_packings(path, count=1, check_equilibrium=False, model=results.contact_model(f))[0]
    reference = next((fits for x, fits in linear if x.shape == positions.shape and np.array_equal(x, positions)), None)
    slacks = thresholds.slacks(packing, 1.0, mu)
    label = rf"{packing.dim}D, $\mu$ = {mu:g}, $p$ = {packing.info.get('pressure', np.nan):.1e}" + \
        (", LAMMPS (stored $f_t$)" if packing.stressed else "")
    return {"path": path, "label": label, "mu": mu, "dim": packing.dim, "stored": packing.stressed,
            "phi": first["phi"], "pressure": float(packing.info.get("pressure", np.nan)),
            "z": float(packing.info.get("z", np.nan)), "contacts": len(slacks.opening), "sweeps": sweeps,
            "linear": reference,
            "predicted": {mode: predictions(s, slacks, mode, packing.dim) for mode, s in sweeps.items()}}


def first_where(amplitude: np.ndarray, series: np.ndarray) -> float:
    """The smallest amplitude at which ``series`` (A,) is above zero; NaN if never."""
    hit = np.flatnonzero(series > 0)
    return float(amplitude[hit[0]]) if hit.size else float("nan")


def _slope(a: np.ndarray, y: np.ndarray) -> float:
    """The log-log slope of y against a over the points where y > 0 (NaN with fewer than 3)."""
    keep = np.isfinite(y) & (y > 0)
    return float(np.polyfit(np.log(a[keep]), np.log(y[keep]), 1)[0]) if keep.sum() >= 3 else float("nan")


def rows(cases: list[dict]) -> list[dict]:
    """One row per (file, mode, k): measured A* of omega and gamma, first amplitude with a contact
    sliding and one opened, the predicted thresholds, the linear run's scaled first crossings,
    and the log-log slopes of the softening below A* and of Q^-1 - Q^-1_0 below and above A*."""
    out = []
    for c in cases:
        for mode, s in c["sweeps"].items():
            a = s.amplitude
            star_w, star_g = stars(c, mode)
            lin = c["linear"][mode] if c["linear"] and mode in c["linear"] else None
            for kk, k in enumerate(s.k):
                opens, slides = thresholds.from_linear_run(a[0], s.opening[0, kk:kk + 1], s.coulomb[0, kk:kk + 1])
                q = 2.0 * s.gamma[:, kk] / s.omega[:, kk]
                q0 = 2.0 * lin["gamma"][kk] / lin["omega"][kk] if lin else q[0]
                slopes = [_slope(a[side], q[side] - q0) for side in (a <= star_w[kk], a > star_w[kk])]
                soft = np.abs(s.omega[:, kk] / (lin["omega"][kk] if lin else s.omega[0, kk]) - 1.0)
                soft_slope = _slope(a[a <= star_w[kk]], soft[a <= star_w[kk]])
                out.append({"case": c["label"], "mode": mode, "k": float(k),
                            "omega linear": float(lin["omega"][kk]) if lin else float("nan"),
                            "omega(A_min)": float(s.omega[0, kk]),
                            "A*_omega": star_w[kk], "A*_gamma": star_g[kk],
                            "first sliding": first_where(a, s.sliding[:, kk]),
                            "first opened": first_where(a, s.opened[:, kk]),
                            "linear run: opens": opens, "linear run: slides": slides,
                            **(c["predicted"][mode] if kk == 0 else {}), "softening slope below A*": soft_slope,
                            "Q^-1 slope below A*": slopes[0], "Q^-1 slope above A*": slopes[1]})
    return out


def stars(c: dict, mode: str) -> results.Crossover:
    """Measured A* (K,) of omega and of gamma for one sweep (``results.crossover``): against the
    linear fits of the same packing when the files have them, else against the smallest amplitude."""
    return results.crossover(c["sweeps"][mode], c["linear"][mode] if c["linear"] and mode in c["linear"] else None)


def reference_omega(c: dict, mode: str) -> float:
    """omega at the smallest k of the linear waves of the same packing, or of the smallest amplitude."""
    s = c["sweeps"][mode]
    return float(c["linear"][mode]["omega"][0]) if c["linear"] and mode in c["linear"] else float(s.omega[0, 0])


def softening(c: dict, mode: str) -> np.ndarray:
    """|omega/omega_0 - 1| (A,) at the smallest k, omega_0 the linear reference."""
    return np.abs(c["sweeps"][mode].omega[:, 0] / reference_omega(c, mode) - 1.0)


def extra_loss(c: dict, mode: str) -> np.ndarray:
    """Q^-1 - Q^-1_0 (A,) at the smallest k, Q^-1 = 2 gamma / omega, Q^-1_0 the linear reference's."""
    s = c["sweeps"][mode]
    lin = c["linear"][mode] if c["linear"] and mode in c["linear"] else None
    q0 = 2.0 * (lin["gamma"][0] / lin["omega"][0] if lin else s.gamma[0, 0] / s.omega[0, 0])
    return 2.0 * s.gamma[:, 0] / s.omega[:, 0] - q0


def markdown(table: list[dict]) -> str:
    keys = list(dict.fromkeys(key for row in table for key in row))
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for row in table:
        cells = [row.get(key, "") for key in keys]
        lines.append("| " + " | ".join(f"{v:.3g}" if isinstance(v, float) else str(v) for v in cells) + " |")
    return "\n".join(lines)


def collapse(cases: list[dict], mode: str) -> dict[str, float]:
    """How well the softening |omega/omega_0 - 1| at the smallest k follows the share of contacts
    opened, and the share sliding, across every 2D file's amplitudes: the RMS residual of a
    straight line in log-log (the smaller, the better that variable predicts the softening)."""
    out = {}
    for name in ("opened", "sliding"):
        x, y = [], []
        for c in cases:
            s = c["sweeps"].get(mode)
            if s is None or c["dim"] != 2:
                continue
            soft = softening(c, mode)
            share = getattr(s, name)[:, 0] / c["contacts"]
            keep = (soft > 0) & (share > 0) & np.isfinite(soft)
            x += list(np.log(share[keep]))
            y += list(np.log(soft[keep]))
        if len(x) >= 4:
            fit = np.polyfit(x, y, 1)
            out[name] = float(np.sqrt(np.mean((np.polyval(fit, x) - np.array(y)) ** 2)))
    return out


MARKERS = (("*", r"measured $A^*$"), ("x", r"measured $A^*$ below the sweep (at its smallest $A$)"),
           ("o", r"$A^*$ predicted (affine)"), ("v", "first contact slides (affine)"),
           ("^", "first contact opens (affine)"))
"""The symbols of the crossover figure and what each marks."""


def figures(cases: list[dict], folder: str = DOCS) -> list[str]:
    """The four figures of the findings into ``folder``; returns the files written."""
    written = []
    modes = [m for m in ("L", "TR") if any(m in c["sweeps"] for c in cases)]
    colors = {c["label"]: plt.get_cmap("tab10")(i % 10) for i, c in enumerate(cases)}
    panels = (("finite_amplitude_softening", softening, r"$|\omega/\omega_0 - 1|$ (smallest $k$)", "softening"),
              ("finite_amplitude_loss", extra_loss, r"$Q^{-1} - Q^{-1}_0$ (smallest $k$)", "extra loss"))
    for name, curve, ylabel, title in panels:
        fig, axes = plt.subplots(1, len(modes), figsize=(6 * len(modes), 4.5), squeeze=False)
        for ax, mode in zip(axes[0], modes):
            for c in (c for c in cases if mode in c["sweeps"]):
                s, y = c["sweeps"][mode], curve(c, mode)
                ax.loglog(s.amplitude[y > 0], y[y > 0], "o-", ms=3, color=colors[c["label"]], label=c["label"])
            if curve is softening:
                ax.axhline(0.01, color="k", lw=0.6, alpha=0.5)
            else:
                guide = np.array([1e-4, 1e-2])
                ax.loglog(guide, 3.0 * guide, "k-", lw=2, alpha=0.3, label=r"$\propto A$ (Mindlin-Deresiewicz)")
            ax.set(xlabel=r"$A$ ($d_0/t_0$)", ylabel=ylabel, title=f"{title}, {mode}")
            log_ticks(ax.xaxis)
            legend(ax)
        fig.tight_layout()
        written += save(fig, os.path.join(folder, name))

    fig, axes = plt.subplots(1, 2, figsize=(12, 5.5))
    for c in cases:
        for mode, marker in (("L", "o"), ("TR", "s")):
            s = c["sweeps"].get(mode)
            if s is None:
                continue
            soft = softening(c, mode)
            for ax, name in zip(axes, ("opened", "sliding")):
                share = getattr(s, name)[:, 0] / c["contacts"]
                keep = (soft > 0) & (share > 0)
                ax.loglog(share[keep], soft[keep], marker + "-", ms=3, lw=0.6, color=colors[c["label"]],
                          label=c["label"] if mode == "L" or "L" not in c["sweeps"] else None)
    for ax, name in zip(axes, ("opened", "sliding")):
        for marker, mode in (("o", "L"), ("s", "TR")):  # the symbols (the colours: the packings)
            ax.plot([], [], marker + "-", ms=3, lw=0.6, color="0.4", label=mode)
        ax.set(xlabel=f"most contacts {name} at once (share)", ylabel=r"$|\omega/\omega_0 - 1|$ (smallest $k$)",
               title=f"softening against the contacts {name}")
        legend(ax)
    fig.tight_layout()
    written += save(fig, os.path.join(folder, "finite_amplitude_contacts"))

    flat = [c for c in cases if c["dim"] == 2 and not c["stored"]]
    pressures = [c["pressure"] for c in flat]
    common = max(set(np.round(np.log10(pressures), 1)), key=lambda v: list(np.round(np.log10(pressures), 1)).count(v)) \
        if flat else None
    series = ((r"$\mu$", "mu", [c for c in flat if np.round(np.log10(c["pressure"]), 1) == common]),
              ("pressure ($k_n$)", "pressure", [c for c in cases if c["dim"] == 2 and c["mu"] == 0.3]))
    fig, axes = plt.subplots(len(modes), 2, figsize=(16, 4.4 * len(modes)), squeeze=False)
    for row, mode in enumerate(modes):
        for col, (xlabel, key, chosen) in enumerate(series):
            ax = axes[row, col]
            for c in chosen:
                s = c["sweeps"].get(mode)
                if s is None:
                    continue
                x, color = c[key], colors[c["label"]]
                star = stars(c, mode).omega[0]  # 0: below the sweep, drawn at its smallest A; NaN: never reached
                if np.isfinite(star):
                    ax.loglog([x], [star if star > 0 else s.amplitude[0]], "*" if star > 0 else "x", ms=12,
                              color=color, label=c["label"])
                for name, marker in (("A* predicted (affine)", "o"), ("first slides (affine)", "v"),
                                     ("first opens (affine)", "^")):
                    ax.loglog([x], [c["predicted"][mode].get(name, np.nan)], marker, ms=7, mfc="none", color=color)
            for marker, what in MARKERS:  # what each symbol is, in every panel (the colours: the packings)
                ax.plot([], [], marker, color="0.4", mfc="none" if marker in "ov^" else "0.4", label=what)
            ax.set(xlabel=xlabel, ylabel=r"$A$ ($d_0/t_0$)",
                   title=f"{mode}, against " + (r"$\mu$" if key == "mu" else key))
            legend(ax, fontsize=7, loc="center left", bbox_to_anchor=(1.02, 0.5))
    fig.suptitle(r"$A^*$ of $\omega$: measured and predicted affinely; the first contact to slide and to open",
                 fontsize=10)
    fig.tight_layout()
    written += save(fig, os.path.join(folder, "finite_amplitude_crossover"))
    return written


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="*")
    args = parser.parse_args()
    files = args.files or sorted(glob.glob("results/finite_amplitude_*.h5"))
    linear = linear_fits(files)
    cases = []
    for path in files:
        with results.open_results(path) as f:
            if not results.sweeps(f):
                continue
        cases.append(case(path, linear))
    for c in cases:
        print(f"{c['path']}: {c['label']}, phi = {c['phi']:.4f}, z = {c['z']:.3f}, {c['contacts']} contacts, "
              f"linear reference: {'yes' if c['linear'] else 'no (the smallest amplitude)'}")
    print()
    print(markdown(rows(cases)))
    print()
    for mode in ("L", "TR"):
        print(f"{mode}: log-log RMS residual of the softening against the share opened / sliding: {collapse(cases, mode)}")
    for path in figures(cases):
        if path.endswith(".pdf"):  # the documentation shows the PNGs
            os.remove(path)
        else:
            print("wrote", path)


if __name__ == "__main__":
    main()
