"""Packing engines side by side (issue 19 item 6): rotsound's FIRE against LAMMPS's FIRE
(solver/packing/lammps_engine.py) on the same starts.

    python -m scripts.benchmarks.bench_engines [N ...] [--dims 2 3] [--seeds S ...] [--ranks 1 2]
    (defaults: N = 32768, 2D at phi = 0.9 and 3D at phi = 0.7, seed 1, LAMMPS on 1 and 2 ranks)
The start is jammed.generate's: bidisperse diameters permuted by the rng of SeedSequence([seed, 0]),
the box from phi, a uniform start from the same rng in spatial order.  Each run is a fresh
process with one BLAS thread: rotsound's FIRE on one core (``fire.minimize`` with
``mechanics.FrictionlessForces``, compiled force loop warmed up first), LAMMPS on 1 rank and under
``mpirun -n 2`` (its start-up included; it is milliseconds).  Every packing is then judged by
rotsound's own force evaluation (max |F| (rotsound)), its rattlers and contact number z, and
compared with rotsound's packing of the same start and with LAMMPS's on the first rank count
(largest minimum-image displacement: near round-off if they reached the same minimum, of order a
diameter if not).  Writes scripts/benchmarks/records/engines.json.
"""

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from scripts.benchmarks.benchlib import PY, mpirun, run_json, save

BENCH = {"order": 30}  # make bench: its place (scripts/benchmarks/bench_all.py)
ME = ["-m", __spec__.name]  # this benchmark again, in a fresh process (run_json runs it from the repository root)
PHI = {2: 0.9, 3: 0.7}
FORCE_TOL, MAX_STEPS = 1e-6, 2_000_000


def start(n: int, phi: float, dim: int, seed: int):
    """jammed.generate's start: (positions (n, dim), diameters (n,), box (dim,))."""
    from solver.packing import jammed

    rng = np.random.default_rng(np.random.SeedSequence([seed, 0]))
    diameters = rng.permutation(jammed.bidisperse_diameters(n))
    box = np.full(dim, jammed.box_length_for(diameters, phi, dim))
    x = rng.uniform(0.0, box[0], size=(n, dim))
    return x[jammed.spatial_order(x, box)], diameters, box


def case(engine: str, n: int, dim: int, seed: int, out: str) -> None:
    """One minimisation; rank 0 saves the positions to ``out`` and prints one JSON line."""
    from mpi4py import MPI

    from solver.packing import fire, lammps_engine, mechanics

    comm = MPI.COMM_WORLD
    x, diameters, box = start(n, PHI[dim], dim, seed)
    if engine == "fire":
        small = start(64, PHI[dim], dim, 0)
        mechanics.FrictionlessForces(small[1], small[2])(small[0])  # load the compiled loop
        t = time.perf_counter()
        result = fire.minimize(x, mechanics.FrictionlessForces(diameters, box), FORCE_TOL, MAX_STEPS)
        seconds = time.perf_counter() - t
        if not result.converged:
            raise RuntimeError(f"rotsound's FIRE did not converge: {result.max_force:.3e} after {result.steps}")
        positions, steps, max_force = result.x, result.steps, result.max_force
    else:
        comm.Barrier()
        t = time.perf_counter()
        positions, steps, max_force = lammps_engine.minimize(x, diameters, box, FORCE_TOL, MAX_STEPS, comm)
        comm.Barrier()
        seconds = time.perf_counter() - t
    if comm.rank:
        return
    from solver.packing import geometry

    positions = geometry.wrap(positions, box)
    force, _ = mechanics.FrictionlessForces(diameters, box)(positions)
    rattler = mechanics.find_rattlers(positions, diameters, box)
    stats = mechanics.describe(positions, diameters, box, rattler)
    np.save(out, positions)
    print(json.dumps({"seconds": seconds, "steps": steps, "max_force": max_force,
                      "rotsound_max_force": float(np.sqrt(np.max(np.sum(force**2, axis=1)))),
                      "z": stats["z"], "pressure": stats["pressure"],
                      "rattler_fraction": stats["rattler_fraction"]}))


def displacement(a: np.ndarray, b: np.ndarray, box: np.ndarray) -> float:
    """Largest minimum-image distance component between two packings (N, D) of the same start."""
    delta = a - b
    return float(np.abs(delta - box * np.rint(delta / box)).max())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("n", nargs="*", type=int, default=[32768])
    parser.add_argument("--dims", nargs="+", type=int, default=[2, 3], choices=[2, 3])
    parser.add_argument("--seeds", nargs="+", type=int, default=[1])
    parser.add_argument("--ranks", nargs="+", type=int, default=[1, 2])
    args = parser.parse_args()
    os.environ.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")  # inherited by the cases
    table = []
    with tempfile.TemporaryDirectory() as scratch:
        for n in args.n:
            for dim in args.dims:
                for seed in args.seeds:
                    runs = [("rotsound FIRE", 1, [PY])] + [("LAMMPS FIRE", r, mpirun(r) + [PY]) for r in args.ranks]
                    box, first = start(n, PHI[dim], dim, seed)[2], {}  # each engine's first packing
                    for engine, ranks, launcher in runs:
                        out = str(Path(scratch) / f"{n}_{dim}_{seed}_{ranks}_{engine[0]}.npy")
                        kind = "fire" if engine.startswith("rotsound") else "lammps"
                        r = run_json(launcher + [*ME, "--case", kind, str(n), str(dim), str(seed), out])
                        positions = np.load(out)
                        first.setdefault(engine, positions)
                        table.append({"D": dim, "N": n, "phi": PHI[dim], "seed": seed, "engine": engine,
                                      "ranks": ranks, "time [s]": round(r["seconds"], 2), "steps": r["steps"],
                                      "ms/step": round(1e3 * r["seconds"] / r["steps"], 3),
                                      "max force (engine)": f"{r['max_force']:.3e}",
                                      "max force (rotsound's forces)": f"{r['rotsound_max_force']:.3e}",
                                      "z": round(r["z"], 4), "pressure": f"{r['pressure']:.4e}",
                                      "rattlers": round(r["rattler_fraction"], 4),
                                      "max dr vs rotsound": f"{displacement(positions, first['rotsound FIRE'], box):.2e}",
                                      f"max dr vs LAMMPS on {args.ranks[0]} rank(s)":
                                          f"{displacement(positions, first[engine], box):.2e}" if kind == "lammps" else ""})
                        print(json.dumps(table[-1]), flush=True)
    save("engines", "python -m scripts.benchmarks.bench_engines " + " ".join(sys.argv[1:]), table,
         f"Same starts (jammed.generate's recipe, SeedSequence([seed, 0])), force_tol = {FORCE_TOL:g}. "
         "rotsound's FIRE: one core. LAMMPS (Debian's lammps 20220106, version 29 Sep 2021, pair gran/hooke without damping "
         "or friction, min_style fire with rotsound's FIRE parameters) on 1 and 2 MPI ranks; time "
         "includes its start-up. max|dr|: largest minimum-image displacement from rotsound's packing "
         "of the same start, or from LAMMPS's on the first rank count (different minima when it is "
         "of order a diameter, the same one when it is near round-off).")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--case"]:
        case(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]), sys.argv[6])
    else:
        main()
