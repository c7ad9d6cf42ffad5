"""FIRE's cost per disk-step on 1 and 2 threads (issue 60 point 3: a 10^6-disk packing in under 30
min, both cores, the same packing on any number of threads).

    python -m scripts.benchmarks.bench_fire_step [N ...] [--steps S] [--start random|jammed] [--whole]
                                                 [--threads T ...] [--fire NAME=VALUE ...]
    (defaults: N = 262144, S = 400, random, T = 1 2; --whole: FIRE until max |F| < 1e-6,
    jammed.generate's criterion, instead of S steps: a whole minimisation; --fire: FIRE's
    parameters other than ``fire.FireParameters``' defaults, e.g. --fire alpha_start=0.25 n_min=20)

Start ``random``: the start of ``jammed.generate`` (phi = 0.9, seed [1, 0], bidisperse disks),
where FIRE's first steps move the disks far and the neighbour list is rebuilt often.  Start
``jammed``: the steady state of FIRE's long end near jamming, which is most of a large
minimisation's steps: the jammed 16384-disk packing of ``benchlib.load_packing`` tiled k x k
times (N = 16384 k^2; a tiling of a force-balanced periodic packing is force-balanced), each disk
moved by a uniform random vector of up to 0.01 d0 (seed 2).  Each (N, T) runs FIRE in a fresh
process with NUMBA_NUM_THREADS = T (numba's pool is made at its first parallel call, with that
many threads), one BLAS thread, for S steps (the force tolerance unreachable, so every step is
taken) or to convergence; the end positions of every T must be equal bit for bit (column
bit_for_bit, against T's first).  Per row: steps, seconds, ns per disk-step, the force engine's
share (the pair forces and the neighbour list, timed inside the same run), and the process's CPU
seconds over its wall seconds ("cores_busy": 2 when both cores work all the time).  Writes
scripts/benchmarks/records/fire_step.json (merged with the rows of before; rows before
2026-12-06 compared numpy's vector updates with the compiled ones, column "code", a comparison
the code no longer has).
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import os
import sys
import time

import solver  # noqa: F401  before numpy: one OpenBLAS thread, as in a run (solver/__init__.py)

import numpy as np

from scripts.benchmarks.benchlib import PY, load_packing, run_json, save
from solver.packing import fire, geometry, jammed, mechanics

BENCH = {"order": 25, "args": ["131072", "--steps", "200"]}


class Timed:
    """A force engine that adds up the time spent in it."""

    def __init__(self, engine):
        self.engine, self.seconds = engine, 0.0

    def __call__(self, x):
        t = time.perf_counter()
        try:
            return self.engine(x)
        finally:
            self.seconds += time.perf_counter() - t


def random_start(n: int):
    """(start (n, 2), diameters (n,), box (2,)) of ``jammed.generate`` at phi = 0.9, seed [1, 0]."""
    rng = np.random.default_rng(np.random.SeedSequence([1, 0]))
    diameters = rng.permutation(jammed.bidisperse_diameters(n))
    box = np.full(2, jammed.box_length_for(diameters, 0.9, 2))
    start = rng.uniform(0.0, box[0], size=(n, 2))
    return start[jammed.spatial_order(start, box)], diameters, box


TILE = 16384


def jammed_start(n: int):
    """(start, diameters, box): ``load_packing(16384)`` tiled k x k (n = 16384 k^2), each disk
    moved by up to 0.01 d0 (seed 2), in spatial order."""
    k = int(round(np.sqrt(n / TILE)))
    if TILE * k * k != n:
        raise SystemExit(f"--start jammed takes N = {TILE} k^2 (k = 1, 2, ...), not {n}")
    tile = load_packing(TILE)
    shifts = np.array([(i, j) for i in range(k) for j in range(k)], dtype=float) * tile.box
    start = (tile.positions[None, :, :] + shifts[:, None, :]).reshape(-1, 2)
    start += np.random.default_rng(2).uniform(-0.01, 0.01, size=start.shape)
    box = k * tile.box
    diameters = np.tile(tile.diameters, k * k)
    order = jammed.spatial_order(geometry.wrap(start, box), box)
    return start[order], diameters[order], box


def parameters(pairs: list[str]) -> fire.FireParameters:
    """FireParameters with the NAME=VALUE ``pairs`` changed (each value of its field's type)."""
    types = {field.name: type(field.default) for field in dataclasses.fields(fire.FireParameters)}
    changed = {}
    for pair in pairs:
        name, _, value = pair.partition("=")
        if name not in types:
            raise SystemExit(f"--fire {pair}: no FIRE parameter {name} (there are {', '.join(types)})")
        changed[name] = value in ("1", "true", "True") if types[name] is bool else types[name](value)
    return fire.FireParameters(**changed)


def child(n: int, start_name: str, force_tol: float, steps: int, params: fire.FireParameters) -> None:
    """One FIRE run on this process's threads; prints one JSON line."""
    import numba

    start, diameters, box = (random_start if start_name == "random" else jammed_start)(n)
    engine = Timed(mechanics.FrictionlessForces(diameters, box))
    engine(start)  # the first list and numba's first calls (compiling or loading), outside the timing
    fire.minimize(start[:TILE], mechanics.FrictionlessForces(diameters[:TILE], box), 0.0, 2, params)
    engine.seconds = 0.0
    cpu, t = os.times(), time.perf_counter()
    result = fire.minimize(start, engine, force_tol, steps, params)
    seconds, used = time.perf_counter() - t, os.times()
    print(json.dumps({"threads": numba.get_num_threads(), "steps": result.steps, "converged": result.converged,
                      "s": seconds, "cores_busy": (used.user + used.system - cpu.user - cpu.system) / seconds,
                      "neighbour_rebuilds": engine.engine.rebuilds, "neighbour_refreshes": engine.engine.refreshes,
                      "force_engine_share": engine.seconds / seconds,
                      "end": hashlib.sha256(result.x.tobytes()).hexdigest()[:16]}))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("n", type=int, nargs="*", default=[262144])
    parser.add_argument("--steps", type=int, default=400)
    parser.add_argument("--start", choices=("random", "jammed"), default="random")
    parser.add_argument("--whole", action="store_true",
                        help="FIRE to jammed.generate's force tolerance (1e-6) instead of S steps")
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--fire", nargs="*", default=[], metavar="NAME=VALUE")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    force_tol, steps = (1e-6, 2_000_000) if args.whole else (0.0, args.steps)
    params = parameters(args.fire)
    if args.child:
        child(args.n[0], args.start, force_tol, steps, params)
        return
    table = []
    for n in args.n:
        first = None
        for threads in args.threads:
            cmd = [PY, "-m", "scripts.benchmarks.bench_fire_step", str(n), "--steps", str(args.steps), "--start",
                   args.start, *(["--whole"] if args.whole else []), "--fire", *args.fire, "--child"]
            out = run_json(cmd, timeout=6 * 3600, env={**os.environ, "NUMBA_NUM_THREADS": str(threads)})
            end = out.pop("end")
            first = first or (end, out["s"] / out["steps"])
            table.append({"N": n, "start": args.start, "fire": " ".join(args.fire) or "defaults", **out,
                          "s_per_step": out["s"] / out["steps"], "ns_per_disk_step": 1e9 * out["s"] / out["steps"] / n,
                          "bit_for_bit": end == first[0], "speedup": first[1] / (out["s"] / out["steps"])})
    table = [{k: float(f"{v:.4g}") if isinstance(v, float) else v for k, v in row.items()} for row in table]
    save("fire_step", "python -m scripts.benchmarks.bench_fire_step " + " ".join(sys.argv[1:]), table,
         merge_by=("N", "start", "threads", "fire", "converged"))


if __name__ == "__main__":
    main()
