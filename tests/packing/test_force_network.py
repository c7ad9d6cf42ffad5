"""The force-chain picture's forces (``mechanics.force_magnitudes``) against brute force: every
contact between non-rattlers with its harmonic normal force; for a frictional packing written by
LAMMPS, the tangential forces of its contact file; the figure drawn from a results file and from
the stressed packing, its line widths on the scale of the drawn particles; and every figure of a
frictional results file readable and drawn without a warning.  Serial: figures and file reading."""

import logging

import numpy as np
import pytest
from conftest import COMM, REPO, all_pairs, jammed_packing, scene_of
from figures import assert_figures, assert_readable, capture
from matplotlib.collections import LineCollection

from solver import pipeline, plots
from solver.io import hdf5
from solver.packing import geometry
from solver.packing.mechanics import force_magnitudes
from solver.plots import common
from solver.plots.packing import SHARE, plot_force_network

pytestmark = pytest.mark.serial_only

DATA = REPO / "tests" / "data" / "dem"


def test_normal_forces_are_the_overlaps_of_every_contact():
    p = jammed_packing(64, 0.9, 7)
    found, f_n, f_t = force_magnitudes(p)
    overlap, _, _ = all_pairs(p)
    active = ~p.rattler
    touching = np.triu((overlap > 0) & active[:, None] & active[None, :], 1)
    i, j = np.nonzero(touching)
    assert np.array_equal(np.sort(found.i * 64 + found.j), np.sort(i * 64 + j))
    np.testing.assert_allclose(np.sort(f_n), np.sort(overlap[i, j]), rtol=1e-12, atol=0)  # kn = 1
    assert np.all(f_t == 0.0)


def test_tangential_forces_are_the_contact_files(tmp_path):
    name = "lammps_2d_friction"
    p = hdf5.read_packings(str(DATA / f"{name}.data"), contacts=str(DATA / f"{name}.contacts"))[0]
    found, f_n, f_t = force_magnitudes(p)
    stored = p.tangential
    active = ~p.rattler
    among = active[stored.pairs[:, 0]] & active[stored.pairs[:, 1]]
    magnitudes = np.linalg.norm(stored.force[among], axis=1)
    assert np.count_nonzero(f_t) == np.count_nonzero(magnitudes) > 0
    np.testing.assert_allclose(np.sort(f_t[f_t > 0]), np.sort(magnitudes[magnitudes > 0]), rtol=1e-12, atol=0)
    reference = geometry.find_contacts(p.positions, p.diameters, p.box, active)
    np.testing.assert_allclose(f_n, reference.overlap, rtol=1e-12, atol=0)  # harmonic, kn = 1
    with common.kept() as figures:  # the figure the files would hold, checked, then written and read back
        plot_force_network(p, str(tmp_path / "stressed"))
    written = [path for stem, fig in figures.items() for path in common.save(fig, stem)]
    assert_figures(figures, written)


def test_plot_results_draws_the_force_network(tmp_path):
    out = tmp_path / "forces.h5"
    pipeline.run(scene_of(out, cache="off", seed=7, packing={"n": 64, "phi": 0.9}, spectrum={}), COMM, [])
    written = plots.plot_results(str(out))
    assert str(tmp_path / "forces_forces.png") in written


@pytest.mark.parametrize("n", [64, 1024])
def test_line_widths_scale_with_the_drawn_particles(tmp_path, monkeypatch, n):
    """The mean normal force is drawn SHARE d0 wide, d0 measured on the drawing (points), whatever
    N: at N = 4096 a fixed 2.5 pt (then 0.4 d0) made the network one black mass."""
    p = jammed_packing(n, 0.9, 7)
    figures = capture(monkeypatch)
    plot_force_network(p, str(tmp_path / "forces"))
    fig = figures["forces.png"]
    fig.canvas.draw()
    ax = fig.axes[0]
    d0_points = ax.get_window_extent().width * 72.0 / fig.dpi / p.box_length
    (lines,) = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert np.mean(lines.get_linewidths()) == pytest.approx(SHARE * d0_points, rel=1e-9)


def test_plot_results_of_a_frictional_file_is_readable_and_quiet(tmp_path, monkeypatch, caplog):
    """A stressed packing (LAMMPS's, with its contact file) at rho = 2/7, its spectrum, participation
    and a TR wave only: every figure keeps its text inside, in mathtext, rho written 0.286, log axes
    with two labelled ticks, and matplotlib logs nothing (it warned of an empty legend on the L
    column of the speeds figure; pytest's filterwarnings does not see matplotlib's log)."""
    name = "lammps_2d_friction"
    out = tmp_path / "frictional.h5"
    scene = scene_of(out, cache="off", packing={"file": str(DATA / f"{name}.data"), "friction": 1.0,
                                                "contacts": str(DATA / f"{name}.contacts")},
                     model={"rho": 2 / 7}, spectrum={"method": "nonhermitian", "energies": True},
                     waves={"modes": ["TR"], "n": [1, 2], "t_end": 4.0, "dt": 0.01, "sample_every": 10})
    pipeline.run(scene, COMM, [])
    figures = capture(monkeypatch)
    with caplog.at_level(logging.WARNING, logger="matplotlib"):
        plots.plot_results(str(out))
    assert not [r.getMessage() for r in caplog.records if r.name.startswith("matplotlib")]
    assert {"frictional_forces.png", "frictional_speeds_attenuation.png", "frictional_participation.png"} <= set(figures)
    assert_readable(figures)
    legend = figures["frictional_vdos.png"].axes[0].get_legend()
    assert [t.get_text() for t in legend.get_texts()] == [r"$\rho$ = 0.286"]
