"""How the modes' damping rate grows with frequency, normal dashpots alone against normal and
tangential ones (the README's check of Koyama, Oyama, Mizuno & Ikeda, Soft Matter 2025).

    .venv/bin/python -m scripts.tools.damping_rates [--n 1024] [--gamma-n 0.2]
Koyama et al. find, with normal dissipation only, a kinetic energy per mode K ~ omega^-2 in the
low-frequency range (no equipartition), because soft modes barely stretch the contacts along their
normals, so normal dashpots hardly damp them.  Under forcing that does not follow the damping
(white noise of one power on every DOF), a lightly damped mode holds K = D / (2 sigma): K ~ omega^-2
is sigma ~ omega^2.  This script measures sigma(omega_d) by pep (dense) on one 2D packing
(rotsound's FIRE, phi = 0.86, rho = 0.5) with gamma_t = 0 and gamma_t = gamma_n / 2, and fits
sigma ~ omega^q over the lowest decade of frequencies and over all modes, with K/Q of the modes.
One process.
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=1024)
    parser.add_argument("--gamma-n", type=float, default=0.2)
    args = parser.parse_args()

    from mpi4py import MPI

    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import damping, dynmat
    from solver.packing import jammed
    from solver.spectrum import pep

    PETSc = petscenv.init([])
    p = jammed.generate(args.n, 0.86, np.random.SeedSequence([3, 0]), comm=MPI.COMM_SELF)
    print("| dashpots | modes | q of sigma ~ omega^q, omega_d < 0.3 | q, 0.3 < omega_d < 1 | sigma / omega^2 at "
          "omega_d < 0.3 (median) | K/Q of those modes (median) |")
    print("|---|---|---|---|---|---|")
    for gamma_t in (0.0, args.gamma_n / 2):
        dm = dynmat.assemble(p, ContactModel(0.5, gamma_n=args.gamma_n, gamma_t=gamma_t), PETSc.COMM_SELF)
        dm.C = damping.assemble(p, dm)
        result = pep.solve(dm, 1e-4, vectors=True, solver="dense")
        dm.destroy()
        lam = result.lam
        under = lam.imag > 0
        omega, sigma = lam.imag[under], -lam.real[under]
        ratio = (result.energies["K"] / result.energies["Q"])[under]
        cells = []
        for lo, hi in ((0.0, 0.3), (0.3, 1.0)):
            band = (omega > lo) & (omega < hi) & (sigma > 0)
            q = np.polyfit(np.log(omega[band]), np.log(sigma[band]), 1)[0] if band.sum() > 3 else np.nan
            cells.append(f"{q:.2f} ({band.sum()} modes)")
        low = (omega < 0.3) & (sigma > 0)
        print(f"| gamma_n = {args.gamma_n:g}, gamma_t = {gamma_t:g} | {under.sum()} (+{result.n_overdamped} "
              f"overdamped roots) | {cells[0]} | {cells[1]} | {np.median(sigma[low] / omega[low] ** 2):.3g} | "
              f"{np.median(ratio[low]):.3g} |")


if __name__ == "__main__":
    main()
