"""The Allen-Feldman diffusivity per omega bin by KPM (``transport.kpm_diffusivity``, issue 45
route 2) against route 1, the exact d_n (``transport.allen_feldman``), and alone at large N.

    python -m scripts.benchmarks.bench_transport_kpm [--ns 256 512 1024 2048] [--width 0.1] [--probes 16]
    python -m scripts.benchmarks.bench_transport_kpm --sizes 1000000 --ranks 2              # issue 45's target, 2D
    python -m scripts.benchmarks.bench_transport_kpm --sizes 1048576 --ranks 2 --engine fire --tile 8
    python -m scripts.benchmarks.bench_transport_kpm --sizes 250000 --ranks 2 --dim 3       # spheres, measured
Small N (default; one process, one core, like bench_transport.py): a FIRE packing at phi = 0.9
(seed 5), D at rho = 0.5; bins of ``--width`` (1/t0) over [0, 1.1 omega_max]; route 1 at
eta = width / pi (the Lorentzian's peak height 1 / (pi eta) equals the box's 1 / width), its d_n
averaged per bin; KPM with automatic moments and ``--probes`` probes.  Columns: seconds of each,
the bins compared ("smooth": centre in [1, 0.8 omega_max], 20 or more modes), the mean and largest
|d_kpm / d_route1 - 1| over them, the mean relative standard error d_err / d there, and how many
of them agree within 4 d_err + 25 % (the test's bound, docs/diffusivity_trace.md).
Large N (``--sizes``): each size in its own ``mpirun -n --ranks`` job on the cached benchmark
packing (2D: phi = 0.9, seed [1, 0]; 3D: phi = 0.7, rho_roll = rho_twist = 0.1, as
bench_scaling.py; ``--engine lammps``, the default there, makes a missing one with LAMMPS on the
same ranks, ``--engine fire`` with rotsound's FIRE: benchlib.load_packing and
bench_spheres.load_spheres), rho = 1, KPM alone: wall time (max over ranks; omega_max's Lanczos
included), peak RSS per rank, moments, the median and largest d_err / d over the bins holding
1 % or more of the modes, the estimated mode count against the true one.  ``--block`` probes per
recursion and ``--bins-per-pass`` bound the memory (2 nloc x block x bins float64 per rank plus
``--chunk`` T_k vectors: module docstring).  ``--tile K`` takes the packing of N / K^D particles and
repeats it K times along each axis (:func:`tiled`): a periodic supercell, as jammed as its tile,
whose cost per MatMult is that of any packing of N; it stands in for a fresh packing of N when
making one would take longer than the measurement (LAMMPS made 10^6 disks in 62 min on 2 ranks,
scripts/benchmarks/records/scaling_after.json).  Its d(omega) is that of the tile's disorder; its
statistical error is what N modes give.
Writes scripts/benchmarks/records/transport_kpm.json (rows merged by N, dim and ranks).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads OpenBLAS: one core, as a rank
import numpy as np  # noqa: E402

from scripts.benchmarks.benchlib import PY, mpirun, peak_rss_gib, run_json, save  # noqa: E402

BENCH = {"order": 240}  # make bench: its place (scripts/benchmarks/bench_all.py)
ME = ["-m", __spec__.name if __spec__ else "scripts.benchmarks.bench_transport_kpm"]
SIGMAS, BROADENING = 4.0, 0.25  # the route-1 comparison's bound: 4 d_err + 25 % (tests/transport)


def small(args) -> None:
    """Route 1 against KPM at each of ``args.ns`` in this process (COMM_WORLD)."""
    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.model.operators import largest_omega
    from solver.packing import jammed
    from solver.transport import allen_feldman, kpm_diffusivity

    PETSc = petscenv.init([])
    from mpi4py import MPI  # after PETSc started MPI

    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    table = []
    for n in args.ns:
        p = jammed.generate(n, 0.9, np.random.SeedSequence([5, 0]))
        dm = dynmat.assemble(p, ContactModel(0.5), comm)
        w = largest_omega(dm)
        edges = np.arange(0.0, 1.1 * w + args.width, args.width)
        mpi.Barrier()
        t0 = time.perf_counter()
        datasets, attrs = kpm_diffusivity.binned_diffusivity(dm, p.positions, p.box, edges, moments=args.moments,
                                                             probes=args.probes, seed=1, comm=comm, chunk=args.chunk)
        t_kpm = mpi.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        t0 = time.perf_counter()
        omega, d = allen_feldman.allen_feldman(dm, p.positions, p.box, args.width / math.pi, comm)
        t_af = mpi.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        count = np.histogram(omega, edges)[0]
        route1 = np.histogram(omega, edges, weights=d)[0] / np.maximum(count, 1)
        centre = 0.5 * (edges[1:] + edges[:-1])
        smooth = (centre >= 1.0) & (centre <= 0.8 * w) & (count >= 20) & np.isfinite(datasets["d"])
        rel = np.abs(datasets["d"][smooth] / route1[smooth] - 1)
        within = np.abs(datasets["d"] - route1)[smooth] <= SIGMAS * datasets["d_err"][smooth] + BROADENING * route1[smooth]
        row = {"N": n, "dim": 2, "ranks": comm.getSize(), "modes": int(omega.size), "bins": int(edges.size - 1),
               "moments": attrs["moments"], "probes": args.probes, "KPM s": f"{t_kpm:.1f}", "route 1 s": f"{t_af:.1f}",
               "smooth bins": int(smooth.sum()), "mean |d_kpm/d_1 - 1|": f"{rel.mean():.3f}",
               "largest |d_kpm/d_1 - 1|": f"{rel.max():.3f}",
               "mean d_err/d": f"{np.mean(datasets['d_err'][smooth] / datasets['d'][smooth]):.3f}",
               "within 4 d_err + 25 %": f"{int(within.sum())}/{int(smooth.sum())}",
               "peak RSS GiB": f"{mpi.allreduce(peak_rss_gib(), op=MPI.MAX):.2f}"}
        table.append(row)
        if comm.getRank() == 0:
            print(row, flush=True)
        dm.destroy()
    if comm.getRank() == 0:
        save("transport_kpm", "python -m scripts.benchmarks.bench_transport_kpm " + " ".join(
            ["--ns", *map(str, args.ns), "--width", f"{args.width:g}", "--probes", str(args.probes)]), table,
            f"2D FIRE packings at phi = 0.9 (seed 5), rho = 0.5, bins of {args.width:g}/t0, route 1 at eta = width/pi; "
            "one process, one core each; KPM with automatic moments (Jackson smearing half a bin at omega = 1).",
            merge_by=("N", "dim", "ranks"))


def packing(n: int, dim: int, engine: str):
    """The cached benchmark packing of n disks (dim 2) or spheres (3); made if absent (LAMMPS on
    this job's ranks, or rotsound's FIRE on rank 0 of a fresh process).  Collective."""
    from mpi4py import MPI

    from scripts.benchmarks import bench_scaling
    from solver.io import hdf5

    path = bench_scaling.packing_file(n, engine, dim)
    if engine == "lammps":
        if not path.exists():
            bench_scaling.make_lammps_packing(n, dim)
        MPI.COMM_WORLD.Barrier()
        return hdf5.read_packings(str(path))[0]
    if dim == 2:
        from scripts.benchmarks.benchlib import load_packing as load
    else:
        from scripts.benchmarks.bench_spheres import load_spheres as load
    comm = MPI.COMM_WORLD
    p = load(n) if comm.rank == 0 else None  # rank 0 makes the file if absent, then the others read it
    comm.Barrier()
    return p if comm.rank == 0 else load(n)


def tiled(p, copies: int):
    """Packing ``p`` repeated ``copies`` times along each axis: a periodic supercell of copies^D
    tiles, jammed and at rest as its tile is (every contact across the tile's seam is a contact
    between neighbouring tiles).  Not collective."""
    from solver.packing.configuration import Packing

    shifts = np.stack(np.meshgrid(*[np.arange(copies)] * p.dim, indexing="ij"), -1).reshape(-1, p.dim) * p.box
    return Packing((p.positions[None] + shifts[:, None]).reshape(-1, p.dim), np.tile(p.diameters, len(shifts)),
                   p.box * copies, np.tile(p.rattler, len(shifts)), dict(p.info), model=p.model)


def large_case(argv: list[str]) -> None:
    """One large-N job on COMM_WORLD (``--case N DIM ENGINE WIDTH PROBES MOMENTS BLOCK BINS CHUNK
    TILE``: N particles, or with TILE > 1 the packing of N / TILE^DIM tiled TILE^DIM times);
    rank 0 prints one JSON line."""
    n, dim, engine, width, probes, moments, block, per_pass, chunk, tile = argv
    n, dim, probes, moments, block, chunk = int(n), int(dim), int(probes), int(moments), int(block), int(chunk)
    tile = int(tile)
    width, per_pass = float(width), int(per_pass) or None
    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.model.operators import largest_omega
    from solver.transport import kpm_diffusivity

    PETSc = petscenv.init([])
    from mpi4py import MPI

    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    p = packing(n // tile**dim, dim, engine) if tile > 1 else packing(n, dim, engine)
    if tile > 1:
        p = tiled(p, tile)
    t0 = time.perf_counter()
    dm = dynmat.assemble(p, ContactModel(1.0) if dim == 2 else ContactModel(1.0, 0.1, 0.1), comm)
    t_assemble = mpi.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    mpi.Barrier()
    t0 = time.perf_counter()
    w = largest_omega(dm)
    edges = np.arange(0.0, 1.1 * w + width, width)
    datasets, attrs = kpm_diffusivity.binned_diffusivity(dm, p.positions, p.box, edges, moments=moments or None,
                                                         probes=probes, seed=1, comm=comm, block=block,
                                                         bins_per_pass=per_pass, chunk=chunk)
    seconds = mpi.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    rss = mpi.allreduce(peak_rss_gib(), op=MPI.MAX)
    count, d, d_err = datasets["count"], datasets["d"], datasets["d_err"]
    held = (count >= 0.01 * attrs["n_modes"]) & np.isfinite(d)
    rel = d_err[held] / d[held]
    if comm.getRank() == 0:
        print(json.dumps({"N": p.n, "tile": tile, "dim": dim, "ranks": comm.getSize(), "DOF": dm.size, "bins": int(edges.size - 1),
                          "moments": attrs["moments"], "probes": probes, "assembly_s": t_assemble, "seconds": seconds,
                          "rss": rss, "median_rel_err": float(np.median(rel)), "max_rel_err": float(rel.max()),
                          "count": float(count.sum()), "modes": attrs["n_modes"], "omega_max": w,
                          "d": [float(x) for x in d], "d_err": [float(x) for x in d_err]}))


def large(args) -> None:
    """Each of ``args.sizes`` in its own mpirun job (:func:`large_case`); the record's rows."""
    table = []
    for n in args.sizes:
        r = run_json(mpirun(args.ranks) + [PY, *ME, "--case", str(n), str(args.dim), args.engine, f"{args.width:g}",
                                           str(args.probes), str(args.moments or 0), str(args.block),
                                           str(args.bins_per_pass or 0), str(args.chunk), str(args.tile)],
                     timeout=4 * 3600)
        table.append({"N": r["N"], "packing": f"{n // args.tile ** args.dim} tiled {args.tile}^{args.dim}"
                      if args.tile > 1 else args.engine, "dim": r["dim"], "ranks": r["ranks"], "modes": r["modes"], "bins": r["bins"],
                      "moments": r["moments"], "probes": r["probes"], "KPM s": f"{r['seconds']:.1f}",
                      "assembly s": f"{r['assembly_s']:.1f}", "peak RSS GiB (largest rank)": f"{r['rss']:.2f}",
                      "median d_err/d": f"{r['median_rel_err']:.4f}", "largest d_err/d": f"{r['max_rel_err']:.4f}",
                      "count / modes": f"{r['count'] / r['modes']:.4f}"})
        print(table[-1], flush=True)
    save("transport_kpm", "python -m scripts.benchmarks.bench_transport_kpm " + " ".join(
        ["--sizes", *map(str, args.sizes), "--ranks", str(args.ranks), "--dim", str(args.dim), "--width",
         f"{args.width:g}", "--probes", str(args.probes), "--engine", args.engine]
        + (["--tile", str(args.tile)] if args.tile > 1 else [])), table,
        "large N: KPM alone (no route 1), rho = 1 (3D: rho_roll = rho_twist = 0.1), bins of the given width; the "
        "relative errors over the bins holding 1 % or more of the modes.", merge_by=("N", "dim", "ranks"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ns", type=int, nargs="+", default=[256, 512, 1024, 2048], help="small N, with route 1")
    parser.add_argument("--sizes", type=int, nargs="+", help="large N, KPM alone, each in an mpirun job")
    parser.add_argument("--ranks", type=int, default=2)
    parser.add_argument("--dim", type=int, choices=(2, 3), default=2)
    parser.add_argument("--engine", choices=("fire", "lammps"), default="lammps", help="large N: packing maker")
    parser.add_argument("--width", type=float, default=0.1, help="omega bin width (1/t0)")
    parser.add_argument("--probes", type=int, default=None, help="default 16 (small N), 4 (large N)")
    parser.add_argument("--moments", type=int, default=None, help="default: automatic")
    parser.add_argument("--block", type=int, default=1, help="large N: probes per recursion")
    parser.add_argument("--bins-per-pass", type=int, default=None, help="large N: bins per pass (memory)")
    parser.add_argument("--chunk", type=int, default=32, help="T_k vectors per dgemm")
    parser.add_argument("--tile", type=int, default=1, help="large N: tile the packing of N / TILE^DIM particles "
                                                              "TILE times along each axis")
    args = parser.parse_args()
    if args.sizes:
        args.probes = args.probes or 4
        large(args)
    else:
        args.probes = args.probes or 16
        small(args)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--case"]:
        large_case(sys.argv[2:])
    else:
        main()
