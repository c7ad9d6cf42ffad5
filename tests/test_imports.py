"""Import hygiene: analysis, reading results and plotting never need PETSc or MPI (STYLE.md, the
PETSc fence); the claims and the lattice model need not even h5py."""

import subprocess
import sys

import pytest

NO_PETSC = ("solver", "solver.io.schema", "solver.io.scenes", "solver.io.results", "solver.analysis.correlations",
            "solver.analysis.fits", "solver.analysis.lattice", "solver.analysis.claims", "solver.analysis.dispersion",
            "solver.spectrum.modes", "solver.plots", "solver.report")
NO_FILES = ("solver.analysis.lattice", "solver.analysis.claims")


def _loaded_after_import(modules, watched) -> str:
    code = (f"import sys, {', '.join(modules)}; "
            f"print(sorted(m for m in {watched!r} if m in sys.modules))")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()


@pytest.mark.serial_only
def test_analysis_modules_do_not_import_petsc_or_mpi():
    assert _loaded_after_import(NO_PETSC, ("petsc4py", "slepc4py", "mpi4py")) == "[]"


@pytest.mark.serial_only
def test_claims_and_lattice_model_do_not_import_h5py():
    assert _loaded_after_import(NO_FILES, ("h5py", "petsc4py", "mpi4py")) == "[]"
