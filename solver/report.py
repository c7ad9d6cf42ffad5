"""Reproduction report: assembles the Markdown of every quantitative claim of the paper against
what the results files hold.

``rotsound report RESULTS.h5 [MORE.h5 ...] [--output REPRODUCTION.md]``: the files are read by
:func:`gather` (vDOS, K/Q and waves/analysis may come from different scenes, e.g. N = 2048
for the vDOS and a larger N for the waves; files whose packings have phi != 0.9 only feed the
phi-insensitivity check, Fig. S1), the claims are evaluated by ``analysis.claims`` (tolerances
fixed there before any run), the figures drawn by ``plots.report_figures`` into
``<output folder>/reproduction/``.  This module only writes the Markdown: sources, the lattice
model fitted, one table row per claim (the paper's value, the value measured here, the tolerance,
PASS / FAIL / not measured) and the figures.  Not collective; never imports PETSc.
"""

from __future__ import annotations

import os

from . import plots
from .analysis.claims import PHI_MAIN, Data, Row, claims
from .errors import InputError
from .io import results

STATUSES = ("PASS", "FAIL", "NOT MEASURED")


def gather(paths: list[str]) -> Data:
    """Read every file for the report: the first file with a quantity at phi = PHI_MAIN provides it
    (the vDOS as a whole; K and Q per rho; the wave analysis as a whole); every file's vDOS feeds
    the phi comparison (Fig. S1)."""
    data = Data()
    for path in paths:
        with results.open_results(path) as f:
            phi, n = results.packing_summary(f)
            data.sources.append((path, phi, n, ", ".join(results.contents(f)) or "nothing usable"))
            curves = results.vdos(f)
            if curves:
                data.s1.setdefault(round(phi, 4), {}).update({rho: v[:3] for rho, v in curves.items()})
            if abs(phi - PHI_MAIN) > 1e-6:
                continue
            if curves and not data.vdos:
                data.vdos, data.vdos_file = curves, path
            for rho, energies in results.mode_energies(f).items():
                if rho in curves and rho not in data.energies:
                    data.energies[rho] = energies
                    data.energies_file[rho] = path
            lat = results.lattice(f)
            if lat is not None and data.lattice is None:
                data.waves_file, data.lattice, data.bands, data.fits = path, lat, results.bands(f), results.fits(f)
    return data


def markdown(d: Data, rows: list[Row], figures: list[tuple[str, str]], base: str, notes: str | None = None) -> str:
    """The report's text; paths are written relative to the folder ``base``; ``notes`` is Markdown
    appended as the Notes section."""
    counts = {s: sum(r.status == s for r in rows) for s in STATUSES}
    lines = ["# Reproduction report", "",
             "Written by `rotsound report` from the results files below; every number is read from them.",
             "Tolerances are fixed in `solver/analysis/claims.py`, not tuned to the data.", "",
             f"**{counts['PASS']} pass, {counts['FAIL']} fail, {counts['NOT MEASURED']} not measured.**", "",
             "## Sources", "", "| file | phi | N | contents |", "|---|---|---|---|"]
    for path, phi, n, what in d.sources:
        lines.append(f"| `{os.path.relpath(path, base)}` | {phi:.3f} | {n} | {what} |")
    if d.lattice:
        lat = d.lattice
        lines += ["", f"Lattice model fitted here: a_r = {lat['a_r']:.4f} ± {lat['a_r_err']:.4f} /t0, "
                      f"l = {lat['l']:.4f} ± {lat['l_err']:.4f} d0 (RT, k d0 ≤ {lat['kd0_max_used']:.3f}, below k_c), "
                      f"a_t = {lat['a_t']:.4f} ± {lat['a_t_err']:.4f} /t0 (TR, same range), "
                      f"a_t beyond k_c = {lat['a_t_edge']:.4f} ± {lat['a_t_edge_err']:.4f} /t0."]
    lines += ["", "## Claims", "", "| # | claim | paper | measured here | tolerance | result |",
              "|---|---|---|---|---|---|"]
    for i, r in enumerate(rows, 1):
        mark = {"PASS": "PASS", "FAIL": "**FAIL**", "NOT MEASURED": "not measured"}[r.status]
        cells = [str(i), r.claim, r.paper, r.measured, r.tolerance, mark]
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    lines += ["", "## Figures", ""]
    for caption, path in figures:
        lines += [f"**{caption}**", "", f"![{caption}]({os.path.relpath(path, base)})", ""]
    if notes:
        lines += ["## Notes", "", notes.strip(), ""]
    return "\n".join(lines) + "\n"


def write(paths: list[str], output: str, notes: str | None = None) -> tuple[str, list[Row]]:
    """Gather, evaluate, draw and write the report; return (output path, rows).  ``notes`` is a
    Markdown file appended as is (what was tried where a claim fails, how the run was made)."""
    text = None
    if notes:
        try:
            with open(notes, encoding="utf-8") as stream:
                text = stream.read()
        except OSError as exc:
            raise InputError(f"notes file {notes}: cannot read ({exc})") from None
    d = gather(paths)
    rows = claims(d)
    base = os.path.dirname(os.path.abspath(output))
    try:
        os.makedirs(os.path.join(base, "reproduction"), exist_ok=True)
    except OSError as exc:
        raise InputError(f"report output {output}: cannot make its figure folder ({exc})") from None
    figures = plots.report_figures(d, os.path.join(base, "reproduction"))
    try:
        with open(output, "w", encoding="utf-8") as stream:
            stream.write(markdown(d, rows, figures, base, text))
    except OSError as exc:
        raise InputError(f"report output {output}: cannot write ({exc})") from None
    return output, rows
