"""Every damped mode (``spectrum.method: pep``): windows against dense, both against the undamped
spectrum slicing of the same matrix.

    python -m scripts.benchmarks.bench_damped [--ns 256 512 1024] [--gamma-t 0.15 0.9] [--dense-max 1024]
                                   [--window-n 32768] [--band 0.2 0.26] [--nev K]
For each N, a 2D jammed packing (rotsound's FIRE, phi = 0.86), D at rho = 0.5, LAMMPS-convention
dashpots gamma_n = 0.3 and gamma_t (0.15 puts the rates on a thin band, C close to 0.15 D; 0.9
spreads them and makes overdamped modes).  In one process, on the same matrix: slicing (every
undamped omega, the issue's reference time), pep windows and, up to --dense-max, pep dense
(LAPACK on the 2n first-order matrix): time, peak memory added (ru_maxrss), windows and shifts,
largest backward error, trace errors, and the largest relative difference of lambda between the
two.  Then, at --window-n (gamma_t = 0.15), the damped modes of one frequency band only
(``spectrum.window``, the large-N path) against the undamped slicing of the same band, with their
energies (K/Q) both.  One core (one BLAS thread), as a scene's rank runs it.  When the windows'
own checks refuse what they found (a count or a trace moment off), the row says so
(column refused) with the time until then, and no dense solve is made for it.  ``--nev K``: K
eigenvalues of T per shift (``-pep_eps_nev``; default the code's NEV): wider and fewer disks.
"""

from __future__ import annotations

import argparse
import os
import resource
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads OpenBLAS: one core each, as a rank
import numpy as np  # noqa: E402

from scripts.benchmarks.benchlib import save  # noqa: E402

BENCH = {"order": 200}  # make bench: its place (scripts/benchmarks/bench_all.py)


def _peak_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ns", type=int, nargs="*", default=[256, 512, 1024])
    parser.add_argument("--gamma-t", type=float, nargs="+", default=[0.15, 0.9])
    parser.add_argument("--dense-max", type=int, default=1024, help="largest N solved dense too")
    parser.add_argument("--window-n", type=int, nargs="*", default=[32768], help="N of the one-band runs")
    parser.add_argument("--band", type=float, nargs=2, default=[0.2, 0.26], help="their band of omega (1/t0)")
    parser.add_argument("--nev", type=int, help="eigenvalues per shift (-pep_eps_nev; default the code's)")
    args = parser.parse_args()

    from mpi4py import MPI

    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import damping, dynmat
    from solver.packing import jammed
    from solver.spectrum import pep, slicing

    from solver.spectrum.quadratic_windows import NEV

    PETSc = petscenv.init([] if args.nev is None else ["-pep_eps_nev", str(args.nev)])
    nev = NEV if args.nev is None else args.nev
    table = []
    for gamma_t, n in ((g, n) for g in args.gamma_t for n in args.ns):
        p = jammed.generate(n, 0.86, np.random.SeedSequence([3, 0]), comm=MPI.COMM_SELF)
        dm = dynmat.assemble(p, ContactModel(0.5, gamma_n=0.3, gamma_t=gamma_t), PETSc.COMM_SELF)
        t0 = time.perf_counter()
        slicing.solve(dm, window=None, vectors=False, tol=1e-12, zero_tol=1e-4)
        undamped = time.perf_counter() - t0
        dm.C = damping.assemble(p, dm)
        row = {"gamma_t": gamma_t, "N": n, "nev": nev, "DOF": dm.size, "2n": 2 * dm.size,
               "slicing s (undamped)": f"{undamped:.1f}"}
        before = _peak_mib()
        t0 = time.perf_counter()
        try:
            w = pep.solve(dm, 1e-4, solver="windows")
        except RuntimeError as refused:  # the windows' own checks (count, trace moments) refused the modes
            row.update({"windows s": f"{time.perf_counter() - t0:.1f}", "refused": str(refused)})
        else:
            windows = time.perf_counter() - t0
            row.update({"windows s": f"{windows:.1f}", "windows / slicing": f"{windows / undamped:.1f}",
                        "windows": w.checks["windows"], "shifts": w.checks["shifts"],
                        "max backward error": f"{w.checks['max_residual']:.1e}",
                        "trace errors": f"{w.checks['trace_error']:.1e} / {w.checks['trace2_error']:.1e}",
                        "overdamped": w.n_overdamped, "windows peak MiB+": f"{_peak_mib() - before:.0f}"})
            if n <= args.dense_max:
                before = _peak_mib()
                t0 = time.perf_counter()
                d = pep.solve(dm, 1e-4, solver="dense")
                dense = time.perf_counter() - t0
                error = max(np.abs(w.lam[:, None] - d.lam[None, :]).min(axis=1).max() / np.abs(d.lam).max(),
                            np.abs(d.lam[:, None] - w.lam[None, :]).min(axis=1).max() / np.abs(d.lam).max())
                row.update({"dense s": f"{dense:.1f}", "dense / windows": f"{dense / windows:.2f}",
                            "dense peak MiB+": f"{max(_peak_mib() - before, 0.0):.0f}",
                            "max lambda error (rel. to max modulus)": f"{error:.1e}"})
        table.append(row)
        print(row, flush=True)
        dm.destroy()
    band = tuple(args.band)
    for n in args.window_n:
        p = jammed.generate(n, 0.86, np.random.SeedSequence([3, 0]), comm=MPI.COMM_SELF)
        dm = dynmat.assemble(p, ContactModel(0.5, gamma_n=0.3, gamma_t=0.15), PETSc.COMM_SELF)
        t0 = time.perf_counter()
        s = slicing.solve(dm, window=band, vectors=True, tol=1e-12, zero_tol=1e-4)
        undamped = time.perf_counter() - t0
        dm.C = damping.assemble(p, dm)
        before = _peak_mib()
        t0 = time.perf_counter()
        w = pep.solve(dm, 1e-4, vectors=True, solver="windows", window=band)
        windows = time.perf_counter() - t0
        row = {"gamma_t": 0.15, "N": n, "nev": nev, "DOF": dm.size, "2n": 2 * dm.size, "band": f"[{band[0]:g}, {band[1]:g})",
               "modes (undamped / damped)": f"{len(s.omega)} / {len(w.lam)}",
               "slicing s (undamped)": f"{undamped:.1f}", "windows s": f"{windows:.1f}",
               "windows / slicing": f"{windows / undamped:.1f}", "windows": w.checks["windows"],
               "shifts": w.checks["shifts"], "max backward error": f"{w.checks['max_residual']:.1e}",
               "overdamped": w.n_overdamped, "windows peak MiB+": f"{_peak_mib() - before:.0f}"}
        table.append(row)
        print(row, flush=True)
        dm.destroy()
    notes = (f"2D jammed packings (rotsound's FIRE, phi = 0.86, seed 3), D at rho = 0.5, dashpots gamma_n = 0.3, "
             f"gamma_t = {', '.join(map(str, args.gamma_t))} (LAMMPS convention); every damped mode by pep windows "
             f"(quadratic_windows.py: Parlett-Saad complex shifts, columns bounded by the numerical range) and dense "
             f"(LAPACK eig of the 2n first-order matrix), against the undamped spectrum slicing of the same D; one "
             f"core. 'peak MiB+' is the growth of the process's peak RSS during that solve (0 when an earlier solve "
             f"peaked higher). Target of issue 29: the damped full spectrum at N = 2048 at most 2x the undamped "
             f"slicing time. Rows with a band: that band only, with K/Q (vectors) on both sides.")
    command = " ".join(["python -m scripts.benchmarks.bench_damped", "--ns", *map(str, args.ns), "--gamma-t",
                        *map(str, args.gamma_t), "--dense-max", str(args.dense_max), "--window-n",
                        *map(str, args.window_n), "--band", *map(str, args.band),
                        *([] if args.nev is None else ["--nev", str(args.nev)])])
    save("damped", command, table, notes, merge_by=("gamma_t", "N", "band", "nev"))


if __name__ == "__main__":
    main()
