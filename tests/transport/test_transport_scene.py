"""The ``transport`` section through a scene (issue 45, point 1): the results file holds every
mode's omega and d where the manual says (docs/results_file.md), equal to the definition
evaluated densely on the scene's own packings, and d(omega) on the vDOS's bins pooled over the
configurations; a rerun loads the units, a new eta recomputes only them, the notebook reader and
``rotsound plot`` take the file; 2D with rotations and 3D with rolling and twisting springs, on 1
and 2 ranks."""

import dataclasses
import pathlib

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close, jammed_packing, scene_of

from solver import pipeline, references
from solver.contact_law import ContactModel
from solver.io import results
from solver.model import dynmat
from solver.spectrum import modes

ETA = 0.2  # 1/t0: a few mean level spacings of these 190- and 186-mode spectra


def _dense(p, model, comm, eta):
    """(omega, d) of the definition on packing ``p`` under ``model``, densely."""
    dm = dynmat.assemble(p, model, comm)
    try:
        return references.allen_feldman_dense(dm, p.positions, p.box, eta)
    finally:
        dm.destroy()


def test_diffusivity_scene_is_the_definition_pooled_on_the_vdos_bins(comm, shared_tmp, capsys, monkeypatch):
    scene = scene_of(shared_tmp / "transport.h5", cache=str(shared_tmp / "cache"), seed=7, packing={"n": 64, "phi": 0.9},
                     model={"rho": [0.5]}, spectrum={}, transport={"eta": ETA})
    pipeline.run(scene, COMM, [])
    with results.open_results(scene.output) as f:
        got = results.diffusivity(f)[0.5]
        vdos = results.vdos(f)[0.5]
        unit = dict(f["diffusivity/r00_p0000"].attrs)
    omega, d = _dense(jammed_packing(64, 0.9, 7), ContactModel(0.5), comm, ETA)
    assert_close(got.omega, omega, rtol=1e-12, what="omega vs eigh")
    # atol: 1e-12 of the largest d, for modes whose d is far below the rest (none is zero here)
    assert_close(got.d, d, rtol=1e-8, atol=1e-12 * d.max(), what="d vs the dense definition")
    assert_close(got.edges, vdos.edges, rtol=0.0, what="d(omega) on the vDOS's bins")
    # equal_nan: a bin without modes has no mean (NaN), in the file exactly where its count is 0
    assert_all(np.array_equal(np.isnan(got.d_binned), got.count == 0), f"NaN bins of {got.count}")
    assert_close(got.d_binned, modes.bin_average(omega, d, vdos.edges), rtol=1e-8, what="bin means", equal_nan=True)
    assert_all(got.count.sum() == omega.size == 190 and got.eta == ETA and got.configurations == 1,
               f"{got.count.sum()} modes binned of {omega.size}, eta {got.eta}")
    assert_all(unit["n_zero_modes"] == 2 and unit["method"] == "exact" and unit["windows"] >= 1, f"{unit}")

    again = pipeline.run(scene, COMM, [])  # finished: loaded, not recomputed
    assert_close(again["units"]["diffusivity/r00_p0000"][0]["d"], got.d, rtol=0.0, what="resumed unit = file")
    wider = dataclasses.replace(scene, output=str(shared_tmp / "wider.h5"),
                                transport=dataclasses.replace(scene.transport, eta=2 * ETA))
    capsys.readouterr()
    pipeline.run(wider, COMM, [])
    said = capsys.readouterr().out
    assert_all(COMM.rank > 0 or ("diffusivity 1 computed" in said and "spectra 1 computed" not in said), said)
    with results.open_results(wider.output) as f:
        redone = results.diffusivity(f)[0.5]
    assert_close(redone.d, _dense(jammed_packing(64, 0.9, 7), ContactModel(0.5), comm, 2 * ETA)[1], rtol=1e-8,
                 atol=1e-12 * d.max(), what="a new eta recomputes the unit")
    if COMM.size == 1:  # drawing is rank 0's alone, from a file the same on 1 or 2 ranks: once, in the 1-rank pass
        from figures import assert_figures, capture
        from solver import plots

        figures = capture(monkeypatch, stems=True)
        written = plots.plot_results(scene.output)
        assert str(shared_tmp / "transport_diffusivity") in figures, sorted(figures)
        assert_figures(figures, written)


def _scratch_scene(shared_tmp, name: str):
    """(scene of 32 disks with the exact diffusivity in blocks of 40 modes, its unit's scratch
    folder, the units folder's ``transport_scratch/``)."""
    scene = scene_of(shared_tmp / f"{name}.h5", cache="off", seed=7, packing={"n": 32, "phi": 0.9},
                     model={"rho": [0.5]}, transport={"eta": ETA, "block": 40})
    parent = pathlib.Path(scene.output + ".units") / "transport_scratch"
    return scene, parent / "r00_p0000", parent


def test_a_stale_scratch_file_of_another_rank_count_goes_with_the_folder(comm, shared_tmp):
    """A run killed on 8 ranks left rank 7's first window in the unit's scratch folder: the rerun
    on 1 or 2 ranks removes it with the folder, and no ``transport_scratch/`` is left (rank 0
    failed alone to remove the folder, and the other ranks hung)."""
    scene, scratch, parent = _scratch_scene(shared_tmp, "stale")
    if COMM.rank == 0:
        scratch.mkdir(parents=True)
        np.save(scratch / "af_window0000_rank0007.npy", np.zeros((4, 2)))
    COMM.Barrier()
    datasets, attrs = pipeline.run(scene, COMM, [])["units"]["diffusivity/r00_p0000"]
    assert_all(datasets["d"].size + attrs["n_zero_modes"] == attrs["dof"], f"the unit is made: {attrs}")
    assert_all(not parent.exists(), f"{parent} is left")


def test_a_write_failing_on_one_rank_stops_every_rank_and_leaves_no_scratch(comm, shared_tmp):
    """The last rank cannot write its first window (a folder holds the file's name): every rank
    raises, and the unit's scratch folder is removed all the same."""
    scene, scratch, parent = _scratch_scene(shared_tmp, "unwritable")
    if COMM.rank == COMM.size - 1:
        (scratch / f"af_window0000_rank{COMM.rank:04d}.npy").mkdir(parents=True)
    COMM.Barrier()
    with pytest.raises(IsADirectoryError):
        pipeline.run(scene, COMM, [])
    assert_all(not parent.exists(), f"{parent} is left")


def test_spheres_with_rolling_and_twisting_pool_their_configurations(comm, shared_tmp):
    model = {"rho": [0.5], "rho_roll": 0.2, "rho_twist": 0.1}
    scene = scene_of(shared_tmp / "spheres.h5", cache="off", seed=5, packing={"n": 32, "phi": 0.68, "dim": 3,
                                                                               "count": 2},
                     model=model, transport={"eta": ETA, "block": 40, "bin_width": 0.25})
    pipeline.run(scene, COMM, [])
    with results.open_results(scene.output) as f:
        got = results.diffusivity(f)[0.5]
        first = f["diffusivity/r00_p0000/d"][()], f["diffusivity/r00_p0000/omega"][()]
        packing = results.packing(f, 0)
        contents = results.contents(f)
    assert_all("vdos" not in contents, "no spectrum asked, none made")
    p = jammed_packing(32, 0.68, 5, dim=3)  # configuration 0: SeedSequence([5, 0])
    assert_close(packing["positions"], p.positions, rtol=0.0, what="the scene's packing")
    omega, d = _dense(p, ContactModel(0.5, rho_roll=0.2, rho_twist=0.1), comm, ETA)
    assert_close(first[1], omega, rtol=1e-12, what="3D omega vs eigh")
    assert_close(first[0], d, rtol=1e-8, atol=1e-12 * d.max(), what="3D d vs the dense definition")
    assert_all(got.configurations == 2 and got.count.sum() == got.omega.size and got.omega.size > omega.size,
               f"two configurations pooled: {got.count.sum()} binned, {got.omega.size} modes")
    assert_close(np.diff(got.edges), np.full(got.edges.size - 1, 0.25), rtol=1e-12, what="transport.bin_width")
    # equal_nan: a bin without modes has no mean (NaN), in the file exactly where its count is 0
    assert_all(np.array_equal(np.isnan(got.d_binned), got.count == 0), f"NaN bins of {got.count}")
    assert_close(got.d_binned, modes.bin_average(got.omega, got.d, got.edges), rtol=1e-12, what="pooled bin means",
                 equal_nan=True)


def test_kpm_scene_pools_its_configurations_within_their_errors(comm, shared_tmp, monkeypatch):
    """transport.method kpm: each unit is the estimator on the scene's packing with the probes of
    seed + packing index, on the kpm vDOS's bins; the pooled d(omega) agrees with the pooled exact
    target (the Jackson-filtered trace at the same moments, references.allen_feldman_binned_dense)
    within 4 of its pooled standard errors in every bin holding 5 modes or more."""
    from solver.model.operators import largest_omega

    scene = scene_of(shared_tmp / "kpm.h5", cache="off", seed=7, packing={"n": 64, "phi": 0.9, "count": 2},
                     model={"rho": [0.5]}, spectrum={"method": "kpm", "bin_width": 0.25},
                     transport={"method": "kpm", "probes": 32})
    pipeline.run(scene, COMM, [])
    with results.open_results(scene.output) as f:
        got = results.diffusivity(f)[0.5]
        vdos = results.vdos(f)[0.5]
        moments = [int(f[f"diffusivity/r00_p000{i}"].attrs["moments"]) for i in range(2)]
    assert_all(got.method == "kpm" and got.omega.size == 0 and got.configurations == 2, f"{got.method}")
    assert_close(got.edges[:vdos.edges.size], vdos.edges[:got.edges.size], rtol=0.0, what="the kpm vDOS's bins")
    count, total = np.zeros(got.count.size), np.zeros(got.count.size)
    for index in range(2):  # configuration i: SeedSequence([7, i])
        from solver.packing import jammed

        p = jammed.generate(64, 0.9, np.random.SeedSequence([7, index]))
        dm = dynmat.assemble(p, ContactModel(0.5), comm)
        try:
            exact = references.allen_feldman_binned_dense(dm, p.positions, p.box, got.edges, largest_omega(dm) ** 2,
                                                          moments=moments[index])
        finally:
            dm.destroy()
        count += exact["count"]
        total += exact["total"]
    held = count >= 5
    target = total[held] / count[held]
    assert_all(held.sum() >= 8, f"{held.sum()} bins hold 5 modes or more")
    # atol: 4 pooled standard errors, the estimator's stated statistical error (no rtol: it is exact in expectation)
    assert_close(got.d_binned[held], target, rtol=0.0, atol=4 * got.d_err[held], what="pooled kpm vs its exact target")
    assert_all(np.all(got.d_err[held] > 0), "every held bin has a standard error")
    if COMM.size == 1:  # rotsound plot reads a kpm file too (no per-mode d: the binned one with its errors);
        # drawn by rank 0 alone from a file the same on 1 or 2 ranks: once, in the 1-rank pass
        from solver import plots

        from figures import assert_figures, capture

        figures = capture(monkeypatch, stems=True)
        written = plots.plot_results(scene.output)
        assert str(shared_tmp / "kpm_diffusivity") in figures, sorted(figures)
        assert_figures(figures, written)


def test_a_low_frequency_window_keeps_the_modes_and_bins_below_its_top(comm, shared_tmp):
    """transport.omega_top through a scene: the unit holds the modes up to omega_top with the
    definition's d whose partners stop at the window's cut (rtol 1e-8, atol 1e-12 of the largest
    d), and d(omega) only in the bins wholly below omega_top = 2.3 (bins of 0.25: those up to 2.25;
    the modes in [2.25, 2.3] are not binned)."""
    from solver.transport.allen_feldman import window_cut

    eta, top = 0.05, 2.3
    scene = scene_of(shared_tmp / "window.h5", cache="off", seed=5, packing={"n": 32, "phi": 0.68, "dim": 3},
                     model={"rho": [0.5], "rho_roll": 0.2, "rho_twist": 0.1},
                     transport={"eta": eta, "block": 40, "bin_width": 0.25, "omega_top": top})
    pipeline.run(scene, COMM, [])
    with results.open_results(scene.output) as f:
        got = results.diffusivity(f)[0.5]
        unit = dict(f["diffusivity/r00_p0000"].attrs)
        pooled_top = f["diffusivity_binned/r00"].attrs["omega_top"]
    p = jammed_packing(32, 0.68, 5, dim=3)
    dm = dynmat.assemble(p, ContactModel(0.5, rho_roll=0.2, rho_twist=0.1), comm)
    try:
        omega, d = references.allen_feldman_dense(dm, p.positions, p.box, eta, partners_to=window_cut(top, eta))
    finally:
        dm.destroy()
    below = omega <= top
    assert_close(got.omega, omega[below], rtol=1e-12, what="omega of the window")
    assert_close(got.d, d[below], rtol=1e-8, atol=1e-12 * d.max(), what="d of the window")
    binned = got.omega < 2.25
    assert_all(got.count.sum() == np.count_nonzero(binned) < got.omega.size and np.all(got.count[got.edges[1:] > top] == 0),
               f"binned {got.count.sum()} of {got.omega.size} window modes, counts {got.count}")
    assert_close(got.d_binned, modes.bin_average(got.omega[binned], got.d[binned], got.edges), rtol=1e-12,
                 what="window bin means", equal_nan=True)
    assert_all(unit["omega_top"] == top == pooled_top and unit["sliced"] == np.count_nonzero(omega <= window_cut(top, eta))
               and unit["n_zero_modes"] == 3, f"{unit}")
