"""The figure checks (tests/figures.py) on figures drawn from small made-up inputs that bring out
what issue 58 point 9 found in `rotsound plot`'s figures: a title wider than its figure, a local
exponent beside the fixed range, a fit without its exponent, an empty bin of g(omega), omega_c at
the end of the spectrum, an inset over the model curves, an amplitude sweep's thresholds.  Serial:
drawing is rank 0's."""

import numpy as np
import pytest
from figures import assert_figures, problems

from solver.analysis import thresholds
from solver.io import results
from solver.plots import common
from solver.plots.attenuation import plot_attenuation_regimes
from solver.plots.spectrum import plot_vdos
from solver.plots.sweeps import plot_sweeps
from solver.plots.transport import plot_diffusivity
from solver.plots.waves import plot_bands, plot_speeds_attenuation

pytestmark = pytest.mark.serial_only


def drawn(draw, *args, **kwargs) -> dict:
    """{stem: figure} that ``draw(*args, "fig", **kwargs)`` makes (``common.kept``: nothing written)."""
    with common.kept() as figures:
        draw(*args, "fig", **kwargs)
    return figures


def _diffusivity(rho: float, eta: float) -> results.Diffusivity:
    omega = np.linspace(0.05, 3.0, 300)
    edges = np.linspace(0.0, 3.2, 33)
    d = 0.2 + 0.05 / omega**2
    binned = np.array([d[(omega >= a) & (omega < b)].mean() if ((omega >= a) & (omega < b)).any() else np.nan
                       for a, b in zip(edges[:-1], edges[1:])])
    nan = np.full(binned.size, np.nan)
    return results.Diffusivity("exact", omega, d, edges, binned, nan, nan, np.histogram(omega, edges)[0], eta, 1)


def test_diffusivity_title_stays_in_the_figure():
    """An eta of three significant figures and two rho: the title used to run off the right (at
    configs/diffusivity.yaml's eta = 0.02 it ended 3 px from the edge)."""
    assert_figures(drawn(plot_diffusivity, {0.0: _diffusivity(0.0, 0.0125), 1.0: _diffusivity(1.0, 0.0125)}))


def _fit(k, omega, gamma, p=np.nan):
    return {"k": k, "omega": omega, "gamma": gamma, "t_end": 1e4, "c": omega / k, "power_law_p": p}


def test_attenuation_exponents_far_from_rayleigh_stay_on_the_axes():
    """An L wave whose gamma barely grows with k (local exponent near 0) and a TR one with
    exponent 5: the exponent panel's range used to be fixed at 1 to d + 2."""
    k = np.geomspace(0.05, 1.0, 8)
    fits = {(0.0, "L"): _fit(k, k, 1e-3 * k**0.1), (0.0, "TR"): _fit(k, 0.6 * k, 1e-2 * k**5)}
    assert_figures(drawn(plot_attenuation_regimes, fits, dim=2))


def test_speeds_without_a_power_law_fit_print_no_nan():
    k = np.geomspace(0.05, 1.0, 8)
    fits = {(0.0, "L"): _fit(k, k, 1e-2 * k**3), (1.0, "L"): _fit(k, 0.9 * k, 1e-2 * k**3, p=2.9),
            (0.0, "TR"): _fit(k, 0.6 * k, 1e-2 * k**3, p=3.1)}
    assert_figures(drawn(plot_speeds_attenuation, fits))


def test_vdos_leaves_empty_bins_blank_and_marks_omega_c_inside_the_frame():
    """An empty bin inside the spectrum is a gap in the line, not a dive to the axis; omega_c at
    the top of the last bin is marked inside the axes."""
    edges = np.linspace(0.0, 3.0, 31)
    density = np.full(30, 0.3)
    density[[0, 12]] = 0.0  # no mode there
    figures = drawn(plot_vdos, {0.5: results.Vdos(edges, density, 3.0, 0.0, 1)})
    (fig,) = figures.values()
    y = fig.axes[0].get_lines()[0].get_ydata()
    assert np.isnan(y[12]) and np.isnan(y[0]) and np.isfinite(np.delete(y, [0, 12])).all(), y
    assert_figures(figures)


def test_bands_keep_every_curve_clear_of_other_axes():
    """The log-log view of the band limits used to be an inset over the model curves."""
    lattice_fit = {"a_r": 0.5, "a_t": 0.3, "a_t_edge": 0.3}
    rho = np.array([0.1, 0.2, 0.5, 1.0, 2.0])
    bands = {"rho": rho, "omega_r0": 0.5 * np.sqrt(40 * rho), "omega_r_kmax": np.sqrt(3 * rho + 1),
             "omega_t_kmax": 0.3 * np.sqrt(10 * rho), "omega_c": np.sqrt(3 * rho + 1) + 0.1}
    assert_figures(drawn(plot_bands, lattice_fit, bands))


def test_overlapping_axes_are_a_problem():
    """The rule behind the bands' test: an axes drawn over another hides what is under it."""
    fig, ax = common.plt.subplots()
    ax.plot([0, 1], [0, 1])
    ax.inset_axes([0.6, 0.1, 0.35, 0.35]).plot([0, 1], [1, 0])
    try:
        assert any("overlaps" in p for p in problems("inset", fig)), problems("inset", fig)
    finally:
        common.plt.close(fig)


def _sweep() -> results.Sweep:
    amplitude = np.geomspace(1e-5, 3e-2, 6)
    k = np.array([0.1, 0.2])
    departure = 0.01 * (amplitude[:, None] / 1e-3) ** np.array([1.0, 1.5])
    omega = k * (1 - departure)
    gamma = 1e-3 * (1 + 5 * departure)
    zeros = np.zeros_like(omega)
    counts = np.round(100 * departure)
    return results.Sweep(amplitude, k, omega, gamma, 1e-6 + zeros, 1e-7 + zeros, counts, counts / 2, zeros,
                         zeros, zeros, zeros)


def test_sweep_figure_explains_every_mark_in_its_own_panel():
    """The predicted thresholds are named in the legend of each panel that draws them (they used
    to be named in the contacts' panel only), the measured A* stars in theirs; text >= 7 pt."""
    predicted = {"first opens (affine)": 2e-5, "first slides (affine)": 1e-4, "A* predicted (affine)": 1e-3}
    figures = drawn(plot_sweeps, {(1.0, "L"): _sweep()}, contacts=200, predicted={(1.0, "L"): predicted})
    (fig,) = figures.values()
    softening, _, contacts = fig.axes
    for ax in (softening, contacts):
        named = set(ax.get_legend().texts and [t.get_text() for t in ax.get_legend().get_texts()])
        assert set(predicted) <= named, (ax.get_title(), named)
    assert any("A^*" in t.get_text() for t in softening.get_legend().get_texts())
    assert_figures(figures)


def test_the_checks_catch_each_kind_of_defect():
    """Each check of tests/figures.py on a figure built to fail it."""
    fig, (ax, bx) = common.plt.subplots(1, 2, figsize=(4, 3))
    ax.plot([0, 1, 2], [0, 1, 5], label="p = nan")
    ax.set_ylim(0, 2)
    ax.legend(fontsize=5)
    bx.set_title("a title far too long for the right-hand panel of a four-inch figure")
    bx.annotate("", xy=(0.5, 0.0), xytext=(0.5, 0.3), arrowprops={"arrowstyle": "->"})
    try:
        found = "\n".join(problems("made", fig))
    finally:
        common.plt.close(fig)
    for what in ("leaves the figure", "points off the axes", "5 pt", "prints a nan", "reaches the frame"):
        assert what in found, found


def _tilted_packing(dim: int) -> dict:
    """A packing dict as ``results.packing`` gives one, in a tilted cell: LAMMPS's triclinic packing
    (3D) or the 2D LAMMPS packing in its sides tilted by xy = -0.35 L_x, positions wrapped into it."""
    from conftest import REPO

    from solver.io import dem_formats
    from solver.packing import geometry

    raw = dem_formats.read(REPO / "tests" / "data" / "dem" / ("lammps_triclinic.data" if dim == 3 else "lammps_2d.data"))
    sides = raw.box_hi - raw.box_lo
    cell = geometry.Cell(sides, raw.tilt if dim == 3 else np.array([-0.35 * sides[0]]), np.ones(dim, dtype=bool))
    n = raw.diameters.size
    return {"positions": geometry.wrap(raw.positions - raw.box_lo, cell), "diameters": raw.diameters,
            "rattler": np.arange(n) % 17 == 0, "box": sides, "tilt": cell.tilt, "periodic": cell.periodic,
            "cell": cell, "phi": 0.8, "z": 4.0}


def _mode(packing: dict) -> results.ModeShapes:
    n, dim = packing["positions"].shape
    rng = np.random.default_rng(3)
    rotation = rng.normal(size=(1, n, 1 if dim == 2 else 3))
    return results.ModeShapes(0.5, 0, np.array([1.0]), np.array([1.01]), rng.normal(size=(1, n, dim)), rotation,
                              np.full((1, n, 2), 1.0 / n), np.array([2.0]), np.array([1.0]), np.array([0.3]))


@pytest.mark.parametrize("dim", [2, 3])
def test_a_tilted_cell_is_drawn_as_its_parallelogram_with_its_particles_inside(dim):
    """The packing picture and a mode's picture of a tilted cell: the parallelogram (3D: the section
    z = L_z/2, shifted by c/2) outlined, the axes its bounding box, every drawn centre inside it."""
    from matplotlib.collections import EllipseCollection
    from matplotlib.patches import Polygon

    from solver.plots.modes import plot_mode
    from solver.plots.packing import plot_packing

    packing = _tilted_packing(dim)
    h = packing["cell"].matrix
    origin = 0.5 * h[:2, 2] if dim == 3 else np.zeros(2)
    corners = origin + np.array([[0, 0], h[:2, 0], h[:2, 0] + h[:2, 1], h[:2, 1]])
    figures = {"packing": drawn(plot_packing, packing)["fig"], "mode": drawn(plot_mode, packing, _mode(packing), 0)["fig"]}
    for fig in figures.values():
        ax = fig.axes[0]
        (outline,) = [p for p in ax.patches if isinstance(p, Polygon)]
        np.testing.assert_allclose(outline.get_xy()[:4], corners, rtol=0, atol=1e-12)
        np.testing.assert_allclose([*ax.get_xlim(), *ax.get_ylim()], [corners[:, 0].min(), corners[:, 0].max(),
                                                                       corners[:, 1].min(), corners[:, 1].max()],
                                   rtol=0, atol=1e-12)
        centres = np.concatenate([c.get_offsets() for c in ax.collections if isinstance(c, EllipseCollection)])
        inside = np.linalg.solve(h[:2, :2], (centres - origin).T).T  # fractional in the parallelogram
        assert len(centres) > 20 and np.all((inside > -1e-12) & (inside < 1 + 1e-12)), (inside.min(), inside.max())
    assert_figures(figures)
