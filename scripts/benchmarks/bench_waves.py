"""Standing-wave benchmarks (issue 4): run time against error, step cost, one N = 32768 run.

    python -m scripts.benchmarks.bench_waves
1. N = 2048, rho = 1, L mode, k = 2 pi 4 / L, t_end = 50: error of z(t) (r_i(0) phase) against
   the exact eigendecomposition solution vs wall time, for each integrator and several dt, TS on
   2 ranks, the exponential path (SLEPc MFN, no time steps) at several tolerances, and a plain
   scipy.sparse velocity-Verlet loop (1 process) in the same run.
2. N = 32768, 2 ranks: one Verlet TS step against one bare MatMult (no sampling).
3. N = 32768, 2 ranks: one (mode, k) run to t = 200 t0, and the paper programme's estimated cost.
Writes scripts/benchmarks/records/waves.json and docs/bench_waves.png.
"""

from solver.contact_law import ContactModel
import json
import subprocess
import sys
import time

import numpy as np

from scripts.benchmarks.benchlib import PY, REPO, exact_l_wave, load_packing, mpirun, run_json, save, scipy_verlet_l_wave

BENCH = {"order": 70}  # make bench: its place (scripts/benchmarks/bench_all.py)
ME = ["-m", __spec__.name]  # this benchmark again, in a fresh process (run_json runs it from the repository root)

T_END = 50.0
SAMPLE = 0.5
CASES = [("verlet", [0.1, 0.05, 0.025, 0.0125]), ("rk", [0.25, 0.125, 0.0625]), ("alpha2", [0.1, 0.05, 0.025]),
         ("cn", [0.1, 0.05])]
EXPONENTIAL_TOLS = [1e-4, 1e-8, 1e-12]
EXACT = REPO / "cache" / "bench_waves_exact.npz"


def exact_reference() -> None:
    """z(t) of the L wave from a dense eigendecomposition (serial, once)."""
    p = load_packing(2048)
    k = 2 * np.pi * 4 / p.box_length
    t = np.arange(0, T_END + 1e-9, SAMPLE)
    np.savez(EXACT, t=t, z=exact_l_wave(p, k, t), k=k)


def _timed_l_wave(solve) -> None:
    """The N = 2048 L wave by ``solve(dm, p, k, times)`` -> WaveSeries on 2 ranks: prints its wall
    time and max relative error of z_fixed against the exact reference (and its own estimate)."""
    from mpi4py import MPI

    from solver import petscenv
    from solver.model import dynmat

    PETSc = petscenv.init([])
    p = load_packing(2048)
    dm = dynmat.assemble(p, ContactModel(1.0), PETSc.COMM_WORLD)
    ref = np.load(EXACT)
    mpi = PETSc.COMM_WORLD.tompi4py()
    mpi.Barrier()
    t0 = time.perf_counter()
    s = solve(dm, p, float(ref["k"]), ref["t"])
    seconds = mpi.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    error = float(np.abs(s.z_fixed - ref["z"]).max() / np.abs(ref["z"]).max())
    if PETSc.COMM_WORLD.rank == 0:
        print(json.dumps({"seconds": seconds, "error": error, "estimate": s.error_estimate}))


def ts_case(integrator: str, dt: float) -> None:
    """TS ``integrator`` at step ``dt``."""
    from solver.waves import integrators
    from solver.waves.schedule import resolve_schedule

    assert abs(SAMPLE / dt - round(SAMPLE / dt)) < 1e-9, "dt must divide the sampling interval"
    _timed_l_wave(lambda dm, p, k, t: integrators.integrate(
        dm, p.positions, "L", 0, k, amplitude=1e-3,
        schedule=resolve_schedule(integrator=integrator, dt=dt, t_end=T_END, sample_every=int(round(SAMPLE / dt)))))


def exponential_case(tol: float) -> None:
    """The exponential path (waves.method: exponential) at tolerance ``tol``."""
    from solver.waves import exponential

    from solver.model.operators import largest_omega

    _timed_l_wave(lambda dm, p, k, t: exponential.exponential_all(dm, p.positions, [("L", 0, k)], amplitude=1e-3,
                                                                  times=t, tol=tol, rate=largest_omega(dm))[0])


def scipy_case(dt: float) -> None:
    """The obvious alternative: velocity Verlet with scipy.sparse, one process."""
    ref = np.load(EXACT)
    seconds, z = scipy_verlet_l_wave(load_packing(2048), float(ref["k"]), dt, T_END, SAMPLE)
    error = float(np.abs(z - ref["z"]).max() / np.abs(ref["z"]).max())
    print(json.dumps({"seconds": seconds, "error": error}))


def step_cost_case() -> None:
    """N = 32768: time per Verlet TS step vs per bare MatMult; and one run to t = 200."""
    from solver import petscenv
    from solver.model import dynmat
    from solver.waves import integrators
    from solver.waves.schedule import resolve_schedule

    PETSc = petscenv.init([])
    p = load_packing(32768)
    dm = dynmat.assemble(p, ContactModel(1.0), PETSc.COMM_WORLD)
    mpi = PETSc.COMM_WORLD.tompi4py()
    x, y = dm.D.createVecs()
    x.setRandom()
    reps = 2000
    mpi.Barrier()
    t0 = time.perf_counter()
    for _ in range(reps):
        dm.D.mult(x, y)
    matmult = mpi.allreduce(time.perf_counter() - t0, op=__import__("mpi4py").MPI.MAX) / reps
    k = 2 * np.pi * 32 / p.box_length
    mpi.Barrier()
    t0 = time.perf_counter()
    s = integrators.integrate(dm, p.positions, "L", 0, k, amplitude=1e-3,
                              schedule=resolve_schedule(integrator="verlet", dt=0.02, t_end=reps * 0.02,
                                                        sample_every=reps))
    step = mpi.allreduce(time.perf_counter() - t0, op=__import__("mpi4py").MPI.MAX) / s.steps
    mpi.Barrier()
    t0 = time.perf_counter()
    full = integrators.integrate(dm, p.positions, "RT", 0, k, amplitude=1e-3,
                                 schedule=resolve_schedule(integrator="verlet", dt=0.02, t_end=200.0, sample_every=5))
    run200 = mpi.allreduce(time.perf_counter() - t0, op=__import__("mpi4py").MPI.MAX)
    batch = [("RT", d, 2 * np.pi * n / p.box_length) for d in (0, 1) for n in (8, 16, 24, 32)]
    mpi.Barrier()
    t0 = time.perf_counter()
    short = resolve_schedule(integrator="verlet", dt=0.02, t_end=20.0, sample_every=5)
    for mode, d, kk in batch:
        integrators.integrate(dm, p.positions, mode, d, kk, amplitude=1e-3, schedule=short)
    singles = mpi.allreduce(time.perf_counter() - t0, op=__import__("mpi4py").MPI.MAX)
    mpi.Barrier()
    t0 = time.perf_counter()
    integrators.integrate_block(dm, p.positions, batch, amplitude=1e-3, schedule=short)
    block = mpi.allreduce(time.perf_counter() - t0, op=__import__("mpi4py").MPI.MAX)
    if PETSc.COMM_WORLD.rank == 0:
        print(json.dumps({"matmult": matmult, "step": step, "run200": run200, "steps200": full.steps,
                          "kd0": k, "L": p.box_length, "singles": singles, "block": block, "R": len(batch)}))


def main() -> None:
    if not EXACT.exists():
        subprocess.run([PY, *ME, "--exact"], check=True, cwd=REPO)
    points, table = [], []
    for integrator, dts in CASES:
        for dt in dts:
            r = run_json(mpirun(2) + [PY, *ME, "--ts", integrator, str(dt)])
            points.append((f"TS {integrator} (2 ranks)", dt, r["seconds"], r["error"]))
    for tol in EXPONENTIAL_TOLS:
        r = run_json(mpirun(2) + [PY, *ME, "--exponential", str(tol)])
        points.append(("exponential, SLEPc MFN (2 ranks)", f"tol {tol:g} (estimate {r['estimate']:.0e})",
                       r["seconds"], r["error"]))
    for dt in CASES[0][1]:
        r = run_json([PY, *ME, "--scipy", str(dt)])
        points.append(("scipy.sparse Verlet (1 process)", dt, r["seconds"], r["error"]))
    for name, dt, sec, err in points:
        table.append({"method": name, "dt [t0] or tol": dt, "wall time [s]": f"{sec:.2f}", "max rel. error of z(t)": f"{err:.2e}"})
    cost = run_json(mpirun(2) + [PY, *ME, "--stepcost"])
    table.append({"method": "N = 32768, 2 ranks: Verlet TS step / bare MatMult",
                  "dt [t0] or tol": 0.02, "wall time [s]": f"{cost['step'] * 1e3:.3f} ms / {cost['matmult'] * 1e3:.3f} ms",
                  "max rel. error of z(t)": f"ratio {cost['step'] / cost['matmult']:.2f}"})
    table.append({"method": f"N = 32768, 2 ranks: {cost['R']} RT waves to t = 20, one by one / as one block",
                  "dt [t0] or tol": 0.02, "wall time [s]": f"{cost['singles']:.1f} / {cost['block']:.1f}",
                  "max rel. error of z(t)": f"block speedup {cost['singles'] / cost['block']:.2f}x (same samples, tested)"})
    kgrid = int(np.floor(cost["L"] * 0.5))  # n = 1 .. L/2: k d0 up to ~pi
    programme = cost["run200"] * 3 * 2 * kgrid * 11 * cost["block"] / cost["singles"]
    table.append({"method": f"N = 32768, 2 ranks: one RT run to t = 200 ({cost['steps200']} steps, sampled every 5)",
                  "dt [t0] or tol": 0.02, "wall time [s]": f"{cost['run200']:.1f}",
                  "max rel. error of z(t)": f"paper programme 3 modes x 2 dirs x {kgrid} k x 11 rho, in blocks: "
                                            f"~{programme / 3600:.1f} h"})
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.2))
    for name in dict.fromkeys(p[0] for p in points):
        pts = [(s, e) for n, _, s, e in points if n == name]
        ax.loglog([s for s, _ in pts], [e for _, e in pts], "o-", label=name)
    ax.set(xlabel="wall time [s]", ylabel="max relative error of z(t), t <= 50 t0",
           title="N = 2048, rho = 1, L wave: error against run time")
    ax.legend(fontsize=8)
    fig.tight_layout()
    (REPO / "docs").mkdir(exist_ok=True)
    fig.savefig(REPO / "docs" / "bench_waves.png", dpi=120)
    save("waves", "python -m scripts.benchmarks.bench_waves", table,
         "Error: max over samples of |z(t) - z_exact(t)| / max |z_exact| with r_i(0) in the phase, z_exact "
         "from the full eigendecomposition (PHYSICS.md section 4). Plot: ![time against error](docs/bench_waves.png)")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--exact"]:
        exact_reference()
    elif sys.argv[1:2] == ["--ts"]:
        ts_case(sys.argv[2], float(sys.argv[3]))
    elif sys.argv[1:2] == ["--exponential"]:
        exponential_case(float(sys.argv[2]))
    elif sys.argv[1:2] == ["--scipy"]:
        scipy_case(float(sys.argv[2]))
    elif sys.argv[1:2] == ["--stepcost"]:
        step_cost_case()
    else:
        main()
