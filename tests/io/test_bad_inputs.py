"""Every row of the bad-input catalogue on 2 ranks: exit 2, the message once, no traceback,
no output written, no rank left hanging (each run has a timeout)."""

import re

import pytest
from bad_inputs import CASES
from conftest import REPO, run_cli

pytestmark = pytest.mark.serial_only  # launches its own mpirun


def materialise(tmp_path, case):
    what, scene, words, message, maker = case
    out = tmp_path / "never.h5"
    file = tmp_path / "packing.h5"
    if maker:
        maker(file)
    args = list(words)
    if scene is not None:
        path = tmp_path / "scene.yaml"
        text = scene.replace("{file}", str(file)).replace("{out}", str(out))
        path.write_text(text if text.startswith(("- ", "packing: {n: 64, phi: 0.9\n")) or not text.strip()
                        else f"output: {out}\n" + text)
        if not words or words[0].startswith("--"):  # options of 'run' (--set, --group-size, ...)
            args = ["run", str(path)] + args
    return args, out


def test_readme_table_is_the_catalogue():
    """The README's bad-input table (rendered by scripts/render_bad_inputs.py) holds exactly the
    catalogue's rows, in order, each showing a message that contains the row's expected
    fragment: a row added, renamed or reworded without re-rendering fails here."""
    text = (REPO / "README.md").read_text()
    block = re.search(r"<!-- bad-inputs -->\n(.*)\n<!-- /bad-inputs -->", text, re.S).group(1)
    rendered = [[cell.strip() for cell in line.split("|")[1:-1]] for line in block.splitlines()[2:]]
    assert [row[1] for row in rendered] == [case[0] for case in CASES]
    assert [row[0] for row in rendered] == [str(i) for i in range(1, len(CASES) + 1)]
    for row, case in zip(rendered, CASES):
        assert case[3].replace("|", "/") in row[2], (case[0], row[2])


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input(tmp_path, case):
    args, out = materialise(tmp_path, case)
    proc = run_cli(args, ranks=2, timeout=120, cwd=tmp_path)
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    assert case[3] in proc.stderr, proc.stderr
    assert proc.stderr.count("rotsound: error:") == 1
    assert "Traceback" not in proc.stderr + proc.stdout
    assert not out.exists() and not (tmp_path / "never.h5.partial").exists()
