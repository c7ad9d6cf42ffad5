"""Helpers shared by scripts/bench_*.py: machine description, timing, JSON records."""

from __future__ import annotations

import datetime
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "results" / "bench"
PY = sys.executable


def machine() -> str:
    cpu = "unknown CPU"
    try:
        for line in open("/proc/cpuinfo", encoding="utf-8"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    return f"{cpu}, {os.cpu_count()} cores, {mem:.0f} GiB, {platform.platform()}, Python {platform.python_version()}"


def mpirun(n: int) -> list[str]:
    cmd = ["mpirun", "-n", str(n)]
    if os.geteuid() == 0:
        cmd.append("--allow-run-as-root")
    return cmd


def run_json(cmd: list[str], timeout: float = 7200) -> dict:
    """Run a case in a fresh process; it prints one JSON line last."""
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=REPO)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stdout}\n{proc.stderr}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def peak_rss_gib() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def save(name: str, command: str, table: list[dict], notes: str = "") -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    record = {"name": name, "command": command, "machine": machine(),
              "date": datetime.datetime.now().isoformat(timespec="minutes"),
              "table": table, "notes": notes}
    (OUT / f"{name}.json").write_text(json.dumps(record, indent=1))
    print(json.dumps(record, indent=1))


class Timer:
    def __enter__(self):
        self.start = time.perf_counter()
        return self

    def __exit__(self, *exc):
        self.seconds = time.perf_counter() - self.start
