"""scripts/tools/crossover_findings.py, which writes up docs/crossover.md: its crossover and
boson-peak rules on a window of modes of known shape, the power-law fit over packings, and the
printed table read back.  Serial: it reads files."""

import h5py
import numpy as np
import pytest
from conftest import assert_all, assert_close

from scripts.tools import crossover_findings as findings

pytestmark = pytest.mark.serial_only

WIDTH = 0.01  # the scene's bins (1/t0)


def _unit(omega0: float, top: float, plateau: float = 0.2):
    """An in-memory (file, unit group, packing group, edges) whose modes up to ``top`` (per bin of
    WIDTH: 3 below omega0, 10 above) have d = plateau (1 + (omega0 / omega)^4), which doubles the
    plateau at omega0."""
    f = h5py.File(f"unit{omega0}.h5", "w", driver="core", backing_store=False)
    edges = np.arange(0.0, 1.0 + WIDTH / 2, WIDTH)
    centres = 0.5 * (edges[1:] + edges[:-1])
    held = centres < top
    counts = np.where(centres < omega0, 3, 10)[held]
    omega = np.repeat(centres[held], counts)
    g = f.create_group("diffusivity/r00_p0000")
    g["omega"], g["d"] = omega, plateau * (1 + (omega0 / omega) ** 4)
    g.attrs.update(omega_top=top, dim=3, rho=0.0, packing=0, n_disks=100, eta=0.002, dof=300, seconds=1.0)
    p = f.create_group("packings/0000")
    p.attrs.update(phi=0.66, z=6.9, pressure=1e-3)
    return f, g, p, edges


@pytest.mark.parametrize("omega0", [0.06, 0.1])
def test_crossover_and_boson_peak_of_a_known_window(omega0):
    """d = d_p (1 + (omega0/omega)^4) reaches 2 d_p at omega0: omega* within a bin of it; the
    plateau is the median d of the window's upper half (within 0.1 % of d_p: (omega0 / omega)^4
    < 5e-4 at its median omega, 0.675)."""
    f, g, p, edges = _unit(omega0, top=0.9)
    with f:
        row = findings.unit_row(g, p, edges, "x.h5")
    assert_close(row["omega_star"], omega0, rtol=0.0, atol=WIDTH, what="omega* within a bin")
    assert_close(row["d_p"], 0.2, rtol=1e-3, atol=0.0, what="plateau")
    assert_all(row["dz"] == pytest.approx(0.9) and row["omega_top"] == 0.9, f"{row}")


@pytest.mark.parametrize("omega0", [0.06, 0.1])
def test_boson_peak_of_a_known_vdos(omega0):
    """Modes per bin of WIDTH growing as omega^3 below omega0 (D / omega^2 rising as omega) and
    constant above (D / omega^2 falling as omega^-2): the peak lies in the merged bin of 2 WIDTH
    at omega0, whose centre is within 2 WIDTH of it."""
    edges = np.arange(0.0, 0.5001, WIDTH)
    centres = 0.5 * (edges[1:] + edges[:-1])
    counts = np.rint(1000 * np.minimum(centres / omega0, 1.0) ** 3).astype(int)
    omega = np.repeat(centres, counts)
    assert_close(findings.boson_peak(omega, edges, 3000), omega0, rtol=0.0, atol=2 * WIDTH, what="omega_BP")


def test_a_boson_peak_at_the_lowest_bin_held_is_not_resolved():
    """D / omega^2 rising down to the lowest bin above 2 omega_1 (10 modes per bin everywhere):
    no peak is resolved (NaN), not the lowest bin."""
    omega = np.repeat(np.arange(0.015, 0.5, WIDTH), 10)
    assert_all(np.isnan(findings.boson_peak(omega, np.arange(0.0, 0.5001, WIDTH), 300)), "a boundary maximum")


def test_a_boson_peak_at_the_highest_bin_held_is_not_resolved():
    """Modes per bin growing as omega^3 up to the window's top (D / omega^2 rising as omega: a
    Debye-like spectrum stiffer than the window): no peak is resolved (NaN), not the highest bin."""
    edges = np.arange(0.0, 0.5001, WIDTH)
    centres = 0.5 * (edges[1:] + edges[:-1])
    omega = np.repeat(centres, np.rint(1000 * (centres / 0.5) ** 3).astype(int))
    assert_all(np.isnan(findings.boson_peak(omega, edges, 3000)), "a boundary maximum")


def test_the_bins_printed_are_the_rows_bins(capsys):
    """--bins prints each row's bins wholly below omega_top: their edges, counts (3 below omega0,
    10 above) and mean d (d_p (1 + (omega0 / omega)^4) at the bin's centre) to 4 digits."""
    f, g, p, edges = _unit(0.06, top=0.2)
    with f:
        row = findings.unit_row(g, p, edges, "x.h5")
    findings.print_bins([row])
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| 0")]
    assert_all(len(lines) == 20, f"{len(lines)} bins printed, not the 20 below omega_top = 0.2")
    for k, line in enumerate(lines):
        lo, hi, count, mean = (float(v) for v in line.strip("|").split("|"))
        centre = (k + 0.5) * WIDTH
        expected = 0.2 * (1 + (0.06 / centre) ** 4)
        assert_all(abs(lo - k * WIDTH) < 1e-12 and count == (3 if centre < 0.06 else 10) and
                   abs(mean - expected) <= 5e-4 * expected, line)


def test_a_crossover_above_half_the_window_is_not_measured():
    """omega0 = 0.4 in a window to 0.5: d already exceeds twice the (overestimated) plateau at
    omega_top / 2, so omega* is not measured (NaN), not extrapolated above it."""
    f, g, p, edges = _unit(0.4, top=0.5)
    with f:
        row = findings.unit_row(g, p, edges, "x.h5")
    assert_all(np.isnan(row["omega_star"]), f"omega* {row['omega_star']} measured above omega_top / 2")


def test_the_power_law_fit_and_the_table_read_back(capsys):
    """omega* = 0.3 Delta z^1.2 times a scatter of +-5 % over 3 packings at each of 5 Delta z: the
    fit recovers beta within two of its standard errors (and the error is not zero); the printed
    per-packing table reads back as the same rows to its 6 digits."""
    rng = np.random.default_rng(1)
    rows = []
    for phi, dz in zip((0.65, 0.652, 0.66, 0.69, 0.76), (0.3, 0.6, 1.0, 1.8, 3.0)):
        for k in range(3):
            star = 0.3 * dz**1.2 * (1 + 0.05 * rng.standard_normal())
            rows.append({"file": "x.h5", "phi": phi, "packing": k, "rho": 0.0, "N": 16000, "z": 6 + dz, "dz": dz,
                         "pressure": 1e-3 * dz**2, "eta": 0.002, "omega_top": 1.0, "omega_1": 0.01, "modes": 999,
                         "d_p": 0.2, "omega_star": star, "omega_bp": star / 1.5, "seconds": 1.0})
    got = findings.fits(rows)
    power = got["power"]
    assert_all(0 < power["beta_err"] < 0.1 and abs(power["beta"] - 1.2) < 2 * power["beta_err"], f"{power}")
    assert_close(got["ratio"], 1.5, rtol=1e-12, what="omega* / omega_BP")
    findings.print_rows(rows)
    path = "table.md"
    import pathlib
    import tempfile
    with tempfile.TemporaryDirectory() as folder:
        (pathlib.Path(folder) / path).write_text("# page\n\n" + capsys.readouterr().out + "\nafter\n")
        back = findings.read_table(str(pathlib.Path(folder) / path))
    assert_all(len(back) == len(rows), f"{len(back)} rows read back")
    for r, b in zip(rows, back):
        assert_close(np.array([b[c] for c in findings.COLUMNS[1:]]), np.array([r[c] for c in findings.COLUMNS[1:]]),
                     rtol=1e-5, what="row read back")



RECORDS = ("scripts/tools/crossover_findings.md", "scripts/tools/crossover_pilot_findings.md",
           "scripts/tools/crossover_eta_findings.md")
"""The committed findings (docs/crossover.md): N = 16384, the pilot with tangential springs, the eta
check; printed from results files, which are not committed."""


@pytest.mark.parametrize("record", RECORDS)
def test_a_committed_record_fits_again_from_its_rows(record, capsys):
    """A committed record's fits printed again from its own per-packing table (``--table``) are the
    record's, line for line (the record's fits are made from its rows as printed): the record was
    printed by this script, and its fits follow from its rows."""
    import pathlib
    text = (pathlib.Path(__file__).resolve().parents[2] / record).read_text(encoding="utf-8")
    findings.main(["--table", str(pathlib.Path(__file__).resolve().parents[2] / record)])
    again = capsys.readouterr().out.strip().splitlines()
    kept = text.split("\n### ")[0]  # --bins' tables, not fits, follow the fits
    kept = [line for line in kept.strip().splitlines() if not line.startswith("figure:")]
    while kept and not kept[-1]:
        kept.pop()
    assert_all(again == kept, f"{record}: the record's fits differ from those of its own table: print it again")


def test_the_manual_quotes_the_n16384_fits():
    """Every fit line the N = 16384 record prints (omega* = a Delta z^beta, omega* / omega_BP) is
    quoted word for word in docs/crossover.md, so the manual's figures are the record's."""
    import pathlib
    root = pathlib.Path(__file__).resolve().parents[2]
    record = (root / RECORDS[0]).read_text(encoding="utf-8").splitlines()
    manual = (root / "docs/crossover.md").read_text(encoding="utf-8")
    quoted = [line for line in record if line.startswith(("omega* = (", "omega* / omega_BP ="))]
    assert_all(len(quoted) >= 2, f"the record prints no fit: {quoted}")
    missing = [line for line in quoted if line not in manual]
    assert_all(not missing, f"docs/crossover.md does not quote {missing}")
