"""How far a short run's attenuation can be trusted, and the regimes of gamma(k), from a results
file with long L and TR runs (configs/rayleigh.yaml):

    .venv/bin/python -m scripts.tools.rayleigh_table RESULTS.h5 [RESULTS.h5 ...] [--short 0.1] [--figure STEM] \
        > scripts/tools/rayleigh_table.md

For every (rho, mode in L, TR) and k, the damped-cosine fit of C(k, t) (``fits.fit_damped_cosine``,
decay_window 3, as the scene's analysis) over the whole run (t_end) and over its first ``--short`` fraction only:
gamma_full, gamma_short, their ratio, and whether each run resolves its decay (gamma t >= 1).  Then
the local exponents d ln gamma / d ln k between resolved points and the Ioffe-Regel k
(``analysis.attenuation``).  Prints Markdown.  With --figure, draws the fits of every file (their
``analysis`` groups, each with its own t_end) in one ``plots.attenuation`` figure at STEM (.png,
.pdf); a (rho, mode) in two files is refused.  Not collective (numpy only).
"""

from __future__ import annotations

import argparse
import re
import warnings

import h5py
import numpy as np

from solver.analysis import attenuation, fits
from solver.io import results
from solver.plots.attenuation import plot_attenuation_regimes
from solver.waves import correlations

_WAVES = re.compile(r"r(\d+)_(L|TR)_p(\d+)$")


def _fit(t, c):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            f = fits.fit_damped_cosine(t, c, 3.0)
            return f.omega, f.gamma
        except (RuntimeError, ValueError):
            return np.nan, np.nan


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("paths", nargs="+")
    parser.add_argument("--short", type=float, default=0.1, help="the short run, as a fraction of t_end")
    parser.add_argument("--figure", help="stem of the combined figure")
    args = parser.parse_args()
    fitted: dict = {}
    for path in args.paths:
        table(path, args.short)
        with results.open_results(path) as f:
            for key, fit in results.fits(f).items():
                if key in fitted:
                    raise SystemExit(f"{path}: rho = {key[0]:g}, {key[1]} is in an earlier file too")
                fitted[key] = fit
    if args.figure:
        plot_attenuation_regimes(fitted, args.figure)


def table(path: str, fraction: float) -> None:
    """Print the Markdown tables of one results file."""
    curves: dict = {}
    with h5py.File(path, "r") as f:
        for name, group in f["waves"].items():
            match = _WAVES.match(name)
            if match:
                curves.setdefault((float(group.attrs["rho"]), match[2]), []).append((group["k"][()], group["t"][()], group["z"][()]))
    print(f"# Attenuation from {path}: whole run against its first {fraction:g}\n")
    for (rho, mode), items in sorted(curves.items()):
        k, t = items[0][0], items[0][1]
        z = np.concatenate([zz for _, _, zz in items], axis=0)
        t_end = t[-1]
        short = fraction * t_end
        window = t <= short
        print(f"## {mode}, rho = {rho:g} (t_end = {t_end:g}, short run to {short:g}, {z.shape[0]} runs)\n")
        print("| k d0 | omega t0 | gamma_full t0 | gamma t_end | gamma_short t0 | gamma t_short | short / full |")
        print("|---|---|---|---|---|---|---|")
        omega, gamma = np.full(k.size, np.nan), np.full(k.size, np.nan)
        for i in range(k.size):
            c = correlations.vaf(z[:, i, :])
            omega[i], gamma[i] = _fit(t, c)
            _, g_short = _fit(t[window], c[window])
            print(f"| {k[i]:.4g} | {omega[i]:.4g} | {gamma[i]:.3e} | {gamma[i] * t_end:.3g} | {g_short:.3e} | "
                  f"{g_short * short:.3g} | {g_short / gamma[i]:.3g} |")
        ok = attenuation.resolved(gamma, t_end)
        if ok.sum() >= 2:
            k_mid, p = attenuation.local_exponents(k[ok], gamma[ok])
            print("\nlocal exponent d ln gamma / d ln k (resolved points): "
                  + ", ".join(f"{p_i:.2f} at k d0 = {k_i:.3g}" for k_i, p_i in zip(k_mid, p)))
        k_ir, omega_ir = attenuation.ioffe_regel(k, omega, gamma)
        print(f"\nIoffe-Regel (omega = 2 pi gamma): k d0 = {k_ir:.3g}, omega t0 = {omega_ir:.3g}\n")


if __name__ == "__main__":
    main()
