"""Spectral standing waves one at a time against side by side (issue 26: the 10^6-disk dispersion
target; waves.spectral.spectral_all).

    python -m scripts.benchmarks.bench_lanczos_batch [N] [--batches B ...] [--before PATH]
    (defaults: N = 131072, B = 1 4 12 24, PATH = /work/bench_after: a worktree of the code before
     spectral_all, commit bbc466c, whose spectral() steps one wave with MatMult)
One scene unit's waves: mode L, both runs (k along x and along y), n = 1..12 (k = 2 pi n / L),
t_end = 200, samples every 1 t0, tol 1e-8, rho = 1, on benchlib.load_packing(N), 2 ranks, one BLAS
thread each, every case in its own fresh mpirun job (omega_max computed once per case, not timed).
  before     the previous code (PYTHONPATH=PATH): ``spectral`` per wave, MatMult per step;
  batch B    ``spectral_all`` on chunks of B waves: one MatMatMult of A with (nloc, B) per step.
Per case: wall time, time per wave, Lanczos steps, peak RSS per rank, and the largest difference of
z from the previous code's, relative to max |z| (both reach tol = 1e-8, so ~1e-8 is agreement).
Writes scripts/benchmarks/records/lanczos_batch.json.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

from scripts.benchmarks.benchlib import PY, REPO, load_packing, mpirun, peak_rss_gib, run_json, save

BENCH = {"order": 90}  # make bench: its place (scripts/benchmarks/bench_all.py)
ME = ["-m", __spec__.name]  # this benchmark again, in a fresh process (run_json runs it from the repository root)
T_END, K_COUNT, TOL = 200.0, 12, 1e-8
Z_FILE = REPO / "results" / "bench" / "lanczos_batch_z_{}.npy"


def case(n: int, batch: int, tag: str) -> None:
    """Every wave on COMM_WORLD in chunks of ``batch`` (0: the previous code's loop); rank 0
    saves z and prints one JSON line."""
    from solver import petscenv

    PETSc = petscenv.init([])
    from mpi4py import MPI

    from solver.contact_law import ContactModel
    from solver.io import hdf5
    from solver.model import dynmat, operators
    from solver.waves import spectral

    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    p = hdf5.read_packings(str(REPO / "cache" / f"bench_{n}.h5"))[0]
    dm = dynmat.assemble(p, ContactModel(1.0), comm)
    omega_max = operators.largest_omega(dm)
    waves = [("L", run, 2 * np.pi * k / float(p.box[0])) for run in (0, 1) for k in range(1, K_COUNT + 1)]
    times = np.arange(0.0, T_END + 0.5, 1.0)
    mpi.Barrier()
    t = time.perf_counter()
    if batch == 0:
        series = [spectral.spectral(dm, p.positions, *wave, amplitude=1e-6, times=times, tol=TOL, omega_max=omega_max)
                  for wave in waves]
    else:
        series = [s for i in range(0, len(waves), batch)
                  for s in spectral.spectral_all(dm, p.positions, waves[i:i + batch], amplitude=1e-6, times=times,
                                                 tol=TOL, omega_max=omega_max)]
    seconds = mpi.allreduce(time.perf_counter() - t, op=MPI.MAX)
    rss = mpi.gather(peak_rss_gib(), root=0)
    if mpi.rank == 0:
        np.save(str(Z_FILE).format(tag), np.array([s.z for s in series]))
        print(json.dumps({"seconds": seconds, "waves": len(waves), "max_steps": max(s.steps for s in series),
                          "max_estimate": max(s.error_estimate for s in series), "rss_max": max(rss)}))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("n", type=int, nargs="?", default=131072)
    parser.add_argument("--batches", type=int, nargs="+", default=[1, 4, 12, 24])
    parser.add_argument("--before", default="/work/bench_after")
    parser.add_argument("--case", nargs=2, type=int, help=argparse.SUPPRESS)
    parser.add_argument("--tag", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case:
        case(args.n, args.case[1], args.tag)
        return
    load_packing(args.n)
    table, reference = [], None
    for batch in [0] + args.batches:
        tag = "before" if batch == 0 else f"b{batch}"
        env = ["-x", f"PYTHONPATH={args.before}"] if batch == 0 else []
        out = run_json(mpirun(2) + env + [PY, *ME, str(args.n), "--case", "0", str(batch), "--tag", tag], timeout=6 * 3600)
        z = np.load(str(Z_FILE).format(tag))
        if reference is None:
            reference = z
        difference = float(np.max(np.abs(z - reference).max(axis=1) / np.abs(reference).max(axis=1)))
        table.append({"N": args.n, "method": "before: spectral per wave (MatMult)" if batch == 0
                      else f"spectral_all, chunks of {batch}", "batch": batch, **out,
                      "seconds_per_wave": out["seconds"] / out["waves"], "z_difference": difference,
                      "speedup": None})
        for row in table:
            row["speedup"] = table[0]["seconds"] / row["seconds"]
        table = [{k: float(f"{v:.4g}") if isinstance(v, float) else v for k, v in row.items()} for row in table]
        save("lanczos_batch", "python -m scripts.benchmarks.bench_lanczos_batch " + " ".join(sys.argv[1:]), table,
             notes="", merge_by=("N", "batch"))
        print(json.dumps(table[-1]), flush=True)
    for batch in [0] + args.batches:
        os.remove(str(Z_FILE).format("before" if batch == 0 else f"b{batch}"))


if __name__ == "__main__":
    main()
