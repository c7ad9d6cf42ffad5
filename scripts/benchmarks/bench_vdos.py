"""Time against error for the vDOS (issue 17, section 4): every way to get g(omega), same run.

    python -m scripts.benchmarks.bench_vdos [N ...] [--skip METHOD[:N] ...] [--eigh-max-gib G]
    (default N: 2048 8192 32768; e.g. --skip slicing:32768 leaves out the hour-long slicing)
Same packing for every method (cache/bench_<N>.h5: benchlib.load_packing, phi = 0.9, seed [1, 0]),
rho = 1, bins [0, w), [w, 2w), ... of w = 0.05/t0, zero modes (omega < 1e-4/t0) left out.
Each method runs in its own fresh process (its peak RSS is its own), 2 MPI ranks with one BLAS
thread each unless its name says otherwise; METHOD is the key given here:
  counting    ``spectrum.counting.solve``: Sylvester inertias at the bin edges, one reused
              factorisation per rank, edges over the ranks.  The reference of every other row.
  counting-1  the same on 1 rank.
  fresh       the previous method (N <= 8192 only): ``slicing.count_below`` at every edge of the
              same grid, a fresh factorisation (symbolic analysis included) each time, 1 rank.
  slicing     ``spectrum.slicing.solve(dm, vectors=False)``: every eigenvalue (no K/Q).
  kpm16/64    ``spectrum.kpm.solve(dm, bin_width=w, probes=16 or 64, moments=0 (automatic), seed=1)``.
  eigh        LAPACK ``scipy.linalg.eigh`` (driver evd, values only, in place on the dense
              Fortran-ordered A) in one process with 2 OpenBLAS threads, where the dense A fits the
              budget: estimate 8 DOF^2 bytes (measured: evd with overwrite_a needs no copy and O(DOF)
              workspace), run if at most --eigh-max-gib (default 2 GiB; N = 8192 needs 4.5 GiB).
Wall time: the library call alone (max over ranks), after assembly; it includes the Lanczos
omega_max of counting, slicing and KPM; for eigh the LAPACK call alone (not the gather to dense).
Peak RSS: summed over the job's ranks (the whole job's memory), whole process (assembly included).
Error: counting, slicing and eigh are exact; the check is that their bin counts (the histogram of
slicing's and eigh's omega on the counting edges) equal the 2-rank counts integer for integer.
KPM: L1 = sum over bins |g_kpm - g_exact| w of the unit-area densities, g_exact the counting
density on the same bins (KPM's bins reach 1.1 omega_max; the exact density is 0 beyond its top).
Time vs counting: this row's wall time over the 2-rank counting time of the same N.
Writes scripts/benchmarks/records/vdos.json (after every N) and prints the table as Markdown at the end.
"""

from solver.contact_law import ContactModel
import argparse
import json
import sys
import time

import numpy as np

from scripts.benchmarks.benchlib import PY, RECORDS, l1_error, load_packing, mpirun, peak_rss_gib, run_json, save

# make bench (scripts/benchmarks/bench_all.py): slicing at N = 32768 takes over an hour (bench_spectrum has it with K/Q)
BENCH = {"order": 110, "args": ["--skip", "slicing:32768"]}

BIN = 0.05  # bin width, 1/t0
ZERO_TOL = 1e-4  # omega below it is a zero mode (slicing's default), 1/t0
SEED = 1
ME = ["-m", __spec__.name]  # this benchmark again, in a fresh process (run_json runs it from the repository root)
METHODS = {  # key: (ranks, row label); rows in this order, "counting" (the reference) runs first
    "counting": (2, "counting, 2 ranks"),
    "counting-1": (1, "counting, 1 rank"),
    "fresh": (1, "fresh factorisation per edge, 1 rank (previous method)"),
    "slicing": (2, "slicing, values only, 2 ranks"),
    "kpm16": (2, "KPM, 16 probes, 2 ranks"),
    "kpm64": (2, "KPM, 64 probes, 2 ranks"),
    "eigh": (1, "LAPACK eigh (evd, values only), 1 process, 2 threads"),
}
FRESH_MAX_N = 8192
SKIPPED = {("slicing", 32768): "not run (see the spectrum section: 6391 s with K/Q)"}
TARGET_EIGH_RATIO, TARGET_32768_S = 0.15, 30.0


def case(n: int, method: str) -> None:
    """One method on the packing of n disks, on COMM_WORLD; rank 0 prints one JSON line."""
    from solver import petscenv

    PETSc = petscenv.init([])
    from mpi4py import MPI

    from solver.model import dynmat, operators
    from solver.spectrum import counting, kpm, slicing

    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    dm = dynmat.assemble(load_packing(n), ContactModel(1.0), comm)
    mpi.Barrier()
    t = time.perf_counter()
    if method in ("counting", "counting-1"):
        datasets, attrs, _ = counting.solve(dm, bin_width=BIN, zero_tol=ZERO_TOL)
        out = {"edges": datasets["edges"], "counts": datasets["counts"], "factorisations": attrs["factorisations"]}
    elif method == "fresh":  # same edges as counting.solve, a new factorisation at each
        omega_max = operators.largest_omega(dm)
        A = operators.scaled_operator(dm)
        edges = BIN * np.arange(int(np.floor(omega_max * (1 + 1e-6) / BIN)) + 2)
        below = [slicing.count_below(A, x) for x in np.concatenate(([ZERO_TOL**2], edges[1:] ** 2))]
        A.destroy()
        out = {"edges": edges, "counts": np.diff(below), "factorisations": len(below)}
    elif method == "slicing":
        out = {"omega": slicing.solve(dm, window=None, vectors=False, zero_tol=ZERO_TOL).omega}
    else:
        datasets, attrs = kpm.solve(dm, bin_width=BIN, moments=0, probes=int(method[3:]),
                                    with_energies=False, seed=SEED)
        out = {"edges": datasets["edges"], "density": datasets["density"], "moments": attrs["moments"]}
    seconds = mpi.allreduce(time.perf_counter() - t, op=MPI.MAX)
    rss = mpi.allreduce(peak_rss_gib(), op=MPI.SUM)
    dof = dm.size
    dm.destroy()
    if mpi.rank == 0:
        out = {k: v.tolist() if isinstance(v, np.ndarray) else v for k, v in out.items()}
        print(json.dumps({**out, "seconds": seconds, "rss": rss, "dof": int(dof)}))


def eigh_case(n: int) -> None:
    """Dense LAPACK eigenvalues of A in this process (threads from OPENBLAS_NUM_THREADS)."""
    import scipy.linalg

    from solver import petscenv

    PETSc = petscenv.init([])
    from solver.model import dynmat, operators

    dm = dynmat.assemble(load_packing(n), ContactModel(1.0), PETSc.COMM_SELF)
    A = operators.scaled_operator(dm)
    dense = dynmat.gather_csr(A).toarray().T  # A is symmetric: its Fortran-ordered view, no copy
    A.destroy()
    dm.destroy()
    t = time.perf_counter()
    lam = scipy.linalg.eigh(dense, eigvals_only=True, driver="evd", overwrite_a=True, check_finite=False)
    seconds = time.perf_counter() - t
    omega = np.sqrt(lam[lam > ZERO_TOL**2])
    print(json.dumps({"omega": omega.tolist(), "seconds": seconds, "rss": peak_rss_gib(), "dof": int(lam.size)}))


def eigh_gib(dof: int) -> float:
    """Estimated memory of dense eigh beyond the process's baseline: the dense A (8 DOF^2 bytes)."""
    return 8.0 * dof**2 / 2**30


def same_counts(a, b) -> bool:
    """Equal integer for integer, a shorter list padded with empty bins."""
    m = max(len(a), len(b))
    return bool(np.array_equal(np.pad(np.asarray(a, np.int64), (0, m - len(a))),
                               np.pad(np.asarray(b, np.int64), (0, m - len(b)))))


def histogram_check(omega, edges, counts) -> str:
    """The error cell of an exact method that gives omega: its histogram against the counts."""
    hist, _ = np.histogram(omega, edges)
    if hist.sum() == len(omega) and same_counts(hist, counts):
        return "exact; histogram = counts"
    return f"exact; histogram != counts (NO: {int(np.sum(hist != counts))} bins, {len(omega) - hist.sum()} outside)"


def parse_skips(values: list[str]) -> set:
    skips = set()
    for value in values:
        method, _, n = value.partition(":")
        if method not in METHODS or method == "counting":
            raise SystemExit(f"--skip {value}: METHOD is one of {', '.join(list(METHODS)[1:])} "
                             "(counting, the reference, always runs)")
        skips.add((method, int(n) if n else None))
    return skips


def measure(n: int, skips: set, eigh_max_gib: float) -> list[dict]:
    """The rows of one N."""
    load_packing(n)  # generated here once if absent, not by two ranks at the same time
    runs = {}
    for method, (ranks, _) in METHODS.items():
        if method == "fresh" and n > FRESH_MAX_N:
            continue
        if (method, n) in skips or (method, None) in skips:
            runs[method] = SKIPPED.get((method, n), "not run (--skip)")
        elif method == "eigh":
            need = eigh_gib(runs["counting"]["dof"])
            if need > eigh_max_gib:
                runs[method] = f"not run (dense A {need:.2f} GiB > budget {eigh_max_gib:g} GiB, --eigh-max-gib)"
            else:
                runs[method] = run_json(["env", "OPENBLAS_NUM_THREADS=2", "OMP_NUM_THREADS=2",
                                         PY, *ME, "--eigh", str(n)], timeout=6 * 3600)
        else:
            runs[method] = run_json(mpirun(ranks) + [PY, *ME, "--case", str(n), method], timeout=6 * 3600)
        print(f"N = {n} {method}: " + (runs[method] if isinstance(runs[method], str) else
                                       f"{runs[method]['seconds']:.2f} s, {runs[method]['rss']:.2f} GiB"), flush=True)
    ref = runs["counting"]
    ref_density = np.asarray(ref["counts"]) / (np.sum(ref["counts"]) * BIN)
    rows = []
    for method, r in runs.items():
        label = METHODS[method][1]
        row = {"N": n, "DOF": ref["dof"], "method": label}
        if isinstance(r, str):
            rows.append({**row, "wall s": r, "peak RSS GiB": "", "error": "", "time vs counting": ""})
            continue
        if "factorisations" in r:
            row["method"] = f"{label}, {r['factorisations']} inertias"
            same = same_counts(r["counts"], ref["counts"])
            error = ("exact (reference)" if method == "counting" else
                     "exact; counts = 2-rank counts" if same else "exact; counts differ (NO)")
        elif "omega" in r:
            error = histogram_check(r["omega"], ref["edges"], ref["counts"])
        else:
            row["method"] = f"{label}, {r['moments']} moments"
            error = f"L1 {l1_error(r['edges'], r['density'], ref['edges'], ref_density, BIN):.4f}"
        if method == "eigh":
            row["method"] = f"{label}, dense A {eigh_gib(r['dof']):.2f} GiB"
        rows.append({**row, "wall s": f"{r['seconds']:.2f}", "peak RSS GiB": f"{r['rss']:.2f}", "error": error,
                     "time vs counting": f"{r['seconds'] / ref['seconds']:.2f}x"})
    return rows


def targets(rows: list[dict]) -> str:
    """The issue's two targets, read off the rows."""
    def seconds(n, start):
        for row in rows:
            if row["N"] == n and row["method"].startswith(start) and not row["wall s"].startswith("not run"):
                return float(row["wall s"])
        return None

    lines = []
    count, eigh = seconds(2048, "counting, 2 ranks"), seconds(2048, "LAPACK eigh")
    if count is not None and eigh is not None:
        ratio = count / eigh
        lines.append(f"counting (2 ranks) at N = 2048 took {ratio:.3f}x the time of eigh (values only, 2 threads): "
                     f"target at most {TARGET_EIGH_RATIO}x, {'met' if ratio <= TARGET_EIGH_RATIO else 'MISSED'}.")
    count = seconds(32768, "counting, 2 ranks")
    if count is not None:
        lines.append(f"exact vDOS (counting) at N = 32768 on 2 ranks: {count:.1f} s: target under "
                     f"{TARGET_32768_S:g} s, {'met' if count < TARGET_32768_S else 'MISSED'}.")
    return " ".join(lines)


def markdown(record: dict) -> str:
    columns = list(dict.fromkeys(k for row in record["table"] for k in row))
    lines = [f"Command: `{record['command']}`  ", f"Date: {record['date']}  ", f"Machine: {record['machine']}", "",
             "| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(str(row.get(c, "")) for c in columns) + " |" for row in record["table"]]
    return "\n".join(lines + ["", record["notes"]])


NOTES = ("phi = 0.9, rho = 1, bins 0.05/t0, the same packing for every row; every row its own process, "
         "2 ranks with one BLAS thread each unless said. Wall time: the library call alone after assembly "
         "(counting, slicing and KPM include the Lanczos omega_max); eigh: the LAPACK call alone (driver evd, "
         "values only, in place). Peak RSS: summed over the job's ranks. Error: counting, slicing and eigh are "
         "exact, and their bin counts (histograms of slicing's and eigh's omega on the counting edges) are "
         "checked against the 2-rank counts integer for integer; KPM: L1 = sum |g_kpm - g_exact| x 0.05 of the "
         "unit-area densities, g_exact from the counts. eigh runs where the dense A (8 DOF^2 bytes; evd in place "
         "needs no copy) fits the budget given by --eigh-max-gib. Time vs counting: over the 2-rank counting "
         "time of the same N.")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sizes", nargs="*", type=int, default=[2048, 8192, 32768], metavar="N")
    parser.add_argument("--skip", action="append", default=[], metavar="METHOD[:N]",
                        help=f"leave a method out (at one N, or at every N); METHOD: {', '.join(list(METHODS)[1:])}")
    parser.add_argument("--eigh-max-gib", type=float, default=2.0,
                        help="run dense eigh only where the dense A takes at most this (GiB; default 2)")
    args = parser.parse_args()
    skips = parse_skips(args.skip)
    command = "python -m scripts.benchmarks.bench_vdos " + " ".join(sys.argv[1:])
    table = []
    for n in args.sizes:
        table += measure(n, skips, args.eigh_max_gib)
        save("vdos", command.strip(), table, f"{NOTES} {targets(table)}".strip())  # kept after every N
    record = json.loads((RECORDS / "vdos.json").read_text())
    print("\n---- Markdown for BENCHMARKS.md ----\n")
    print(markdown(record))


if __name__ == "__main__":
    if sys.argv[1:2] == ["--case"]:
        case(int(sys.argv[2]), sys.argv[3])
    elif sys.argv[1:2] == ["--eigh"]:
        eigh_case(int(sys.argv[2]))
    else:
        main()
