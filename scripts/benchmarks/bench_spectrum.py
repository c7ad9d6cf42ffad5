"""Spectrum benchmarks (issue 3): SLEPc slicing on 2 ranks vs scipy.linalg.eigh, same matrix.

    python -m scripts.benchmarks.bench_spectrum [--sizes 2048,8192] [--window-n 32768]
Cases run one after another, each in fresh processes: SLEPc under mpirun -n 2 (peak RSS summed
over ranks), eigh in one process with 2 BLAS threads (both cores, the fair comparison).
"""

from solver.contact_law import ContactModel
import argparse
import json
import os
import sys
import time

import numpy as np

from scripts.benchmarks.benchlib import (PY, RECORDS, REPO, SCRATCH, NpzCheckpoint, file_sha, mpirun, peak_rss_gib, run_json,
                                 save, save_exact_spectrum)

BENCH = {"order": 50}  # make bench: its place (scripts/benchmarks/bench_all.py)
ME = ["-m", __spec__.name]  # this benchmark again, in a fresh process (run_json runs it from the repository root)

REPEATS_SMALL = 3
COMMAND = ["python -m scripts.benchmarks.bench_spectrum " + " ".join(sys.argv[1:])]


def packing_file(n: int) -> str:
    path = REPO / "cache" / f"bench_{n}.h5"
    if not path.exists():
        from solver.io import hdf5
        from solver.packing import jammed

        path.parent.mkdir(exist_ok=True)
        hdf5.save_packings(str(path), [jammed.generate(n, 0.9, np.random.SeedSequence([1, 0]))])
    return str(path)


def slepc_case(path: str, vectors: bool, window: str) -> None:
    from solver import petscenv
    from solver.model import dynmat
    from solver.io import hdf5
    from solver.spectrum import slicing

    PETSc = petscenv.init([])
    comm = PETSc.COMM_WORLD
    (p,) = hdf5.read_packings(path)
    dm = dynmat.assemble(p, ContactModel(1.0), comm)
    win = None if window == "full" else tuple(map(float, window.split(",")))
    mpi = comm.tompi4py()
    # windows of a killed run are resumed from here (a full N = 32768 spectrum outlasts a session)
    tag = f"{file_sha(path)[:12]}_{window}_{int(vectors)}".replace(",", "_")
    checkpoint = NpzCheckpoint(REPO / "cache" / f"bench_spectrum_windows_{tag}", comm.rank)
    mpi.Barrier()
    t = checkpoint.last = time.perf_counter()
    log = SCRATCH / "spectrum_progress.log"  # follow a long run with tail -f
    SCRATCH.mkdir(parents=True, exist_ok=True)

    def progress(done, total, modes):
        if comm.rank == 0:
            with open(log, "a", encoding="utf-8") as f:
                f.write(f"DOF={dm.size} {window}: window {done}/{total}, {modes} modes, "
                        f"{time.perf_counter() - t:.0f} s, rank-0 peak RSS {peak_rss_gib():.2f} GiB\n")

    result = slicing.solve(dm, window=win, vectors=vectors, progress=progress, checkpoint=checkpoint)
    seconds = mpi.allreduce(time.perf_counter() - t, op=__import__("mpi4py").MPI.MAX) + checkpoint.credited
    mpi.Barrier()
    checkpoint.clear()
    rss = mpi.allreduce(peak_rss_gib())
    if comm.rank == 0:
        if window == "full" and vectors:  # the exact reference bench_kpm.py compares against
            save_exact_spectrum(path, result, seconds)
        print(json.dumps({"seconds": seconds, "modes": int(result.omega.size), "rss": rss,
                          "residual": result.max_residual, "windows": result.windows,
                          "omega_max": float(result.omega.max()), "dof": dm.size,
                          "resumed_windows": checkpoint.resumed}))


def eigh_case(path: str, vectors: bool) -> None:
    import scipy.linalg as sl

    from solver import petscenv
    from solver.model import dynmat
    from solver.io import hdf5
    from solver.model import operators

    PETSc = petscenv.init([])
    (p,) = hdf5.read_packings(path)
    dm = dynmat.assemble(p, ContactModel(1.0), PETSc.COMM_SELF)
    A = operators.scaled_operator(dm)
    dense = dynmat.gather_csr(A).toarray()
    t = time.perf_counter()
    out = sl.eigh(dense, eigvals_only=not vectors, driver="evr" if vectors else "evd")
    seconds = time.perf_counter() - t
    lam = out[0] if vectors else out
    print(json.dumps({"seconds": seconds, "rss": peak_rss_gib(), "omega_max": float(np.sqrt(lam.max()))}))


def omega_max_case(path: str) -> None:
    """The top of the band, by the cheap largest-eigenvalue solve (slicing [4.5, 100] took 7 min)."""
    from solver import petscenv
    from solver.model import dynmat
    from solver.io import hdf5
    from solver.model import operators

    PETSc = petscenv.init([])
    (p,) = hdf5.read_packings(path)
    omega_max = operators.largest_omega(dynmat.assemble(p, ContactModel(1.0), PETSc.COMM_WORLD))
    if PETSc.COMM_WORLD.rank == 0:
        print(json.dumps({"omega_max": omega_max}))


def fmt(values):
    v = sorted(values)
    return f"{v[0]:.1f} / {v[len(v) // 2]:.1f} / {v[-1]:.1f}"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--sizes", default="2048,8192,32768")
    parser.add_argument("--window-n", type=int, default=32768)
    parser.add_argument("--merge", action="store_true",
                        help="keep the rows of the last record that this run does not re-measure")
    args = parser.parse_args()
    table = []
    if args.merge and (RECORDS / "spectrum.json").exists():
        last = json.loads((RECORDS / "spectrum.json").read_text())
        COMMAND[0] = f"{last['command']} (rows of {last['date']}) + {COMMAND[0]}"
        table = last["table"]
    env_eigh = {**os.environ, "OPENBLAS_NUM_THREADS": "2", "OMP_NUM_THREADS": "2"}
    if args.window_n:
        path = packing_file(args.window_n)
        top = run_json(mpirun(2) + [PY, *ME, "--omega-max", path])["omega_max"]
        lo = 0.9 * top  # the top 10 % of the band [0, omega_max]
        r = run_json(mpirun(2) + [PY, *ME, "--slepc", path, "1", f"{lo},{top * 1.001}"])
        table = [t for t in table if not (t["N"] == args.window_n and t["what"].startswith("window"))]
        table.append({"N": args.window_n, "DOF": r["dof"], "what": f"window [{lo:.3f}, {top:.3f}] + K/Q",
                      "SLEPc 2 ranks min/med/max [s]": fmt([r["seconds"]]), "modes": r["modes"],
                      "SLEPc peak RSS [GiB]": f"{r['rss']:.2f}", "max rel. residual": f"{r['residual']:.1e}",
                      "windows": r["windows"]})
        save_table(table)
    for n in map(int, args.sizes.split(",")):
        path = packing_file(n)
        for vectors in (False, True) if n <= 2048 else (True,):
            repeats = REPEATS_SMALL if n <= 2048 else 1
            slepc = [run_json(mpirun(2) + [PY, *ME, "--slepc", path, str(int(vectors)), "full"],
                              timeout=6 * 3600) for _ in range(repeats)]
            what = "omega + K/Q" if vectors else "omega only"
            if slepc[0]["resumed_windows"]:  # time = this run + the windows kept by a killed run
                what += f" (resumed: {slepc[0]['resumed_windows'] - 1} of {slepc[0]['windows']} windows)"
            row = {"N": n, "DOF": slepc[0]["dof"], "what": what,
                   "SLEPc 2 ranks min/med/max [s]": fmt([r["seconds"] for r in slepc]),
                   "SLEPc peak RSS [GiB]": f"{max(r['rss'] for r in slepc):.2f}",
                   "max rel. residual": f"{max(r['residual'] for r in slepc):.1e}",
                   "windows": slepc[0]["windows"]}
            if n <= 2048:  # eigh grows as n^3: 15-30 min at N = 8192, hours beyond
                os.environ.update(env_eigh)
                eigh = [run_json([PY, *ME, "--eigh", path, str(int(vectors))]) for _ in range(repeats)]
                for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
                    os.environ[var] = "1"
                ratio = np.median([r["seconds"] for r in eigh]) / np.median([r["seconds"] for r in slepc])
                row.update({"eigh (2 threads) min/med/max [s]": fmt([r["seconds"] for r in eigh]),
                            "eigh peak RSS [GiB]": f"{max(r['rss'] for r in eigh):.2f}",
                            "eigh / SLEPc time (median)": f"{ratio:.2f}"})
            table = [t for t in table if (t["N"], t["what"][:11]) != (n, what[:11])] + [row]
            save_table(table)  # each row kept as soon as it is measured: the N = 32768 run takes hours


def save_table(table: list[dict]) -> None:
    save("spectrum", COMMAND[0], table,
         "phi = 0.9, rho = 1. SLEPc: Krylov-Schur spectrum slicing, MUMPS Cholesky, eps_tol 1e-12, "
         "<= 2000 eigenpairs per window, 2 ranks (one sub-interval each). eigh: LAPACK evd "
         "(values) / evr (vectors) on the dense M^-1/2 D M^-1/2 with 2 OpenBLAS threads. "
         "Targets (issue 3): faster than eigh at N = 2048; N = 32768 full spectrum with K/Q "
         "under 30 min and 16 GiB.")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--slepc"]:
        slepc_case(sys.argv[2], sys.argv[3] == "1", sys.argv[4])
    elif sys.argv[1:2] == ["--eigh"]:
        eigh_case(sys.argv[2], sys.argv[3] == "1")
    elif sys.argv[1:2] == ["--omega-max"]:
        omega_max_case(sys.argv[2])
    else:
        main()
