"""Run every scripts/bench_*.py (and the crosscheck_*.py) in turn (alone: the machine has 2 cores)
and write BENCHMARKS.md.

    make bench          # or: python scripts/bench_all.py [--render-only]
Each benchmark leaves a JSON record in scripts/records/ (committed: BENCHMARKS.md's source); this
script renders them all, then appends the measured runs of whole scenes, written by hand from their
logs (``HAND_WRITTEN``).
"""

import json
import subprocess
import sys

from benchlib import PY, RECORDS, REPO, machine

ORDER = ["bench_packing.py", "bench_packing3d.py", "bench_engines.py", "bench_assembly.py", "bench_spectrum.py",
         "bench_ciss.py", "bench_waves.py", "bench_spectral.py", "bench_lanczos_batch.py", "bench_kpm.py", "bench_vdos.py",
         "bench_spheres.py", "bench_blr.py",
         "crosscheck_lammps.py",
         "crosscheck_stressed.py", "crosscheck_yade.py", "crosscheck_damped.py", "bench_stressed_spectrum.py",
         "bench_nonhermitian.py", "bench_damped.py", "bench_damped_waves.py", "bench_scaling.py"]
ARGS = {"bench_vdos.py": ["--skip", "slicing:32768"],  # over an hour; the spectrum section has it with K/Q
        "bench_blr.py": ["4096", "--eps", "1e-2"],  # N = 32768: hours; see scripts/bench_blr.md
        "bench_ciss.py": ["32768", "--modes", "500", "--ip", "16"],  # one window: CISS against Krylov-Schur
        "bench_scaling.py": ["131072", "262144", "--ranks", "1", "2", "4", "--tag", "_after"]}  # the code as it is now
ALSO = {"bench_scaling.py": ["scaling"]}  # records rendered before the script's own: the scaling before issue 26's changes
HAND_WRITTEN = ["bench_paper_programme.md"]  # configs/paper.yaml, timed from its own log
RECORD_NAMES = {"crosscheck_lammps.py": "crosscheck", "crosscheck_stressed.py": "crosscheck_stressed",
           "crosscheck_yade.py": "crosscheck_yade", "crosscheck_damped.py": "crosscheck_damped"}  # record names of scripts not called bench_<name>.py


def _record(script: str) -> str:
    """Name of ``script``'s record: scripts/records/<name>.json and BENCHMARKS.md's '## name'."""
    return RECORD_NAMES.get(script, script[6:-3] + ("_after" if script == "bench_scaling.py" else ""))


def _sections(text: str) -> dict[str, str]:
    """The '## name' sections of an existing BENCHMARKS.md, name -> text (heading included)."""
    parts = ("\n" + text).split("\n## ")[1:]
    return {part.split("\n", 1)[0].strip(): "## " + part.strip() for part in parts}


def render() -> None:
    """Write BENCHMARKS.md from scripts/records/*.json; a benchmark with no record here (measured
    on another checkout, or not rerun) keeps its section from the existing BENCHMARKS.md."""
    old = _sections((REPO / "BENCHMARKS.md").read_text()) if (REPO / "BENCHMARKS.md").exists() else {}
    lines = ["# Benchmarks", "",
             "Regenerate with `make bench` (runs `scripts/bench_*.py` one after another, then "
             "renders this file from `scripts/records/*.json`). Every comparison is measured in the "
             "same run, on the same machine, with the machine otherwise idle.", "",
             f"Rendered on: {machine()}. Each section names the machine it was measured on.", ""]
    for script, name in [(script, name) for script in ORDER for name in ALSO.get(script, []) + [_record(script)]]:
        path = RECORDS / f"{name}.json"
        if not path.exists():
            kept = old.get(name)
            missing = [f"## {name}", "", f"not run yet (`python scripts/{script}`)", ""]
            lines += [kept, ""] if kept else missing
            continue
        record = json.loads(path.read_text())
        lines += [f"## {record['name']}", "", f"Command: `{record['command']}`  ", f"Date: {record['date']}  ",
                  f"Machine: {record['machine']}", ""]
        columns = list(dict.fromkeys(k for row in record["table"] for k in row))
        lines += ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
        for row in record["table"]:
            lines.append("| " + " | ".join(str(row.get(c, "")) for c in columns) + " |")
        lines += ["", record["notes"], ""]
        analysis = REPO / "scripts" / f"{script[:-3]}.md"
        if analysis.exists() and name == _record(script):
            lines += [analysis.read_text().strip(), ""]
    for name in HAND_WRITTEN:
        lines += [(REPO / "scripts" / name).read_text().strip(), ""]
    (REPO / "BENCHMARKS.md").write_text("\n".join(lines))
    print(f"wrote {REPO / 'BENCHMARKS.md'}")


def main() -> None:
    if "--render-only" not in sys.argv:
        for script in ORDER:
            print(f"== {script}", flush=True)
            subprocess.run([PY, str(REPO / "scripts" / script), *ARGS.get(script, [])], check=True, cwd=REPO)
    render()


if __name__ == "__main__":
    main()
