"""Import hygiene: analysis, reading results and plotting never need PETSc or MPI (STYLE.md, the
PETSc fence); the claims and the lattice model need not even h5py; the figure modules form no
circle."""

import ast
import pathlib
import subprocess
import sys

import pytest

NO_PETSC = ("solver", "solver.io.schema", "solver.io.scenes", "solver.io.results", "solver.analysis.correlations",
            "solver.analysis.fits", "solver.analysis.lattice", "solver.analysis.claims", "solver.analysis.dispersion",
            "solver.spectrum.modes", "solver.plots", "solver.plots.common", "solver.plots.packing",
            "solver.plots.spectrum", "solver.plots.waves", "solver.plots.attenuation", "solver.plots.modes",
            "solver.plots.damped", "solver.analysis.loss", "solver.report")
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


LAYERS = {  # module -> solver packages it must not load (imports run downward only)
    "solver.contact_law": ("solver.packing", "solver.model", "solver.io", "solver.spectrum", "solver.waves"),
    "solver.packing.jammed": ("solver.model", "solver.spectrum", "solver.waves", "solver.io"),
    "solver.packing.mechanics": ("solver.model", "solver.spectrum", "solver.waves", "solver.io"),
    "solver.io.results": ("solver.analysis", "solver.model", "solver.spectrum", "solver.waves"),
}


@pytest.mark.serial_only
@pytest.mark.parametrize("module", sorted(LAYERS))
def test_imports_run_downward(module):
    """The contact law sits below packing and model; packing imports no later stage; the results
    reader imports no analysis (the report joins them)."""
    code = (f"import sys, {module}; "
            f"print(sorted({{m.rsplit('.', 1)[0] if m.count('.') > 1 else m for m in sys.modules}} & "
            f"set({LAYERS[module]!r})))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert loaded == "[]", f"{module} loads {loaded}"


PLOTS = pathlib.Path(__file__).resolve().parents[2] / "solver" / "plots"


def _siblings(path: pathlib.Path) -> set[str]:
    """The modules of ``solver.plots`` that the module at ``path`` imports (relative imports)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            found |= {node.module.split(".")[0]} if node.module else {alias.name for alias in node.names}
    return found


@pytest.mark.serial_only
@pytest.mark.parametrize("name", sorted(p.stem for p in PLOTS.glob("*.py") if p.stem != "__init__"))
def test_figure_modules_import_only_common(name):
    """A stage's figure module imports ``common`` and no other figure module (the entry,
    ``solver/plots/__init__.py``, imports them all); ``common`` imports none."""
    assert _siblings(PLOTS / f"{name}.py") <= ({"common"} if name != "common" else set())
