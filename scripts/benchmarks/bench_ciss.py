"""Block solves for the full spectrum (issue 26): one window of the N = 32768-disk spectrum by
SLEPc's contour-integral solver CISS against the Krylov-Schur slicing that ``spectrum.solve``
uses, on the same matrix, window and ranks.

    python -m scripts.benchmarks.bench_ciss [N] [--modes W] [--at F] [--ip P ...] [--ms M]

Why: a Krylov-Schur window costs about one pair of triangular solves per converged mode, each
reading the whole MUMPS factor (memory-bandwidth bound: BENCHMARKS "spectrum"); CISS factorises
A - z_j at its P quadrature points of the interval (real Chebyshev points in real arithmetic) and
solves each for a block of B right-hand sides at once (one read of the factor per block), then
extracts the window's eigenpairs from the B x M moments by a Rayleigh-Ritz step.  The window
holds W modes starting at the F-th fraction of the band, cut by Sylvester inertias.  Both
solvers' eigenvalues are Rayleigh quotients of their vectors; the table gives the time, the
modes found against the inertia count, the largest relative residual ||A x - lam x|| / |lam|, and
the largest difference from Krylov-Schur's eigenvalues on one rank.  Krylov-Schur runs on 1 and 2
ranks (one sub-interval per rank), CISS on one rank, with B = 3 W / M: a subspace of 1.5 W missed a
third of the modes (N = 2048, W = 200: 140 found).  Not on 2 ranks: there SLEPc 3.18's CISS in real
arithmetic returned 0-3 of the 200 modes (N = 2048, with 1 or 2 partitions, Cholesky or LU factors,
P = 16, B = 38 or 75) where one rank found all 200.  Each case is one fresh mpirun job.

Writes scripts/benchmarks/records/ciss.json (merged by N, W, F, method, ranks, P, B, M).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from scripts.benchmarks.benchlib import PY, SCRATCH, load_packing, mpirun, peak_rss_gib, run_json, save

# make bench (scripts/benchmarks/bench_all.py): one window, CISS against Krylov-Schur
BENCH = {"order": 60, "args": ["32768", "--modes", "500", "--ip", "16"]}
ME = ["-m", __spec__.name]  # this benchmark again, in a fresh process (run_json runs it from the repository root)
GOOD = 1e-8  # a converged pair counts as found below this relative residual (Krylov-Schur's: ~1e-12)
CISS_TOL = 1e-9  # asked 1e-12, CISS stalls near 2e-10 and refines 5 times (factorisations and all)


def _window(A, modes: int, at: float) -> tuple[float, float, int]:
    """(lo, hi, count): an interval of the scaled operator holding ~``modes`` eigenvalues, the
    first of them near the ``at`` fraction of the band, cut by inertias.  Collective."""
    from petsc4py import PETSc

    from solver.spectrum import slicing

    n = A.getSize()[0]
    top = A.norm(PETSc.NormType.INFINITY) * (1 + 1e-9)  # Gershgorin: above lambda_max
    known = {1e-8: slicing.count_below(A, 1e-8), top: slicing.count_below(A, top)}
    first = max(known[1e-8] + 1, int(at * n))
    lo, hi = slicing.place_cuts(A, known, np.array([first, first + modes], dtype=float), 1.0, top)
    return lo, hi, slicing.count_below(A, hi) - slicing.count_below(A, lo)


def _quotients(eps, A) -> tuple[np.ndarray, np.ndarray]:
    """Rayleigh quotients of the converged vectors (ascending) and their relative residuals
    ||A x - lam x|| / (|lam| ||x||)."""
    vec, image = A.createVecRight(), A.createVecLeft()
    lam, residual = [], []
    for i in range(eps.getConverged()):
        eps.getEigenpair(i, vec)
        A.mult(vec, image)
        q = image.dot(vec) / vec.dot(vec)
        image.axpy(-q, vec)
        residual.append(image.norm() / (abs(q) * vec.norm()))
        lam.append(q)
    order = np.argsort(lam)
    return np.array(lam)[order], np.array(residual)[order]


def case(n: int, modes: int, at: float, method: str, ip: int, bs: int, ms: int) -> None:
    """One job: the window by ``method`` (krylovschur or ciss); rank 0 prints a JSON line."""
    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.model.operators import scaled_operator
    from solver.spectrum import slicing

    PETSc = petscenv.init([])
    from mpi4py import MPI
    from slepc4py import SLEPc

    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    p = load_packing(n)
    dm = dynmat.assemble(p, ContactModel(1.0), comm)
    A = scaled_operator(dm)
    lo, hi, count = _window(A, modes, at)
    mpi.Barrier()
    t = time.perf_counter()
    if method == "krylovschur":  # what spectrum.solve does for one window
        known = {lo: slicing.count_below(A, lo), hi: slicing.count_below(A, hi)}
        edges = slicing.split_window(A, known, lo, hi, comm.size)
        eps = SLEPc.EPS().create(comm)
        slicing.configure_window(eps, A, edges, 1e-12)
    else:
        eps = SLEPc.EPS().create(comm)
        eps.setOperators(A)
        eps.setProblemType(SLEPc.EPS.ProblemType.HEP)
        eps.setType(SLEPc.EPS.Type.CISS)
        eps.getRG().setType(SLEPc.RG.Type.INTERVAL)
        eps.getRG().setIntervalEndpoints(lo, hi, 0.0, 0.0)
        eps.setTolerances(tol=CISS_TOL)
        eps.setCISSSizes(ip=ip, bs=bs, ms=ms, npart=comm.size, bsmax=bs)
        eps.setOptionsPrefix("ciss_")
        opts = PETSc.Options()
        for key, value in (("eps_ciss_ksp_type", "preonly"), ("eps_ciss_pc_type", "cholesky"),
                           ("eps_ciss_pc_factor_mat_solver_type", "mumps")):
            opts.setValue("ciss_" + key, value)  # a benchmark job's own options database
        eps.setFromOptions()
    eps.solve()
    seconds = mpi.allreduce(time.perf_counter() - t, op=MPI.MAX)
    lam, residual = _quotients(eps, A)
    good = (lam > lo) & (lam <= hi) & (residual < GOOD)
    inside = lam[good]
    row = {"seconds": seconds, "found": int(inside.size), "count": int(count), "converged": int(lam.size),
           "residual": float(residual[good].max(initial=0.0)), "lo": lo, "hi": hi, "dof": A.getSize()[0],
           "rss_max": mpi.allreduce(peak_rss_gib(), op=MPI.MAX)}
    if comm.rank == 0:
        np.save(SCRATCH / f"ciss_{n}_{modes}_{at}_{method}_{comm.size}.npy", inside)
        print(json.dumps(row))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("n", type=int, nargs="?", default=32768)
    parser.add_argument("--modes", type=int, default=500, help="modes in the window")
    parser.add_argument("--at", type=float, default=0.5, help="where the window starts, as a fraction of the DOF")
    parser.add_argument("--ip", type=int, nargs="+", default=[32], help="CISS quadrature points")
    parser.add_argument("--ms", type=int, default=8, help="CISS moments")
    parser.add_argument("--case", nargs=5, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case:
        method, ip, bs, ms, at = args.case
        case(args.n, args.modes, float(at), method, int(ip), int(bs), int(ms))
        return
    SCRATCH.mkdir(parents=True, exist_ok=True)
    load_packing(args.n)
    bs = -(-3 * args.modes // args.ms)  # a subspace of 3x the window's modes (1.5x missed a third)
    table = []
    cases = [("krylovschur", 0, 1), ("krylovschur", 0, 2)] + [("ciss", ip, 1) for ip in args.ip]
    for method, ip, ranks in cases:
        out = run_json(mpirun(ranks) + [PY, *ME, str(args.n), "--modes", str(args.modes), "--case", method, str(ip),
                                        str(bs), str(args.ms), str(args.at)], timeout=4 * 3600)
        row = {"N": args.n, "modes": args.modes, "at": args.at, "method": method, "ranks": ranks,
               **({"ip": ip, "bs": bs, "ms": args.ms} if method == "ciss" else {}), **out}
        reference = np.load(SCRATCH / f"ciss_{args.n}_{args.modes}_{args.at}_krylovschur_1.npy")
        mine = np.load(SCRATCH / f"ciss_{args.n}_{args.modes}_{args.at}_{method}_{ranks}.npy")
        row["max_rel_diff_vs_ks"] = (float(np.max(np.abs(mine - reference) / reference))
                                     if mine.size == reference.size else None)
        table.append({k: float(f"{v:.4g}") if isinstance(v, float) else v for k, v in row.items()})
        save("ciss", "python -m scripts.benchmarks.bench_ciss " + " ".join(sys.argv[1:]), table,
             merge_by=("N", "modes", "at", "method", "ranks", "ip", "bs", "ms"))


if __name__ == "__main__":
    main()
