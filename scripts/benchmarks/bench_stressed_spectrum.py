"""What stored tangential forces do to the spectrum (issue 25, items 2 and 4): the stressed
matrix of frictional packings made by LAMMPS against the unstressed one, by dense eigenvalues.

    python -m scripts.benchmarks.bench_stressed_spectrum [--n 256] [--phi 0.84] [--seeds 2] [--mus 0.1 0.3 1 1e4]
For each Coulomb coefficient mu and seed, ``jammed.generate(..., engine="lammps", friction=mu)``
makes a 2D frictional packing at phi (kt = 2/7 kn while it settles), and rotsound builds D with
its stored forces (stressed) and without them (unstressed), at rho = 2/7 (the springs it was made
with).  Dense eigenvalues lambda = omega^2 of A = M^-1/2 D M^-1/2 (numpy.linalg.eigvals: no
symmetry assumed) give, per packing: the asymmetry |D - D^T|_F / |D|_F; how many eigenvalues are
complex or real and negative, i.e. unstable (oscillatory or static), at which Re omega, and the
largest growth rate Im sqrt(lambda) (1/t0), as ``spectrum.method: nonhermitian`` classifies them;
and how far the stressed frequencies sit from the unstressed ones (sorted by real part, relative
to omega_max).
One process.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from scripts.benchmarks.benchlib import save

BENCH = {"order": 180}  # make bench: its place (scripts/benchmarks/bench_all.py)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=256)
    parser.add_argument("--phi", type=float, default=0.84)
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--mus", type=float, nargs="+", default=[0.1, 0.3, 1.0, 1e4])
    args = parser.parse_args()

    from mpi4py import MPI

    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.packing import jammed
    from solver.spectrum import nonhermitian

    PETSc = petscenv.init([])
    model = ContactModel(2.0 / 7.0)
    table = []
    for mu in args.mus:
        for seed in range(args.seeds):
            t0 = time.perf_counter()
            p = jammed.generate(args.n, args.phi, np.random.SeedSequence([seed, 0]), force_tol=1e-10,
                                engine="lammps", comm=MPI.COMM_SELF, friction=mu)
            made = time.perf_counter() - t0
            stressed = dynmat.assemble(p, model, PETSc.COMM_SELF)
            plain = dynmat.assemble(dataclasses.replace(p, tangential=None), model, PETSc.COMM_SELF)
            d = dynmat.gather_csr(stressed.D).toarray()
            t0 = time.perf_counter()
            found, found0 = (nonhermitian.solve(dm, zero_tol=1e-4) for dm in (stressed, plain))  # as scenes do
            seconds = time.perf_counter() - t0
            lam, lam0 = found.omega2, found0.omega2  # non-zero eigenvalues, sorted by real part
            unstable = lam[np.abs(lam.imag) > nonhermitian.IMAG_TOL * np.abs(lam).max()]
            shift = np.abs(np.sqrt(np.abs(lam.real)) - np.sqrt(lam0.real)) / np.sqrt(np.abs(lam0).max())
            ft = np.linalg.norm(p.tangential.force, axis=1)
            table.append({
                "mu": f"{mu:g}", "seed": seed, "N'": int((~p.rattler).sum()), "z": f"{p.info['z']:.3f}",
                "pressure": f"{p.info['pressure']:.2e}", "mean |f_t|": f"{ft.mean():.2e}",
                "mobilised": p.info["n_mobilised"],
                "asymmetry": f"{np.linalg.norm(d - d.T) / np.linalg.norm(d):.2e}",
                "complex": found.n_complex, "negative": found.n_negative, "modes": lam.size + found.n_zero_modes,
                "complex at omega": " ".join(f"{w:.3f}" for w in np.unique(np.round(np.sqrt(unstable).real, 3))),
                "max growth (1/t0)": f"{found.max_growth:.2e}",
                "max shift / omega_max": f"{shift.max():.2e}", "mean shift / omega_max": f"{shift.mean():.2e}",
                "packing s": f"{made:.1f}", "eig s": f"{seconds:.1f}"})
            print(table[-1], flush=True)
            stressed.destroy()
            plain.destroy()
    notes = (f"2D frictional packings made by LAMMPS (packing.friction = mu, engine lammps: squeezed from 0.75 phi "
             f"to phi = {args.phi}, kt = 2/7 kn, damped to forces below 1e-10), N = {args.n}; D at rho = 2/7 with "
             f"the stored forces (stressed) and without (unstressed); every eigenvalue of M^-1/2 D M^-1/2 by "
             f"spectrum.method nonhermitian (dense LAPACK). "
             f"complex: |Im lambda| > 1e-9 lambda_max; negative: real and < -1e-9 lambda_max; growth: "
             f"max |Im sqrt(lambda)|; shift: |omega_stressed - omega_unstressed| of the modes sorted by Re lambda.")
    save("stressed_spectrum", "python -m scripts.benchmarks.bench_stressed_spectrum", table, notes)


if __name__ == "__main__":
    main()
