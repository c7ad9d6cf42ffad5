"""Dynamical-matrix assembly for N = 32768 on 1 and 2 ranks, against a serial scipy.sparse build.

    python -m scripts.benchmarks.bench_assembly     # needs cache/bench_32768.h5 from bench_packing.py
"""

from solver.contact_law import ContactModel
import json
import sys
import time

import numpy as np

from scripts.benchmarks.benchlib import PY, REPO, mpirun, run_json, save

BENCH = {"order": 40}  # make bench: its place (scripts/benchmarks/bench_all.py)
ME = ["-m", __spec__.name]  # this benchmark again, in a fresh process (run_json runs it from the repository root)

REPEATS = 5
FILE = str(REPO / "cache" / "bench_32768.h5")


def case() -> None:
    from solver import petscenv
    from solver.model import dynmat
    from solver.io import hdf5

    PETSc = petscenv.init([])
    comm = PETSc.COMM_WORLD
    (p,) = hdf5.read_packings(FILE)
    times, scipy_times = [], []
    for _ in range(REPEATS):
        comm.tompi4py().Barrier()
        t = time.perf_counter()
        dm = dynmat.assemble(p, ContactModel(1.0), comm)
        times.append(comm.tompi4py().allreduce(time.perf_counter() - t, op=__import__("mpi4py").MPI.MAX))
        size = dm.size
        dm.destroy()
        if comm.size == 1:  # the obvious alternative: the whole matrix with scipy.sparse
            t = time.perf_counter()
            dynmat.local_csr(p, ContactModel(1.0), np.flatnonzero(~p.rattler), (0, int((~p.rattler).sum())))
            scipy_times.append(time.perf_counter() - t)
    if comm.rank == 0:
        print(json.dumps({"ranks": comm.size, "times": times, "scipy": scipy_times, "size": size}))


def main() -> None:
    table = []
    one = run_json([PY, *ME, "--case"])
    two = run_json(mpirun(2) + [PY, *ME, "--case"])
    for r in (one, two):
        t = sorted(r["times"])
        table.append({"ranks": r["ranks"], "DOF": r["size"],
                      "assembly min/median/max [s]": f"{t[0]:.3f} / {t[len(t) // 2]:.3f} / {t[-1]:.3f}",
                      "speedup vs 1 rank (median)": f"{np.median(one['times']) / np.median(r['times']):.2f}"})
    s = sorted(one["scipy"])
    table.append({"ranks": "scipy.sparse COO->CSR only (1 process, no PETSc)", "DOF": one["size"],
                  "assembly min/median/max [s]": f"{s[0]:.3f} / {s[len(s) // 2]:.3f} / {s[-1]:.3f}",
                  "speedup vs 1 rank (median)": f"{np.median(one['times']) / np.median(s):.2f}"})
    save("assembly", "python -m scripts.benchmarks.bench_assembly", table,
         f"rho = 1, phi = 0.9, {REPEATS} repeats. Target (issue 2): under 10 s on 2 ranks. The PETSc "
         "path includes contact detection (cKDTree), the vectorised blocks, CSR build and MatCreate.")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--case"]:
        case()
    else:
        main()
