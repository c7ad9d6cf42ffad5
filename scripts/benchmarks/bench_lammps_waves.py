"""LAMMPS's standing waves at finite amplitude (``waves.lammps_dem``, issue 46 point 6): what the
sampling costs LAMMPS, and a ten-amplitude sweep's time, N disks on the ranks of the job.

    mpirun -n 2 python -m scripts.benchmarks.bench_lammps_waves [--n 8192] [--steps 5000] [--every 5 10] [--record 1 10]
The packing: benchlib's cached FIRE packing of N disks at phi = 0.9; rho = 1, harmonic,
mu = 0.3, the TR run with k along x at k = 2 pi / L, A = 1e-3, dt = 0.02.  "standalone": LAMMPS
with the same pair style, fixes and hold, sampled only at the start and the end (one ``run`` of
``--steps``); each "every" row samples the velocities every that many steps, as a scene does
(``waves.sample_every``, default 5), and records the contacts (``compute pair/local``) every
"record"-th sample (``waves.contacts_every``, default 10; 1: the first version's every sample).
Each row runs --steps and 2 x --steps: the difference is the cost of --steps steps, without
the fixed cost of a run (LAMMPS's start, the rest check, the hold; column "fixed s").  Columns:
ms per step, steps per second, the share of the standalone step rate kept (issue 46's target:
>= 80 %), and a ten-amplitude sweep of one (mode, k) (2 runs each in 2D) to t_end = 200
extrapolated from that rate (target: under 30 min).  LAMMPS runs on COMM_WORLD.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402

from scripts.benchmarks.benchlib import load_packing, save  # noqa: E402

BENCH = {"order": 236, "args": []}  # make bench: its place (scripts/benchmarks/bench_all.py); run under mpirun -n 2 by hand


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=8192)
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--every", type=int, nargs="+", default=[5, 10])
    parser.add_argument("--record", type=int, nargs="+", default=[1, 10])
    args = parser.parse_args()

    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.waves import excitation, lammps_dem

    PETSc = petscenv.init([])
    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    p = load_packing(args.n) if mpi.rank == 0 else None
    p = mpi.bcast(p)
    model = ContactModel(1.0)
    dm = dynmat.assemble(p, model, comm)
    k = 2 * np.pi / float(p.box[0])
    start = excitation.whole_start(dm, p.positions, 0, 1, k, 1e-3, mpi)  # TR: v_x with k along y
    table = []

    def timed(steps, every, record=1):
        mpi.Barrier()
        t0 = time.perf_counter()
        _, contacts = lammps_dem.run(p.positions, p.diameters, p.box, dm.active, model, 0.3, start, 0.02,
                                     steps, every, 1e-6, (0, np.exp(-1j * k * p.positions[dm.active, 1])), mpi,
                                     record_every=record)
        return mpi.allreduce(time.perf_counter() - t0, op=_max()), contacts

    def per_step(every, record=1):  # the fixed cost (LAMMPS's start, the rest check, the hold) cancels
        short, _ = timed(args.steps, min(every, args.steps), record)
        long, contacts = timed(2 * args.steps, min(every, 2 * args.steps), record)
        return (long - short) / args.steps, long - 2 * (long - short), contacts

    alone, fixed, _ = per_step(2 * args.steps)
    sweep_minutes = 10 * 2 * (200 / 0.02) * alone / 60
    table.append({"N": args.n, "ranks": mpi.size, "sampling": "standalone (start and end)",
                  "ms per step": f"{1e3 * alone:.3f}", "steps/s": f"{1 / alone:.0f}", "of standalone": "100 %",
                  "fixed s": f"{fixed:.1f}", "sweep of 10 A (min)": f"{sweep_minutes:.1f}"})
    for every, record in ((e, r) for e in args.every for r in args.record):
        step, fixed, contacts = per_step(every, record)
        table.append({"N": args.n, "ranks": mpi.size, "sampling": f"every {every} steps, contacts every {record}",
                      "ms per step": f"{1e3 * step:.3f}", "steps/s": f"{1 / step:.0f}",
                      "of standalone": f"{100 * alone / step:.0f} %", "fixed s": f"{fixed:.1f}",
                      "sweep of 10 A (min)": f"{sweep_minutes * step / alone:.1f}"})
    dm.destroy()
    if mpi.rank == 0:
        save("lammps_waves", f"mpirun -n {mpi.size} python -m scripts.benchmarks.bench_lammps_waves --n {args.n} "
                             f"--steps {args.steps} --every {' '.join(map(str, args.every))} "
                             f"--record {' '.join(map(str, args.record))}", table,
             notes=f"{args.steps} and {2 * args.steps} steps of dt = 0.02 each; rho = 1, mu = 0.3, TR at k = 2 pi / L, A = 1e-3; the "
                   f"largest number of contacts sliding at once in the last run: {int(contacts.sliding.max())}.")


def _max():
    from mpi4py import MPI

    return MPI.MAX


if __name__ == "__main__":
    main()
