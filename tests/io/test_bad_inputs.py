"""Every row of the bad-input catalogue, through ``solver.__main__.main`` in this process on every
rank of the suite (1, then 2 under mpirun): exit code 2, the message once (rank 0), no traceback,
nothing written (no output, no units folder or marker; only the finished units of a row refused
after a packing was made, keyed by content), no rank left hanging (a rank that went on alone
would hang its collective: the test's timeout fails it).  A few rows also as real ``mpirun -n 2`` processes, for the exit status
the shell sees.  [decision] In-process, because one subprocess per row (112 rows x ~3 s of
interpreter, PETSc and MPI start-up) was half of ``make test``'s serial time."""

import re

import pytest
from conftest import COMM, REPO, assert_all, run_cli

from solver import __main__ as cli, options
from scripts.tools.bad_inputs import CASES, materialise


def test_docs_table_is_the_catalogue():
    """The manual's bad-input table (docs/bad_inputs.md, rendered by scripts/tools/render_bad_inputs.py)
    holds exactly the catalogue's rows, in order, each showing a message that contains the row's
    expected fragment: a row added, renamed or reworded without re-rendering fails here."""
    text = (REPO / "docs" / "bad_inputs.md").read_text()
    block = re.search(r"<!-- bad-inputs -->\n(.*)\n<!-- /bad-inputs -->", text, re.S).group(1)
    rendered = [[cell.strip() for cell in line.split("|")[1:-1]] for line in block.splitlines()[2:]]
    assert [row[1] for row in rendered] == [case[0] for case in CASES]
    assert [row[0] for row in rendered] == [str(i) for i in range(1, len(CASES) + 1)]
    for row, case in zip(rendered, CASES):
        assert case[3].replace("|", "/") in row[2], (case[0], row[2])


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input(shared_tmp, case, capsys, monkeypatch):
    if COMM.rank == 0:
        args, out = materialise(shared_tmp, case)
    args, out = COMM.bcast((args, out) if COMM.rank == 0 else None, root=0)
    monkeypatch.chdir(shared_tmp)
    files = _tree(shared_tmp)
    before = options.snapshot()
    try:
        code = cli.main(args)
    finally:
        options.restore(before)  # a row's options must not reach the tests after it
    made = _tree(shared_tmp) - files
    err = capsys.readouterr()
    assert_all(code == 2, f"exit code {code}: {err.err}")
    messages = err.err.count("rotsound: error:")
    assert_all(messages == (1 if COMM.rank == 0 else 0), err.err)
    assert_all(COMM.rank > 0 or case[3] in err.err, err.err)
    assert_all("Traceback" not in err.err + err.out, err.err)
    assert_all(not out.exists() and not (shared_tmp / "never.h5.partial").exists(), "an output was written")
    assert_all(all(_finished_unit(path) for path in made), f"a refused run left {sorted(made)}")
    assert_all(all(any(folder.iterdir()) for folder in (shared_tmp / p for p in made) if folder.is_dir()),
               f"a refused run left an empty folder: {sorted(made)}")


def _tree(folder) -> set:
    """Every file and folder below ``folder``, as paths relative to it."""
    return {path.relative_to(folder) for path in folder.rglob("*")}


def _finished_unit(path) -> bool:
    """Whether ``path`` (relative) is a finished unit, which a refusal after some compute keeps
    (content-keyed, it blocks no scene), or a folder holding them: ``cache/<stage>/<key>.h5`` or
    ``never.h5.units/<unit>.h5``; never the units folder's marker ``scene.yaml``."""
    if path.parts[0] == "cache":
        return len(path.parts) <= 3 and (len(path.parts) < 3 or path.suffix == ".h5")
    return path.parts[0] == "never.h5.units" and (len(path.parts) == 1 or (len(path.parts) == 2 and
                                                   path.suffix == ".h5" and path.name != "scene.yaml"))


PROCESS_ROWS = ("unknown top-level key", "LAMMPS data file cut short", "bare solver option on the command line (-ts_dt)")


@pytest.mark.spawns_ranks
@pytest.mark.serial_only  # launches its own mpirun
@pytest.mark.parametrize("what", PROCESS_ROWS)
def test_bad_input_as_a_process(tmp_path, what):
    """The process's exit status on 2 ranks, the message once: rows of three kinds (scene,
    packing file, command line)."""
    case = next(c for c in CASES if c[0] == what)
    args, out = materialise(tmp_path, case)
    proc = run_cli(args, ranks=2, timeout=120, cwd=tmp_path)
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    assert case[3] in proc.stderr, proc.stderr
    assert proc.stderr.count("rotsound: error:") == 1
    assert "Traceback" not in proc.stderr + proc.stdout
    assert not out.exists() and not (tmp_path / "never.h5.partial").exists()
    assert not (tmp_path / "never.h5.units").exists() and not (tmp_path / "cache").exists()


CASES_BY_NAME = {case[0]: case for case in CASES}
STORIES = {  # refused scene -> the corrected one, run to the same output
    "contact file above the Coulomb limit": (
        "packing: {{file: '{data}', contacts: '{data}.contacts', friction: {mu}}}\nmodel: {{rho: 0.5}}\n"
        "spectrum: {{method: nonhermitian}}\n", {"mu": 0.1}, {"mu": 1.0}),
    "generated packing that does not jam": (
        "packing: {{n: {n}, phi: {phi}}}\nspectrum: {{}}\n", {"n": 256, "phi": 0.8}, {"n": 64, "phi": 0.9}),
}


@pytest.mark.parametrize("story", STORIES)
def test_the_corrected_scene_runs_where_the_refused_one_did_not(shared_tmp, story, capsys):
    """A user's sequence: a scene refused (a packing file's forces, before any write; a generated
    packing, after one), then the corrected scene to the same output, without --fresh: it runs,
    and nothing of the refused scene is left but finished units, keyed by content."""
    text, bad, good = STORIES[story]
    out = shared_tmp / "story.h5"
    if COMM.rank == 0:
        stressed_copy = shared_tmp / "frictional.data"
        CASES_BY_NAME["stored force above the Coulomb limit"][4](stressed_copy)
    COMM.Barrier()
    codes = []
    for values in (bad, good):
        scene = shared_tmp / "story.yaml"
        if COMM.rank == 0:
            scene.write_text(f"output: {out}\n" + text.format(data=shared_tmp / "frictional.data", **values))
        COMM.Barrier()
        codes.append(cli.main(["run", str(scene)]))
        if len(codes) == 1:
            left = sorted(p.name for p in shared_tmp.iterdir())
            units = shared_tmp / "story.h5.units"
            marker = sorted(p.name for p in units.iterdir()) if units.is_dir() else []
    err = capsys.readouterr().err
    assert_all(codes == [2, 0], f"exit codes {codes}: {err}")
    assert_all("different scene" not in err, err)
    assert_all("story.h5" not in left and "scene.yaml" not in marker, f"the refusal left {left}, {marker}")
    assert_all(out.exists(), "the corrected scene wrote no results")

