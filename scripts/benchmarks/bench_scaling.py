"""Where the memory and the time of the chain go as N grows (issue 26, "measure first").

    python -m scripts.benchmarks.bench_scaling N [N ...] [--ranks P [P ...]] [--skip STAGE ...] [--tag TAG]
                                       [--shuffle] [--factor-ranks G] [--engine fire|lammps] [--dim 2|3]
                                       [--blr EPS] [--ordering ICNTL7]
    (e.g. 131072 262144 --ranks 1 2; --ranks 4 oversubscribes this 2-core machine: memory only;
     1000000 --engine lammps --skip counting: the 10^6-disk chain on LAMMPS's packing)
--shuffle lists the packing's particles in a random order (seed 11) before anything else, as a DEM
file lists them (by id), so that the assembly row shows what the matrix's particle order makes of
it; --factor-ranks G shares each counting factorisation among G ranks (``spectrum.factor_ranks``;
without it, the code's default: a factor per rank); --blr EPS factorises with MUMPS's block low-rank
compression at dropping parameter EPS (the factorisation stage then also reports the compressed
factor's entries, INFOG 35; counts are no longer exact: ``counting`` module docstring).  Rows carry
"shuffled", "factor_ranks" and "blr"; --ordering sets MUMPS's ordering (ICNTL 7: 2 AMF, 4 PORD, ...; row
"ordering", empty for MUMPS's own choice).

One row per (N, ranks, stage), each (N, ranks) in its own fresh ``mpirun`` job on the packing of
``benchlib.load_packing(N)`` (2D disks, phi = 0.9, seed [1, 0], rotsound's FIRE on one core; the
time to make it is its own row, ranks = 1, stage "packing (FIRE)", measured once per N when the
cached file is made).  With ``--engine lammps`` the same start is minimised by LAMMPS on 2 ranks
(``jammed.generate(engine="lammps")``, row "packing (LAMMPS)", cache/bench_<N>_lammps.h5); with
``--dim 3`` the packing is of spheres at phi = 0.7 (LAMMPS only here; rotsound's FIRE makes
bench_spheres' files) and the model has rolling and twisting springs (rho_roll = rho_twist = 0.1).
rho = 1, harmonic law.  Stages, in this order, on COMM_WORLD:
  read        every rank reads the packing file (``hdf5.read_packings``: the whole packing);
  assembly    ``dynmat.assemble`` (contacts, blocks, the PETSc matrix) and the Lanczos omega_max;
  factorisation  two MUMPS Cholesky factorisations of A - sigma I (A = M^-1/2 D M^-1/2; sigma =
              0.25 and 0.5 /t0^2), the counting method's unit of work, on groups of --factor-ranks
              ranks (default one per rank, as counting's auto chooses while a whole factor fits):
              seconds of the first (with the symbolic analysis) and of the second (numeric only), the
              counts below
              them (first_below, second_below: equal in every exact layout), the factor's
              entries (INFOG(29)) over A's lower triangle ("fill") and MUMPS's memory (INFOG(17)
              estimated, INFOG(22) used; MB summed over a group's ranks); how many edges an hour
              buys where counting itself is too long to run.  MUMPS's working memory is capped at
              80 % of the node's available memory per rank (ICNTL 23): a factor that would not fit
              stops after the analysis, and the row has fits = False with the analysis's estimates
              (INFOG 20 entries, INFOG 16 / 17 MB on the largest rank / in all);
  counting    ``spectrum.counting.solve`` (bin 0.05/t0): the exact vDOS by Sylvester inertias;
  kpm         ``spectrum.kpm.solve`` with K/Q (16 probes, automatic moments, seed 1); with counting
              in the same job, the L1 distance of its density from counting's ("l1_vs_counting");
  waves       ``waves.spectral.spectral``: one L, one TR and one RT wave at the smallest k along x,
              t_end = 200, samples every 1 t0 (tol 1e-8).
Per stage: wall time (max over ranks, after a barrier) and peak RSS of each rank *during the
stage* (the kernel's high-water mark VmHWM, reset by writing 5 to /proc/self/clear_refs before it;
"rss max/rank" is the largest rank's, "rss sum" the job's), and the RSS each rank holds when the
stage starts ("held", after glibc's malloc_trim returned the heap's free pages: a stage's freed
temporaries are not held, the next stage would reuse them), and the largest rank's RSS in mapped
files at the stage's end ("file": the libraries' pages, one physical copy per node however many
ranks map them, so rss - file is what a rank holds privately).  The matrix's row for assembly
also gives the off-process share of its non-zeros (columns outside the rank's own rows, summed
over ranks) and MatMult time (100 products).
``-log_view`` of every job goes to results/bench/scaling_logs/N<N>_p<P>.txt (log stages per
stage above: PETSc's own count of flops, messages and time).
Writes scripts/benchmarks/records/scaling<TAG>.json (merged by N, ranks, stage and the options above) after every job.
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import json
import os
import sys
import time

import h5py
import numpy as np

from scripts.benchmarks.benchlib import PY, REPO, l1_error, load_packing, mpirun, run_json, save

# make bench (scripts/benchmarks/bench_all.py): the code as it is now, record scaling_after, under the scaling
# measured before issue 26's changes (record scaling, kept as measured)
BENCH = {"order": 220, "args": ["131072", "262144", "--ranks", "1", "2", "4", "--tag", "_after"],
         "record": "scaling_after", "also": ["scaling"]}
ME = ["-m", __spec__.name]  # this benchmark again, in a fresh process (run_json runs it from the repository root)
LOGS = REPO / "results" / "bench" / "scaling_logs"
STAGES = ("read", "assembly", "factorisation", "counting", "kpm", "waves")
LOG_STAGES = {"read": "packings", "assembly": "assembly", "factorisation": "spectrum", "counting": "spectrum",
              "kpm": "kpm", "waves": "waves"}
"""Each stage's PETSc log stage (``profiling.STAGES``) in -log_view."""
BIN, ZERO_TOL, PROBES, T_END = 0.05, 1e-4, 16, 200.0


def reset_peak() -> None:
    """Return the heap's free pages to the system (glibc malloc_trim: what the stages before freed,
    which glibc otherwise keeps, so that "held" is what the rank holds), then start a new
    high-water mark of this process's RSS (Linux: clear_refs 5)."""
    gc.collect()
    ctypes.CDLL("libc.so.6").malloc_trim(0)
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")


def status_gib(key: str) -> float:
    """VmHWM, VmRSS, RssAnon or RssFile of this process, GiB."""
    for line in open("/proc/self/status"):
        if line.startswith(key + ":"):
            return int(line.split()[1]) / 2**20
    raise KeyError(key)


def off_process_share(A) -> tuple[int, int]:
    """(non-zeros of this rank's rows, those in columns owned by other ranks). Not collective."""
    start, stop = A.getOwnershipRange()
    _, cols, _ = A.getValuesCSR()
    return int(cols.size), int(np.count_nonzero((cols < start) | (cols >= stop)))


PHI = {2: 0.9, 3: 0.7}
"""The packings' area or volume fraction (benchlib.load_packing's and bench_spheres' values)."""


def packing_file(n: int, engine: str, dim: int = 2):
    """The cached packing of n disks or spheres made by ``engine`` (2D fire: benchlib.load_packing's file)."""
    name = "bench" if dim == 2 else "bench_spheres"
    return REPO / "cache" / (f"{name}_{n}.h5" if engine == "fire" else f"{name}_{n}_{engine}.h5")


def model(dim: int):
    """The contact model: rho = 1; in 3D also rolling and twisting springs (0.1 kn, as bench_spheres)."""
    from solver.contact_law import ContactModel

    return ContactModel(1.0) if dim == 2 else ContactModel(1.0, 0.1, 0.1)


def make_lammps_packing(n: int, dim: int) -> None:
    """jammed.generate's packing of n disks or spheres (PHI, seed [1, 0]) by LAMMPS on COMM_WORLD;
    rank 0 writes it and prints one JSON line with the steps and the wall time."""
    from mpi4py import MPI

    from solver.io import hdf5
    from solver.packing import jammed

    comm = MPI.COMM_WORLD
    comm.Barrier()
    t = time.perf_counter()
    p = jammed.generate(n, PHI[dim], np.random.SeedSequence([1, 0]), dim=dim, engine="lammps", comm=comm)
    seconds = comm.allreduce(time.perf_counter() - t, op=MPI.MAX)
    if comm.rank == 0:
        hdf5.save_packings(str(packing_file(n, "lammps", dim)), [p])
        print(json.dumps({"seconds": seconds, "fire_steps": p.info["fire_steps"], "z": p.info.get("z"),
                          "rss_max": float(status_gib("VmHWM"))}))


def case(n: int, skip: set[str], shuffle: bool, factor_ranks: int | None, engine: str, dim: int,
         blr: float | None, ordering: int | None = None) -> None:
    """Every stage on the packing of n disks or spheres, on COMM_WORLD; rank 0 prints one JSON line."""
    from solver import petscenv

    LOGS.mkdir(parents=True, exist_ok=True)
    size = int(os.environ.get("OMPI_COMM_WORLD_SIZE", "1"))
    tag = ("_shuffled" if shuffle else "") + (f"_g{factor_ranks}" if factor_ranks else "") + (
        "" if engine == "fire" else f"_{engine}") + ("" if dim == 2 else "_3d") + (f"_blr{blr:g}" if blr else "") + (
        f"_o{ordering}" if ordering is not None else "")
    PETSc = petscenv.init(["-log_view", f":{LOGS / f'N{n}_p{size}{tag}.txt'}", *blr_options(blr),
                           *([] if ordering is None else ["-inertia_mat_mumps_icntl_7", str(ordering)])])
    from mpi4py import MPI

    from solver import profiling
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
        reset_peak()
        held_gib = status_gib("VmRSS")
        t = time.perf_counter()
        with profiling.stage(LOG_STAGES[name]):
            extra = work() or {}
        seconds = mpi.allreduce(time.perf_counter() - t, op=MPI.MAX)
        peaks = mpi.gather(status_gib("VmHWM"), root=0)
        helds = mpi.gather(held_gib, root=0)
        files = mpi.gather(status_gib("RssFile"), root=0)  # mapped files: libraries, shared by a node's ranks
        if mpi.rank == 0:
            rows.append({"stage": name, "dim": dim, "engine": engine, "shuffled": shuffle, "factor_ranks": factor_ranks or 1,
                         "blr": blr, **({} if ordering is None else {"ordering": ordering}),
                         "seconds": seconds, "rss_max": max(peaks), "rss_sum": sum(peaks),
                         "held_max": max(helds), "file_max": max(files), **extra})

    def read():
        p = hdf5.read_packings(str(packing_file(n, engine, dim)))[0]
        if shuffle:
            from solver.packing import jammed

            order = np.random.default_rng(11).permutation(p.n)
            p = jammed.from_arrays(p.positions[order], p.diameters[order], p.box, p.rattler[order], dict(p.info))
        state["p"] = p

    def assembly():
        dm = dynmat.assemble(state["p"], model(dim), comm)
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

    def factorisation():
        from solver import parallel
        from solver.spectrum import slicing

        A = operators.scaled_operator(state["dm"])
        result = {}
        with parallel.Groups(mpi, factor_ranks or 1) as groups:
            local = counting.group_copy(A, groups)
            counter = slicing.ShiftedInertia(local)
            factor = counter.pc.getFactorMatrix()
            # MB per rank, the same on every rank (every group fails alike, or none: the loop's allreduce)
            cap = int(mpi.allreduce(0.8 * 1024 * counting.available_gib() / groups.count / groups.size, op=MPI.MIN))
            factor.setMumpsIcntl(23, cap)  # over it, MUMPS stops after its analysis (-19) instead of the OOM killer
            result["cap_mb_per_rank"] = cap
            try:
                for label, sigma in (("first", 0.25), ("second", 0.5)):  # omega^2 in 1/t0^2 (omega = 0.5 and 0.71/t0)
                    groups.local.Barrier()
                    t = time.perf_counter()
                    result[f"{label}_below"] = counter.count_below(sigma)  # to compare layouts and BLR
                    result[f"{label}_s"] = mpi.allreduce(time.perf_counter() - t, op=MPI.MAX)
            except RuntimeError as exc:  # the analysis's estimates are what a factor that does not fit leaves
                estimated = factor.getMumpsInfog(20)  # estimated entries in the factor (negative: millions)
                result.update(fits=False, error=str(exc).split(";")[0],
                              factor_entries_estimate=float(estimated if estimated >= 0 else -estimated * 1e6),
                              factor_mb_estimate=factor.getMumpsInfog(17),
                              factor_mb_estimate_max_rank=factor.getMumpsInfog(16))
            else:
                entries = factor.getMumpsInfog(29)  # entries in the factor (negative: millions)
                compressed = factor.getMumpsInfog(35)  # the same after BLR compression (= INFOG 29 without)
                result.update(fits=True, factor_entries=float(entries if entries >= 0 else -entries * 1e6),
                              factor_entries_blr=float(compressed if compressed >= 0 else -compressed * 1e6),
                              factor_mb_estimate=factor.getMumpsInfog(17), factor_mb=factor.getMumpsInfog(22))
                result["a_entries"] = float(local.getInfo()["nz_used"]) if groups.size == 1 else float(
                    A.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"])
                result["fill"] = result["factor_entries"] / (0.5 * (result["a_entries"] + state["dm"].size))
            factor.destroy()
            counter.destroy()
            if local is not A:
                local.destroy()
            groups.wait()
        result = mpi.bcast(result, root=0)
        return {"factor_ranks": factor_ranks or 1, **result}

    def count():
        layout = {} if factor_ranks is None else {"factor_ranks": factor_ranks}
        datasets, attrs, _ = counting.solve(state["dm"], bin_width=BIN, zero_tol=ZERO_TOL, **layout)
        state["counting"] = datasets
        return {"factorisations": attrs["factorisations"], "count_window": attrs["count_window"],
                "counts_sum": int(datasets["counts"].sum()),
                "counts_digest": int(np.sum(datasets["counts"] * np.arange(1, datasets["counts"].size + 1)))}

    def stochastic():
        datasets, attrs = kpm.solve(state["dm"], bin_width=BIN, moments=None, probes=PROBES, with_energies=True, seed=1)
        exact = state.get("counting")  # the accuracy target: L1 against exact counting
        return {"moments": attrs["moments"], **({} if exact is None else {"l1_vs_counting": l1_error(
            datasets["edges"], datasets["density"], exact["edges"], exact["density"], BIN)})}

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
    stage("factorisation", factorisation)
    stage("counting", count)
    stage("kpm", stochastic)
    stage("waves", waves)
    if "dm" in state:
        state["dm"].destroy()
    if mpi.rank == 0:
        print(json.dumps({"rows": [{k: float(f"{v:.4g}") if isinstance(v, float) else v for k, v in row.items()}
                                   for row in rows]}))


MERGE_BY = ("N", "ranks", "stage", "dim", "engine", "shuffled", "factor_ranks", "blr", "ordering")


def blr_options(blr: float | None) -> list[str]:
    """PETSc options for counting's factorisations with MUMPS's block low-rank compression."""
    return ["-inertia_mat_mumps_icntl_35", "1", "-inertia_mat_mumps_cntl_7", f"{blr:g}"] if blr else []


def rounded(table: list[dict]) -> list[dict]:
    """The rows with every float to 4 significant digits (as the case jobs print them)."""
    return [{k: float(f"{v:.4g}") if isinstance(v, float) else v for k, v in row.items()} for row in table]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("n", type=int, nargs="+")
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--skip", nargs="*", default=[], choices=STAGES)
    parser.add_argument("--tag", default="", help="suffix of the record's name (e.g. _after)")
    parser.add_argument("--shuffle", action="store_true", help="list the particles in a random order first")
    parser.add_argument("--factor-ranks", type=int, help="ranks sharing each counting factorisation")
    parser.add_argument("--engine", choices=("fire", "lammps"), default="fire",
                        help="the packing's engine: rotsound's FIRE on one core, or LAMMPS on 2 ranks")
    parser.add_argument("--dim", type=int, choices=(2, 3), default=2, help="disks (2) or spheres (3)")
    parser.add_argument("--blr", type=float, help="MUMPS block low-rank factorisations with this dropping parameter "
                        "(ICNTL 35 = 1, CNTL 7): counts then carry counting's count_window")
    parser.add_argument("--ordering", type=int, help="MUMPS's ordering for counting's factorisations (ICNTL 7)")
    parser.add_argument("--case", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--make-packing", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.make_packing:
        make_lammps_packing(args.n[0], args.dim)
        return
    if args.case:
        case(args.n[0], set(args.skip), args.shuffle, args.factor_ranks, args.engine, args.dim, args.blr, args.ordering)
        return
    for n in args.n:
        table = []
        if not packing_file(n, args.engine, args.dim).exists() and args.engine == "fire":
            if args.dim == 3:
                raise SystemExit("3D packings by rotsound's FIRE: make them with scripts/benchmarks/bench_spheres.py")
            t = time.perf_counter()
            load_packing(n)
            seconds = time.perf_counter() - t
            with h5py.File(packing_file(n, args.engine, args.dim), "r") as f:  # what the read's info leaves out
                steps = int(f["packings/0000"].attrs["fire_steps"])
            table.append({"N": n, "ranks": 1, "stage": "packing (FIRE)", "seconds": seconds, "fire_steps": steps,
                          "rss_max": None})
        elif not packing_file(n, args.engine, args.dim).exists():
            t = time.perf_counter()
            out = run_json(mpirun(2) + [PY, *ME, str(n), "--make-packing", "--dim", str(args.dim)], timeout=6 * 3600)
            table.append({"N": n, "ranks": 2, "stage": "packing (LAMMPS)", "dim": args.dim, "engine": "lammps",
                          "seconds": out["seconds"],
                          "job_seconds": time.perf_counter() - t, "fire_steps": out["fire_steps"],
                          "z": out["z"], "rss_max": out["rss_max"]})
            table = rounded(table)
            save(f"scaling{args.tag}", "python -m scripts.benchmarks.bench_scaling " + " ".join(sys.argv[1:]), table,
                 notes="", merge_by=MERGE_BY)
        for ranks in args.ranks:
            cmd = mpirun(ranks) + (["--oversubscribe"] if ranks > (os.cpu_count() or 1) else []) + [
                PY, *ME, str(n), "--case", *(["--skip", *args.skip] if args.skip else []),
                *(["--shuffle"] if args.shuffle else []),
                *(["--factor-ranks", str(args.factor_ranks)] if args.factor_ranks else []),
                *(["--blr", str(args.blr)] if args.blr else []),
                *(["--ordering", str(args.ordering)] if args.ordering is not None else []),
                "--engine", args.engine, "--dim", str(args.dim)]
            out = run_json(cmd, timeout=6 * 3600)
            table = rounded(table + [{"N": n, "ranks": ranks, **row} for row in out["rows"]])
            save(f"scaling{args.tag}", "python -m scripts.benchmarks.bench_scaling " + " ".join(sys.argv[1:]), table,
                 notes="", merge_by=MERGE_BY)


if __name__ == "__main__":
    main()
