"""Damped standing waves (issue 29 item 7): TS against SLEPc MFN at equal error, time against error.

    python scripts/bench_damped_waves.py [--n 2048]
One L wave (k = 2 pi 4 / L, t_end = 50, samples every 0.5) on a 2D jammed packing of N disks
(rotsound's FIRE, phi = 0.86), rho = 0.5, LAMMPS-convention dashpots gamma_n = 0.3,
gamma_t = 0.15.  Reference: the exponential path at tol 1e-13 (tests/waves/test_damped_waves.py
equals it to a dense expm to 3e-15).  Then RK4 (waves.integrator rk) at several dt below its
damped step limit and the exponential path at several tolerances: wall time and the largest error
of z(t) relative to max |z|.  One process, one core.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402
from benchlib import save  # noqa: E402

T_END, SAMPLE = 50.0, 0.5


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=2048)
    args = parser.parse_args()

    from mpi4py import MPI

    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import damping, dynmat
    from solver.model.operators import largest_damping_rate, largest_omega
    from solver.packing import jammed
    from solver.waves import exponential, integrators
    from solver.waves.schedule import STABILITY_DAMPED, resolve_schedule

    PETSc = petscenv.init([])
    p = jammed.generate(args.n, 0.86, np.random.SeedSequence([3, 0]), comm=MPI.COMM_SELF)
    dm = dynmat.assemble(p, ContactModel(0.5, gamma_n=0.3, gamma_t=0.15), PETSc.COMM_SELF)
    dm.C = damping.assemble(p, dm)
    k = 2 * np.pi * 4 / p.box[0]
    times = np.arange(0.0, T_END + 1e-9, SAMPLE)
    rate = max(largest_omega(dm), largest_damping_rate(dm))
    limit = STABILITY_DAMPED[("rk", "4")] / rate

    def exact(tol):
        t0 = time.perf_counter()
        s = exponential.exponential_all(dm, p.positions, [("L", 0, k)], amplitude=1e-3, times=times, tol=tol,
                                        rate=rate)[0]
        return s.z_fixed, time.perf_counter() - t0

    reference, _ = exact(1e-13)
    scale = np.abs(reference).max()
    table = []
    for tol in (1e-4, 1e-8, 1e-12):
        z, seconds = exact(tol)
        table.append({"method": "exponential (SLEPc MFN)", "dt or tol": f"tol {tol:g}", "seconds": f"{seconds:.2f}",
                      "max error (rel. to max z)": f"{np.abs(z - reference).max() / scale:.1e}"})
        print(table[-1], flush=True)
    for dt in (0.25, 0.125, 0.0625, 0.03125):
        if dt >= limit:
            continue
        t0 = time.perf_counter()
        s = integrators.integrate(dm, p.positions, "L", 0, k, amplitude=1e-3,
                                  schedule=resolve_schedule(integrator="rk", dt=dt, t_end=T_END,
                                                            sample_every=int(round(SAMPLE / dt))))
        seconds = time.perf_counter() - t0
        table.append({"method": "TS rk (RK4)", "dt or tol": f"dt {dt:g}", "seconds": f"{seconds:.2f}",
                      "max error (rel. to max z)": f"{np.abs(s.z_fixed - reference).max() / scale:.1e}"})
        print(table[-1], flush=True)
    notes = (f"One L wave, N = {args.n} (2D, phi = 0.86, {dm.size} DOF), rho = 0.5, gamma_n = 0.3, gamma_t = 0.15, "
             f"k = 2 pi 4 / L, t_end = {T_END:g}, samples every {SAMPLE:g}; reference: the exponential path at tol "
             f"1e-13; RK4's damped step limit {limit:.3f} (2.6156 / max(omega_max, c_max)). One process, one core.")
    save("damped_waves", f"python scripts/bench_damped_waves.py --n {args.n}", table, notes)


if __name__ == "__main__":
    main()
