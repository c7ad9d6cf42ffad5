"""The findings of configs/wet.yaml: what capillary bridges do to sound (docs/wet_packings.md).

    .venv/bin/python -m scripts.tools.wet_findings results/dry_phi*.h5 results/wet_phi*.h5 [--figures docs]

Each results file is one scene: dry or wet (its packings' ``cohesion_law`` attribute), its
bridges' law, phi, the pressure (the virial of the net forces), z, the bridged pairs, the vDOS
cutoff omega_c, c and gamma of L and TR and omega_r, gamma_r of RT at the smallest k, and the
share of the vDOS above omega = 2.5 (the rotational band of the paper's Fig. 3c at rho = 1).
Prints one Markdown table and draws three figures into ``--figures``: the vDOS of dry and wet at
one phi and of a wet packing below dry jamming (``wet_vdos.png``), the speeds and the rotational
frequencies against the pressure, dry and wet (``wet_pressure.png``), and against the bridges'
volume, contact angle and surface tension (``wet_bridges.png``).  Means over each scene's
configurations.  Not MPI.
"""

from __future__ import annotations

import argparse
import os

import numpy as np

from solver.io import results
from solver.plots.common import DPI, legend, log_ticks, plt

ROTATIONAL = 2.5
"""omega (1/t0) above which the vDOS at rho = 1 is the rotational band (the paper's Fig. 3c: the
RT band spans 2.5 <= omega t0 <= 4.7)."""


def scene(path: str) -> dict:
    """One results file's numbers (module docstring)."""
    with results.open_results(path) as f:
        groups = [f["packings"][name].attrs for name in sorted(f["packings"])]
        wet = "cohesion_law" in groups[0]
        rho, vdos = min(results.vdos(f).items())  # the scene's (configs/wet.yaml: rho = 1)
        fits = results.fits(f)
        width = np.diff(vdos.edges)
        upper = vdos.edges[:-1] >= ROTATIONAL - 1e-12
        row = {"name": os.path.basename(path).removesuffix(".h5"), "wet": wet,
               "phi": float(np.mean([g["phi"] for g in groups])),
               "pressure": float(np.mean([g["pressure"] for g in groups])),
               "z": float(np.mean([g["z"] for g in groups])),
               "bridges": float(np.mean([g["n_bridges"] for g in groups])) if wet else 0.0,
               "volume": float(groups[0]["bridge_volume"]) if wet else np.nan,
               "angle": float(groups[0]["contact_angle"]) if wet else np.nan,
               "tension": float(groups[0]["surface_tension"]) if wet else 0.0,
               "omega_c": vdos.omega_c, "rotational": float((vdos.density * width)[upper].sum()),
               "vdos": vdos}
        for mode in ("L", "TR", "RT"):
            fit = fits[(rho, mode)]
            row[f"k_{mode}"] = float(fit["k"][0])
            row[f"c_{mode}"] = float(fit["c"][0])
            row[f"omega_{mode}"] = float(fit["omega"][0])
            row[f"gamma_{mode}"] = float(fit["gamma"][0])
    return row


def table(rows: list[dict]) -> str:
    """The Markdown table of every scene."""
    head = ("| scene | φ | p (kn) | z | bridged pairs | ω_c | rotational share | c_L | c_T | γ_L | γ_T | ω_r | γ_r |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    lines = [head]
    for r in rows:
        lines.append(f"| {r['name']} | {r['phi']:.3f} | {r['pressure']:.2e} | {r['z']:.2f} | "
                     f"{r['bridges']:.0f} | {r['omega_c']:.3f} | {100 * r['rotational']:.1f} % | {r['c_L']:.3f} | "
                     f"{r['c_TR']:.3f} | {r['gamma_L']:.1e} | {r['gamma_TR']:.1e} | {r['omega_RT']:.3f} | "
                     f"{r['gamma_RT']:.2e} |")
    k = rows[0]
    return "\n".join(lines) + (f"\n\nc and γ of L and TR at k d0 = {k['k_L']:.3f}, ω_r and γ_r of RT at k d0 = "
                               f"{k['k_RT']:.3f}; the rotational share is the vDOS above ω = {ROTATIONAL} / t0.")


def figures(rows: list[dict], folder: str) -> list[str]:
    """Write the three figures (:func:`draw`) into ``folder`` as PNG; return their paths."""
    written = []
    for name, fig in draw(rows).items():
        written.append(os.path.join(folder, f"{name}.png"))
        fig.savefig(written[-1], dpi=DPI)
        plt.close(fig)
    return written


def draw(rows: list[dict]) -> dict:
    """The three figures (module docstring), {file name without .png: figure}, open."""
    base = [r for r in rows if not r["wet"] or (r["volume"] == 1e-3 and r["angle"] == 0.0 and r["tension"] == 0.002)]
    drawn = {}
    fig, ax = plt.subplots(figsize=(6, 4))
    for r in base:
        if abs(r["phi"] - 0.86) < 1e-9 or (r["wet"] and r["phi"] == min(b["phi"] for b in base if b["wet"])):
            v = r["vdos"]
            centres = 0.5 * (v.edges[1:] + v.edges[:-1])
            ax.plot(centres, np.where(v.density > 0, v.density, np.nan),
                    label=rf"{'wet' if r['wet'] else 'dry'}, $\phi$ = {r['phi']:.2f}, $p$ = {r['pressure']:.1e}")
    ax.axvline(ROTATIONAL, color="0.6", lw=0.8, ls=":", label="rotational band above")
    ax.set(xlabel=r"$\omega\,t_0$", ylabel=r"$g(\omega)\,t_0$", title=r"2048 disks, $\rho$ = 1: dry and wet")
    legend(ax, fontsize=8)
    fig.tight_layout()
    drawn["wet_vdos"] = fig

    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    for wet, marker, colour in ((False, "o", "C0"), (True, "s", "C1")):
        series = sorted((r for r in base if r["wet"] == wet), key=lambda r: r["pressure"])
        p = [r["pressure"] for r in series]
        label = "wet" if wet else "dry"
        axes[0].plot(p, [r["c_L"] for r in series], marker + "-", color=colour, label=f"$c_L$, {label}")
        axes[0].plot(p, [r["c_TR"] for r in series], marker + "--", color=colour, label=f"$c_T$, {label}")
        axes[1].plot(p, [r["omega_RT"] for r in series], marker + "-", color=colour, label=rf"$\omega_r$, {label}")
        axes[1].plot(p, [r["omega_c"] for r in series], marker + "--", color=colour, label=rf"$\omega_c$, {label}")
        axes[2].plot(p, [r["gamma_RT"] for r in series], marker + "-", color=colour, label=rf"$\gamma_r$, {label}")
        for r in series:
            axes[1].annotate(f"{r['phi']:.2f}", (r["pressure"], r["omega_RT"]), fontsize=7)
    for ax, ylabel in zip(axes, (r"speed ($d_0/t_0$)", r"frequency ($1/t_0$)", r"$\gamma_r$ ($1/t_0$)")):
        ax.set(xlabel=r"pressure $p$ ($k_n$)", ylabel=ylabel)
        legend(ax)
    axes[0].set_title(r"sound speeds, smallest $k$")
    axes[1].set_title(r"rotational band (labels: $\phi$)")
    axes[2].set_title("damping of the RT wave")
    fig.tight_layout()
    drawn["wet_pressure"] = fig

    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), sharey=True)
    at = [r for r in rows if r["wet"] and abs(r["phi"] - 0.86) < 1e-9]
    dry = next((r for r in rows if not r["wet"] and abs(r["phi"] - 0.86) < 1e-9), None)
    defaults = {"volume": 1e-3, "angle": 0.0, "tension": 0.002}
    for ax, key, xlabel, log in ((axes[0], "volume", r"bridge volume $V$ ($d_0^3$)", True),
                                 (axes[1], "angle", r"contact angle $\theta$ (rad)", False),
                                 (axes[2], "tension", r"surface tension $\gamma$ ($k_n$)", True)):
        series = sorted((r for r in at if all(r[name] == defaults[name] for name in defaults if name != key)),
                        key=lambda r: r[key])
        x = [r[key] for r in series]
        for name, label, style in (("omega_RT", r"$\omega_r$", "s-"), ("omega_c", r"$\omega_c$", "s--"),
                                   ("c_L", "$c_L$", "o-"), ("c_TR", "$c_T$", "o--")):
            if dry is not None:  # change against the dry packing of the same phi, in %
                ax.plot(x, [100 * (r[name] / dry[name] - 1) for r in series], style, label=label)
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set(xlabel=xlabel, xscale="log" if log else "linear")
        log_ticks(ax.xaxis)
        legend(ax)
    axes[0].set_ylabel(r"wet against dry, $\phi$ = 0.86 (%)")
    axes[0].set_title("the bridges' volume")
    axes[1].set_title("contact angle")
    axes[2].set_title("surface tension")
    fig.tight_layout()
    drawn["wet_bridges"] = fig
    return drawn


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="+")
    parser.add_argument("--figures", default="docs", help="folder for the figures (default docs)")
    args = parser.parse_args()
    rows = sorted((scene(path) for path in args.files), key=lambda r: (r["wet"], r["phi"], r["name"]))
    print(table(rows))
    for path in figures(rows, args.figures):
        print("wrote", path)


if __name__ == "__main__":
    main()
