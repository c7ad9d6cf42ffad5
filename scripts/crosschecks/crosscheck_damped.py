"""Damped standing waves integrated by LAMMPS itself against rotsound's exact damped C(k, t)
(issue 29, item 6; docs/damping.md).

    python -m scripts.crosschecks.crosscheck_damped [--n2 64] [--n3 64] [--seed 1] [--gamma-n 0.3] [--gamma-t 0.15]
                                            [--t-end 10] [--dt 0.002] [--halvings 2] [--sample 0.1] [--amplitude 1e-6]
For 2D disks (phi = 0.9) and 3D spheres (phi = 0.7) under each law, on one jammed packing made by
rotsound (as scripts/crosschecks/crosscheck_lammps.py: the springs unstressed at the start, which ``fix
external`` holds at rest, rattlers left out): every run of every mode from rotsound's v(0) at +A
and -A, integrated by LAMMPS (``gran/hooke/history`` or ``gran/hertz/history`` with kn = 1,
kt = kn, the dashpots gamma_n and gamma_t, dampflag 1, friction 1e4, masses 1, ``fix
nve/sphere``) at dt, dt/2, dt/4; the half difference gives C(k, t) as rotsound pools it.
References on the same packing and start, exact to round-off: exp(tJ) of the damped first-order
system J = [[0, I], [-M^-1 D, -M^-1 C]] (D and C from ``dynmat`` and ``damping``;
``references.first_order_flow``), and of the undamped one, to show the check can fail.
LAMMPS's velocity Verlet evaluates the dashpots with half-step velocities, so it converges at
first order in dt (the "order" column).

Writes scripts/crosschecks/records/crosscheck_damped.json (BENCHMARKS.md "crosscheck_damped").  One process.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from scripts.crosschecks.harness import PACKINGS, add_wave_arguments, convergence_columns, lammps_z, pooled_c, save

BENCH = {"order": 170}  # make bench: its place (scripts/benchmarks/bench_all.py)


def case(dim: int, law: str, n: int, args) -> dict:
    """Every mode of one (dimension, law): max |C_LAMMPS - C| per dt, against the exact damped and
    undamped C.  LAMMPS and PETSc on COMM_SELF."""
    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import damping, dynmat
    from solver.packing import jammed
    from solver.references import first_order_flow
    from solver.waves import excitation

    PETSc = petscenv.init([])
    comm = PETSc.COMM_SELF.tompi4py()
    p = jammed.generate(n, PACKINGS[dim], np.random.SeedSequence([args.seed, 0]), dim=dim, law=law)
    dm = dynmat.assemble(p, ContactModel(1.0, law=law, gamma_n=args.gamma_n, gamma_t=args.gamma_t), PETSc.COMM_SELF)
    dm.C = damping.assemble(p, dm)
    plain = dynmat.assemble(p, ContactModel(1.0, law=law), PETSc.COMM_SELF)
    k = 2 * np.pi / float(p.box[0])
    count = int(round(args.t_end / args.sample)) + 1
    x = p.positions[dm.active]
    dts = [args.dt / 2 ** h for h in range(args.halvings + 1)]
    row = {"dim": dim, "law": law, "n": n, "rattlers": int(p.rattler.sum()), "modes": {}}
    for mode in excitation.RUNS[dim]:
        runs = excitation.runs(mode, dim)
        starts = [excitation.whole_start(dm, p.positions, c, a, k, args.amplitude, comm) for c, a in runs]

        def pooled(velocities):
            return pooled_c([v[:, :, c] @ np.exp(-1j * k * x[:, a]) for v, (c, a) in zip(velocities, runs)],
                            args.sample)

        exact = pooled([first_order_flow(dm, s, args.sample, count)[:, 1] for s in starts])
        undamped = pooled([first_order_flow(plain, s, args.sample, count)[:, 1] for s in starts])
        errors, misses, seconds = [], [], 0.0
        for dt in dts:
            every, steps = int(round(args.sample / dt)), int(round(args.t_end / dt))
            t0 = time.perf_counter()
            lmp = pooled_c([lammps_z(p, dm, law, run, k, args.amplitude, dt, steps, every, comm, hold=True)
                            for run in runs], args.sample)
            seconds += time.perf_counter() - t0
            errors.append(float(np.abs(lmp - exact).max()))
            misses.append(float(np.abs(lmp - undamped).max()))
        row["modes"][mode] = {"dt": dts, "error": errors, "undamped_error": misses, "lammps_seconds": seconds,
                              "decay": float(abs(exact[-1]))}
        print(f"{dim}D {law} {mode}: |C_LAMMPS - C_damped| {['%.2e' % e for e in errors]}, "
              f"|C_LAMMPS - C_undamped| {['%.2e' % e for e in misses]}", flush=True)
    dm.destroy()
    plain.destroy()
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n2", type=int, default=64)
    parser.add_argument("--n3", type=int, default=64)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--gamma-n", type=float, default=0.3)
    parser.add_argument("--gamma-t", type=float, default=0.15)
    add_wave_arguments(parser)
    parser.add_argument("--laws", nargs="+", default=["harmonic", "hertz"])
    parser.add_argument("--dims", nargs="+", type=int, default=[2, 3])
    args = parser.parse_args()
    cases = [case(dim, law, args.n2 if dim == 2 else args.n3, args) for dim in args.dims for law in args.laws]
    table = []
    for c in cases:
        for mode, m in c["modes"].items():
            row = {"D": c["dim"], "law": c["law"], "N": c["n"], "rattlers left out": c["rattlers"], "mode": mode,
                   "abs C(t_end)": f"{m['decay']:.2e}"}
            row.update(convergence_columns("LAMMPS - damped", m["dt"], m["error"]))
            row[f"LAMMPS - undamped, dt={m['dt'][-1]:g}"] = f"{m['undamped_error'][-1]:.2e}"
            row["LAMMPS s"] = f"{m['lammps_seconds']:.1f}"
            table.append(row)
    notes = (f"C(k, t) of damped standing waves integrated by LAMMPS (gran/*/history, kt = kn, gamma_n = "
             f"{args.gamma_n:g}, gamma_t = {args.gamma_t:g}, dampflag 1, friction 1e4, fix nve/sphere, the start "
             f"held by fix external) against exp(tJ) of rotsound's damped first-order system on the same packing and "
             f"start, and against the undamped one. k = 2 pi / L, A = {args.amplitude:g}, +-A half difference, runs "
             f"of a mode pooled; each column: max over t <= {args.t_end:g} (sampled every {args.sample:g}) of "
             f"abs(C_LAMMPS - C). Order: log2 of successive error ratios (1 = first order in dt: LAMMPS's dashpots "
             f"see half-step velocities).")
    save("crosscheck_damped", "python -m scripts.crosschecks.crosscheck_damped " + " ".join(sys.argv[1:]), table, notes)


if __name__ == "__main__":
    sys.exit(main())
