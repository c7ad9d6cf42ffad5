"""Render the bad-input catalogue (scripts/tools/bad_inputs.py) into the manual's page docs/bad_inputs.md
with the real messages.

    .venv/bin/python -m scripts.tools.render_bad_inputs
Runs every case once, in this process (``solver.__main__.main``, as tests/io/test_bad_inputs.py
does; the options a case leaves in PETSc's database are taken out again, ``options.restore``), and
replaces the text between the page's markers <!-- bad-inputs --> and <!-- /bad-inputs -->.
"""

import contextlib
import io
import os
import re
import tempfile
from pathlib import Path

from solver import __main__ as cli, options, petscenv
from scripts.tools.bad_inputs import CASES, materialise

REPO = Path(__file__).resolve().parents[2]
PAGE = "docs/bad_inputs.md"  # the manual's page "Bad inputs and their messages"


def main() -> None:
    petscenv.init([])  # once, as the tests' conftest does: every case's run then finds PETSc started
    rows = ["| # | bad input | what the user sees (stderr, exit code 2) |", "|---|---|---|"]
    for number, case in enumerate(CASES, 1):
        with tempfile.TemporaryDirectory() as tmp:
            args, _ = materialise(Path(tmp), case)
            before, here, err = options.snapshot(), os.getcwd(), io.StringIO()
            os.chdir(tmp)
            try:
                with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                    code = cli.main(args)
            finally:
                os.chdir(here)
                options.restore(before)
            text = err.getvalue().strip()
            message = text.splitlines()[0] if text else "(none)"
            message = message.replace(tmp, "DIR")
        assert code == 2, (case[0], code, text)
        rows.append(f"| {number} | {case[0]} | `{message.replace('|', '/')}` |")
    page = REPO / PAGE
    block = "<!-- bad-inputs -->\n" + "\n".join(rows) + "\n<!-- /bad-inputs -->"
    text = re.sub(r"<!-- bad-inputs -->.*<!-- /bad-inputs -->", lambda _: block, page.read_text(), flags=re.S)
    page.write_text(text)
    print(f"{len(CASES)} rows written to {PAGE}")


if __name__ == "__main__":
    main()
