"""Every row of the bad-input catalogue on 2 ranks: exit 2, the message once, no traceback,
no output written, no rank left hanging (each run has a timeout)."""

import pytest
from bad_inputs import CASES
from conftest import run_cli

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
        if "--set" in words or not words:
            args = ["run", str(path)] + args
    return args, out


def test_catalogue_has_at_least_30_rows():
    assert len(CASES) >= 30


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input(tmp_path, case):
    args, out = materialise(tmp_path, case)
    proc = run_cli(args, ranks=2, timeout=120, cwd=tmp_path)
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    assert case[3] in proc.stderr, proc.stderr
    assert proc.stderr.count("rotsound: error:") == 1
    assert "Traceback" not in proc.stderr + proc.stdout
    assert not out.exists() and not (tmp_path / "never.h5.partial").exists()
