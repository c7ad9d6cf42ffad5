"""Reading a rotsound results file from Python (a notebook, a script, a laptop without MPI):
``solver.io.results`` opens the file, checks it is one this rotsound reads, and gives each
quantity as NumPy arrays in named fields.  It imports neither MPI nor PETSc.

    .venv/bin/python docs/notebook_example.py results/quick.h5

tests/io/test_notebook_example.py runs this script on a small scene's file.
"""

import sys

import numpy as np

from solver.io import results


def main(path: str) -> None:
    with results.open_results(path) as f:  # InputError naming the file if it is not a results file
        print("holds:", ", ".join(results.contents(f)))
        packing = results.packing(f, 0)  # dict of arrays: positions (N, D), diameters, rattler; box, phi, z
        print(f"packing 0: N = {packing['diameters'].size}, D = {packing['positions'].shape[1]}, "
              f"phi = {packing['phi']:.4f}, rattlers = {int(packing['rattler'].sum())}")
        for rho, g in results.vdos(f).items():  # {rho: Vdos(edges, density, omega_c, omega_c_std, configurations)}
            centres = 0.5 * (g.edges[1:] + g.edges[:-1])
            peak = centres[np.argmax(g.density)]
            print(f"vDOS rho = {rho:g}: omega_c = {g.omega_c:.4f}/t0, peak at omega = {peak:.3f}/t0")
        for rho, (omega, K, Q) in results.mode_energies(f).items():  # per mode, with spectrum.energies
            low = int(np.argmax(Q > 0))  # the lowest mode with a potential energy (not a zero mode)
            print(f"modes rho = {rho:g}: {omega.size} modes, K/Q at the lowest = {K[low] / Q[low]:.3g}")
        for rho, g in results.diffusivity(f).items():  # Diffusivity: omega, d per mode (exact); edges, d_binned, ...
            print(f"diffusivity rho = {rho:g} ({g.method}): {g.omega.size} modes with their d, "
                  f"d = {np.nanmedian(g.d_binned):.3g} d0^2/t0 (median over the vDOS's bins)")
        for (rho, mode), fit in sorted(results.fits(f).items()):  # {(rho, mode): datasets and attributes}
            k, omega, gamma = fit["k"], fit["omega"], fit["gamma"]
            print(f"dispersion rho = {rho:g} {mode}: k d0 = {k[0]:.3f}..{k[-1]:.3f}, "
                  f"omega = {omega[0]:.4f}..{omega[-1]:.4f}/t0, gamma(k_min) = {gamma[0]:.2e}/t0")
        for (rho, mode), sweep in sorted(results.sweeps(f).items()):  # Sweep: amplitude (A,), omega (A, K), ...
            star = results.crossover(sweep).omega[0]  # Crossover(omega, gamma): A* per k, against the smallest A
            print(f"amplitude sweep rho = {rho:g} {mode}: A = {sweep.amplitude[0]:.1e}..{sweep.amplitude[-1]:.1e}, "
                  f"omega(k_min) {sweep.omega[0, 0]:.4f} -> {sweep.omega[-1, 0]:.4f}/t0, A* of omega {star:.1e} "
                  f"(nan: not reached), contacts sliding at once at the largest A: {int(sweep.sliding[-1].max())}")
        for shapes in results.mode_shapes(f):  # ModeShapes: omega (M,), displacement (M, N, D), rotation, ...
            m = int(np.argmin(shapes.participation))
            u = np.linalg.norm(shapes.displacement[m], axis=1)
            print(f"mode shapes rho = {shapes.rho:g}: {shapes.omega.size} kept; the most localised has "
                  f"omega = {shapes.omega[m]:.4f}/t0, participation {shapes.participation[m]:.3f}, "
                  f"largest |u| on particle {int(np.argmax(u))}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "results/quick.h5")
