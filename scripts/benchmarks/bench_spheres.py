"""Spheres in 3D (issue 18): the matrix, the vDOS by counting and by KPM, how the
factorisation's fill-in grows against 2D, and one spectral standing wave, at up to N = 32768.

    python -m scripts.benchmarks.bench_spheres [--n N] [--count-n N ...] [--skip ROW ...]
    (defaults: --n 32768 --count-n 2048 4096 8192; ROW: assembly fill counting kpm wave)
Packings: 3D, phi = 0.7, seed [1, 0] (``load_spheres``: generated once into cache/; how long that
takes is scripts/benchmarks/bench_packing3d.py's table); 2D comparisons use benchlib.load_packing (phi = 0.9).  rho = 1 unless a row says otherwise.  Every case runs in its own fresh process,
2 MPI ranks with one BLAS thread each unless the row says otherwise.
  assembly  dynmat.assemble at N, rho = 1, and with rho_roll = rho_twist = 0.1.
  fill      one MUMPS Cholesky of A - sigma I (the counting method's unit of work) on one rank,
            3D N and 2D 2N (the same DOF: 6 per sphere, 3 per disk): seconds and the factor's
            entries (MatGetInfo: MUMPS's INFOG(20)) over A's entries.
  counting  the exact vDOS (spectrum.counting.solve, 0.05/t0 bins) at each --count-n.
  kpm       spectrum.kpm.solve, 16 probes, automatic moments, at each --count-n and at N; L1
            error against the counting density of the same N where it was run.
  wave      waves.spectral.spectral: one L standing wave at N, k = 2 pi / L along x, t_end = 100,
            samples every 0.1 t0: wall time, Lanczos steps, error estimate.
Writes scripts/benchmarks/records/spheres.json after every row and prints the table.
"""

from solver.contact_law import ContactModel
import argparse
import json
import sys
import time

import numpy as np

from scripts.benchmarks.benchlib import PY, REPO, l1_error, load_packing, mpirun, peak_rss_gib, run_json, save

BENCH = {"order": 120}  # make bench: its place (scripts/benchmarks/bench_all.py)

PHI = 0.7
BIN = 0.05
ZERO_TOL = 1e-4
ME = ["-m", __spec__.name]  # this benchmark again, in a fresh process (run_json runs it from the repository root)


def spheres_path(n: int):
    return REPO / "cache" / f"bench_spheres_{n}.h5"


def load_spheres(n: int):
    """The 3D benchmark packing of n spheres (made by the ``packing`` case if absent)."""
    from solver.io import hdf5

    path = spheres_path(n)
    if not path.exists():
        run_json([PY, *ME, "--case", "packing", str(n)], timeout=4 * 3600)
    return hdf5.read_packings(str(path))[0]


def packing_case(n: int) -> dict:
    from solver.io import hdf5
    from solver.packing import jammed

    p = jammed.generate(n, PHI, np.random.SeedSequence([1, 0]), dim=3)
    spheres_path(n).parent.mkdir(exist_ok=True)
    hdf5.save_packings(str(spheres_path(n)), [p])
    return {"z": p.info["z"]}


def _init():
    from solver import petscenv

    return petscenv.init([])


def assembly_case(n: int, roll: float) -> dict:
    PETSc = _init()
    from mpi4py import MPI

    from solver.model import dynmat

    p = load_spheres(n)
    mpi = PETSc.COMM_WORLD.tompi4py()
    mpi.Barrier()
    t = time.perf_counter()
    dm = dynmat.assemble(p, ContactModel(1.0, rho_roll=roll, rho_twist=roll), PETSc.COMM_WORLD)
    seconds = mpi.allreduce(time.perf_counter() - t, op=MPI.MAX)
    out = {"seconds": seconds, "rss": mpi.allreduce(peak_rss_gib(), op=MPI.SUM), "dof": dm.size,
           "nnz": int(dm.D.getInfo()["nz_used"]), "contacts": dm.n_contacts}
    dm.destroy()
    return out


def fill_case(n: int, dim: int) -> dict:
    PETSc = _init()
    from solver.model import dynmat, operators
    from solver.spectrum.slicing import ShiftedInertia

    p = load_spheres(n) if dim == 3 else load_packing(n)
    dm = dynmat.assemble(p, ContactModel(1.0), PETSc.COMM_SELF)
    A = operators.scaled_operator(dm)
    counter = ShiftedInertia(A)
    t = time.perf_counter()
    counter.count_below(1.0)  # symbolic analysis and the first numeric factorisation
    first = time.perf_counter() - t
    t = time.perf_counter()
    counter.count_below(4.0)  # a refactorisation: what every further bin edge costs
    again = time.perf_counter() - t
    factor = counter.pc.getFactorMatrix()
    entries = float(factor.getInfo()["nz_used"])
    out = {"seconds": again, "first": first, "dof": dm.size, "a_nnz": int(A.getInfo()["nz_used"]),
           "factor_nnz": entries, "rss": peak_rss_gib()}
    counter.destroy()
    A.destroy()
    dm.destroy()
    return out


def vdos_case(n: int, method: str) -> dict:
    PETSc = _init()
    from mpi4py import MPI

    from solver.model import dynmat
    from solver.spectrum import counting, kpm

    dm = dynmat.assemble(load_spheres(n), ContactModel(1.0), PETSc.COMM_WORLD)
    mpi = PETSc.COMM_WORLD.tompi4py()
    mpi.Barrier()
    t = time.perf_counter()
    if method == "counting":
        datasets, attrs, _ = counting.solve(dm, bin_width=BIN, zero_tol=ZERO_TOL)
        out = {"edges": datasets["edges"], "density": datasets["density"], "factorisations": attrs["factorisations"],
               "zero_modes": attrs["n_zero_modes"]}
    else:
        datasets, attrs = kpm.solve(dm, bin_width=BIN, moments=0, probes=16, with_energies=False, seed=1)
        out = {"edges": datasets["edges"], "density": datasets["density"], "moments": attrs["moments"]}
    out.update(seconds=mpi.allreduce(time.perf_counter() - t, op=MPI.MAX),
               rss=mpi.allreduce(peak_rss_gib(), op=MPI.SUM), dof=dm.size)
    dm.destroy()
    return {k: v.tolist() if isinstance(v, np.ndarray) else v for k, v in out.items()}


def wave_case(n: int) -> dict:
    PETSc = _init()
    from mpi4py import MPI

    from solver.model import dynmat, operators
    from solver.waves import spectral

    p = load_spheres(n)
    dm = dynmat.assemble(p, ContactModel(1.0), PETSc.COMM_WORLD)
    mpi = PETSc.COMM_WORLD.tompi4py()
    omega_max = operators.largest_omega(dm)
    k = 2 * np.pi / p.box_length
    mpi.Barrier()
    t = time.perf_counter()
    series = spectral.spectral(dm, p.positions, "L", 0, k, amplitude=1e-3, times=np.arange(0.0, 100.0 + 1e-9, 0.1),
                               tol=1e-8, omega_max=omega_max)
    out = {"seconds": mpi.allreduce(time.perf_counter() - t, op=MPI.MAX), "steps": int(series.steps),
           "error": float(series.error_estimate), "rss": mpi.allreduce(peak_rss_gib(), op=MPI.SUM), "dof": dm.size}
    dm.destroy()
    return out


def case_main(argv: list[str]) -> None:
    name, n = argv[0], int(argv[1])
    if name == "packing":
        out = packing_case(n)
    elif name == "assembly":
        out = assembly_case(n, float(argv[2]))
    elif name == "fill":
        out = fill_case(n, int(argv[2]))
    elif name == "wave":
        out = wave_case(n)
    else:
        out = vdos_case(n, name)
    from mpi4py import MPI

    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(out))


def main() -> None:
    if sys.argv[1:2] == ["--case"]:
        case_main(sys.argv[2:])
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=32768)
    parser.add_argument("--count-n", type=int, nargs="*", default=[2048, 4096, 8192])
    parser.add_argument("--skip", nargs="*", default=[])
    args = parser.parse_args()
    rows, command = [], "python -m scripts.benchmarks.bench_spheres " + " ".join(sys.argv[1:])

    def add(row):
        rows.append(row)
        print(row, flush=True)
        save("spheres", command, rows, NOTES)

    sizes = sorted(set(args.count_n) | {args.n})
    for n in sizes:
        load_spheres(n)  # made once, before any timing (its own timing: scripts/benchmarks/bench_packing3d.py)
    if "assembly" not in args.skip:
        for roll in (0.0, 0.1):
            r = run_json(mpirun(2) + [PY, *ME, "--case", "assembly", str(args.n), str(roll)])
            add({"row": f"assembly, rho = 1, rho_roll = rho_twist = {roll:g}", "N": args.n, "DOF": r["dof"],
                 "wall s": f"{r['seconds']:.2f}", "peak RSS GiB": f"{r['rss']:.2f}",
                 "result": f"{r['contacts']} contacts, {r['nnz']} non-zeros"})
    if "fill" not in args.skip:
        for n in args.count_n:
            for dim, size in ((3, n), (2, 2 * n)):
                r = run_json([PY, *ME, "--case", "fill", str(size), str(dim)], timeout=4 * 3600)
                add({"row": f"one Cholesky of A - sigma I, {dim}D, 1 rank", "N": size, "DOF": r["dof"],
                     "wall s": f"{r['seconds']:.2f}", "peak RSS GiB": f"{r['rss']:.2f}",
                     "result": f"factor {r['factor_nnz']:.3g} entries = {r['factor_nnz'] / r['a_nnz']:.1f} x nnz(A); "
                               f"first (with analysis) {r['first']:.2f} s"})
    exact = {}
    for method in ("counting", "kpm"):
        if method in args.skip:
            continue
        for n in (args.count_n if method == "counting" else sizes):
            r = run_json(mpirun(2) + [PY, *ME, "--case", method, str(n)], timeout=6 * 3600)
            if method == "counting":
                exact[n] = r
                result = f"{r['factorisations']} inertias, exact, {r['zero_modes']} zero modes"
            else:
                result = f"{r['moments']} moments, " + (f"L1 {l1_error(r['edges'], r['density'], exact[n]['edges'], exact[n]['density'], BIN):.4f} vs counting"
                                                       if n in exact else "no exact reference at this N")
            add({"row": f"vDOS, {method}{', 16 probes' if method == 'kpm' else ''}, 2 ranks", "N": n,
                 "DOF": r["dof"], "wall s": f"{r['seconds']:.2f}", "peak RSS GiB": f"{r['rss']:.2f}",
                 "result": result})
    if "wave" not in args.skip:
        r = run_json(mpirun(2) + [PY, *ME, "--case", "wave", str(args.n)], timeout=6 * 3600)
        add({"row": "spectral L wave, k = 2 pi/L, t_end = 100, 2 ranks", "N": args.n, "DOF": r["dof"],
             "wall s": f"{r['seconds']:.2f}", "peak RSS GiB": f"{r['rss']:.2f}",
             "result": f"{r['steps']} Lanczos steps, error estimate {r['error']:.1e}"})


NOTES = ("3D packings at phi = 0.7 (seed [1, 0]); rho = 1; vDOS bins 0.05/t0. Wall time is the library "
         "call alone (max over ranks); peak RSS is summed over ranks. See scripts/benchmarks/bench_spheres.md.")

if __name__ == "__main__":
    main()
