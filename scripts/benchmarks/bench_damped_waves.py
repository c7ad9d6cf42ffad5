"""Damped standing waves (issue 29 item 7): TS against SLEPc MFN at equal error, time against error,
and both against the undamped spectral wave of the same packing.

    python -m scripts.benchmarks.bench_damped_waves [--n 2048 32768] [--t-end 50 300] [--cuts F ...] [--cuts-only]
For each N (with its t_end): one L wave (k = 2 pi 4 / L, samples every 0.5) on a 2D jammed packing
of N disks (rotsound's FIRE, phi = 0.86), rho = 0.5, LAMMPS-convention dashpots gamma_n = 0.3,
gamma_t = 0.15.  Reference: the damped spectral path (waves.method spectral with dashpots: the
Chebyshev-Bessel series of exp(tJ), solver/waves/chebyshev.py) at tol 1e-11, which
tests/waves/test_damped_spectral.py holds to a dense exp(tJ).  Then the same path at looser
tolerances, the exponential path (SLEPc MFN) at tol 1e-8, and RK4 (waves.integrator rk) at
several dt below its damped step limit: wall time and the largest error of z(t) relative to
max |z|.  The first row of each N is the same wave without dashpots by the
spectral path (Lanczos, tol 1e-8), the issue's yardstick (a damped dispersion point at N = 32768
at most 3x the undamped spectral wave); every row's time is also given as a ratio to it.
``--cuts F ...``: the series at tol 1e-8 again with each block's terms cut to the fraction F of
what the rigorous bound plans (``chebyshev.plan``), and the error then reached: what stopping
the series a posteriori (on the terms' own size) could save at most (``--cuts-only``: those rows
and the reference only, without the MFN and TS rows).
One process, one core.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402

from scripts.benchmarks.benchlib import save  # noqa: E402

BENCH = {"order": 210}  # make bench: its place (scripts/benchmarks/bench_all.py)

SAMPLE = 0.5


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, nargs="+", default=[2048, 32768])
    parser.add_argument("--t-end", type=float, nargs="+", default=[50.0, 300.0], help="one per --n")
    parser.add_argument("--cuts", type=float, nargs="*", default=[], help="fractions of the planned terms")
    parser.add_argument("--cuts-only", action="store_true", help="no MFN and TS rows")
    args = parser.parse_args()
    if len(args.t_end) != len(args.n):
        parser.error("give one --t-end per --n")

    from mpi4py import MPI

    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import damping, dynmat
    from solver.model.operators import largest_damping_rate, largest_omega
    from solver.packing import jammed
    from solver.waves import chebyshev, exponential, integrators, spectral
    from solver.waves.schedule import STABILITY_DAMPED, resolve_schedule

    PETSc = petscenv.init([])
    table, notes = [], []
    for n, t_end in zip(args.n, args.t_end):
        p = jammed.generate(n, 0.86, np.random.SeedSequence([3, 0]), comm=MPI.COMM_SELF)
        dm = dynmat.assemble(p, ContactModel(0.5, gamma_n=0.3, gamma_t=0.15), PETSc.COMM_SELF)
        k = 2 * np.pi * 4 / p.box[0]
        times = np.arange(0.0, t_end + 1e-9, SAMPLE)
        omega_max = largest_omega(dm)
        t0 = time.perf_counter()
        undamped = spectral.spectral(dm, p.positions, "L", 0, k, amplitude=1e-3, times=times, tol=1e-8,
                                     omega_max=omega_max)
        yardstick = time.perf_counter() - t0
        dm.C = damping.assemble(p, dm)
        rate_c = largest_damping_rate(dm)
        rate = max(omega_max, rate_c)
        limit = STABILITY_DAMPED[("rk", "4")] / rate

        def damped(tol):
            t0 = time.perf_counter()
            s = chebyshev.damped_spectral(dm, p.positions, "L", 0, k, amplitude=1e-3, times=times, tol=tol,
                                          omega_max=omega_max, damping_max=rate_c)
            return s, time.perf_counter() - t0

        def row(method, setting, seconds, error):
            table.append({"N": n, "DOF": dm.size, "t_end": f"{t_end:g}", "method": method, "dt or tol": setting,
                          "seconds": f"{seconds:.2f}", "/ undamped spectral": f"{seconds / yardstick:.1f}",
                          "max error (rel. to max z)": error})
            print(table[-1], flush=True)

        row("spectral (Lanczos), no dashpots", "tol 1e-08", yardstick,
            f"{undamped.error_estimate:.1e} (estimate; {undamped.steps} steps)")
        reference, _ = damped(1e-11)
        scale = np.abs(reference.z).max()
        for tol in (1e-4, 1e-8):
            s, seconds = damped(tol)
            row("spectral (Chebyshev-Bessel)", f"tol {tol:g}", seconds,
                f"{np.abs(s.z - reference.z).max() / scale:.1e} (bound {s.error_estimate:.0e}; {s.steps} products)")
        notes.append(f"N = {n}: {dm.size} DOF, RK4's damped step limit {limit:.3f} (2.6156 / max(omega_max, c_max))")
        planned = chebyshev.plan
        for cut in args.cuts:

            def cut_plan(*key, cut=cut):
                full = planned(*key)
                return dataclasses.replace(full, terms=math.ceil(cut * full.terms))

            chebyshev.plan = cut_plan
            try:
                s, seconds = damped(1e-8)
            finally:
                chebyshev.plan = planned
            row(f"spectral (Chebyshev-Bessel), terms cut to {cut:g} of the plan", "tol 1e-08", seconds,
                f"{np.abs(s.z - reference.z).max() / scale:.1e} ({s.steps} products)")
        if args.cuts_only:
            dm.destroy()
            continue
        t0 = time.perf_counter()
        s = exponential.exponential_all(dm, p.positions, [("L", 0, k)], amplitude=1e-3, times=times, tol=1e-8,
                                        rate=rate)[0]
        row("exponential (SLEPc MFN)", "tol 1e-08", time.perf_counter() - t0,
            f"{np.abs(s.z_fixed - reference.z).max() / scale:.1e}")
        for dt in (0.25, 0.125, 0.0625):
            if dt >= limit:
                continue
            t0 = time.perf_counter()
            s = integrators.integrate(dm, p.positions, "L", 0, k, amplitude=1e-3,
                                      schedule=resolve_schedule(integrator="rk", dt=dt, t_end=t_end,
                                                                sample_every=int(round(SAMPLE / dt))))
            row("TS rk (RK4)", f"dt {dt:g}", time.perf_counter() - t0,
                f"{np.abs(s.z_fixed - reference.z).max() / scale:.1e}")
        dm.destroy()
    notes = (f"One L wave per N (2D, phi = 0.86), rho = 0.5, gamma_n = 0.3, gamma_t = 0.15, k = 2 pi 4 / L, samples "
             f"every {SAMPLE:g}; reference: the damped spectral path (Chebyshev-Bessel series) at tol 1e-11, which "
             f"equals a dense exp(tJ) to 1e-10 in tests/waves/test_damped_spectral.py (the MFN row is the independent "
             f"check). Yardstick: the same wave without "
             f"dashpots by the spectral path (Lanczos to 1e-8); the issue's target is a damped point at N = 32768 "
             f"within 3x of it. {'; '.join(notes)}. One process, one core.")
    save("damped_waves", "python -m scripts.benchmarks.bench_damped_waves " + " ".join(
        ["--n", *map(str, args.n), "--t-end", *(f"{t:g}" for t in args.t_end),
         *(["--cuts", *(f"{c:g}" for c in args.cuts)] if args.cuts else []), *(["--cuts-only"] if args.cuts_only else [])]),
        table, notes, merge_by=("N", "method", "dt or tol"))


if __name__ == "__main__":
    main()
