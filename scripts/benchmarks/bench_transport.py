"""The exact Allen-Feldman diffusivity of every mode (``transport.allen_feldman``) against its
dense evaluation (``references.allen_feldman_dense``): time and agreement, N disks.

    python -m scripts.benchmarks.bench_transport [--ns 256 512 1024 2048] [--eta 0.1] [--block 1000] [--dense-max 2048]
    mpirun -n 2 python -m scripts.benchmarks.bench_transport --ns 8192     # issue 45's target: the library alone
For each N, a FIRE packing at phi = 0.9 (seed 5), D at rho = 0.5 (translations and rotations).
Both routes run in the same process on the same matrix: the library route (position operators
X^a on D's pattern, slicing windows of ~``block`` modes with their vectors in scratch files,
the double sum over pairs of blocks) and the dense one (``eigh`` of the gathered A, X^a dense,
Y^a = V^T X^a V, the definition summed literally).  Columns: seconds of each, their ratio, the
modes, the d error (the largest |d_lib - d_dense| over max d_dense) and the omega error, and the
peak resident memory after each (ru_maxrss only grows: the dense column is the larger of the two).  One process, one BLAS
thread per rank; under mpirun the library runs on every rank (COMM_WORLD) and the dense route,
for N <= ``--dense-max`` only, on the gathered matrix (every rank computes it: time it on one).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads OpenBLAS: one core, as a rank
import numpy as np  # noqa: E402

from scripts.benchmarks.benchlib import peak_rss_gib, save  # noqa: E402

BENCH = {"order": 230}  # make bench: its place (scripts/benchmarks/bench_all.py)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ns", type=int, nargs="+", default=[256, 512, 1024, 2048])
    parser.add_argument("--eta", type=float, default=0.1, help="Lorentzian half-width (1/t0)")
    parser.add_argument("--block", type=int, default=1000, help="modes per slicing window")
    parser.add_argument("--dense-max", type=int, default=2048, help="largest N the dense route runs at")
    args = parser.parse_args()

    from solver import petscenv, references
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.packing import jammed
    from solver.transport import allen_feldman

    PETSc = petscenv.init([])
    from mpi4py import MPI  # after PETSc started MPI

    comm = PETSc.COMM_WORLD

    def say(text: str) -> None:
        if comm.getRank() == 0:
            print(text, flush=True)

    ranks = comm.getSize()
    table = []
    for n in args.ns:
        p = jammed.generate(n, 0.9, np.random.SeedSequence([5, 0]))
        dm = dynmat.assemble(p, ContactModel(0.5), comm)
        with tempfile.TemporaryDirectory(prefix="bench_transport_") as scratch:
            comm.barrier()
            t0 = time.perf_counter()
            omega, d = allen_feldman.allen_feldman(dm, p.positions, p.box, args.eta, comm,
                                                   block=args.block, scratch=scratch)
            library = time.perf_counter() - t0
        rss_library = comm.tompi4py().allreduce(peak_rss_gib(), op=MPI.MAX)
        say(f"library {n}: {library:.1f} s")
        row = {"N": n, "ranks": ranks, "DOF": dm.size, "modes": int(omega.size), "library s": f"{library:.1f}",
               "peak RSS library GiB": f"{rss_library:.2f}"}
        if n <= args.dense_max:
            t0 = time.perf_counter()
            omega_dense, d_dense = references.allen_feldman_dense(dm, p.positions, p.box, args.eta)
            dense = time.perf_counter() - t0
            say(f"dense {n}: {dense:.1f} s")
            same = omega.size == omega_dense.size
            row.update({
                "dense s": f"{dense:.1f}", "dense / library": f"{dense / library:.2f}",
                "d error (largest, of max d)":
                    f"{np.abs(d - d_dense).max() / d_dense.max():.1e}" if same else "count differs",
                "omega error (largest, of omega_max)":
                    f"{np.abs(omega - omega_dense).max() / omega_dense.max():.1e}" if same else "",
                "peak RSS dense GiB": f"{peak_rss_gib():.2f}"})
        table.append(row)
        say(str(row))
        dm.destroy()
    if comm.getRank() != 0:
        return
    notes = (f"2D FIRE packings at phi = 0.9 (seed 5), N = {', '.join(map(str, args.ns))}; D at rho = 0.5; eta = "
             f"{args.eta:g}/t0; the library's windows of ~{args.block} modes with vectors in scratch files; the dense "
             f"route is the definition (docs/diffusivity.md) with LAPACK's eigh, in the same process (rank), one core "
             f"each; column ranks: the library's.")
    save("transport", "python -m scripts.benchmarks.bench_transport " + " ".join(
        ["--ns", *map(str, args.ns), "--eta", f"{args.eta:g}", "--block", str(args.block)]), table, notes,
         merge_by=("N", "ranks"))


if __name__ == "__main__":
    main()
