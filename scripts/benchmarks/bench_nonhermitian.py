"""Windows against dense for every eigenvalue of a stressed dynamical matrix
(``spectrum.method: nonhermitian``, ``spectrum.solver: windows`` and ``dense``).

    python -m scripts.benchmarks.bench_nonhermitian [--ns 512 1024 2048] [--mu 1] [--pressure 0.01] [--nev 200]
For each N, ``jammed.generate(..., engine="lammps", friction=mu, pressure=p)`` makes a 2D
frictional packing held at pressure p (as configs/frictional.yaml does); D at rho = 2/7 with its
stored forces.  Both solvers run in the same process on the same matrix: time, the windows'
count, largest backward residual and trace-moment errors, and the largest difference of the
eigenvalues (Re sorted, |Im| sorted, relative to max |lambda|) and of the stable frequencies.
One process (dense LAPACK with one BLAS thread, as a scene's rank 0 runs it).
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads OpenBLAS: one core each, as a rank
import numpy as np  # noqa: E402

from scripts.benchmarks.benchlib import save  # noqa: E402

BENCH = {"order": 190}  # make bench: its place (scripts/benchmarks/bench_all.py)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ns", type=int, nargs="+", default=[512, 1024, 2048])
    parser.add_argument("--mu", type=float, default=1.0)
    parser.add_argument("--pressure", type=float, default=0.01)
    parser.add_argument("--nev", type=int, default=None, help="-nonhermitian_eps_nev (default: the code's)")
    args = parser.parse_args()

    from mpi4py import MPI

    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.packing import jammed
    from solver.spectrum import nonhermitian

    PETSc = petscenv.init([] if args.nev is None else ["-nonhermitian_eps_nev", str(args.nev)])
    table = []
    for n in args.ns:
        p = jammed.generate(n, 0.82, np.random.SeedSequence([5, 0]), force_tol=1e-10, engine="lammps",
                            comm=MPI.COMM_SELF, friction=args.mu, pressure=args.pressure)
        dm = dynmat.assemble(p, ContactModel(2.0 / 7.0), PETSc.COMM_SELF)
        found, seconds = {}, {}
        for solver in ("windows", "dense"):
            t0 = time.perf_counter()
            found[solver] = nonhermitian.solve(dm, zero_tol=1e-4, solver=solver)
            seconds[solver] = time.perf_counter() - t0
            print(solver, n, f"{seconds[solver]:.1f} s", flush=True)
        w, d = found["windows"], found["dense"]
        scale = np.abs(d.omega2).max()
        same = w.omega2.size == d.omega2.size and w.omega.size == d.omega.size
        checks = w.checks
        table.append({
            "N'": int(dm.active.sum()), "DOF": dm.size, "z": f"{p.info['z']:.3f}",
            "dense s": f"{seconds['dense']:.1f}", "windows s": f"{seconds['windows']:.1f}",
            "dense / windows": f"{seconds['dense'] / seconds['windows']:.2f}",
            "windows": checks["windows"], "nev": checks["settings"]["spectrum"]["nev"],
            "max backward residual": f"{checks['max_residual']:.1e}",
            "tr A error": f"{checks['trace_error']:.1e}", "tr A^2 error": f"{checks['trace2_error']:.1e}",
            "complex (w/d)": f"{w.n_complex}/{d.n_complex}", "zero (w/d)": f"{w.n_zero_modes}/{d.n_zero_modes}",
            "max |d Re lambda| / max|lambda|": f"{np.abs(w.omega2.real - d.omega2.real).max() / scale:.1e}" if same else "count differs",
            "max |d |Im lambda|| / max|lambda|":
                f"{np.abs(np.sort(np.abs(w.omega2.imag)) - np.sort(np.abs(d.omega2.imag))).max() / scale:.1e}" if same else "",
            "max |d omega| / omega_max": f"{np.abs(w.omega - d.omega).max() / d.omega.max():.1e}" if same else ""})
        print(table[-1], flush=True)
        dm.destroy()
    notes = (f"2D frictional packings made by LAMMPS at mu = {args.mu:g}, held at pressure {args.pressure:g} kn "
             f"(configs/frictional.yaml's protocol), N = {', '.join(map(str, args.ns))} (N' without rattlers); D at "
             f"rho = 2/7 with the stored forces; every eigenvalue by spectrum.solver windows (SLEPc shift-and-invert "
             f"windows, shifted_windows.py) and dense (LAPACK), same process, one core. Errors: windows against dense.")
    save("nonhermitian", "python -m scripts.benchmarks.bench_nonhermitian", table, notes)


if __name__ == "__main__":
    main()
