"""Which tests the MPI pass leaves out (docs/development.md, "Testing"): a test marked
``serial_only`` (its module's ``pytestmark``, or its own decorator) runs only in the 1-rank pass,
so it must name no communicator.  These tests read the test modules' text (ast) and fail when a
``serial_only`` test, or a fixture or helper of its module that it reaches, names a
communicator, MPI or PETSc, or one of conftest's collective helpers, so that a test whose code
communicates is not silently left out of the MPI pass.  The modules that do so for a stated
reason (they start processes of their own, or their second rank would only wait for rank 0's
file and figure work) are listed in ``EXEMPT`` with that reason."""

import ast
import pathlib

import pytest
from conftest import REPO

pytestmark = pytest.mark.serial_only  # reads source files; no communicator

TESTS = REPO / "tests"

COMMUNICATING = frozenset({
    "comm", "COMM", "COMM_WORLD", "COMM_SELF", "tompi4py",  # a communicator: conftest's fixture and COMM, mpi4py's
    "MPI", "PETSc", "SLEPc", "mpi4py", "petsc4py", "slepc4py",  # the libraries that make parallel objects
    "shared_tmp", "main_here", "run_stopped_after_windows",  # conftest's collective helpers
})
"""Names whose appearance in a test's code means the test may communicate: every function of
``solver`` that communicates takes its communicator (STYLE.md: no hidden COMM_WORLD), so a test
that names none cannot; ``main_here`` runs the command line, which takes COMM_WORLD."""

EXEMPT = {
    # whole modules
    "tests/analysis/test_analysis.py": "runs a tiny scene in-process (main_here) for the report it checks: one process's files and figures",
    "tests/io/test_export.py": "a scene run on one rank makes the file it exports; what is checked is the export (files, OVITO's process)",
    "tests/io/test_mercury.py": "file reading; the one pipeline call only reads the packing (nothing to gain from a second rank)",
    "tests/io/test_notebook_example.py": "a scene run on one rank makes the file the manual's notebook example reads in one process",
    "tests/io/test_render.py": "a scene run on one rank makes the file VTK renders in one process",
    "tests/io/test_results_format.py": "file reading and the CLI on one rank (an old results file read as written)",
    "tests/io/test_round_trip.py": "scenes run on one rank make the files every reader reads back: readers, not the run, are checked",
    "tests/packing/test_force_network.py": "a scene run on one rank makes the file the force-chain figure reads: forces and figures on arrays",
    "tests/packing/test_wet_packing.py": "FIRE is serial; the wet matrix is checked on 2 ranks in test_wet_dynmat",
    "tests/run/test_boxes_findings.py": "the findings tool on COMM_SELF: one process's matrix, no second rank by design",
    "tests/run/test_cli.py": "starts rotsound processes of its own (its mpirun jobs: marker spawns_ranks)",
    "tests/run/test_crosscheck_stressed.py": "LAMMPS runs in fresh processes (crosscheck_stressed.fresh)",
    "tests/run/test_resume.py": "starts and kills rotsound jobs of its own (marker spawns_ranks)",
    "tests/transport/test_diffusivity_findings.py": "a scene run on one rank makes the file the findings tool reads",
    "tests/waves/test_liggghts_walls.py": "dense exp(tJ) of 900 DOF against LIGGGHTS's files, the same on every rank",
    "tests/waves/test_liggghts_waves.py": "dense exp(tJ) of 1500 DOF against LIGGGHTS's files, the same on every rank",
    "tests/waves/test_sheared_waves.py": "dense exp(tJ) of 756 DOF against LAMMPS's files, the same on every rank",
    "tests/waves/test_walls_waves.py": "dense exp(tJ) of 900 DOF against LAMMPS's files, the same on every rank",
    # single tests of modules the MPI pass runs
    "tests/analysis/test_loss.py::test_weak_dashpots_add_their_rate_to_the_scattering":
        "two scenes of waves; the MPI pass runs the same chain in test_pep and test_damped_waves",
    "tests/io/test_mercury_waves.py::test_mercurys_waves_converge_to_the_stressed_matrixs_exact_solution":
        "dense exp(tJ) against MercuryDPM's files; the stressed matrix on 2 ranks is test_stressed's",
    "tests/run/test_box_kinds.py::test_figures_and_exports_carry_the_cell":
        "rank 0's files and figures, and OVITO's process (test_export's reason)",
    "tests/waves/test_lammps_dem.py::test_stored_forces_go_into_lammps_history_and_the_linear_limit_is_the_stressed_matrix":
        "four LAMMPS runs and a dense exp(tJ) each; on 2 ranks: the stored-forces scene test of test_lammps_scene",
    "tests/waves/test_lammps_dem.py::test_rolling_and_twisting_springs_under_pair_granular_are_the_matrix_at_small_amplitude":
        "three LAMMPS runs and a dense exp(tJ) each; LAMMPS on 2 ranks: the gran/*/history tests",
    "tests/waves/test_lammps_dem.py::test_pair_granular_with_stored_forces_is_the_stressed_matrix_at_small_amplitude":
        "six LAMMPS runs and four dense exp(tJ); LAMMPS on 2 ranks: the gran/*/history tests",
    "tests/waves/test_lammps_scene.py::test_rolling_and_twisting_scene_runs_pair_granular_as_its_verlet_waves":
        "a 3D pair granular scene; LAMMPS's scenes on 2 ranks: the 2D scene tests of its module",
}
"""Modules (and single tests, ``path::test``) left out of the MPI pass although they name a
communicator, and why."""


def _marked(decorators, mark: str) -> bool:
    """A decorator ``pytest.mark.<mark>`` on the whole test (a mark on one parametrisation leaves
    the others in the MPI pass)."""
    return any(ast.unparse(d) == f"pytest.mark.{mark}" for d in decorators)


def _names(node) -> set[str]:
    """Every name, attribute, argument and imported module (each dotted part) in ``node``."""
    out = set()
    for n in ast.walk(node):
        if isinstance(n, ast.Name):
            out.add(n.id)
        elif isinstance(n, ast.Attribute):
            out.add(n.attr)
        elif isinstance(n, ast.arg):
            out.add(n.arg)
        elif isinstance(n, (ast.Import, ast.ImportFrom)):
            for alias in n.names:
                out.update(alias.name.split("."))
                out.add(alias.asname or alias.name)
            if isinstance(n, ast.ImportFrom) and n.module:
                out.update(n.module.split("."))
    return out


def _reached(function: ast.FunctionDef, definitions: dict) -> set[str]:
    """The names in ``function`` and in the module's functions (fixtures, helpers) it reaches
    by name or as a fixture argument, transitively."""
    seen, todo, out = set(), [function], set()
    while todo:
        node = todo.pop()
        names = _names(node)
        out |= names
        for name in names & definitions.keys():
            if name not in seen:
                seen.add(name)
                todo.append(definitions[name])
    return out


def serial_only_tests_naming_a_communicator(path: pathlib.Path) -> dict[str, list[str]]:
    """{test name or "<module>": the communicating names it reaches} for the tests of the module
    at ``path`` that are ``serial_only`` and do not start mpirun jobs of their own
    (``spawns_ranks``); "<module>" when the module's ``pytestmark`` is ``serial_only`` (then the
    whole module's text counts)."""
    tree = ast.parse(path.read_text(), str(path))
    whole = any(isinstance(n, ast.Assign) and any(getattr(t, "id", None) == "pytestmark" for t in n.targets)
                and "serial_only" in ast.unparse(n.value) for n in tree.body)
    if whole:
        found = sorted(_names(tree) & COMMUNICATING)
        return {"<module>": found} if found else {}
    definitions = {n.name: n for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    out = {}
    for name, node in definitions.items():
        if (name.startswith("test_") and isinstance(node, ast.FunctionDef) and _marked(node.decorator_list, "serial_only")
                and not _marked(node.decorator_list, "spawns_ranks")):
            found = sorted(_reached(node, definitions) & COMMUNICATING)
            if found:
                out[name] = found
    return out


def test_tests_left_out_of_the_mpi_pass_name_no_communicator():
    """Every ``serial_only`` test module (the exempt ones aside) names no communicator; a test
    that does belongs in the MPI pass."""
    found = {}
    for path in sorted(TESTS.rglob("test_*.py")):
        where = str(path.relative_to(REPO))
        hits = {f"{where}::{test}": names for test, names in serial_only_tests_naming_a_communicator(path).items()}
        found.update({test: names for test, names in hits.items()
                      if test not in EXEMPT and test.replace("::<module>", "") not in EXEMPT})
    assert not found, ("serial_only tests that name a communicator (move them to the MPI pass, or state in "
                       f"EXEMPT why their second rank has nothing to check): {found}")


def test_every_exemption_names_a_serial_only_test_naming_a_communicator():
    """An exemption names a module left out of the MPI pass whole, or a serial_only test, that
    names a communicator (a stale row would hide nothing, but say something false)."""
    def named(where):
        path, _, test = where.partition("::")
        return (REPO / path).exists() and (test or "<module>") in serial_only_tests_naming_a_communicator(REPO / path)
    stale = {where for where in EXEMPT if not named(where)}
    assert not stale, f"EXEMPT rows that are not serial_only modules naming a communicator: {stale}"


@pytest.mark.parametrize("source, expected", [
    ("import pytest\npytestmark = pytest.mark.serial_only\ndef test_a(comm):\n    pass\n", {"<module>": ["comm"]}),
    ("import pytest\npytestmark = pytest.mark.serial_only\ndef test_a():\n    from mpi4py import MPI\n",
     {"<module>": ["MPI", "mpi4py"]}),
    ("import pytest\npytestmark = pytest.mark.serial_only\ndef test_a():\n    assert 1 + 1 == 2\n", {}),
    # a test's own mark: what it reaches through the module's fixtures and helpers counts
    ("import pytest\n@pytest.fixture\ndef made(shared_tmp):\n    return shared_tmp\n"
     "def helper(x):\n    return x\n"
     "@pytest.mark.serial_only\ndef test_a(made):\n    helper(made)\n"
     "@pytest.mark.serial_only\ndef test_b():\n    helper(1)\n"
     "def test_c(comm):\n    pass\n", {"test_a": ["shared_tmp"]}),
    ("import pytest\nfrom conftest import COMM\ndef run():\n    return COMM.size\n"
     "@pytest.mark.serial_only\ndef test_a():\n    run()\n", {"test_a": ["COMM"]}),
    ("import pytest\n@pytest.mark.spawns_ranks\n@pytest.mark.serial_only\ndef test_a(comm):\n    pass\n", {}),
])
def test_the_guard_sees_a_communicator(tmp_path, source, expected):
    """The guard's own check, on small modules: it finds a communicator named in a serial_only
    module, in a serial_only test's fixtures and helpers, and not where none is named."""
    path = tmp_path / "test_example.py"
    path.write_text(source)
    assert serial_only_tests_naming_a_communicator(path) == expected
