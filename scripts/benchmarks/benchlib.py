"""Helpers shared by the benchmarks (scripts/benchmarks/bench_*.py) and the cross-checks (crosschecks/): machine
description, timing, JSON records, the cached benchmark packings, the plain-scipy competitor of
the standing-wave benchmarks."""

from __future__ import annotations

import datetime
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from solver.io.atomic import atomic_write

REPO = Path(__file__).resolve().parents[2]
RECORDS = REPO / "scripts" / "benchmarks" / "records"  # the JSON records BENCHMARKS.md is rendered from (committed)
SCRATCH = REPO / "results" / "bench"  # logs, progress files and other by-products (not committed)
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
    """mpirun with one BLAS thread per rank (the benchmarks import numpy before solver can set it)."""
    cmd = ["mpirun", "-n", str(n), "-x", "OPENBLAS_NUM_THREADS=1", "-x", "OMP_NUM_THREADS=1"]
    if os.geteuid() == 0:
        cmd.append("--allow-run-as-root")
    return cmd


def run_json(cmd: list[str], timeout: float = 7200, env: dict | None = None) -> dict:
    """Run a case in a fresh process (environment ``env``, default this one's); it prints one
    JSON line last."""
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=REPO, env=env)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stdout}\n{proc.stderr}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def peak_rss_gib() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def save(name: str, command: str, table: list[dict], notes: str = "", merge_by: tuple[str, ...] = (),
         records: Path = RECORDS) -> None:
    """Write <records>/<name>.json (default scripts/benchmarks/records/; the cross-checks' go to
    scripts/crosschecks/records/).  ``merge_by``: keep the rows of the record already there
    whose values of these columns no new row has (a script run in parts, e.g. one N more); the
    command and date then list every part's.  When the parts ran on different CPUs every row
    carries its own in a column "cpu" (part of the merge key), and the record's machine says so."""
    records.mkdir(parents=True, exist_ok=True)
    date = datetime.datetime.now().isoformat(timespec="minutes")
    path = records / f"{name}.json"
    here = machine()
    if merge_by and path.exists():
        old = json.loads(path.read_text())
        cpu, old_cpu = here.split(",")[0], old["machine"].split(",")[0]
        if cpu != old_cpu or any("cpu" in row for row in old["table"]):
            old["table"] = [{**row, "cpu": row.get("cpu", old_cpu)} for row in old["table"]]
            table = [{**row, "cpu": cpu} for row in table]
            merge_by = (*merge_by, "cpu")
            here += " (rows measured on other CPUs name theirs in column cpu)"
        new = {tuple(str(row.get(k)) for k in merge_by) for row in table}
        kept = [row for row in old["table"] if tuple(str(row.get(k)) for k in merge_by) not in new]
        if kept:
            table = kept + table
            if old["command"].split("; then ")[-1] == command:  # the same run, saving after another case
                command, date = old["command"], old["date"]
            else:
                command, date = f"{old['command']}; then {command}", f"{old['date']}; {date}"
    record = {"name": name, "command": command, "machine": here, "date": date, "table": table, "notes": notes}
    path.write_text(json.dumps(record, indent=1))
    print(json.dumps(record, indent=1))


def exact_spectrum_file(packing_path) -> Path:
    """Where bench_spectrum.py keeps the full spectrum with K/Q of a benchmark packing (rank 0)."""
    return Path(str(packing_path).replace(".h5", "_exact_spectrum.npz"))


def file_sha(path) -> str:
    import hashlib

    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def save_exact_spectrum(packing_path, result, seconds: float) -> None:
    np.savez(exact_spectrum_file(packing_path), omega=result.omega, seconds=seconds,
             packing_sha=file_sha(packing_path), **result.energies)


def load_exact_spectrum(packing_path) -> dict | None:
    """The cached exact spectrum of ``packing_path``, or None if absent or made from another file."""
    path = exact_spectrum_file(packing_path)
    if not path.exists():
        return None
    with np.load(path) as data:
        if str(data["packing_sha"]) != file_sha(packing_path):
            return None
        return {k: data[k] for k in data.files}


class NpzCheckpoint:
    """``spectrum.solve(checkpoint=...)`` for the benchmarks: one npz per finished window in
    ``directory`` (rank 0 writes, atomically; every rank reads), each with the seconds it took,
    so a run of hours killed by the end of a session resumes and still reports its total time:
    the seconds of this run plus ``credited``, the seconds of the windows taken from disk."""

    def __init__(self, directory: Path, rank: int):
        self.directory, self.rank = Path(directory), rank
        self.directory.mkdir(parents=True, exist_ok=True)
        self.credited, self.resumed, self.last = 0.0, 0, time.perf_counter()

    def load(self, name: str) -> dict | None:
        path = self.directory / f"{name}.npz"
        if not path.exists():
            return None
        with np.load(path) as data:
            part = {k: data[k] for k in data.files}
        self.credited += float(part.pop("seconds"))
        self.resumed += 1
        self.last = time.perf_counter()
        return part

    def save(self, name: str, datasets: dict) -> None:
        now = time.perf_counter()
        if self.rank == 0:
            with atomic_write(str(self.directory / f"{name}.npz")) as partial, open(partial, "wb") as stream:
                np.savez(stream, seconds=now - self.last, **datasets)  # a stream: savez adds no suffix
        self.last = now

    def clear(self) -> None:
        if self.rank == 0:
            for f in self.directory.glob("*.npz"):
                f.unlink()
            self.directory.rmdir()


class Timer:
    def __enter__(self):
        self.start = time.perf_counter()
        return self

    def __exit__(self, *exc):
        self.seconds = time.perf_counter() - self.start


# ---- the standing-wave comparison shared by bench_waves.py and bench_spectral.py: an L wave
#      (v_x = A sin(k x), uniform translation removed) on a cached packing, rho = 1


def load_packing(n: int):
    """A jammed packing of n disks at phi = 0.9 (seed [1, 0]), generated once into cache/."""
    from solver.io import hdf5
    from solver.packing import jammed

    path = REPO / "cache" / f"bench_{n}.h5"
    if not path.exists():
        path.parent.mkdir(exist_ok=True)
        hdf5.save_packings(str(path), [jammed.generate(n, 0.9, np.random.SeedSequence([1, 0]))])
    return hdf5.read_packings(str(path))[0]


def exact_l_wave(p, k, times):
    """z(t) of the L wave (``references.l_wave_start``) from a dense eigendecomposition of the
    packing's matrix at rho = 1 (``references.exact_l_wave``; serial; PHYSICS.md section 4)."""
    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.references import exact_l_wave as exact

    PETSc = petscenv.init([])
    dm = dynmat.assemble(p, ContactModel(1.0), PETSc.COMM_SELF)
    try:
        return exact(p, dm, k, times)
    finally:
        dm.destroy()


def scipy_verlet_l_wave(p, k, dt, t_end, sample):
    """The obvious alternative: velocity Verlet with scipy.sparse in one process.
    Returns (seconds, z sampled every ``sample``)."""

    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.references import l_wave_start

    D, _, _ = dynmat.local_csr(p, ContactModel(1.0), np.flatnonzero(~p.rattler), (0, int((~p.rattler).sum())))
    minv = 1.0 / dynmat.mass_diagonal(p.diameters[~p.rattler], dynmat.particle_masses(p)[~p.rattler], 2, 3)
    r0, v = l_wave_start(p, k)
    v = v.ravel()
    u = np.zeros_like(v)
    phase = np.exp(-1j * k * r0[:, 0])
    every, steps = int(round(sample / dt)), int(round(t_end / dt))
    t0 = time.perf_counter()
    acc = -minv * (D @ u)
    z = [np.dot(v[0::3], phase)]
    for step in range(1, steps + 1):
        v += 0.5 * dt * acc
        u += dt * v
        acc = -minv * (D @ u)
        v += 0.5 * dt * acc
        if step % every == 0:
            z.append(np.dot(v[0::3], phase))
    return time.perf_counter() - t0, np.array(z)


def l1_error(edges, density, ref_edges, ref_density, bin_width: float) -> float:
    """sum |g - g_ref| w of two unit-area densities on the grids [0, w), [w, 2w), ... (the shorter
    padded with empty bins); raises if the grids differ beyond rounding."""
    m = min(len(edges), len(ref_edges))
    if not np.allclose(edges[:m], ref_edges[:m], rtol=0.0, atol=1e-9 * bin_width):
        raise RuntimeError("the two densities' bins differ")
    size = max(len(density), len(ref_density))
    g, g_ref = (np.pad(np.asarray(x, float), (0, size - len(x))) for x in (density, ref_density))
    return float(np.sum(np.abs(g - g_ref)) * bin_width)
