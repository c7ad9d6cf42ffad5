"""Import hygiene: analysis, reading results and plotting never need PETSc or MPI (STYLE.md, the
PETSc fence); the claims and the lattice model need not even h5py; every module imports downward, in the
stages' order, and no modules import each other in a circle; the figure modules import only their
common module."""

import ast
import pathlib
import subprocess
import sys

import pytest
from conftest import REPO

pytestmark = pytest.mark.serial_only  # source text and child processes, no communicator

NO_PETSC = ("solver", "solver.io.schema", "solver.io.scenes", "solver.io.results", "solver.waves.correlations",
            "solver.analysis.fits", "solver.analysis.lattice", "solver.analysis.claims", "solver.analysis.dispersion",
            "solver.spectrum.modes", "solver.plots", "solver.plots.common", "solver.plots.packing",
            "solver.plots.spectrum", "solver.plots.waves", "solver.plots.attenuation", "solver.plots.modes",
            "solver.plots.damped", "solver.analysis.loss", "solver.report")
NO_FILES = ("solver.analysis.lattice", "solver.analysis.claims")


def _loaded_after_import(modules, watched) -> str:
    code = (f"import sys, {', '.join(modules)}; "
            f"print(sorted(m for m in {watched!r} if m in sys.modules))")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()


def test_analysis_modules_do_not_import_petsc_or_mpi():
    assert _loaded_after_import(NO_PETSC, ("petsc4py", "slepc4py", "mpi4py")) == "[]"


def test_claims_and_lattice_model_do_not_import_h5py():
    assert _loaded_after_import(NO_FILES, ("h5py", "petsc4py", "mpi4py")) == "[]"


STAGES = (  # lowest first: a module imports from its own stage or lower ones, never from a higher one
    ("solver", "solver.errors", "solver.profiling", "solver.parallel", "solver.petscenv", "solver.options",
     "solver.contact_law"),  # the leaf utilities
    ("solver.packing",),
    ("solver.model",),
    ("solver.references",),  # dense references: the matrix only, never the spectrum or waves code they check
    ("solver.spectrum", "solver.waves"),  # side by side: neither imports the other
    ("solver.transport",),  # energy transport by the modes: uses the spectrum's slicing, below analysis
    ("solver.analysis",),
    ("solver.io",),
    ("solver.plots",),
    ("solver.report",),
    ("solver.pipeline",),
    ("solver.__main__",),
)


def _modules() -> dict[str, pathlib.Path]:
    """Every module of solver/ by its dotted name (a package by its own name)."""
    found = {}
    for path in sorted((REPO / "solver").rglob("*.py")):
        parts = path.relative_to(REPO).with_suffix("").parts
        found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


def _imports(name: str, path: pathlib.Path, modules) -> set[str]:
    """The modules of solver/ that ``name`` imports anywhere in its text (at the top, inside
    functions, under TYPE_CHECKING), read from its syntax tree."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = ".".join(package[:len(package) - node.level + 1] + ([node.module] if node.module else [])) \
                if node.level else node.module
            found.update(f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base for alias in node.names)
    return {m for m in found if m in modules and m != name}


def _stage(name: str) -> tuple[int, str]:
    """(level, stage) of a module: the longest stage name it falls under."""
    return max((level, stage) for level, stages in enumerate(STAGES) for stage in stages
               if name == stage or name.startswith(stage + "."))


def test_every_module_imports_downward_and_without_a_circle():
    """Every module of solver/: its imports (lazy ones included) go to its own stage or a lower one
    (``STAGES``: the data flow packing -> model -> references -> spectrum, waves -> transport -> analysis -> io ->
    plots -> report -> pipeline), stages side by side do not import each other, and no modules import each
    other in a circle."""
    modules = _modules()
    graph = {name: _imports(name, path, modules) for name, path in modules.items()}
    assert all(_stage(name) for name in modules)
    upward = sorted(f"{a} -> {b}" for a, targets in graph.items() for b in targets
                    if _stage(b)[0] > _stage(a)[0] or (_stage(b)[0] == _stage(a)[0] > 0 and _stage(b)[1] != _stage(a)[1]))
    assert not upward, f"imports from a higher (or a side-by-side) stage: {upward}"
    done, circles = {}, []

    def visit(name, trail):  # depth-first; a module met again on the current trail closes a circle
        if name in trail:
            circles.append(trail[trail.index(name):] + [name])
            return
        if done.get(name):
            return
        for target in sorted(graph[name]):
            visit(target, trail + [name])
        done[name] = True

    for name in sorted(graph):
        visit(name, [])
    assert not circles, f"modules importing each other in a circle: {circles[:3]}"


PLOTS = REPO / "solver" / "plots"


def _siblings(path: pathlib.Path) -> set[str]:
    """The modules of ``solver.plots`` that the module at ``path`` imports (relative imports)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            found |= {node.module.split(".")[0]} if node.module else {alias.name for alias in node.names}
    return found


@pytest.mark.parametrize("name", sorted(p.stem for p in PLOTS.glob("*.py") if p.stem != "__init__"))
def test_figure_modules_import_only_common(name):
    """A stage's figure module imports ``common`` and no other figure module (the entry,
    ``solver/plots/__init__.py``, imports them all); ``common`` imports none."""
    assert _siblings(PLOTS / f"{name}.py") <= ({"common"} if name != "common" else set())
