"""Fill-reducing orderings for the exact 3D vDOS (issue 48 point 2): one MUMPS Cholesky of
A - sigma I of the spheres matrix per ordering, with Debian's MUMPS (PORD, AMD, AMF, QAMD) and
Debian's PT-Scotch build of the same MUMPS 5.5.1 (package libmumps-ptscotch-5.5), whose SCOTCH
nested dissection (ICNTL 7 = 3) the default build lacks.

    python -m scripts.benchmarks.bench_orderings [N ...] [--disks] [--cases BUILD:ORDERING[:CNTL1] ...]
    (defaults: N = 4096, cases debian:4 debian:2 debian:0 debian:6 ptscotch:3; CNTL1, MUMPS's
    relative pivot threshold, left at its default 0.01 unless given: 0 asks for no pivoting)

Packing: bench_spheres.load_spheres(N) (phi = 0.7), or with --disks benchlib.load_packing(N)
(phi = 0.9: the paper's counting at N = 2048), rho = 1.  Each case runs alone in a fresh
process on one rank with one BLAS thread (the layout of ``--group-size 1`` counting: a factor per
rank), with the build chosen by ROTSOUND_MUMPS (``petscenv.mumps_build``; column build_loaded says
which one the case loaded).  Per case: the first count (symbolic analysis
and numeric factorisation, seconds) at sigma = 1, a second count at sigma = 4 (numeric only, as
every further bin edge of counting), MUMPS's factor entries (INFOG 29), flops of the elimination
(RINFOG 3), MB used (INFOG 22), the ordering used (INFOG 7), the pivots delayed by the threshold
pivoting (INFOG 13), the peak RSS, and both counts: equal in every row, or the ordering (or the
pivot threshold) changed an exact count.  Writes scripts/benchmarks/records/orderings.json
after every case.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

from scripts.benchmarks.bench_spheres import load_spheres
from scripts.benchmarks.benchlib import PY, load_packing, peak_rss_gib, run_json, save

BENCH = {"order": 131, "args": ["4096"]}
ME = ["-m", __spec__.name]
SHIFTS = (1.0, 4.0)


def case(n: int, ordering: int, dim: int, cntl1: str) -> None:
    """Two counts of the spheres (``dim`` 3) or disks (2) matrix with ICNTL 7 = ``ordering`` and
    CNTL 1 = ``cntl1`` ("" for MUMPS's default); prints one JSON line."""
    from solver import petscenv

    PETSc = petscenv.init(["-inertia_mat_mumps_icntl_7", str(ordering)]
                          + (["-inertia_mat_mumps_cntl_1", cntl1] if cntl1 else []))
    from solver.contact_law import ContactModel
    from solver.model import dynmat, operators
    from solver.spectrum import slicing

    dm = dynmat.assemble(load_spheres(n) if dim == 3 else load_packing(n), ContactModel(1.0), PETSc.COMM_SELF)
    A = operators.scaled_operator(dm)
    counter = slicing.ShiftedInertia(A)
    row = {}
    try:
        for name, sigma in zip(("first", "refactor"), SHIFTS):
            t = time.perf_counter()
            row[f"count_below_{sigma:g}"] = counter.count_below(sigma)
            row[f"{name}_s"] = time.perf_counter() - t
        factor = counter.pc.getFactorMatrix()
        row.update({"build_loaded": petscenv.mumps_build(), "ordering_used_infog7": factor.getMumpsInfog(7),
                    "entries_infog29": factor.getMumpsInfog(29),
                    "flops_rinfog3": factor.getMumpsRinfog(3), "mb_infog22": factor.getMumpsInfog(22),
                    "delayed_infog13": factor.getMumpsInfog(13), "cntl1_used": factor.getMumpsCntl(1)})
        factor.destroy()
    finally:
        counter.destroy()
    print(json.dumps({**row, "dof": dm.size, "rss_gib": peak_rss_gib()}))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("n", type=int, nargs="*", default=[4096])
    parser.add_argument("--cases", nargs="+", default=["debian:4", "debian:2", "debian:0", "debian:6", "ptscotch:3"])
    parser.add_argument("--disks", action="store_true")
    parser.add_argument("--case", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case:
        n, ordering, dim, cntl1 = args.case
        case(int(n), int(ordering), int(dim), cntl1)
        return
    for spec in args.cases:
        if len(spec.split(":")) not in (2, 3):
            parser.error(f"--cases {spec}: BUILD:ORDERING or BUILD:ORDERING:CNTL1")
    command = "python -m scripts.benchmarks.bench_orderings " + " ".join(sys.argv[1:])
    table = []
    dim = 2 if args.disks else 3
    for n in args.n:
        (load_spheres if dim == 3 else load_packing)(n)  # made once, before any timing
        for spec in args.cases:
            build, ordering, *cntl1 = spec.split(":")
            env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "ROTSOUND_MUMPS": build}
            out = run_json([PY, *ME, "--case", str(n), ordering, str(dim), cntl1[0] if cntl1 else ""], timeout=4 * 3600, env=env)
            table.append({"dim": dim, "N": n, "build": build, "ordering_icntl_7": int(ordering),
                          **({"cntl1_asked": float(cntl1[0])} if cntl1 else {}),
                          **{k: float(f"{v:.4g}") if isinstance(v, float) else v for k, v in out.items()}})
            save("orderings", command, table, merge_by=("dim", "N", "build", "ordering_icntl_7", "cntl1_asked"))


if __name__ == "__main__":
    main()
