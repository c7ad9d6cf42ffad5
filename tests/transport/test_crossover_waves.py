"""scripts/tools/crossover_waves.py, which gives docs/crossover.md its Ioffe-Regel frequencies:
the fits of damped standing waves of known attenuation, the power law over packings, the printed
table read back and the committed record fitted again from its rows.  Serial: it reads files."""

import pathlib

import h5py
import numpy as np
import pytest
from conftest import assert_all, assert_close

from scripts.tools import crossover_waves as waves

pytestmark = pytest.mark.serial_only

ROOT = pathlib.Path(__file__).resolve().parents[2]
RECORD = "scripts/tools/crossover_waves.md"
SPEEDS = {"TR": (0.1, 0.04), "L": (0.3, 0.1)}
"""mode -> (c, a): omega = c k, gamma = a k^3 in the synthetic files."""


def _results(path, dz: float, ks: np.ndarray, rho: float = 0.0) -> None:
    """A results file with one packing (z = 6 + dz) whose TR and L waves (at ``rho``) are exactly
    exp(-gamma t) cos(omega t) with omega = c k and gamma = a k^3 (:data:`SPEEDS`)."""
    t = np.arange(0.0, 2000.0, 0.25)
    with h5py.File(path, "w") as f:
        f.attrs["format_version"] = 1
        p = f.create_group("packings/0000")
        p.attrs.update(phi=0.66, z=6.0 + dz, pressure=1e-3)
        p["rattler"] = np.array([False] * 99 + [True])
        p["positions"] = np.zeros((100, 3))
        for mode, (c, a) in SPEEDS.items():
            g = f.create_group(f"waves/r00_{mode}_p0000")
            g["k"], g["t"] = ks, t
            g["C"] = np.exp(-np.outer(a * ks**3, t)) * np.cos(np.outer(c * ks, t))
            g.attrs.update(packing=0, mode=mode, rho=rho)


def test_the_ioffe_regel_frequency_of_known_waves(tmp_path):
    """Q = c / (2 pi a k^2) falls to 1 at k_IR = sqrt(c / (2 pi a)); Q and omega are power laws of
    k, so the log-log interpolation between the bracketing k is exact: omega_IR = c k_IR to the
    fits' accuracy (exact damped cosines: 1e-6), c and Q at the smallest k likewise; the row counts
    the 99 non-rattlers."""
    ks = 2 * np.pi * np.arange(1, 9) / 20.0
    _results(tmp_path / "w.h5", 0.8, ks)
    (row,) = waves.measure(str(tmp_path / "w.h5"))
    for mode, (c, a) in SPEEDS.items():
        k_ir = np.sqrt(c / (2 * np.pi * a))
        assert_all(ks[0] < k_ir < ks[-1], f"{mode}: k_IR {k_ir} not bracketed by the test's k")
        assert_close(row[f"omega_ir_{mode}"], c * k_ir, rtol=1e-6, atol=0.0, what=f"{mode} omega_IR")
        assert_close(row[f"c_{mode}"], c, rtol=1e-6, atol=0.0, what=f"{mode} c")
        assert_close(row[f"q_1_{mode}"], c / (2 * np.pi * a * ks[0] ** 2), rtol=1e-6, atol=0.0, what=f"{mode} Q_1")
    assert_all(row["N"] == 99 and row["dz"] == pytest.approx(0.8, abs=1e-12) and row["t_end"] == 1999.75, f"{row}")


def test_delta_z_with_tangential_springs_counts_from_four(tmp_path):
    """With rho > 0 the isostatic count of spheres is D + 1 = 4, not 2 D = 6: the same packing
    (z = 6.8) has Delta z = 2.8, and its row carries its rho."""
    _results(tmp_path / "w.h5", 0.8, 2 * np.pi * np.arange(1, 9) / 20.0, rho=0.5)
    (row,) = waves.measure(str(tmp_path / "w.h5"))
    assert_all(row["rho"] == 0.5 and row["dz"] == pytest.approx(2.8, abs=1e-12), f"{row}")


def test_a_crossover_below_the_smallest_k_is_not_measured(tmp_path):
    """k from 1.2 up (Q < 1 for TR from the first k, its k_IR = 0.63): no omega_IR (NaN), and
    omega_1 is its upper bound."""
    ks = np.linspace(1.2, 2.0, 5)
    _results(tmp_path / "w.h5", 0.8, ks)
    (row,) = waves.measure(str(tmp_path / "w.h5"))
    assert_all(np.isnan(row["omega_ir_TR"]) and row["q_1_TR"] < 1, f"{row}")
    assert_close(row["omega_1_TR"], 0.1 * 1.2, rtol=1e-6, atol=0.0, what="omega_1 TR")


def test_a_crossing_at_the_box_edge_is_not_read():
    """Q_1 = 1.05 (a crossing just above the smallest k, within Q_1's scatter between packings):
    omega_IR is NaN; Q_1 = 1.2 reads it (the log-log crossing of two power laws: exact)."""
    k = np.array([0.3, 0.6, 1.2])
    for q_1, read in ((1.05, False), (1.2, True)):
        omega = 0.1 * k
        gamma = omega / (2 * np.pi * q_1 * (k[0] / k) ** 2)  # Q = q_1 (k_1 / k)^2
        row = waves.mode_columns("TR", k, omega, gamma)
        assert_close(row["q_1_TR"], q_1, rtol=1e-12, atol=0.0, what="Q_1")
        expected = 0.1 * k[0] * np.sqrt(q_1) if read else np.nan
        assert_all(np.isnan(row["omega_ir_TR"]) if not read else abs(row["omega_ir_TR"] - expected) < 1e-12,
                   f"Q_1 = {q_1}: omega_IR {row['omega_ir_TR']}, expected {expected}")


def _rows(rng):
    rows = []
    for phi, dz in zip((0.65, 0.652, 0.66, 0.69, 0.76), (0.3, 0.6, 1.0, 1.8, 3.0)):
        for k in range(3):
            rows.append({"file": "x.h5", "phi": phi, "packing": k, "rho": 0.0, "N": 16000, "dz": dz, "pressure": 1e-3 * dz**2,
                         "t_end": 1000.0, "c_TR": 0.2, "omega_1_TR": 0.05, "q_1_TR": 2.0,
                         "omega_ir_TR": 0.05 * dz * (1 + 0.05 * rng.standard_normal()), "c_L": 0.7,
                         "omega_1_L": 0.2, "q_1_L": 2.0, "omega_ir_L": 0.2 * dz**0.5 * (1 + 0.05 * rng.standard_normal())})
    return rows


def test_the_power_law_fit_and_the_table_read_back(capsys, tmp_path):
    """omega_IR = 0.05 Delta z (TR) and 0.2 Delta z^0.5 (L) times a +-5 % scatter over 3 packings at
    each of 5 Delta z: each fit recovers its exponent within two of its standard errors (not zero);
    the printed table reads back as the same rows to its 6 digits."""
    rows = _rows(np.random.default_rng(2))
    got = waves.fits(rows)
    for mode, beta in (("TR", 1.0), ("L", 0.5)):
        p = got[mode]["power"]
        assert_all(0 < p["beta_err"] < 0.1 and abs(p["beta"] - beta) < 2 * p["beta_err"], f"{mode}: {p}")
    one_phi = [r for r in rows if r["phi"] == 0.76]
    assert_all(waves.fits(one_phi)["TR"]["power"] is None, "a power law over one phi")
    waves.print_rows(rows)
    (tmp_path / "t.md").write_text("# page\n\n" + capsys.readouterr().out + "\nafter\n")
    back = waves.read_table(str(tmp_path / "t.md"))
    assert_all(len(back) == len(rows), f"{len(back)} rows read back")
    for r, b in zip(rows, back):
        assert_close(np.array([b[c] for c in waves.COLUMNS[1:]]), np.array([r[c] for c in waves.COLUMNS[1:]]),
                     rtol=1e-5, atol=0.0, what="row read back")


def test_the_allen_feldman_columns_join_only_the_same_packing():
    """A row joins the Allen-Feldman record's omega* and omega_BP of its (phi, packing) only when
    Delta z agrees within 1e-3: a re-minimised packing (Delta z moved by 0.03) gets NaN."""
    rows = _rows(np.random.default_rng(3))[:2]
    af = [{"phi": rows[0]["phi"], "packing": 0, "rho": 0.0, "dz": rows[0]["dz"] + 5e-4, "omega_star": 0.01,
           "omega_bp": 0.02, "eta": 0.001},
          {"phi": rows[1]["phi"], "packing": 1, "rho": 0.0, "dz": rows[1]["dz"] + 0.03, "omega_star": 0.01,
           "omega_bp": 0.02, "eta": 0.001}]
    first, second = waves.joined(rows, af)
    assert_all(first["omega_star"] == 0.01 and first["omega_bp"] == 0.02, f"{first}")
    assert_all(np.isnan(second["omega_star"]) and np.isnan(second["omega_bp"]), f"{second}")


def test_the_committed_record_fits_again_from_its_rows(capsys):
    """The committed record's fits, printed again from its own table and the Allen-Feldman record
    (``--table``, ``--allen-feldman``), are the record's line for line."""
    waves.main(["--table", str(ROOT / RECORD), "--allen-feldman", str(ROOT / "scripts/tools/crossover_findings.md")])
    again = capsys.readouterr().out.strip().splitlines()
    kept = [line for line in (ROOT / RECORD).read_text(encoding="utf-8").strip().splitlines()
            if not line.startswith("figure:")]
    while kept and not kept[-1]:
        kept.pop()
    assert_all(again == kept, f"{RECORD}: the record's fits differ from those of its own table: print it again")


def test_the_manual_quotes_the_waves_fits():
    """Every fit line of the record (omega_IR = a Delta z^beta per mode, the ratios) is quoted word
    for word in docs/crossover.md."""
    record = (ROOT / RECORD).read_text(encoding="utf-8").splitlines()
    manual = (ROOT / "docs/crossover.md").read_text(encoding="utf-8")
    quoted = [line for line in record if line.startswith(("TR: omega_IR", "L: omega_IR", "omega_IR^TR /"))]
    assert_all(len(quoted) >= 3, f"the record prints no fit: {quoted}")
    missing = [line for line in quoted if line not in manual]
    assert_all(not missing, f"docs/crossover.md does not quote {missing}")
