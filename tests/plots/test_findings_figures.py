"""The figure checks (tests/figures.py) on the docs figures of scripts/tools/finite_amplitude_findings.py,
drawn from made-up sweeps standing in for configs/finite_amplitude.yaml's results (hours of LAMMPS
runs, not on a test machine): symbols in mathtext ($\\mu$, not mu), legends of 7 pt, each marker
explained in its own panel, no mark for a crossover never reached.  Serial."""

import numpy as np
import pytest
from figures import assert_figures

from scripts.tools import finite_amplitude_findings as findings
from solver.io import results
from solver.plots import common

pytestmark = pytest.mark.serial_only


def _case(mu: float, pressure: float, shift: float, stored: bool = False) -> dict:
    amplitude = np.geomspace(1e-5, 3e-2, 8)
    k = np.array([0.1, 0.2])
    departure = shift * (amplitude[:, None] / 1e-3) ** np.array([1.0, 1.2])
    omega, gamma = k * (1 - 0.5 * departure / (1 + departure)), 1e-3 * (1 + departure)
    zeros = np.zeros_like(omega)
    counts = np.round(300 * departure / (1 + departure))
    sweep = results.Sweep(amplitude, k, omega, gamma, 1e-6 + zeros, 1e-7 + zeros, counts, counts / 3, zeros, zeros,
                          zeros, zeros)
    label = rf"2D, $\mu$ = {mu:g}, $p$ = {pressure:.1e}" + (", LAMMPS (stored $f_t$)" if stored else "")
    predicted = {"first opens (affine)": 3e-6 * mu, "first slides (affine)": 1e-6 * mu, "A* predicted (affine)": 3e-4 * mu}
    return {"label": label, "mu": mu, "dim": 2, "stored": stored, "pressure": pressure, "contacts": 600,
            "sweeps": {"L": sweep, "TR": sweep}, "linear": None, "predicted": {"L": predicted, "TR": predicted}}


def test_finite_amplitude_figures_pass_the_checks(tmp_path):
    cases = [_case(0.1, 8e-3, 0.3), _case(0.3, 8e-3, 0.1), _case(1.0, 8e-3, 0.03), _case(0.3, 3e-2, 0.02),
             _case(0.3, 8e-3, 1e-4, stored=True)]
    with common.kept() as figures:
        findings.figures(cases, str(tmp_path))
    assert {name.rsplit("/", 1)[-1] for name in figures} == {f"finite_amplitude_{n}" for n in
                                                             ("softening", "loss", "contacts", "crossover")}
    crossover = figures[str(tmp_path / "finite_amplitude_crossover")]
    for ax in crossover.axes:
        named = [t.get_text() for t in ax.get_legend().get_texts()]
        assert all(what in named for _, what in findings.MARKERS), named
    assert_figures(figures)


def test_diffusivity_spheres_figure_passes_the_checks():
    """scripts/tools/diffusivity_findings.py's spheres figure on six made-up d(omega) (the title
    used to run off the left of its panel)."""
    from scripts.tools import diffusivity_findings

    edges = np.geomspace(0.02, 3.0, 40)
    centres = 0.5 * (edges[1:] + edges[:-1])
    rows = []
    for i, dz in enumerate((0.64, 0.85, 0.91, 1.54, 2.34, 3.56)):
        binned = 0.2 + 0.01 * dz / centres**2
        nan = np.full(binned.size, np.nan)
        g = results.Diffusivity("exact", centres, binned, edges, binned, nan, nan, np.ones(binned.size), 0.02, 1)
        rows.append({"dim": 3, "rho": 0.0, "dz": dz, "pressure": 3e-3 * (1 + i), "N": 1005 + 3 * i, "g": g,
                     "omega_star": 0.12 + 0.01 * i})
    figures = diffusivity_findings.draw(rows, None)
    assert list(figures) == ["diffusivity_spheres"]
    assert_figures(figures)


def _boxes_row(shear: float, phi: float, pressure: float) -> dict:
    """A made-up scene of scripts/tools/boxes_findings.py: a vDOS, c(theta) with a cos(2 theta) part."""
    from scripts.tools import boxes_findings

    edges = np.arange(0.0, 4.65, 0.05)
    centres = 0.5 * (edges[1:] + edges[:-1])
    density = centres ** 2 / (1 + centres ** 3) + 0.3 * (centres > 2.5)
    density /= (density * 0.05).sum()
    theta, _ = boxes_findings.angles()
    row = {"name": f"boxes_phi{phi}_shear{shear}", "shear": shear, "phi": phi, "pressure": pressure, "n": 1024,
           "theta": theta, "vdos": results.Vdos(edges, density, 4.6, 0.01, 4)}
    for mode, c in (("L", 1.0), ("T", 0.68)):
        row[f"c_{mode}_angle"] = c * (1 + 0.1 * shear * np.sin(2 * theta))[None, :].repeat(4, axis=0)
        for label, degrees in boxes_findings.DIRECTION_NAMES.items():
            row[f"c_{mode}_{label}"] = c * (1 + 0.1 * shear * np.sin(np.radians(2 * degrees)))
    return row


def test_boxes_figures_pass_the_checks():
    """scripts/tools/boxes_findings.py's three figures on made-up scenes and walls."""
    from scripts.tools import boxes_findings

    square = [_boxes_row(0.0, phi, p) for phi, p in ((0.85, 4e-3), (0.87, 1.3e-2), (0.89, 2.4e-2))]
    tilted = [_boxes_row(0.3, phi, 1.05 * p) for phi, p in ((0.85, 4e-3), (0.87, 1.3e-2), (0.89, 2.4e-2))]
    sheared = [_boxes_row(0.3, phi, 0.9 * p) for phi, p in ((0.85, 4e-3), (0.87, 1.3e-2), (0.89, 2.4e-2))]
    omega = np.linspace(0.05, 4.6, 300)
    edges = np.arange(0.0, 4.7, 0.1)
    flat = np.full(edges.size - 1, 1 / 4.6)
    walled = {"n": 1024, "phi": 0.87, "omega": omega, "share": 1 + 0.2 * np.sin(omega), "edges": edges,
              "layer_vdos": flat, "bulk_vdos": flat}
    figures = boxes_findings.draw(square, tilted, sheared, walled)
    assert set(figures) == {"boxes_vdos", "boxes_speeds", "boxes_walls"}
    assert_figures(figures)


def test_crossover_figures_pass_the_checks():
    """scripts/tools/crossover_findings.py's figures on made-up rows: five phi of frictionless
    packings (N = 16000): the spheres figure; one packing with tangential springs (N = 4000) and
    its own frictionless row: the rotations figure (drawn instead of it with rows of rho > 0)."""
    from scripts.tools import crossover_findings

    edges = np.arange(0.0, 0.4001, 0.01)
    centres = 0.5 * (edges[1:] + edges[:-1])
    rows = []
    for k, (phi, dz, n, rho) in enumerate(((0.65, 0.4, 16000, 0.0), (0.652, 0.6, 16000, 0.0), (0.66, 1.0, 16000, 0.0),
                                           (0.69, 1.8, 16000, 0.0), (0.76, 3.0, 16000, 0.0), (0.65, 0.4, 4000, 0.0),
                                           (0.65, 2.4, 4000, 0.5))):
        star = 0.05 * dz
        mean = 0.3 * (1 + (star / centres) ** 4)
        rows.append({"phi": phi, "packing": 0, "rho": rho, "N": n, "dz": dz, "omega_star": star, "pressure": 1e-3,
                     "d_p": 0.3,
                     "omega_bp": star / 1.2, "bins": (edges, mean, np.full(centres.size, 10))})
    spheres = crossover_findings.draw(rows[:5])
    assert list(spheres) == ["crossover_spheres"]
    rotations = crossover_findings.draw(rows[5:])
    assert list(rotations) == ["crossover_rotations"]
    assert_figures({**spheres, **rotations})


def test_crossover_waves_figure_passes_the_checks():
    """scripts/tools/crossover_waves.py's figure on made-up rows: three phi, two packings each, TR
    waves with omega = c k, gamma = a k^3 / Delta z (an Ioffe-Regel point inside the k's at the two
    larger Delta z, below them at the smallest: NaN omega_IR, drawn as no marker), joined with
    Allen-Feldman columns of which some are NaN."""
    from scripts.tools import crossover_waves

    k = 2 * np.pi * np.arange(1, 8) / 24.0
    rows = []
    for phi, dz in ((0.66, 0.8), (0.69, 1.7), (0.76, 3.0)):
        for packing in range(2):
            row = {"phi": phi, "packing": packing, "rho": 0.0, "N": 16000, "dz": dz, "pressure": 1e-3, "t_end": 1000.0, "curves": {},
                   "omega_star": 0.04 * dz if dz > 1 else np.nan,
                   "omega_bp": 0.05 * dz if dz < 2 else np.nan}
            for mode, c, a in (("TR", 0.2 * dz**0.5, 0.4), ("L", 0.7, 0.05)):
                omega, gamma = c * k, a * k**3 / dz
                row["curves"][mode] = (k, omega, gamma)
                row.update(crossover_waves.mode_columns(mode, k, omega, gamma))
            rows.append(row)
    assert np.isnan(rows[0]["omega_ir_TR"]) and np.isfinite(rows[-1]["omega_ir_TR"]), "the rows' premise"
    springs = dict(rows[-1], rho=0.5, dz=5.0, omega_ir_TR=0.4)  # drawn as its own marker
    rows.append(springs)
    assert_figures({"crossover_waves": crossover_waves.draw(rows)})
