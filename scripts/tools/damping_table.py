"""The damping scene's findings (configs/damping.yaml): scattering against loss, as a Markdown table
and a figure.

    .venv/bin/python -m scripts.tools.damping_table UNDAMPED.h5 DAMPED.h5 [DAMPED.h5 ...] [--figure docs/damping_attenuation.png]
For each damped file (same packings as UNDAMPED, dashpots on): per mode and k, the decay rates
gamma (damped) and gamma_s (undamped), the damped modes' mean rate <sigma>(omega(k))
(``analysis.loss``, Gaussian width --width), the deviation (gamma - gamma_s - <sigma>) / gamma,
and the phase speed's change omega / omega_s - 1; then the fitted exponents p of gamma ~ k^p
(L, TR) with and without dashpots, and the phase speeds omega / k of L and TR by k for every file
(Saitoh et al. 2023's transverse dip).  The figure: gamma, gamma_s and gamma_s + <sigma> against k
for L and TR, log-log, a k^3 guide; and the TR phase speed against k for every file.
"""

from __future__ import annotations

import argparse

import numpy as np

from solver.analysis import loss
from solver.io import results


def _read(path: str) -> tuple[dict, dict, str]:
    import yaml

    with results.open_results(path) as f:
        dashpots = (yaml.safe_load(f.attrs["scene"]).get("model") or {}).get("damping") or {}
        damping = ", ".join(f"{k} = {v:g}" for k, v in dashpots.items()) or "none"
        return results.fits(f), {rho: m.lam for rho, m in results.damped_modes(f).items()}, damping


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("undamped")
    parser.add_argument("damped", nargs="+")
    parser.add_argument("--width", type=float, default=0.02, help="Gaussian width of <sigma>(omega) (1/t0)")
    parser.add_argument("--figure", default="docs/damping_attenuation.png")
    args = parser.parse_args()

    scattering, _, _ = _read(args.undamped)
    print("| dashpots | mode | k d0 | omega | gamma_s | gamma | <sigma>(omega) | (gamma - gamma_s - <sigma>) / gamma "
          "| omega / omega_s - 1 | modes in the kernel |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    runs = []
    for path in args.damped:
        fits, lam, damping = _read(path)
        rows = loss.additivity(fits, scattering, lam, args.width)
        runs.append((damping, fits, rows))
        for row in rows:
            ref = scattering[(row["rho"], row["mode"])]
            j = int(np.argmin(np.abs(ref["k"] - row["k"])))
            print(f"| {damping} | {row['mode']} | {row['k']:.3f} | {row['omega']:.3f} | {row['gamma_s']:.2e} | "
                  f"{row['gamma']:.2e} | {row['sigma']:.2e} | {row['deviation']:+.3f} | "
                  f"{row['omega'] / ref['omega'][j] - 1:+.1e} | {row['modes']:.0f} |")
    print()
    print("| dashpots | L: p of gamma ~ k^p | TR: p |")
    print("|---|---|---|")
    for damping, fits in [("none", scattering)] + [(d, f) for d, f, _ in runs]:
        cells = []
        for mode in ("L", "TR"):
            found = [fit for (rho, m), fit in fits.items() if m == mode]
            p = found[0].get("power_law_p", np.nan) if found else np.nan
            err = found[0].get("power_law_p_err", np.nan) if found else np.nan
            cells.append(f"{p:.2f} +- {err:.2f}")
        print(f"| {damping} | {' | '.join(cells)} |")
    print()
    speeds = [("none", scattering)] + [(d, f) for d, f, _ in runs]
    for mode in ("L", "TR"):
        ref = next((fit for (rho, m), fit in scattering.items() if m == mode), None)
        if ref is None:
            continue
        print(f"| {mode}: omega / k at k d0 = | " + " | ".join(f"{k:.3f}" for k in ref["k"]) + " |")
        print("|---|" + "---|" * len(ref["k"]))
        for damping, fits in speeds:
            fit = next(fit for (rho, m), fit in fits.items() if m == mode)
            print(f"| {damping} | " + " | ".join(f"{w / k:.4f}" for w, k in zip(fit["omega"], fit["k"])) + " |")
        print()

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    colours = plt.cm.viridis(np.linspace(0, 0.8, len(runs)))
    for ax, mode in zip(axes, ("L", "TR")):
        ref = next((fit for (rho, m), fit in scattering.items() if m == mode), None)
        if ref is None:
            continue
        ax.loglog(ref["k"], ref["gamma"], "ko-", ms=4, label="no dashpots (gamma_s)")
        for colour, (damping, _, rows) in zip(colours, runs):
            mine = [r for r in rows if r["mode"] == mode]
            k = np.array([r["k"] for r in mine])
            ax.loglog(k, [r["gamma"] for r in mine], "s-", color=colour, ms=4, label=f"{damping}: gamma")
            ax.loglog(k, [r["sum"] for r in mine], ":", color=colour, label="gamma_s + <sigma>")
            ax.loglog(k, [r["sigma"] for r in mine], "--", color=colour, lw=0.8, label="<sigma>(omega(k))")
        k = np.geomspace(ref["k"].min(), ref["k"].max(), 10)
        scale = ref["gamma"][np.argmax(ref["k"])] / ref["k"].max() ** 3
        ax.loglog(k, scale * k**3, color="0.6", lw=0.8, label="k^3")
        ax.set(xlabel="k d0", ylabel="gamma (1/t0)", title=mode)
        ax.legend(fontsize=6)
    speed_colours = ["k"] + list(colours)
    for colour, (damping, fits) in zip(speed_colours, speeds):
        fit = next(fit for (rho, m), fit in fits.items() if m == "TR")
        axes[2].semilogx(fit["k"], fit["omega"] / fit["k"], "o-", color=colour, ms=4, label=damping)
    axes[2].set(xlabel="k d0", ylabel="omega / k (d0/t0)", title="TR phase speed")
    axes[2].legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(args.figure, dpi=150)
    print(f"\nwrote {args.figure}")


if __name__ == "__main__":
    main()
