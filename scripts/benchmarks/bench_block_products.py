"""Block (BAIJ) matrices for the damped waves' products (issue 48 point 4, a lever the README
named): the products y = A x and y = C^ x of the damped spectral series (``waves.chebyshev``,
~88 % of its time in MatMult) with PETSc's AIJ matrices, as rotsound assembles them (block size
D + rotations set, so PETSc's i-node routines already treat rows of a node together), against the
same matrices converted to BAIJ, in the same run.

    python -m scripts.benchmarks.bench_block_products [--disks N ...] [--spheres N ...] [--products P]
    (defaults: disks 16384, spheres 4096, P = 400)

Packings: ``benchlib.load_packing`` (2D, phi = 0.9) and ``bench_spheres.load_spheres`` (3D,
phi = 0.7); model rho = 0.5 with LAMMPS-convention dashpots gamma_n = 0.3, gamma_t = 0.15 (as
bench_damped_waves), A = M^-1/2 D M^-1/2 and C^ = M^-1/2 C M^-1/2.  Per matrix and format:
microseconds per product (the best of three runs of P products), and the largest difference of
the two formats' products relative to max |y| (they sum in other orders).  One process, one core,
one BLAS thread.  Writes scripts/benchmarks/records/block_products.json.
"""

from __future__ import annotations

import argparse
import sys
import time

import solver  # noqa: F401  before numpy: one OpenBLAS thread, as in a run (solver/__init__.py)

import numpy as np

from scripts.benchmarks.bench_spheres import load_spheres
from scripts.benchmarks.benchlib import load_packing, save

BENCH = {"order": 211}  # make bench: its place (scripts/benchmarks/bench_all.py)


def per_product(mat, x, y, products: int) -> float:
    """Seconds per ``mat.mult(x, y)``, the best of three runs of ``products``."""
    best = np.inf
    for _ in range(3):
        t = time.perf_counter()
        for _ in range(products):
            mat.mult(x, y)
        best = min(best, (time.perf_counter() - t) / products)
    return best


def rows_for(packing, label: str, products: int, PETSc) -> list[dict]:
    """The AIJ and BAIJ rows of A and C^ of ``packing``."""
    from solver.contact_law import ContactModel
    from solver.model import damping, dynmat, operators

    dm = dynmat.assemble(packing, ContactModel(0.5, gamma_n=0.3, gamma_t=0.15), PETSc.COMM_SELF)
    dm.C = damping.assemble(packing, dm)
    rows = []
    for name, aij in (("A", operators.scaled_operator(dm)), ("C^", operators.scaled_damping(dm))):
        baij = aij.convert("baij")
        x, y = aij.createVecs()
        x.setArray(np.random.default_rng(0).normal(size=x.getLocalSize()))
        y_baij = y.duplicate()
        seconds = {fmt: per_product(mat, x, out, products) for fmt, mat, out in (("aij", aij, y), ("baij", baij, y_baij))}
        difference = np.abs(y.getArray() - y_baij.getArray()).max() / np.abs(y.getArray()).max()
        rows.append({"packing": label, "DOF": dm.size, "block": aij.getBlockSize(), "matrix": name,
                     "nonzeros": int(aij.getInfo()["nz_used"]), "aij_us": 1e6 * seconds["aij"],
                     "baij_us": 1e6 * seconds["baij"], "aij / baij": seconds["aij"] / seconds["baij"],
                     "max difference (rel.)": difference})
        for obj in (aij, baij, x, y, y_baij):
            obj.destroy()
    dm.destroy()
    return rows


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--disks", type=int, nargs="*", default=[16384])
    parser.add_argument("--spheres", type=int, nargs="*", default=[4096])
    parser.add_argument("--products", type=int, default=400)
    args = parser.parse_args()
    from solver import petscenv

    PETSc = petscenv.init([])
    table = []
    for n in args.disks:
        table += rows_for(load_packing(n), f"{n} disks", args.products, PETSc)
    for n in args.spheres:
        table += rows_for(load_spheres(n), f"{n} spheres", args.products, PETSc)
    table = [{k: float(f"{v:.3g}") if isinstance(v, float) else v for k, v in row.items()} for row in table]
    save("block_products", "python -m scripts.benchmarks.bench_block_products " + " ".join(sys.argv[1:]), table,
         merge_by=("packing", "matrix"))


if __name__ == "__main__":
    main()
