"""Run every benchmark and cross-check in turn (alone: the machine has 2 cores) and write
BENCHMARKS.md.

    make bench          # or: python -m scripts.benchmarks.bench_all [--render-only]

Found by convention, not listed here: every ``scripts/benchmarks/bench_*.py`` (but this one) and every
``scripts/crosschecks/crosscheck_*.py`` declares how it is run and rendered in a module constant, a
literal ``BENCH = {"order": ..., ...}``:

  order    its place in ``make bench`` and in BENCHMARKS.md (ascending; no two the same);
  args     the arguments ``make bench`` runs it with (default none);
  record   the name of its record, ``<folder>/records/<record>.json``, and of its section
           "## <record>" (default the module's name, ``bench_`` dropped: bench_kpm -> kpm);
  also     records rendered before its own (older measurements it keeps; default none).

bench_all reads ``BENCH`` from each module's source (``ast.literal_eval``) and imports no
benchmark: importing one runs its top level (numpy, and bench_damped's one-BLAS-thread setting,
which every benchmark run after it would inherit).  Each runs as ``python -m <package>.<module>
<args>`` from the repository's root and leaves its JSON record (committed: BENCHMARKS.md's
source).  A module's reading, ``<folder>/<module>.md``, is rendered under its own record; a
reading named like a benchmark of which there is no module (bench_paper_programme.md: the
measured run of configs/paper.yaml, written by hand from its log) is appended at the end, in name
order.  A record that is missing keeps its section of the existing BENCHMARKS.md (measured on
another checkout), or says "not run yet".
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

from scripts.benchmarks.benchlib import PY, REPO, machine

FOLDERS = {"scripts/benchmarks": "bench_*.py", "scripts/crosschecks": "crosscheck_*.py"}  # where benchmarks are found, and how named


def declared(path: Path) -> dict:
    """The ``BENCH`` constant of the module at ``path``, read from its source (never imported);
    SystemExit naming the module if it has none."""
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "BENCH" for t in node.targets):
            return ast.literal_eval(node.value)
    raise SystemExit(f"{path.relative_to(REPO)}: no BENCH = {{\"order\": ...}} (how bench_all runs it: "
                     f"scripts/benchmarks/bench_all.py)")


def benchmarks() -> list[dict]:
    """Every benchmark and cross-check in order: module (dotted), path, args, record, also."""
    found = []
    for folder, pattern in FOLDERS.items():
        for path in sorted((REPO / folder).glob(pattern)):
            if path.stem == "bench_all":
                continue
            bench = declared(path)
            found.append({"module": f"{folder.replace('/', '.')}.{path.stem}", "path": path, "order": bench["order"],
                          "args": list(bench.get("args", [])), "also": list(bench.get("also", [])),
                          "record": bench.get("record", path.stem.removeprefix("bench_"))})
    orders = [b["order"] for b in found]
    if len(set(orders)) != len(orders):
        raise SystemExit(f"two benchmarks share an order: {sorted(orders)}")
    return sorted(found, key=lambda b: b["order"])


def hand_written(todo: list[dict]) -> list[Path]:
    """The readings named like a benchmark of which there is no module, in name order."""
    modules = {b["path"].stem for b in todo} | {"bench_all"}
    return sorted((path for folder, pattern in FOLDERS.items()
                   for path in (REPO / folder).glob(pattern.replace(".py", ".md")) if path.stem not in modules),
                  key=lambda path: path.name)


def _cell(value) -> str:
    """A table cell's text, its '|' (an absolute value) escaped so that it does not end the cell."""
    return str(value).replace("|", "\\|")


def _sections(text: str) -> dict[str, str]:
    """The '## name' sections of an existing BENCHMARKS.md, name -> text (heading included)."""
    parts = ("\n" + text).split("\n## ")[1:]
    return {part.split("\n", 1)[0].strip(): "## " + part.strip() for part in parts}


def text(todo: list[dict]) -> str:
    """BENCHMARKS.md from the records and readings of ``todo`` (:func:`benchmarks`); a benchmark with
    no record here (measured on another checkout, or not rerun) keeps its section from the existing
    BENCHMARKS.md (tests/run/test_bench_all.py checks the committed file is this text)."""
    old = _sections((REPO / "BENCHMARKS.md").read_text()) if (REPO / "BENCHMARKS.md").exists() else {}
    lines = ["# Benchmarks", "",
             "Regenerate with `make bench` (runs `scripts/benchmarks/bench_*.py` and `scripts/crosschecks/crosscheck_*.py` one after "
             "another, then renders this file from their `records/*.json`). Every comparison is measured in the "
             "same run, on the same machine, with the machine otherwise idle. Each command runs from the "
             "checkout's root (`python -m scripts.benchmarks.NAME`, `scripts.crosschecks.NAME` for a cross-check).", "",
             f"Rendered on: {machine()}. Each section names the machine it was measured on.", ""]
    for bench in todo:
        for name in bench["also"] + [bench["record"]]:
            path = bench["path"].parent / "records" / f"{name}.json"
            if not path.exists():
                kept = old.get(name)
                missing = [f"## {name}", "", f"not run yet (`python -m {bench['module']}`)", ""]
                lines += [kept, ""] if kept else missing
                continue
            record = json.loads(path.read_text())
            lines += [f"## {record['name']}", "", f"Command: `{record['command']}`  ", f"Date: {record['date']}  ",
                      f"Machine: {record['machine']}", ""]
            columns = list(dict.fromkeys(k for row in record["table"] for k in row))
            lines += ["| " + " | ".join(map(_cell, columns)) + " |", "|" + "---|" * len(columns)]
            for row in record["table"]:
                lines.append("| " + " | ".join(_cell(row.get(c, "")) for c in columns) + " |")
            lines += ["", record["notes"], ""]
            reading = bench["path"].with_suffix(".md")
            if reading.exists() and name == bench["record"]:
                lines += [reading.read_text().strip(), ""]
    for reading in hand_written(todo):
        lines += [reading.read_text().strip(), ""]
    return "\n".join(lines)


def render(todo: list[dict]) -> None:
    """Write BENCHMARKS.md (:func:`text`)."""
    (REPO / "BENCHMARKS.md").write_text(text(todo))
    print(f"wrote {REPO / 'BENCHMARKS.md'}")


def main() -> None:
    todo = benchmarks()
    if "--render-only" not in sys.argv:
        for bench in todo:
            print(f"== {bench['module']} {' '.join(bench['args'])}", flush=True)
            subprocess.run([PY, "-m", bench["module"], *bench["args"]], check=True, cwd=REPO)
    render(todo)


if __name__ == "__main__":
    main()
