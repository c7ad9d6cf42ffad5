"""FIRE's cost per disk-step (issue 48 point 3: a 10^6-disk packing): the compiled vector updates
(``packing.fire_steps``) and Verlet-list check (``pair_forces.largest_squared_move``) against the
numpy expressions they replaced, in the same run, from the same start, and where a step's time
goes.  One BLAS thread, as in a run: ``solver`` is
imported before numpy (records before 2026-11-28T11:10 had OpenBLAS's two threads in FIRE's
three dot products).

    python -m scripts.benchmarks.bench_fire_step [N ...] [--steps S] [--start random|jammed] [--whole]
    (defaults: N = 262144, S = 400, random; --whole: FIRE until max |F| < 1e-6, jammed.generate's
    criterion, instead of S steps: a whole minimisation, before and after)

Start ``random``: the start of ``jammed.generate`` (phi = 0.9, seed [1, 0], bidisperse disks),
where FIRE's first steps move the disks far and the neighbour list is rebuilt often.  Start
``jammed``: the steady state of FIRE's long end near jamming, which is most of a large
minimisation's steps: the jammed 16384-disk packing of ``benchlib.load_packing`` tiled k x k
times (N = 16384 k^2; a tiling of a force-balanced periodic packing is force-balanced), each disk
moved by a uniform random vector of up to 0.01 d0 (seed 2).  FIRE for S steps
(the force tolerance unreachable, so every step is taken) with each version of the code, one
core, one BLAS thread; the two end positions must be equal bit for bit.  Per version: seconds per
step, ns per disk-step, and the force engine's share (the pair forces and the neighbour list,
timed inside the same run).  Writes scripts/benchmarks/records/fire_step.json.
"""

from __future__ import annotations

import argparse
import sys
import time

import solver  # noqa: F401  before numpy: one OpenBLAS thread, as in a run (solver/__init__.py)

import numpy as np

from scripts.benchmarks.benchlib import load_packing, save
from solver.packing import fire, fire_steps, geometry, jammed, mechanics

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

    @staticmethod
    def largest_squared_move(x, reference):
        """The Verlet list's check (``pair_forces.largest_squared_move``) as numpy did it."""
        step = x - reference
        return np.einsum("nd,nd->n", step, step).max()


def numpy_minimize(x0, forces, force_tol, steps):
    """``fire.minimize`` with :class:`NumpySteps` for the compiled updates and the force engine's
    (``forces.engine``) compiled list check; its FireResult."""
    forces.engine.largest_squared_move = NumpySteps.largest_squared_move
    saved = {name: getattr(fire_steps, name) for name in ("largest_squared_force", "kick", "mix_and_move", "move")}
    try:
        for name in saved:
            setattr(fire_steps, name, getattr(NumpySteps, name))
        return fire.minimize(x0, forces, force_tol, steps)
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


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("n", type=int, nargs="*", default=[262144])
    parser.add_argument("--steps", type=int, default=400)
    parser.add_argument("--start", choices=("random", "jammed"), default="random")
    parser.add_argument("--whole", action="store_true",
                        help="FIRE to jammed.generate's force tolerance (1e-6) instead of S steps")
    args = parser.parse_args()
    force_tol, steps = (1e-6, 2_000_000) if args.whole else (0.0, args.steps)
    table = []
    for n in args.n:
        start, diameters, box = (random_start if args.start == "random" else jammed_start)(n)
        ends = {}
        for name, run in (("numpy updates and check (before)", lambda s, e: numpy_minimize(s, e, force_tol, steps)),
                          ("compiled updates and check", lambda s, e: fire.minimize(s, e, force_tol, steps))):
            engine = Timed(mechanics.FrictionlessForces(diameters, box))
            engine(start)  # the first list and numba's first call, outside the timing
            engine.seconds = 0.0
            t = time.perf_counter()
            result = run(start, engine)
            seconds = time.perf_counter() - t
            ends[name] = result.x
            table.append({"N": n, "start": args.start, "code": name, "steps": result.steps,
                          "converged": result.converged, "s": seconds,
                          "neighbour_rebuilds": engine.engine.rebuilds, "neighbour_refreshes": engine.engine.refreshes,
                          "s_per_step": seconds / result.steps, "ns_per_disk_step": 1e9 * seconds / result.steps / n,
                          "force_engine_share": engine.seconds / seconds})
        table[-1]["bit_for_bit"] = table[-2]["bit_for_bit"] = bool(np.array_equal(*ends.values()))
        table[-1]["speedup"] = table[-2]["s_per_step"] / table[-1]["s_per_step"]
    table = [{k: float(f"{v:.4g}") if isinstance(v, float) else v for k, v in row.items()} for row in table]
    save("fire_step", "python -m scripts.benchmarks.bench_fire_step " + " ".join(sys.argv[1:]), table,
         merge_by=("N", "start", "code", "converged"))


if __name__ == "__main__":
    main()
