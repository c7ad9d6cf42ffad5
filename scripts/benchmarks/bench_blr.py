"""Exact vDOS of spheres by counting: MUMPS's block low-rank (BLR) factorisation and orderings
against the exact full-rank factorisation (issue 26: the N = 32768 spheres target).

    python -m scripts.benchmarks.bench_blr [N] [--bin-width W] [--eps E ...] [--orderings O ...] [--factor-ranks F ...]
    (defaults: N = 8192, W = 0.05, E = 1e-8 1e-6 1e-4 1e-2, O = 4 (PORD, MUMPS's choice here),
     F = 1)
Packing: bench_spheres.load_spheres(N) (phi = 0.7, seed [1, 0]), rho = 1, no rolling or twisting
springs; ``counting.solve`` with the given bin width on 2 ranks, one BLAS thread each, every case in
its own fresh mpirun job.  Cases: the exact count (ICNTL 35 = 0) for each ordering (ICNTL 7) and
factor layout, then BLR (ICNTL 35 = 1, CNTL 7 = eps) with the first ordering and layout.
Per case: wall time, factorisations, time per factorisation, MUMPS's full-rank factor entries
(INFOG 29) and entries after compression (INFOG 35), total MB used (INFOG 22) of one factorisation
at the middle shift with the ordering MUMPS used (INFOG 7), counting's count_window (omega^2),
and against the exact counts of the same layout: how many edges count a different number of modes
below them, the largest and the summed difference (modes on the wrong side of an edge).
Writes scripts/benchmarks/records/blr.json after every case.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from scripts.benchmarks.bench_spheres import load_spheres
from scripts.benchmarks.benchlib import PY, mpirun, peak_rss_gib, run_json, save

# make bench (scripts/benchmarks/bench_all.py) runs it at N = 4096: N = 32768 takes hours (scripts/benchmarks/bench_blr.md)
BENCH = {"order": 130, "args": ["4096", "--eps", "1e-2"]}
ME = ["-m", __spec__.name]  # this benchmark again, in a fresh process (run_json runs it from the repository root)


def case(n: int, bin_width: float, factor_ranks: int) -> None:
    """counting.solve under the PETSc options of the command line; rank 0 prints one JSON line."""
    from solver import petscenv

    PETSc = petscenv.init(sys.argv[1:])
    from mpi4py import MPI

    from solver.contact_law import ContactModel
    from solver.model import dynmat, operators
    from solver.spectrum import counting, slicing

    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    dm = dynmat.assemble(load_spheres(n), ContactModel(1.0), comm)
    mpi.Barrier()
    t = time.perf_counter()
    datasets, attrs, _ = counting.solve(dm, bin_width=bin_width, zero_tol=1e-4, factor_ranks=factor_ranks)
    seconds = mpi.allreduce(time.perf_counter() - t, op=MPI.MAX)
    A = operators.scaled_operator(dm)
    counter = slicing.ShiftedInertia(A)  # one more factorisation, all ranks sharing it, for MUMPS's numbers
    try:
        counter.count_below(float(datasets["edges"][datasets["edges"].size // 2] ** 2))
        factor = counter.pc.getFactorMatrix()
        infog = {"infog29_entries": factor.getMumpsInfog(29), "infog35_entries_blr": factor.getMumpsInfog(35),
                 "infog22_mb_total": factor.getMumpsInfog(22), "ordering_used_infog7": factor.getMumpsInfog(7)}
        factor.destroy()
    finally:
        counter.destroy()
        A.destroy()
    rss = mpi.gather(peak_rss_gib(), root=0)
    if mpi.rank == 0:
        print(json.dumps({"seconds": seconds, "factorisations": attrs["factorisations"],
                          "seconds_per_factorisation_per_rank": seconds * comm.size / factor_ranks / attrs["factorisations"],
                          "counts": datasets["counts"].tolist(), "count_window": attrs["count_window"],
                          "counts_exact": bool(attrs["counts_exact"]),
                          **infog, "rss_max": max(rss)}))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("n", type=int, nargs="?", default=8192)
    parser.add_argument("--bin-width", type=float, default=0.05)
    parser.add_argument("--eps", type=float, nargs="*", default=[1e-8, 1e-6, 1e-4, 1e-2])
    parser.add_argument("--orderings", type=int, nargs="+", default=[4])
    parser.add_argument("--factor-ranks", type=int, nargs="+", default=[1])
    parser.add_argument("--case", nargs=2, type=float, help=argparse.SUPPRESS)
    args, _ = parser.parse_known_args()  # the rest: PETSc options, read by a case from sys.argv
    if args.case:
        case(args.n, args.case[0], int(args.case[1]))
        return
    load_spheres(args.n)  # made once, before any timing
    command = "python -m scripts.benchmarks.bench_blr " + " ".join(sys.argv[1:])
    cases = [(0.0, o, f) for f in args.factor_ranks for o in args.orderings]
    cases += [(eps, args.orderings[0], args.factor_ranks[0]) for eps in args.eps]
    table, exact = [], {}
    for eps, ordering, ranks in cases:
        options = ["-inertia_mat_mumps_icntl_7", str(ordering)]
        if eps:
            options += ["-inertia_mat_mumps_icntl_35", "1", "-inertia_mat_mumps_cntl_7", f"{eps:g}"]
        out = run_json(mpirun(2) + [PY, *ME, str(args.n), "--case", str(args.bin_width), str(ranks), *options],
                       timeout=12 * 3600)
        below = np.cumsum(out.pop("counts"))
        if eps == 0.0:
            exact[ranks] = below
        reference = exact.get(ranks, exact.get(args.factor_ranks[0]))
        wrong = np.abs(below - reference[:below.size]) if below.size == reference.size else None
        table.append({"N": args.n, "bin_width": args.bin_width, "ordering_icntl_7": ordering,
                      "factor_ranks": ranks, "blr_cntl_7": eps, **out,
                      "edges_miscounted": None if wrong is None else int((wrong > 0).sum()),
                      "max_miscount": None if wrong is None else int(wrong.max()),
                      "sum_miscount": None if wrong is None else int(wrong.sum())})
        table = [{k: float(f"{v:.4g}") if isinstance(v, float) else v for k, v in row.items()} for row in table]
        save("blr", command, table, merge_by=("N", "bin_width", "ordering_icntl_7", "factor_ranks", "blr_cntl_7"))


if __name__ == "__main__":
    main()
