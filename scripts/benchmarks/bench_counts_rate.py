"""The 3D counts at the machine's rate (issue 60 point 5): MUMPS's factorisation rate in the
counting path against a dense dgemm rate measured in the same run on the same cores.

    python -m scripts.benchmarks.bench_counts_rate [N] [--edges K] [--dgemm-n M]
        [--cases RANKS:GROUP:BLAS[:CNTL1] ...]
    (defaults: N = 4096, K = 8, M = 2000, cases 2:1:1 2:2:1 1:1:2 1:1:1 2:1:1:1e-6 2:1:1:0; RANKS MPI ranks,
    GROUP ranks sharing one factor (counting's factor_ranks: 1 a factor per rank, as
    ``--group-size 1`` runs it; RANKS one factor shared by all), BLAS OpenBLAS threads per rank,
    CNTL1 MUMPS's relative pivot threshold, -inertia_mat_mumps_cntl_1, default 0.01)

Packing: bench_spheres.load_spheres(N) (phi = 0.7, seed [1, 0]), rho = 1.  Each case is a fresh
``mpirun -n RANKS`` with OPENBLAS_NUM_THREADS = BLAS and the PT-Scotch MUMPS (ICNTL 7 = 7, SCOTCH
at these sizes).  ``spectrum.counting.counts_below``, the counting path itself, counts below
G + K shifts (G = RANKS / GROUP factorising groups): G first counts (with the symbolic analysis;
the snake deals one to each group, left out of the rate) at the middle one of the K measured
shifts, omega_max (k + 1/2) / K squared, k < K, whose numeric refactorisations make up the rate,
as they make up a vDOS (``refactor_work``).
Per case: flops per refactorisation (MUMPS RINFOG 3), seconds per refactorisation per group,
their rate (all groups' flops over the slowest rank's seconds, GFlop/s), the dgemm rate of the
same ranks and threads (numpy's matmul of two M x M float64 matrices, the OpenBLAS MUMPS calls,
every rank at once, summed over ranks; measured just before and just after the counts, the mean
kept) and their ratio: the time of the counts over the floor K x flops / dgemm rate.  The rate
RATIO is the reading: measured within a minute in one process on the same cores, it holds when
other jobs load the machine, which inflates both absolute rates alike (the 1-minute load average
before and after is recorded).  The same per CPU second (``refactor_cpu_seconds``; the dgemm's
flops over its processes' CPU time): cpu_over_floor, the ratio that a varying share of loaded
cores does not blur (a thread spinning idle, OpenBLAS's or MPI's, counts as used).  The counts
must be the same in every case (column counts_equal).
Writes scripts/benchmarks/records/counts_rate.json after every case.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

from scripts.benchmarks.bench_spheres import load_spheres
from scripts.benchmarks.benchlib import PY, run_json, save

BENCH = {"order": 132, "args": ["4096"]}
ME = ["-m", __spec__.name]


def dgemm_gflops(mpi, m: int, seconds: float = 4.0) -> tuple[float, float]:
    """(GFlop/s, GFlop per CPU second) of numpy's float64 matmul of two ``m`` x ``m`` matrices,
    run on every rank of ``mpi`` at once for about ``seconds`` (after one untimed product): the
    ranks' rates summed, and all ranks' flops over all their processes' CPU time.  Collective."""
    rng = np.random.default_rng(mpi.rank)
    a, b = rng.standard_normal((m, m)), rng.standard_normal((m, m))
    a @ b
    mpi.Barrier()
    start, cpu, products = time.perf_counter(), time.process_time(), 0
    while time.perf_counter() - start < seconds:
        a @ b
        products += 1
    flops = 2.0 * m**3 * products / 1e9
    rate = flops / (time.perf_counter() - start)
    return mpi.allreduce(rate), mpi.allreduce(flops) / mpi.allreduce(time.process_time() - cpu)


def case(n: int, edges: int, group: int, m: int, cntl1: str) -> None:
    """One case of the module docstring on COMM_WORLD; rank 0 prints one JSON line."""
    from solver import petscenv

    PETSc = petscenv.init(["-inertia_mat_mumps_cntl_1", cntl1] if cntl1 else [])
    from mpi4py import MPI

    from solver.contact_law import ContactModel
    from solver.model import dynmat, operators
    from solver.spectrum import counting

    mpi = PETSc.COMM_WORLD.tompi4py()
    dm = dynmat.assemble(load_spheres(n), ContactModel(1.0), PETSc.COMM_WORLD)
    A = operators.scaled_operator(dm)
    try:
        omega_max = operators.largest_omega(dm)
        measured = (omega_max * (np.arange(edges) + 0.5) / edges) ** 2
        shifts = np.concatenate((np.full(mpi.size // group, measured[edges // 2]), measured))  # one first count per group
        load_before = os.getloadavg()[0]
        dgemm_before = dgemm_gflops(mpi, m)
        start = time.perf_counter()
        below, settings = counting.counts_below(A, shifts, mpi, factor_ranks=group)
        seconds = mpi.allreduce(time.perf_counter() - start, op=MPI.MAX)
        dgemm_after = dgemm_gflops(mpi, m)
    finally:
        A.destroy()
        dm.destroy()
    flops, refactor_s = settings["refactor_flops"], settings["refactor_seconds"]
    rate, cpu_rate = flops / refactor_s / 1e9, flops / settings["refactor_cpu_seconds"] / 1e9
    dgemm, dgemm_cpu = 0.5 * (dgemm_before[0] + dgemm_after[0]), 0.5 * (dgemm_before[1] + dgemm_after[1])
    row = {"dof": dm.size, "omega_max": omega_max, "refactorisations": settings["refactorisations"],
           "gflop_per_refactorisation": flops / settings["refactorisations"] / 1e9,
           "s_per_refactorisation_per_group": refactor_s / (settings["refactorisations"] * group / mpi.size),
           "mumps_gflops": rate, "dgemm_gflops": dgemm, "time_over_floor": dgemm / rate,
           "mumps_gflop_per_cpu_s": cpu_rate, "dgemm_gflop_per_cpu_s": dgemm_cpu,
           "cpu_over_floor": dgemm_cpu / cpu_rate,
           "dgemm_before": dgemm_before[0], "dgemm_after": dgemm_after[0], "counts_s": seconds,
           "ordering_infog7": settings["mumps_ordering_infog7"], "load_before": load_before,
           "load_after": os.getloadavg()[0], "counts": [int(c) for c in below[mpi.size // group:]]}
    if mpi.rank == 0:
        print(json.dumps(row))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("n", type=int, nargs="?", default=4096)
    parser.add_argument("--edges", type=int, default=8)
    parser.add_argument("--dgemm-n", type=int, default=2000)
    parser.add_argument("--cases", nargs="+", default=["2:1:1", "2:2:1", "1:1:2", "1:1:1", "2:1:1:1e-6", "2:1:1:0"])
    parser.add_argument("--case", nargs=5, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case:
        n, edges, group, m, cntl1 = args.case
        case(int(n), int(edges), int(group), int(m), cntl1)
        return
    specs = [spec.split(":") for spec in args.cases]
    for spec, text in zip(specs, args.cases):
        if len(spec) not in (3, 4) or not all(s.isdigit() for s in spec[:3]) or int(spec[0]) % int(spec[1]):
            parser.error(f"--cases {text}: RANKS:GROUP:BLAS[:CNTL1], GROUP a divisor of RANKS")
        if (args.edges + int(spec[0]) // int(spec[1])) % (int(spec[0]) // int(spec[1])):
            parser.error(f"--edges {args.edges}: a multiple of the groups of case {text}, so that every group "
                         "refactorises as often")
    command = "python -m scripts.benchmarks.bench_counts_rate " + " ".join(sys.argv[1:])
    load_spheres(args.n)  # made once, before any timing
    table, first = [], None
    for (ranks, group, blas, *cntl1), text in zip(specs, args.cases):
        env = {**os.environ, "OPENBLAS_NUM_THREADS": blas, "OMP_NUM_THREADS": blas}
        cmd = ["mpirun", "-n", ranks, *(["--allow-run-as-root"] if os.geteuid() == 0 else []),
               "-x", "OPENBLAS_NUM_THREADS", "-x", "OMP_NUM_THREADS", PY, *ME,
               "--case", str(args.n), str(args.edges), group, str(args.dgemm_n), cntl1[0] if cntl1 else ""]
        out = run_json(cmd, timeout=4 * 3600, env=env)
        counts = out.pop("counts")
        first = counts if first is None else first
        table.append({"N": args.n, "edges": args.edges, "case": text, "ranks": int(ranks), "factor_ranks": int(group),
                      "blas_threads": int(blas), "cntl1": float(cntl1[0]) if cntl1 else 0.01,
                      **{k: float(f"{v:.4g}") if isinstance(v, float) else v for k, v in out.items()},
                      "counts_equal": counts == first})
        save("counts_rate", command, table, merge_by=("N", "edges", "case"))


if __name__ == "__main__":
    main()
