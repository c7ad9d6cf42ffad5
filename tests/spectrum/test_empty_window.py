"""A spectrum window that holds no modes (issue 58 point 4: 32 disks, ``window: [20, 21]``, above
their largest omega) through the pipeline, on 1 and 2 ranks: the unit is stored with an empty
``omega`` and resumed, the log says so in one line, ``rotsound plot`` draws the file (the
figures that have something to show, checked), and nothing raises or warns (warnings are errors
under pytest)."""

import pytest
from conftest import COMM, assert_all, scene_of

from solver import pipeline
from solver.io.unit_keys import Unit


@pytest.mark.parametrize("energies", [False, True])
def test_a_window_without_modes_is_a_stored_unit_said_in_one_line(shared_tmp, capsys, monkeypatch, energies):
    scene = scene_of(shared_tmp / "empty.h5", cache="off", seed=1, packing={"n": 32, "phi": 0.9},
                     model={"rho": [0.5]}, spectrum={"window": [20, 21], "energies": energies})
    name = Unit("spectrum", 0, 0, 0.5).name
    for run, how in enumerate(("computed", "resumed")):
        datasets, attrs = pipeline.run(scene, COMM, [])["units"][name]
        said = capsys.readouterr().out.splitlines()
        assert_all(datasets["omega"].size == 0 and attrs["window"] == "20,21", f"run {run}: {datasets}, {attrs}")
        if COMM.rank == 0:  # the log is rank 0's
            assert f"spectra 1 {how}" in "\n".join(said), said
            if how == "computed":
                lines = [line for line in said if line.startswith("spectrum rho = 0.5")]
                assert len(lines) == 1 and "no modes in the window omega in [20, 21]" in lines[0], said
    if COMM.size == 1:  # drawing is rank 0's alone, from a file the same on 1 or 2 ranks: once, in the 1-rank pass
        from figures import assert_figures, capture
        from solver import plots

        figures = capture(monkeypatch, stems=True)
        written = plots.plot_results(scene.output)  # plot_participation took omega.max() of no modes
        assert_figures(figures, written)
