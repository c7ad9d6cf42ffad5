"""scripts/tools/diffusivity_findings.py, which writes up docs/diffusion.md: its crossover rule on a d(omega)
of known shape, its prediction of d from the waves' attenuation against the closed form of one
branch, and its reading of a real scene's results file (per-mode participation and rotational
shares paired with the modes' d).  Serial: it reads files."""

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close, scene_of

from solver import pipeline
from solver.io import results
from scripts.tools import diffusivity_findings as findings

pytestmark = pytest.mark.serial_only


def _curve(omega0: float, plateau: float) -> results.Diffusivity:
    """d(omega) = plateau (1 + (omega0 / omega)^4) on bins of 0.05 up to 3, 10 modes per bin."""
    edges = np.arange(0.0, 3.0001, 0.05)
    centres = 0.5 * (edges[1:] + edges[:-1])
    omega = np.repeat(centres, 10)
    d = plateau * (1 + (omega0 / omega) ** 4)
    binned = plateau * (1 + (omega0 / centres) ** 4)
    count = np.full(centres.size, 10)
    return results.Diffusivity("exact", omega, d, edges, binned, np.zeros_like(binned), np.full_like(binned, np.nan),
                               count, 0.02, 1)


@pytest.mark.parametrize("omega0", [0.3, 0.6])
def test_crossover_is_where_d_doubles_its_plateau(omega0):
    """d = d_p (1 + (omega0/omega)^4) reaches 2 d_p at omega = omega0 exactly; the rule interpolates
    between bin centres in log d, so it lands within a bin of it (and moves with omega0)."""
    g = _curve(omega0, 0.2)
    star = findings.crossover(g, 0.2)
    assert_close(star, omega0, rtol=0.0, atol=0.05, what="omega* within a bin")


def test_attenuation_prediction_of_one_branch_is_c_squared_over_four_gamma():
    """With equal branches (gamma_L = gamma_T = gamma, c_L = c_T = c) the two-branch prediction is one
    branch's d = c l / D with l = c / (2 gamma), D = 2: c^2 / (4 gamma)."""
    k = np.array([0.1, 0.2, 0.4])
    omega = 0.5 * k  # c = 0.5
    gamma = np.array([0.01, 0.02, 0.05])
    table = {(mode, 0.0): np.column_stack([k, omega, gamma]) for mode in ("L", "TR")}
    at = np.array([0.05, 0.1, 0.2])
    assert_close(findings.predicted(table, 0.0, at), 0.25 / (4 * gamma), rtol=1e-12, what="c^2 / (4 gamma)")
    assert_all(np.isnan(findings.predicted(table, 0.0, np.array([0.3])))[0], "outside the measured omega: NaN")


def test_measure_pairs_every_mode_of_a_scene(tmp_path):
    scene = scene_of(tmp_path / "f.h5", cache="off", seed=3, packing={"n": 64, "phi": 0.9},
                     model={"rho": [0.0, 1.0]}, spectrum={"energies": True}, transport={"eta": 0.2})
    pipeline.run(scene, COMM, [])
    rows = {row["rho"]: row for row in findings.measure(scene.output)}
    assert_all(set(rows) == {0.0, 1.0}, f"{sorted(rows)}")
    for rho, row in rows.items():
        assert_all("P" in row and row["P"].size == row["modes"] > 0, f"rho {rho}: participation paired")
        assert_all(np.isfinite(row["d_p"]) and row["d_p"] > 0, f"rho {rho}: plateau {row['d_p']}")
    share = rows[1.0]["w_R"]  # each mode's rotational share of |e|^2 = 1
    assert_all(np.all((share >= -1e-12) & (share <= 1 + 1e-12)) and "w_R" not in rows[0.0], "shares in [0, 1]")
    # the shares add up to the rotations' part of the trace, r N of the 3 N DOF (r = 1 in 2D): the two
    # rigid modes left out are uniform translations, with no share in the rotations
    assert_close(share.sum(), rows[1.0]["N"], rtol=1e-8, what="sum of rotational shares")
