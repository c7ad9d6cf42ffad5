"""The crossover near jamming from the standing waves (issue 61, point 1; docs/crossover.md):
per packing of configs/crossover_waves.yaml, the transverse and longitudinal Ioffe-Regel
frequencies, with no broadening eta:

    python -m scripts.tools.crossover_waves results/crossover_waves_phi*.h5 \
        [--allen-feldman scripts/tools/crossover_findings.md] [--figure docs/crossover_waves.png] \
        > scripts/tools/crossover_waves.md
    python -m scripts.tools.crossover_waves --table scripts/tools/crossover_waves.md \
        [--allen-feldman scripts/tools/crossover_findings.md]

The first form measures every packing and prints its row and the fits; the second fits again from
the rows of a printed table alone (the committed record: results files are not committed); both
fit the rows as printed (6 digits), so they agree exactly (tests/transport/test_crossover_waves.py
checks the committed record so, and that docs/crossover.md quotes its fits).

Per packing and mode (TR: the 6 transverse runs, L: the 3 longitudinal, k along x, y, z; C(k, t)
averaged over them, the results file's ``waves`` groups):

- at each k, the damped-cosine fit exp(-gamma t) cos(omega t) of C(k, t) (``fits.fit_damped_cosine``,
  decay window 3, as the scene's own analysis), and its quality Q = omega / (2 pi gamma): Q > 1, the
  wave outlives a period (a phonon); Q < 1, it is scattered within one;
- c = omega / k at the smallest k (the box's lowest shell, k_1 = 2 pi / L), and Q_1 there;
- the Ioffe-Regel point (``attenuation.ioffe_regel``): the first k at which Q falls to 1, and the
  frequency there, omega_IR; NaN when Q_1 < :data:`Q_EDGE` (then omega_IR is below, or within the
  scatter of, the box's smallest k: the table's ``omega_1`` is its upper bound), or when Q stays
  above 1 up to the largest k.  Q_EDGE = 1.1: Q_1 scatters by 3-25 % between packings of one phi
  (docs/crossover.md, section 6), so a crossing read within 10 % of Q = 1 at k_1 cannot be told
  from one below the box.

Fits: log omega_IR = log a + beta log Delta z by least squares over the packings with an omega_IR
(errors from the residuals' scatter), per mode; per phi the mean and standard error of each column.
With ``--allen-feldman`` (the Allen-Feldman record, scripts/tools/crossover_findings.md), the same
packings' omega* (from d(omega), at one eta) and omega_BP, joined by (phi, packing), and
omega_IR^T / omega_BP.  Prints Markdown.  Reads only: no MPI, no PETSc.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from solver.analysis import attenuation, fits as fitting
from solver.io import results
from solver.plots.common import DPI, log_ticks, plt, series_colour
from scripts.tools import crossover_findings

MODES = ("TR", "L")
Q_EDGE = 1.1
"""Q at the smallest k below which omega_IR is not read (module docstring)."""
COLUMNS = ("file", "phi", "packing", "rho", "N", "dz", "pressure", "t_end",
           "c_TR", "omega_1_TR", "q_1_TR", "omega_ir_TR", "c_L", "omega_1_L", "q_1_L", "omega_ir_L")
"""The per-packing table's columns, in print order (:func:`print_rows`, :func:`read_table`)."""


def fit_waves(t: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(omega (K,), gamma (K,)) of the damped-cosine fit of each row of ``C`` (K, S) on times ``t``
    (S,); NaN where the fit fails."""
    omega, gamma = np.full(len(C), np.nan), np.full(len(C), np.nan)
    for i, c in enumerate(C):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                fit = fitting.fit_damped_cosine(t, c, 3.0)
            except (RuntimeError, ValueError):
                continue
        omega[i], gamma[i] = fit.omega, fit.gamma
    return omega, gamma


def mode_columns(mode: str, k: np.ndarray, omega: np.ndarray, gamma: np.ndarray) -> dict:
    """One mode's columns (module docstring) from its fits at increasing ``k``."""
    q_1 = omega[0] / (2 * np.pi * gamma[0])
    return {f"c_{mode}": omega[0] / k[0], f"omega_1_{mode}": omega[0], f"q_1_{mode}": q_1,
            f"omega_ir_{mode}": attenuation.ioffe_regel(k, omega, gamma)[1] if q_1 >= Q_EDGE else float("nan")}


def measure(path: str) -> list[dict]:
    """Every (rho, packing)'s row of the results file ``path``, with its fits per mode (``curves``:
    mode -> (k, omega, gamma)).  Delta z = z - 2 D without tangential springs, z - (D + 1) with
    (rho > 0: the isostatic counts of crossover_findings)."""
    rows = []
    with results.open_results(path) as f:
        groups = [f["waves"][name] for name in sorted(f["waves"])]
        for rho, index in sorted({(float(g.attrs["rho"]), int(g.attrs["packing"])) for g in groups}):
            packing = f["packings"][f"{index:04d}"]
            dim = packing["positions"].shape[1]
            row = {"file": path.split("/")[-1], "phi": float(packing.attrs["phi"]), "packing": index, "rho": rho,
                   "N": int(np.count_nonzero(~packing["rattler"][()])),
                   "dz": float(packing.attrs["z"]) - (dim + 1 if rho > 0 else 2 * dim),
                   "pressure": float(packing.attrs["pressure"]), "curves": {}}
            for mode in MODES:
                (g,) = [g for g in groups if (float(g.attrs["rho"]), int(g.attrs["packing"]), g.attrs["mode"]) ==
                        (rho, index, mode)]
                t = g["t"][()]
                omega, gamma = fit_waves(t, g["C"][()])
                row["t_end"] = float(t[-1])
                row["curves"][mode] = (g["k"][()], omega, gamma)
                row.update(mode_columns(mode, g["k"][()], omega, gamma))
            rows.append(row)
    return rows


def fits(rows: list[dict]) -> dict:
    """Per mode: {"n", "power": {"a", "a_err", "beta", "beta_err"} or None (fewer than 3 packings,
    or one phi)} of omega_IR = a Delta z^beta over ``rows`` (of one rho); "by_phi": per phi
    {column: (mean, standard error)}."""
    out: dict = {}
    for mode in MODES:
        held = [r for r in rows if np.isfinite(r[f"omega_ir_{mode}"]) and r["dz"] > 0]
        power = None
        if len(held) >= 3 and len({r["phi"] for r in held}) >= 2:
            dz, ir = (np.array([r[key] for r in held]) for key in ("dz", f"omega_ir_{mode}"))
            (beta, log_a), cov = np.polyfit(np.log(dz), np.log(ir), 1, cov=True)
            power = {"a": float(np.exp(log_a)), "a_err": float(np.exp(log_a) * np.sqrt(cov[1, 1])),
                     "beta": float(beta), "beta_err": float(np.sqrt(cov[0, 0]))}
        out[mode] = {"n": len(held), "power": power}
    out["by_phi"] = {phi: {key: crossover_findings._mean_err(np.array([r[key] for r in rows if r["phi"] == phi]))
                           for key in COLUMNS[4:]} | {"n": sum(r["phi"] == phi for r in rows)}
                     for phi in sorted({r["phi"] for r in rows})}
    return out


def joined(rows: list[dict], af_rows: list[dict]) -> list[dict]:
    """``rows`` each with the Allen-Feldman record's ``omega_star``, ``omega_bp`` and ``eta`` of the
    same packing and rho: the same (phi, packing, rho) and Delta z within 1e-3 (a re-minimised
    packing has moved: NaN, as when the record lacks it)."""
    af = {(r["phi"], int(r["packing"]), r["rho"]): r for r in af_rows}
    out = []
    for r in rows:
        other = af.get((r["phi"], int(r["packing"]), r["rho"]), {})
        same = other and abs(other["dz"] - r["dz"]) < 1e-3
        out.append(r | {key: other[key] if same else float("nan") for key in ("omega_star", "omega_bp", "eta")})
    return out


def print_rows(rows: list[dict]) -> None:
    """The per-packing table (:data:`COLUMNS`) as Markdown."""
    crossover_findings.print_rows(rows, COLUMNS)


def as_printed(row: dict) -> dict:
    """``row`` with its numbers rounded as printed (6 digits), its ``curves`` kept."""
    return crossover_findings.as_printed(row, ("file", "curves"))


def read_table(path: str) -> list[dict]:
    """The rows of the first table of :data:`COLUMNS` in the Markdown file ``path``."""
    return crossover_findings.read_table(path, COLUMNS)


def print_fits(rows: list[dict]) -> None:
    """Per rho: the per-phi summary, the power laws and, with joined Allen-Feldman columns, the
    comparison."""
    for rho in sorted({r["rho"] for r in rows}):
        print(f"\n## rho = {rho:g}")
        _print_fits([r for r in rows if r["rho"] == rho])


def _print_fits(rows: list[dict]) -> None:
    """:func:`print_fits` for ``rows`` of one rho."""
    got = fits(rows)
    print("\n| phi | packings | Delta z | c_TR | omega_1_TR | Q_1 TR | omega_IR TR | c_L | omega_IR L |")
    print("|---|---|---|---|---|---|---|---|---|")
    for phi, s in got["by_phi"].items():
        print(f"| {phi:g} | {s['n']} | " + " | ".join(f"{s[k][0]:.4g} ± {s[k][1]:.2g}" for k in
              ("dz", "c_TR", "omega_1_TR", "q_1_TR", "omega_ir_TR", "c_L", "omega_ir_L")) + " |")
    for mode in MODES:
        p, n = got[mode]["power"], got[mode]["n"]
        if p:
            print(f"\n{mode}: omega_IR = ({p['a']:.3g} ± {p['a_err']:.2g}) Delta z^({p['beta']:.3f} ± "
                  f"{p['beta_err']:.3f}) over {n} packings (least squares in logs; errors from their scatter)")
        else:
            print(f"\n{mode}: omega_IR measured on {n} packings: too few for the power law (3 or more, at 2 or "
                  f"more phi)")
    if "omega_bp" in rows[0]:
        ratio = np.array([r["omega_ir_TR"] / r["omega_bp"] for r in rows])
        star = np.array([r["omega_ir_TR"] / r["omega_star"] for r in rows])
        for name, values in (("omega_IR^TR / omega_BP", ratio), ("omega_IR^TR / omega* (Allen-Feldman)", star)):
            if not np.isfinite(values).any():
                continue
            mean, err = crossover_findings._mean_err(values)
            print(f"\n{name} = {mean:.3g} ± {err:.2g} over {np.isfinite(values).sum()} packings with both")


def draw(rows: list[dict]):
    """Q(omega) per packing and mode (left), omega_IR against Delta z with the fits (right)."""
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4.2))
    springs = [r for r in rows if r["rho"] > 0]
    rows = [r for r in rows if r["rho"] == 0]
    phis = sorted({r["phi"] for r in rows})
    for r in rows:
        colour = series_colour(phis.index(r["phi"]), len(phis))
        for mode, style in zip(MODES, ("o-", "s--")):
            k, omega, gamma = r["curves"][mode]
            ax.loglog(omega, omega / (2 * np.pi * gamma), style, color=colour, ms=3, lw=0.7, mfc="none",
                      label=rf"$\phi$ = {r['phi']:g}" if r["packing"] == 0 and mode == "TR" else None)
    ax.axhline(1.0, color="k", lw=0.6)
    ax.set(xlabel=r"$\omega\,t_0$ (fitted)", ylabel=r"$Q = \omega / 2\pi\gamma$",
           title="standing waves per packing, $\\rho$ = 0: TR (circles),\nL (squares, dashed); $Q$ = 1: Ioffe-Regel")
    ax.legend(fontsize=7, ncol=2)
    dz = np.array([r["dz"] for r in rows])
    got = fits(rows)
    for mode, mark in zip(MODES, ("o", "s")):
        bx.loglog(dz, [r[f"omega_ir_{mode}"] for r in rows], mark, mfc="none", label=rf"$\omega_{{IR}}$ {mode}")
        bx.loglog(dz, [r[f"omega_1_{mode}"] for r in rows], mark, ms=3, color="0.6",
                  label=r"lowest wave ($k_1$): bound where $Q_1 < 1$" if mode == "TR" else None)
        p = got[mode]["power"]
        if p:  # over the Delta z it was fitted on only
            fitted = dz[np.isfinite([r[f"omega_ir_{mode}"] for r in rows])]
            line = np.geomspace(fitted.min(), fitted.max(), 20)
            bx.loglog(line, p["a"] * line ** p["beta"], "k--" if mode == "TR" else "k:", lw=0.8,
                      label=rf"{mode}: ${p['a']:.3f}\,\Delta z^{{{p['beta']:.2f}}}$")
    if "omega_star" in rows[0]:
        bx.loglog(dz, [r["omega_star"] for r in rows], "x", label=r"$\omega^*$ Allen-Feldman")
        bx.loglog(dz, [r["omega_bp"] for r in rows], "+", ms=9, label=r"$\omega_{BP}$")
    for rho in sorted({r["rho"] for r in springs}):
        held = [r for r in springs if r["rho"] == rho]
        bx.loglog([r["dz"] for r in held], [r["omega_ir_TR"] for r in held], "D", ms=5, color="k",
                  label=rf"$\omega_{{IR}}$ TR, $\rho$ = {rho:g}")
    bx.set(xlabel=r"$\Delta z = z - 6$" + (r" ($z - 4$ with $\rho > 0$)" if springs else ""), ylabel=r"$\omega\,t_0$", title="Ioffe-Regel frequencies against $\\Delta z$")
    low, high = bx.get_ylim()
    bx.set_ylim(low, high * 4)  # room above the points for the legend
    bx.legend(fontsize=7, loc="upper left", ncol=2)
    for axis in (ax.xaxis, ax.yaxis, bx.xaxis, bx.yaxis):
        log_ticks(axis)
    fig.tight_layout()
    return fig


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("paths", nargs="*", help="results files of configs/crossover_waves.yaml")
    parser.add_argument("--table", help="fit again from the per-packing table of a printed findings page")
    parser.add_argument("--allen-feldman", help="the Allen-Feldman record (scripts/tools/crossover_findings.md)")
    parser.add_argument("--figure", help="the figure's path (.png; with results files)")
    args = parser.parse_args(argv)
    rows = read_table(args.table) if args.table else [as_printed(r) for path in args.paths for r in measure(path)]
    rows = sorted(rows, key=lambda r: (r["rho"], -r["phi"], r["packing"]))
    if args.allen_feldman:
        rows = joined(rows, crossover_findings.read_table(args.allen_feldman))
    print("# The crossover from the standing waves: findings (scripts/tools/crossover_waves.py)\n")
    print_rows(rows)
    print_fits(rows)
    if args.figure and not args.table:
        fig = draw(rows)
        fig.savefig(args.figure, dpi=DPI)
        plt.close(fig)
        print(f"\nfigure: {args.figure}")


if __name__ == "__main__":
    main()
