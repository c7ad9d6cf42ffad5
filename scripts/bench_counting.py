"""Exact vDOS by counting (Sylvester inertias at the bin edges) against the obvious alternatives.

    python scripts/bench_counting.py [N ...]        (default 2048 8192 32768)
Same run, same packing (cache/bench_<N>.h5, phi = 0.9), rho = 1, bins 0.05/t0:
  counting   ``spectrum.counting.solve`` (one reused factorisation per rank, edges over ranks), 1 and 2 ranks;
  fresh      the previous method: ``slicing.count_below`` at every edge (symbolic analysis every time), 1 rank;
  eigh       LAPACK ``scipy.linalg.eigh`` values only on the dense A, 2 BLAS threads (N = 2048 only),
             whose histogram must equal the counts exactly.
Wall time includes the Lanczos omega_max; peak RSS is the largest rank's.
"""

import json
import sys
import time

import numpy as np
from benchlib import PY, REPO, mpirun, peak_rss_gib, run_json, save


def case(n: int, method: str) -> None:
    from benchlib import load_packing

    from solver import petscenv

    PETSc = petscenv.init([])
    from mpi4py import MPI

    from solver.model import dynmat, operators
    from solver.spectrum import counting, slicing

    mpi = PETSc.COMM_WORLD.tompi4py()

    p = load_packing(n)
    dm = dynmat.assemble(p, 1.0, PETSc.COMM_WORLD)
    mpi.Barrier()
    t = time.perf_counter()
    if method == "counting":
        datasets, attrs, _ = counting.solve(dm, bin_width=0.05, zero_tol=1e-4)
        counts, factorisations = datasets["counts"], attrs["factorisations"]
    else:  # fresh factorisation at every edge, same edges
        omega_max = operators.largest_omega(dm)
        A = operators.scaled_operator(dm)
        edges = 0.05 * np.arange(int(np.floor(omega_max * (1 + 1e-6) / 0.05)) + 2)
        below = [slicing.count_below(A, x) for x in np.concatenate(([1e-8], edges[1:] ** 2))]
        A.destroy()
        counts, factorisations = np.diff(below), len(below)
    seconds = mpi.allreduce(time.perf_counter() - t, op=MPI.MAX)
    rss = mpi.allreduce(peak_rss_gib(), op=MPI.MAX)
    dm.destroy()
    if mpi.rank == 0:
        print(json.dumps({"seconds": seconds, "rss": rss, "factorisations": int(factorisations),
                          "counts": [int(c) for c in counts]}))


def eigh_case(n: int) -> None:
    import scipy.linalg
    from benchlib import load_packing

    from solver import petscenv

    PETSc = petscenv.init([])
    from solver.model import dynmat, operators

    p = load_packing(n)
    dm = dynmat.assemble(p, 1.0, PETSc.COMM_WORLD)
    A = operators.scaled_operator(dm)
    dense = dynmat.gather_csr(A).toarray()
    A.destroy()
    dm.destroy()
    t = time.perf_counter()
    lam = scipy.linalg.eigh(dense, eigvals_only=True)
    seconds = time.perf_counter() - t
    omega = np.sqrt(lam[lam > 1e-8])
    edges = 0.05 * np.arange(int(np.floor(omega.max() * (1 + 1e-6) / 0.05)) + 2)
    counts, _ = np.histogram(omega, edges)
    print(json.dumps({"seconds": seconds, "rss": peak_rss_gib(), "counts": [int(c) for c in counts]}))


def main() -> None:
    sizes = [int(a) for a in sys.argv[1:]] or [2048, 8192, 32768]
    table = []
    me = str(REPO / "scripts" / "bench_counting.py")
    for n in sizes:
        runs = {"counting, 1 rank": run_json(mpirun(1) + [PY, me, "--case", str(n), "counting"]),
                "counting, 2 ranks": run_json(mpirun(2) + [PY, me, "--case", str(n), "counting"])}
        if n <= 8192:
            runs["fresh factorisation per edge, 1 rank"] = run_json(mpirun(1) + [PY, me, "--case", str(n), "fresh"])
        if n <= 2048:
            cmd = ["mpirun", "-n", "1", "-x", "OPENBLAS_NUM_THREADS=2", "-x", "OMP_NUM_THREADS=2",
                   "--allow-run-as-root", PY, me, "--eigh", str(n)]
            runs["LAPACK eigh (values), 2 threads"] = run_json(cmd)
        reference = runs["counting, 2 ranks"]
        for name, r in runs.items():
            m = min(len(r["counts"]), len(reference["counts"]))
            same = (r["counts"][:m] == reference["counts"][:m] and not any(r["counts"][m:])
                    and not any(reference["counts"][m:]))
            table.append({"N": n, "DOF": 3 * n, "method": name, "wall s": f"{r['seconds']:.2f}",
                          "inertias": r.get("factorisations", ""),
                          "s per inertia": (f"{r['seconds'] / r['factorisations']:.3f}"
                                            if r.get("factorisations") else ""),
                          "peak RSS GiB": f"{r['rss']:.2f}",
                          "vs counting (2 ranks)": f"{r['seconds'] / reference['seconds']:.2f}x",
                          "histogram identical": "yes" if same else "NO"})
            print(table[-1], flush=True)
    save("counting", "python scripts/bench_counting.py " + " ".join(map(str, sizes)), table,
         "rho = 1, phi = 0.9, bins 0.05/t0; 'vs counting' is this row's time over the 2-rank counting time; "
         "'histogram identical' compares the bin counts with the 2-rank counting run.")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--case"]:
        case(int(sys.argv[2]), sys.argv[3])
    elif sys.argv[1:2] == ["--eigh"]:
        eigh_case(int(sys.argv[2]))
    else:
        main()
