"""Where the memory and the time of the chain go as N grows (issue 26, "measure first").

    python scripts/bench_scaling.py N [N ...] [--ranks P [P ...]] [--skip STAGE ...] [--tag TAG]
                                    [--shuffle] [--factor-ranks G]
    (e.g. 131072 262144 --ranks 1 2; --ranks 4 oversubscribes this 2-core machine: memory only)
--shuffle lists the packing's particles in a random order (seed 11) before anything else, as a DEM
file lists them (by id), so that the assembly row shows what the matrix's particle order makes of
it; --factor-ranks G shares each counting factorisation among G ranks (``spectrum.factor_ranks``;
without it, the code's default: a factor per rank).  Rows carry "shuffled" and "factor_ranks".

One row per (N, ranks, stage), each (N, ranks) in its own fresh ``mpirun`` job on the packing of
``benchlib.load_packing(N)`` (2D disks, phi = 0.9, seed [1, 0], rotsound's FIRE on one core; the
time to make it is its own row, ranks = 1, stage "packing (FIRE)", measured once per N when the
cached file is made).  rho = 1, harmonic law.  Stages, in this order, on COMM_WORLD:
  read        every rank reads the packing file (``hdf5.read_packings``: the whole packing);
  assembly    ``dynmat.assemble`` (contacts, blocks, the PETSc matrix) and the Lanczos omega_max;
  counting    ``spectrum.counting.solve`` (bin 0.05/t0): the exact vDOS by Sylvester inertias;
  kpm         ``spectrum.kpm.solve`` with K/Q (16 probes, automatic moments, seed 1);
  waves       ``waves.spectral.spectral``: one L, one TR and one RT wave at the smallest k along x,
              t_end = 200, samples every 1 t0 (tol 1e-8).
Per stage: wall time (max over ranks, after a barrier) and peak RSS of each rank *during the
stage* (the kernel's high-water mark VmHWM, reset by writing 5 to /proc/self/clear_refs before it;
"rss max/rank" is the largest rank's, "rss sum" the job's), and the RSS each rank holds when the
stage starts ("held").  The matrix's row for assembly also gives the off-process share of its
non-zeros (columns outside the rank's own rows, summed over ranks) and MatMult time (100 products).
``-log_view`` of every job goes to results/bench/scaling_logs/N<N>_p<P>.txt (log stages per
stage above: PETSc's own count of flops, messages and time).
Writes results/bench/scaling<TAG>.json (merged by N, ranks and stage) after every job.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np
from benchlib import PY, REPO, load_packing, mpirun, run_json, save

ME = str(REPO / "scripts" / "bench_scaling.py")
LOGS = REPO / "results" / "bench" / "scaling_logs"
STAGES = ("read", "assembly", "counting", "kpm", "waves")
LOG_STAGES = {"read": "packings", "assembly": "assembly", "counting": "spectrum", "kpm": "kpm", "waves": "waves"}
"""Each stage's PETSc log stage (``profiling.STAGES``) in -log_view."""
BIN, ZERO_TOL, PROBES, T_END = 0.05, 1e-4, 16, 200.0


def reset_peak() -> None:
    """Start a new high-water mark of this process's RSS (Linux: clear_refs 5)."""
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")


def status_gib(key: str) -> float:
    """VmHWM or VmRSS of this process, GiB."""
    for line in open("/proc/self/status"):
        if line.startswith(key + ":"):
            return int(line.split()[1]) / 2**20
    raise KeyError(key)


def off_process_share(A) -> tuple[int, int]:
    """(non-zeros of this rank's rows, those in columns owned by other ranks). Not collective."""
    start, stop = A.getOwnershipRange()
    _, cols, _ = A.getValuesCSR()
    return int(cols.size), int(np.count_nonzero((cols < start) | (cols >= stop)))


def case(n: int, skip: set[str], shuffle: bool, factor_ranks: int | None) -> None:
    """Every stage on the packing of n disks, on COMM_WORLD; rank 0 prints one JSON line."""
    from solver import petscenv

    LOGS.mkdir(parents=True, exist_ok=True)
    size = int(os.environ.get("OMPI_COMM_WORLD_SIZE", "1"))
    tag = ("_shuffled" if shuffle else "") + (f"_g{factor_ranks}" if factor_ranks else "")
    PETSc = petscenv.init(["-log_view", f":{LOGS / f'N{n}_p{size}{tag}.txt'}"])
    from mpi4py import MPI

    from solver import profiling
    from solver.contact_law import ContactModel
    from solver.io import hdf5
    from solver.model import dynmat, operators
    from solver.spectrum import counting, kpm
    from solver.waves import excitation, spectral

    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    rows = []
    state: dict = {}

    def stage(name, work):
        if name in skip:
            return
        mpi.Barrier()
        held_gib = status_gib("VmRSS")
        reset_peak()
        t = time.perf_counter()
        with profiling.stage(LOG_STAGES[name]):
            extra = work() or {}
        seconds = mpi.allreduce(time.perf_counter() - t, op=MPI.MAX)
        peaks = mpi.gather(status_gib("VmHWM"), root=0)
        helds = mpi.gather(held_gib, root=0)
        if mpi.rank == 0:
            rows.append({"stage": name, "shuffled": shuffle, "factor_ranks": factor_ranks or 1, "seconds": seconds, "rss_max": max(peaks), "rss_sum": sum(peaks),
                         "held_max": max(helds), **extra})

    def read():
        p = hdf5.read_packings(str(REPO / "cache" / f"bench_{n}.h5"))[0]
        if shuffle:
            from solver.packing import jammed

            order = np.random.default_rng(11).permutation(p.n)
            p = jammed.from_arrays(p.positions[order], p.diameters[order], p.box, p.rattler[order], dict(p.info))
        state["p"] = p

    def assembly():
        dm = dynmat.assemble(state["p"], ContactModel(1.0), comm)
        operators.largest_omega(dm)
        state["dm"] = dm
        nnz, off = mpi.allreduce(np.array(off_process_share(dm.D)), op=MPI.SUM)
        x, y = dm.D.createVecs()
        x.set(1.0)
        mpi.Barrier()
        t = time.perf_counter()
        for _ in range(100):
            dm.D.mult(x, y)
        matmult = mpi.allreduce(time.perf_counter() - t, op=MPI.MAX) / 100
        return {"dof": dm.size, "nnz": int(nnz), "off_process": int(off) / int(nnz), "matmult_ms": 1e3 * matmult,
                "omega_max": dm.omega_max}

    def count():
        layout = {} if factor_ranks is None else {"factor_ranks": factor_ranks}
        datasets, attrs, settings = counting.solve(state["dm"], bin_width=BIN, zero_tol=ZERO_TOL, **layout)
        return {"factorisations": attrs["factorisations"], "counts_sum": int(datasets["counts"].sum()),
                "counts_digest": int(np.sum(datasets["counts"] * np.arange(1, datasets["counts"].size + 1)))}

    def stochastic():
        _, attrs = kpm.solve(state["dm"], bin_width=BIN, moments=None, probes=PROBES, with_energies=True, seed=1)
        return {"moments": attrs["moments"]}

    def waves():
        dm, p = state["dm"], state["p"]
        k = 2 * np.pi / float(p.box[0])
        times = np.arange(0.0, T_END + 0.5, 1.0)
        steps = {}
        for mode in ("L", "TR", "RT"):
            run = next(i for i, (_, axis) in enumerate(excitation.runs(mode, dm.dim)) if axis == 0)
            steps[f"lanczos_{mode}"] = spectral.spectral(dm, p.positions, mode, run, k, amplitude=1e-6,
                                                         times=times).steps
        return {"k_d0": k, **steps}

    stage("read", read)
    stage("assembly", assembly)
    stage("counting", count)
    stage("kpm", stochastic)
    stage("waves", waves)
    if "dm" in state:
        state["dm"].destroy()
    if mpi.rank == 0:
        print(json.dumps({"rows": [{k: float(f"{v:.4g}") if isinstance(v, float) else v for k, v in row.items()}
                                   for row in rows]}))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("n", type=int, nargs="+")
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--skip", nargs="*", default=[], choices=STAGES)
    parser.add_argument("--tag", default="", help="suffix of the record's name (e.g. _after)")
    parser.add_argument("--shuffle", action="store_true", help="list the particles in a random order first")
    parser.add_argument("--factor-ranks", type=int, help="ranks sharing each counting factorisation")
    parser.add_argument("--case", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case:
        case(args.n[0], set(args.skip), args.shuffle, args.factor_ranks)
        return
    for n in args.n:
        packing_file = REPO / "cache" / f"bench_{n}.h5"
        table = []
        if not packing_file.exists():
            t = time.perf_counter()
            p = load_packing(n)
            table.append({"N": n, "ranks": 1, "stage": "packing (FIRE)", "seconds": time.perf_counter() - t,
                          "fire_steps": p.info.get("fire_steps"), "rss_max": None})
        for ranks in args.ranks:
            cmd = mpirun(ranks) + (["--oversubscribe"] if ranks > (os.cpu_count() or 1) else []) + [
                PY, ME, str(n), "--case", *(["--skip", *args.skip] if args.skip else []),
                *(["--shuffle"] if args.shuffle else []),
                *(["--factor-ranks", str(args.factor_ranks)] if args.factor_ranks else [])]
            out = run_json(cmd, timeout=6 * 3600)
            table += [{"N": n, "ranks": ranks, **row} for row in out["rows"]]
            save(f"scaling{args.tag}", "python scripts/bench_scaling.py " + " ".join(sys.argv[1:]), table,
                 notes="", merge_by=("N", "ranks", "stage", "shuffled", "factor_ranks"))


if __name__ == "__main__":
    main()
