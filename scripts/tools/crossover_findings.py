"""Findings on the diffusivity crossover omega* near jamming (issue 61, point 1) from the results
of configs/crossover.yaml (frictionless spheres, the exact Allen-Feldman route in its
low-frequency window, ``transport.omega_top``; docs/crossover.md):

    python -m scripts.tools.crossover_findings results/crossover_*.h5 [--figures docs/] \
        > scripts/tools/crossover_findings.md
    python -m scripts.tools.crossover_findings --table scripts/tools/crossover_findings.md
    python -m scripts.tools.crossover_findings results/crossover_pilot_*.h5 --bins   # d(omega) per bin

The first form measures every packing and prints its row and the fits; the second fits again from
the rows of a printed table alone (the committed record: the results files are not committed).
The first form fits the rows as printed (6 digits), so the second reproduces its fits exactly:
tests/transport/test_crossover_findings.py checks the committed record so, and that
docs/crossover.md quotes its fits.

Per packing (one transport unit, its modes up to omega_top):

- Delta z = z - 2 D over the non-rattlers (z_iso = 2 D: frictionless, translations only; with
  tangential springs, rho > 0, z_iso = D + 1), the pressure, the lowest mode omega_1;
- d(omega): the mean d_n of each bin of the scene's bins that lies wholly below omega_top;
- the plateau d_p: the median d_n of the modes between omega_top / 2 and omega_top (the window
  must reach well into the plateau: an omega* above omega_top / 2 is not measured, NaN);
- omega*: scanning the bins down from omega_top / 2, the first whose mean d exceeds 2 d_p
  (``diffusivity_findings.crossover_below``: linear in log d between bin centres); Xu et al.'s
  omega_d*, which they find proportional to Delta z;
- the boson peak omega_BP: the maximum of D(omega) / omega^2 (D: the window's modes per bin over
  the matrix's DOF and the bin width) over bins of ``BP_BINS`` of the scene's bins merged, above
  the two lowest shells of plane waves (omega > 2 omega_1: below, a finite box has single
  degenerate shells, whose spikes in D / omega^2 are no boson peak); NaN (not resolved) when the
  maximum is the lowest or the highest bin held.

Fits, with errors from the spread over packings: log omega* = log a + beta log Delta z by least
squares over every packing (errors of a, beta from the residuals' scatter, np.polyfit's
covariance), and omega* / omega_BP, its mean and standard error over the packings, per phi and in
all.  Prints Markdown; draws the figures.  Reads only: no MPI, no PETSc.
"""

from __future__ import annotations

import argparse
import pathlib

import numpy as np

from solver.io import results
from solver.plots.common import DPI, log_ticks, plt, series_colour
from scripts.tools.diffusivity_findings import crossover_below

BP_BINS = 2  # the scene's bins merged for D(omega) / omega^2
COLUMNS = ("file", "phi", "packing", "rho", "N", "z", "dz", "pressure", "eta", "omega_top", "omega_1", "modes",
           "d_p", "omega_star", "omega_bp", "seconds")
"""The per-packing table's columns, in print order (:func:`print_rows`, :func:`read_table`)."""


def unit_row(d_group, packing_group, edges: np.ndarray, path: str) -> dict:
    """One packing's row (module docstring) from its transport unit ``d_group`` (h5py group of
    ``diffusivity/``), its packing's group ``packing_group`` and the scene's bins ``edges``; the
    row's ``bins`` holds (edges, mean d, count) of the bins wholly below omega_top."""
    attrs = d_group.attrs
    omega, d = d_group["omega"][()], d_group["d"][()]
    top = float(attrs.get("omega_top", omega.max(initial=0.0)))
    edges = edges[edges <= top]
    count = np.histogram(omega, bins=edges)[0]
    with np.errstate(invalid="ignore"):
        mean = np.histogram(omega, bins=edges, weights=d)[0] / count
    upper = (omega >= top / 2) & (omega <= top)
    plateau = float(np.median(d[upper])) if upper.any() else float("nan")
    dim = int(attrs["dim"])
    rho = float(attrs["rho"])
    z = float(packing_group.attrs.get("z", np.nan))
    return {"file": path.split("/")[-1], "phi": float(packing_group.attrs["phi"]), "packing": int(attrs["packing"]),
            "rho": rho, "N": int(attrs["n_disks"]), "z": z, "dz": z - (dim + 1 if rho > 0 else 2 * dim),
            "pressure": float(packing_group.attrs.get("pressure", np.nan)), "eta": float(attrs["eta"]),
            "omega_top": top, "omega_1": float(omega.min()) if omega.size else float("nan"), "modes": int(omega.size),
            "d_p": plateau, "omega_star": crossover_below(edges, mean, count, top / 2, plateau),
            "omega_bp": boson_peak(omega, edges, int(attrs["dof"])), "seconds": float(attrs["seconds"]),
            "bins": (edges, mean, count)}


def boson_peak(omega: np.ndarray, edges: np.ndarray, dof: int) -> float:
    """omega_BP (module docstring) of the modes ``omega`` (1/t0) of a matrix of ``dof`` DOF on the
    bins ``edges`` merged by :data:`BP_BINS`: the centre of the bin of largest D(omega) / omega^2
    above 2 omega_1; NaN without such a bin, or when the largest is the lowest bin held (D / omega^2
    still rising towards the box's lowest modes) or the highest (still rising towards omega_top):
    the peak is not resolved."""
    coarse = edges[::BP_BINS]
    count = np.histogram(omega, bins=coarse)[0]
    centres = 0.5 * (coarse[1:] + coarse[:-1])
    ratio = count / (dof * np.diff(coarse)) / centres**2
    held = np.flatnonzero(coarse[:-1] > 2 * omega.min(initial=np.inf))
    if held.size == 0 or np.argmax(ratio[held]) in (0, held.size - 1):
        return float("nan")
    return float(centres[held][np.argmax(ratio[held])])


def measure(path: str) -> list[dict]:
    """Every transport unit's row (:func:`unit_row`) of the results file ``path``."""
    rows = []
    with results.open_results(path) as f:
        for name in sorted(f["diffusivity"]):
            unit = f["diffusivity"][name]
            edges = f["diffusivity_binned"][name.split("_")[0]]["edges"][()]
            rows.append(unit_row(unit, f["packings"][f"{int(unit.attrs['packing']):04d}"], edges, path))
    return rows


def fits(rows: list[dict]) -> dict:
    """The fits of the module docstring over ``rows`` of one rho: {"a", "a_err", "beta", "beta_err",
    "n"} of omega* = a Delta z^beta (None with fewer than 3 packings measured), "ratio", "ratio_err"
    (omega* / omega_BP), and "by_phi": per phi (n, Delta z mean and standard error, omega* and
    omega_BP the same)."""
    held = [r for r in rows if np.isfinite(r["omega_star"]) and r["dz"] > 0]
    out: dict = {"n": len(held), "power": None}
    if len(held) >= 3:
        dz, star = (np.array([r[k] for r in held]) for k in ("dz", "omega_star"))
        (beta, log_a), cov = np.polyfit(np.log(dz), np.log(star), 1, cov=True)
        out["power"] = {"a": float(np.exp(log_a)), "a_err": float(np.exp(log_a) * np.sqrt(cov[1, 1])),
                        "beta": float(beta), "beta_err": float(np.sqrt(cov[0, 0]))}
    ratios = np.array([r["omega_star"] / r["omega_bp"] for r in held if np.isfinite(r["omega_bp"])])
    out["ratio"], out["ratio_err"] = _mean_err(ratios)
    by_phi = {}
    for phi in sorted({r["phi"] for r in rows}):
        group = [r for r in rows if r["phi"] == phi]
        by_phi[phi] = {"n": len(group), **{key: _mean_err(np.array([r[key] for r in group]))
                                           for key in ("dz", "pressure", "omega_star", "omega_bp", "d_p")}}
    out["by_phi"] = by_phi
    return out


def _mean_err(values: np.ndarray) -> tuple[float, float]:
    """(mean, standard error) of the finite ``values``: NaN, NaN without any; error NaN with one."""
    values = values[np.isfinite(values)]
    if values.size == 0:
        return float("nan"), float("nan")
    err = values.std(ddof=1) / np.sqrt(values.size) if values.size > 1 else float("nan")
    return float(values.mean()), float(err)


def print_rows(rows: list[dict], columns: tuple[str, ...] = COLUMNS) -> None:
    """The per-packing table of ``columns`` (a "file" name, then numbers) as Markdown."""
    print("| " + " | ".join(columns) + " |")
    print("|" + "---|" * len(columns))
    for r in rows:
        print("| " + " | ".join(r[c] if c == "file" else f"{r[c]:.6g}" for c in columns) + " |")


def print_bins(rows: list[dict]) -> None:
    """Each measured row's d(omega) as Markdown: per bin (edges in 1/t0) its modes and mean d."""
    for r in rows:
        edges, mean, count = r["bins"]
        print(f"\n### {r['file']}, packing {r['packing']:g}, rho = {r['rho']:g}, eta = {r['eta']:g}\n")
        print("| omega from | to | modes | mean d |")
        print("|---|---|---|---|")
        for lo, hi, c, d in zip(edges[:-1], edges[1:], count, mean):
            print(f"| {lo:.4g} | {hi:.4g} | {c} | {d:.4g} |")


def as_printed(row: dict, kept: tuple[str, ...] = ("file", "bins")) -> dict:
    """``row`` with its numbers rounded as :func:`print_rows` prints them (6 digits), the entries
    ``kept`` as they are: the fits of a measured row and of its printed table are then the same."""
    return {c: v if c in kept else float(f"{v:.6g}") for c, v in row.items()}


def read_table(path: str, columns: tuple[str, ...] = COLUMNS) -> list[dict]:
    """The rows of the first table of ``columns`` in the Markdown file ``path`` (a printed
    findings page), numbers as floats."""
    rows, inside = [], False
    for line in open(path, encoding="utf-8"):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if tuple(cells) == columns:
            inside = True
        elif inside and line.startswith("|---"):
            continue
        elif inside and line.startswith("|"):
            rows.append({c: v if c == "file" else float(v) for c, v in zip(columns, cells)})
        elif inside:
            break
    return rows


def print_fits(rows: list[dict]) -> None:
    """Per rho: the per-phi summary and the fits (:func:`fits`) as Markdown."""
    for rho in sorted({r["rho"] for r in rows}):
        got = fits([r for r in rows if r["rho"] == rho])
        print(f"\n## rho = {rho:g}\n")
        print("| phi | packings | Delta z | pressure | omega* t0 | omega_BP t0 | d_p [d0^2/t0] |")
        print("|---|---|---|---|---|---|---|")
        for phi, s in got["by_phi"].items():
            print(f"| {phi:g} | {s['n']} | " + " | ".join(f"{s[k][0]:.4g} ± {s[k][1]:.2g}" for k in
                                                            ("dz", "pressure", "omega_star", "omega_bp", "d_p")) + " |")
        if got["power"]:
            p = got["power"]
            print(f"\nomega* = ({p['a']:.3g} ± {p['a_err']:.2g}) Delta z^({p['beta']:.3f} ± {p['beta_err']:.3f}) over "
                  f"{got['n']} packings (least squares in logs; errors from their scatter; Xu et al.: exponent 1)")
        else:
            print(f"\nomega* measured on {got['n']} packings: too few for the power law (3 or more)")
        print(f"\nomega* / omega_BP = {got['ratio']:.3g} ± {got['ratio_err']:.2g} (mean and standard error over the "
              f"packings)")


def draw(rows: list[dict]) -> dict:
    """{file name without .png: figure} of measured ``rows`` (with their ``bins``): with rows of
    rho > 0, ``crossover_rotations``: their d(omega) beside the rho = 0 rows of the same phi and N
    (the same packings, read from one file); without, ``crossover_spheres``: d(omega) of each
    packing coloured by phi, and omega* and omega_BP against Delta z with the fit."""
    springs = [r for r in rows if r["rho"] > 0]
    if springs:
        return {"crossover_rotations": _draw_rotations(springs, [r for r in rows if r["rho"] == 0])}
    rows = sorted(rows, key=lambda r: r["dz"])
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4.2))
    phis = sorted({r["phi"] for r in rows})
    for r in rows:
        edges, mean, _ = r["bins"]
        colour = series_colour(phis.index(r["phi"]), len(phis))
        ax.plot(0.5 * (edges[1:] + edges[:-1]), mean, "-", color=colour, lw=0.8,
                label=rf"$\phi$ = {r['phi']:g}" if r["packing"] == 0 else None)
        if np.isfinite(r["omega_star"]):
            ax.axvline(r["omega_star"], color=colour, ls=":", lw=0.6)
    ax.set(xscale="log", yscale="log", xlabel=r"$\omega\,t_0$", ylabel=r"$d(\omega)\;[d_0^2/t_0]$",
           title=f"frictionless spheres, $N$ = {min(r['N'] for r in rows):.0f}-{max(r['N'] for r in rows):.0f}"
                 " (non-rattlers)\n"
                 r"$d(\omega)$ per packing, dotted: $\omega^*$")
    ax.legend(fontsize=7)
    dz = np.array([r["dz"] for r in rows])
    for key, mark, label in (("omega_star", "o", r"$\omega^*$"), ("omega_bp", "s", r"$\omega_{BP}$")):
        bx.loglog(dz, [r[key] for r in rows], mark, mfc="none", label=label)
    power = fits(rows)["power"]
    if power:
        line = np.geomspace(dz.min(), dz.max(), 20)
        bx.loglog(line, power["a"] * line ** power["beta"], "k--", lw=0.8,
                  label=rf"$\omega^* = {power['a']:.2f}\,\Delta z^{{{power['beta']:.2f}}}$")
    bx.set(xlabel=r"$\Delta z = z - 6$", ylabel=r"$\omega\,t_0$", title=r"crossover and boson peak against $\Delta z$")
    bx.legend(fontsize=8)
    for axis in (ax.xaxis, ax.yaxis, bx.xaxis, bx.yaxis):
        log_ticks(axis)
    fig.tight_layout()
    return {"crossover_spheres": fig}


def _draw_rotations(springs: list[dict], frictionless: list[dict]):
    """:func:`draw`'s figure of the rows with tangential springs ``springs`` and the rho = 0 rows."""
    fig, ax = plt.subplots(figsize=(5.5, 4.2))
    for k, s in enumerate(springs):
        colour = series_colour(k, len(springs))
        for r, style, label in [(s, "-", rf"$\rho$ = {s['rho']:g}")] + [
                (r, "--", r"$\rho$ = 0") for r in frictionless if (r["phi"], r["N"]) == (s["phi"], s["N"])]:
            edges, mean, _ = r["bins"]
            ax.plot(0.5 * (edges[1:] + edges[:-1]), mean, style, color=colour, lw=0.9,
                    label=rf"$\phi$ = {s['phi']:g}, {label}, $\Delta z$ = {r['dz']:.2f}")
    ax.set(xscale="log", yscale="log", xlabel=r"$\omega\,t_0$", ylabel=r"$d(\omega)\;[d_0^2/t_0]$",
           title=f"with and without tangential springs, $N$ = {springs[0]['N']:.0f}\n"
                 r"$\Delta z = z - 4$ with, $z - 6$ without")
    ax.legend(fontsize=7)
    log_ticks(ax.xaxis)
    log_ticks(ax.yaxis)
    fig.tight_layout()
    return fig


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("paths", nargs="*", help="results files of configs/crossover.yaml")
    parser.add_argument("--table", help="fit again from the per-packing table of a printed findings page")
    parser.add_argument("--figures", help="folder to draw the figures into (with results files)")
    parser.add_argument("--bins", action="store_true", help="also print each packing's d(omega) per bin (with "
                                                            "results files)")
    args = parser.parse_args(argv)
    rows = read_table(args.table) if args.table else [as_printed(row) for path in args.paths for row in measure(path)]
    print("# The diffusivity crossover near jamming: findings (scripts/tools/crossover_findings.py)\n")
    print_rows(rows)
    print_fits(rows)
    if args.bins and not args.table:
        print_bins(rows)
    if args.figures and not args.table:
        for name, fig in draw(rows).items():
            path = pathlib.Path(args.figures) / f"{name}.png"
            fig.savefig(path, dpi=DPI)
            plt.close(fig)
            print(f"\nfigure: {path}")


if __name__ == "__main__":
    main()
