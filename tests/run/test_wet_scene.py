"""A wet scene (model.cohesion) through the pipeline on 1 and 2 ranks: the packing rotsound's FIRE
makes with the bridges, its units resumed, its results file read back by packing.file (the same
counts), by the notebook API (the bridges), by the plots, the export and scripts/tools/wet_findings.py."""

import numpy as np
from conftest import COMM, assert_all, assert_close, scene_of

from solver import pipeline
from solver.capillary import Cohesion
from solver.io import results
from solver.packing import jammed

WET = {"law": "willett", "surface_tension": 0.01, "volume": 1.0e-3}


def test_wet_scene_runs_resumes_and_reads_back(comm, shared_tmp):
    scene = scene_of(shared_tmp / "wet.h5", cache="off", seed=3, packing={"n": 64, "phi": 0.8},
                     model={"rho": [0.5], "cohesion": WET}, spectrum={"bin_width": 0.1},
                     waves={"modes": ["L", "TR", "RT"], "n": [1], "t_end": 20.0, "dt": 0.05})
    first = pipeline.run(scene, COMM, [])["units"]
    again = pipeline.run(scene, COMM, [])["units"]  # every unit finished: loaded
    made = jammed.generate(64, 0.8, np.random.SeedSequence([3, 0]), cohesion=Cohesion(**WET))
    with results.open_results(scene.output) as f:
        packing = results.packing(f, 0)
        assert_all(results.contact_model(f).cohesion == Cohesion(**WET), "the results file's model is dry")
    assert_close(packing["positions"], made.positions, rtol=0.0, what="the scene's wet packing")
    assert_all(np.array_equal(packing["bridges"], made.bridges), "the bridges written")
    vdos = "spectra/r00_p0000"
    assert_all(np.array_equal(first[vdos][0]["counts"], again[vdos][0]["counts"]), "resumed counts")
    reread = scene_of(shared_tmp / "reread.h5", cache="off", packing={"file": str(scene.output)},
                      model={"rho": [0.5], "cohesion": WET}, spectrum={"bin_width": 0.1})
    units = pipeline.run(reread, COMM, [])["units"]
    assert_all(np.array_equal(units[vdos][0]["counts"], first[vdos][0]["counts"]), "read back: other counts")
    if COMM.size == 1:  # the readers are serial: once, in the 1-rank pass
        from solver import plots

        from scripts.tools import wet_findings

        # the re-read scene's file (its packing with the bridges; a vDOS, no waves: fewer figures)
        assert any(path.endswith("_forces.png") for path in plots.plot_results(str(reread.output)))
        from solver.io import export

        written, _ = export.export(str(reread.output), "extxyz", str(shared_tmp / "wet.xyz"))
        assert int(open(written[0]).readline()) == 64, written
        row = wet_findings.scene(str(scene.output))
        assert row["wet"] and row["bridges"] == made.info["n_bridges"] and row["phi"] == made.phi, row
        assert "| wet |" in wet_findings.table([row]).replace(row["name"], "wet")
        from figures import assert_figures

        written = wet_findings.figures([row], str(shared_tmp))
        assert_figures({str(shared_tmp / name): fig for name, fig in wet_findings.draw([row]).items()}, written)
        assert len(written) == 3, written
