"""docs/notebook_example.py, the manual's way to read results from Python (docs/results.md), runs on a small scene's
file (vDOS with per-mode energies, spectral waves with their fits, mode shapes), prints what that
file holds, and imports neither MPI nor PETSc.  Serial: it is one process."""

import subprocess
import sys

import numpy as np
import pytest
from conftest import COMM, REPO, scene_of

from solver import pipeline
from solver.io import results

pytestmark = pytest.mark.serial_only

RUN = f"""\
import runpy, sys
sys.argv = ["notebook_example.py", sys.argv[1]]
runpy.run_path({str(REPO / "docs" / "notebook_example.py")!r}, run_name="__main__")
loaded = [m for m in ("petsc4py", "slepc4py", "mpi4py") if m in sys.modules]
sys.exit(f"imported {{loaded}}" if loaded else 0)
"""


def test_notebook_example_reads_every_kind_without_mpi_or_petsc(tmp_path):
    out = tmp_path / "small.h5"
    scene = scene_of(out, cache="off", seed=3, packing={"n": 64, "phi": 0.9}, model={"rho": [0.5]},
                     spectrum={"energies": True}, modes={"omega": [1.0], "count": 2},
                     waves={"n": [1, 2], "method": "spectral", "t_end": 40, "modes": ["L", "TR"]})
    pipeline.run(scene, COMM, [])
    proc = subprocess.run([sys.executable, "-c", RUN, str(out)], cwd=REPO, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    with results.open_results(str(out)) as f:
        omega_c = results.vdos(f)[0.5].omega_c
        fit = results.fits(f)[(0.5, "TR")]
        shapes = results.mode_shapes(f)[0]
    lines = proc.stdout.splitlines()
    assert lines[0] == "holds: vdos, spectra, modes, waves, analysis", lines
    assert f"omega_c = {omega_c:.4f}/t0" in proc.stdout
    assert f"dispersion rho = 0.5 TR: k d0 = {fit['k'][0]:.3f}..{fit['k'][-1]:.3f}" in proc.stdout
    m = int(np.argmin(shapes.participation))
    assert f"omega = {shapes.omega[m]:.4f}/t0, participation {shapes.participation[m]:.3f}" in proc.stdout
