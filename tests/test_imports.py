"""Import hygiene: analysis and plotting never need PETSc or MPI (STYLE.md, the PETSc fence)."""

import subprocess
import sys

import pytest


@pytest.mark.serial_only
def test_analysis_modules_do_not_import_petsc_or_mpi():
    code = ("import sys, solver, solver.io.schema, solver.analysis.correlations, solver.analysis.fits, "
            "solver.analysis.dispersion, solver.spectrum.modes, "
            "solver.plots; print(sorted(m for m in ('petsc4py', 'slepc4py', 'mpi4py') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
