"""FIRE's cost per disk-step (issue 48 point 3: a 10^6-disk packing): the compiled vector updates
(``packing.fire_steps``) against the numpy expressions they replaced, in the same run, from the
same start, and where a step's time goes.

    python -m benchmarks.bench_fire_step [N ...] [--steps S]   (defaults: N = 262144, S = 400)

The start of ``jammed.generate`` (phi = 0.9, seed [1, 0], bidisperse disks), FIRE for S steps
(the force tolerance unreachable, so every step is taken) with each version of the updates, one
core, one BLAS thread; the two end positions must be equal bit for bit.  Per version: seconds per
step, ns per disk-step, and the force engine's share (the pair forces and the neighbour list,
timed inside the same run).  Writes benchmarks/records/fire_step.json.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from benchmarks.benchlib import save
from solver.packing import fire, fire_steps, jammed, mechanics

BENCH = {"order": 25, "args": ["131072", "--steps", "200"]}


class NumpySteps:
    """The numpy expressions ``packing.fire_steps`` replaced (named in its docstrings), put in its
    place while ``fire.minimize`` runs: the same algorithm, the previous updates."""

    @staticmethod
    def largest_squared_force(f):
        return np.max(np.sum(f * f, axis=1))

    @staticmethod
    def kick(v, f, dt):
        v += dt * f

    @staticmethod
    def mix_and_move(x, v, f, keep, push, dt):
        v[:] = keep * v + push * f
        x += dt * v

    @staticmethod
    def move(x, v, dt):
        x += dt * v


def numpy_minimize(x0, forces, steps):
    """``fire.minimize`` with :class:`NumpySteps` for the compiled updates; end positions."""
    saved = {name: getattr(fire_steps, name) for name in ("largest_squared_force", "kick", "mix_and_move", "move")}
    try:
        for name in saved:
            setattr(fire_steps, name, getattr(NumpySteps, name))
        return fire.minimize(x0, forces, 0.0, steps).x
    finally:
        for name, function in saved.items():
            setattr(fire_steps, name, function)


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


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("n", type=int, nargs="*", default=[262144])
    parser.add_argument("--steps", type=int, default=400)
    args = parser.parse_args()
    table = []
    for n in args.n:
        rng = np.random.default_rng(np.random.SeedSequence([1, 0]))
        diameters = rng.permutation(jammed.bidisperse_diameters(n))
        box = np.full(2, jammed.box_length_for(diameters, 0.9, 2))
        start = rng.uniform(0.0, box[0], size=(n, 2))
        start = start[jammed.spatial_order(start, box)]
        ends = {}
        for name, run in (("numpy updates (before)", lambda s, e: numpy_minimize(s, e, args.steps)),
                          ("compiled updates", lambda s, e: fire.minimize(s, e, 0.0, args.steps).x)):
            engine = Timed(mechanics.FrictionlessForces(diameters, box))
            engine(start)  # the first list and numba's first call, outside the timing
            engine.seconds = 0.0
            t = time.perf_counter()
            ends[name] = run(start, engine)
            seconds = time.perf_counter() - t
            table.append({"N": n, "code": name, "steps": args.steps, "s_per_step": seconds / args.steps,
                          "ns_per_disk_step": 1e9 * seconds / args.steps / n,
                          "force_engine_share": engine.seconds / seconds})
        table[-1]["bit_for_bit"] = table[-2]["bit_for_bit"] = bool(np.array_equal(*ends.values()))
        table[-1]["speedup"] = table[-2]["s_per_step"] / table[-1]["s_per_step"]
    table = [{k: float(f"{v:.4g}") if isinstance(v, float) else v for k, v in row.items()} for row in table]
    save("fire_step", "python -m benchmarks.bench_fire_step " + " ".join(sys.argv[1:]), table)


if __name__ == "__main__":
    main()
