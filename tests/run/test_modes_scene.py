"""The ``modes`` section through a scene: only the shapes are computed (no spectrum), the results
file holds them where the manual says (docs/results_file.md), a rerun loads them, the 3D slab picture and the 2D
pictures are drawn, and the notebook reader gives the same arrays; 1 and 2 ranks."""

import os

import numpy as np
from conftest import COMM, assert_all, assert_close, jammed_packing, scene_of

from solver import pipeline
from solver.contact_law import ContactModel
from solver.io import results
from solver.model import dynmat
from solver.references import dense_eigen


def test_mode_shapes_scene_writes_reads_resumes_and_draws(comm, shared_tmp, monkeypatch):
    scene = scene_of(shared_tmp / "modes.h5", cache="off", seed=7, packing={"n": 64, "phi": 0.9},
                     model={"rho": [0.5]}, modes={"omega": [0.3, 2.0], "count": 2})
    pipeline.run(scene, COMM, [])
    again = pipeline.run(scene, COMM, [])  # every unit is finished: loaded, not recomputed
    with results.open_results(scene.output) as f:
        assert_all("spectra" not in f and "vdos" not in f, "no spectrum solved for mode shapes alone")
        (group,) = results.mode_shapes(f)
        packing = results.packing(f, group.packing)
    p = jammed_packing(64, 0.9, 7)  # the scene's configuration 0: SeedSequence([7, 0])
    assert_close(packing["positions"], p.positions, rtol=0.0, what="the scene's packing")
    dm = dynmat.assemble(p, ContactModel(0.5), comm)
    lam, _ = dense_eigen(dm)
    dm.destroy()
    lam = lam[lam > 1e-8]
    near = np.concatenate([np.sort(lam[np.argsort(np.abs(lam - t**2))[:2]]) for t in (0.3, 2.0)])
    assert_close(group.omega, np.sqrt(near), rtol=1e-11, what="omega vs eigh")
    assert_all(group.displacement.shape == (4, 64, 2) and group.rotation.shape == (4, 64, 1), "shapes")
    unit = again["units"]["modes/r00_p0000"][0]
    assert_close(unit["displacement"], group.displacement, rtol=0.0, what="resumed unit = file")
    if COMM.size == 1:  # drawing is rank 0's alone, from a file the same on 1 or 2 ranks: once, in the 1-rank pass
        from figures import assert_figures, capture
        from solver import plots

        figures = capture(monkeypatch, stems=True)
        written = plots.plot_results(scene.output)
        assert sum("_mode_" in os.path.basename(stem) for stem in figures) == 4, sorted(figures)
        assert_figures(figures, written)


def test_mode_shapes_of_spheres_draw_their_section(comm, shared_tmp, monkeypatch):
    scene = scene_of(shared_tmp / "modes3d.h5", cache="off", seed=5, packing={"n": 32, "phi": 0.68, "dim": 3},
                     model={"rho": [0.5], "rho_roll": 0.2, "rho_twist": 0.1}, modes={"omega": [1.0]})
    pipeline.run(scene, COMM, [])
    with results.open_results(scene.output) as f:
        (group,) = results.mode_shapes(f)
    assert_all(group.displacement.shape == (1, 32, 3) and group.rotation.shape == (1, 32, 3), "3D shapes")
    if COMM.size == 1:  # drawing is rank 0's alone, from a file the same on 1 or 2 ranks: once, in the 1-rank pass
        from solver import plots

        from figures import assert_figures, capture

        figures = capture(monkeypatch, stems=True)
        written = plots.plot_results(scene.output)
        assert any(stem.endswith("_mode_rho0.5_p0_0") for stem in figures), sorted(figures)
        assert_figures(figures, written)


def test_localised_modes_are_the_extremes_of_the_participation(comm, shared_tmp, monkeypatch):
    cache = str(shared_tmp / "cache")
    scene = scene_of(shared_tmp / "localised.h5", cache=cache, seed=7, packing={"n": 64, "phi": 0.9},
                     model={"rho": [0.5]}, spectrum={"energies": True}, modes={"localised": 2, "omega": [1.0]})
    pipeline.run(scene, COMM, [])
    with results.open_results(scene.output) as f:
        (group,) = results.mode_shapes(f)
        omega, participation = f["spectra/r00_p0000/omega"][()], f["spectra/r00_p0000/participation"][()]
    order = np.argsort(participation, kind="stable")
    picked = np.concatenate((order[:2], order[::-1][:2]))
    assert_all(group.omega.size == 5, f"1 near omega = 1 and 2 + 2 extremes, got {group.omega}")
    assert_close(group.omega[1:], omega[picked], rtol=1e-11, what="the extremes' omega")
    assert_close(group.participation[1:], participation[picked], rtol=1e-8, what="their participation")
    assert_close(group.target[1:], omega[picked], rtol=0.0, what="each found at its own omega")
    if COMM.size == 1:  # the pictures (a colour bar beside each) and the log P axis readable; drawn
        # by rank 0 alone from a file the same on 1 or 2 ranks: once, in the 1-rank pass
        from figures import assert_figures, capture
        from solver import plots

        figures = capture(monkeypatch, stems=True)
        written = plots.plot_results(scene.output)
        assert str(shared_tmp / "localised_participation") in figures, sorted(figures)
        assert sum("_mode_" in os.path.basename(stem) for stem in figures) == 5, sorted(figures)
        assert_figures(figures, written)
    # the spectrum from the cache, new modes: the modes unit takes the spectrum's datasets from the store
    again = scene_of(shared_tmp / "again.h5", cache=cache, seed=7, packing={"n": 64, "phi": 0.9},
                     model={"rho": [0.5]}, spectrum={"energies": True}, modes={"localised": 1})
    summary = pipeline.run(again, COMM, [])
    assert_all("spectra/r00_p0000" in summary["units"], "spectrum there")
    with results.open_results(again.output) as f:
        (group,) = results.mode_shapes(f)
    assert_close(group.omega, omega[picked[[0, 2]]], rtol=1e-11, what="lowest and highest participation")
