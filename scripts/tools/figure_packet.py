"""The spreading packet (``transport.packet``, issue 45 point 3) against route 1 (the exact
Allen-Feldman d_n): the numbers and the figure of docs/diffusivity_packet.md.

    .venv/bin/python -m scripts.tools.figure_packet [--n 1024] [--dim 2] [--centres 4] [--probes 8]
        [--tmax 80] [--figure docs/diffusivity_packet.png]
One FIRE packing (2D: phi = 0.9, seed 7, rho = 0.5; 3D: phi = 0.68, seed 5, rho = 0.5 with
rolling 0.2 and twisting 0.1), one process.  For each band: the packet's d (default window,
``--probes`` starts in each of ``--centres`` regions of radius 3 d0, averaged over the regions)
and route 1's d_n weighted by each start's modal energies E_n (dense eigendecomposition), at
eta = 0.02, 0.05, 0.1, 0.2; |Y^a_nm|^2 is made once (dense, as ``references.allen_feldman_dense``)
and reweighted for each eta.  Also the packet started at rest alone (phase A), to show the
2 omega breathing the second phase removes.  Prints a markdown table; draws <dr^2>(t) with the
2 D d_AF t line and the local d(t) / d_AF of every band.
"""

from __future__ import annotations

import argparse
import math
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402

ETAS = (0.02, 0.05, 0.1, 0.2)
BANDS = {2: [(1.0, 2.0), (1.5, 2.0), (2.0, 2.5), (2.0, 3.0), (2.5, 3.0)], 3: [(1.0, 2.0), (2.0, 3.0), (3.0, 4.0)]}
FIGURE_BAND = {2: (2.0, 3.0), 3: (2.0, 3.0)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=1024)
    parser.add_argument("--dim", type=int, default=2, choices=(2, 3))
    parser.add_argument("--centres", type=int, default=4)
    parser.add_argument("--probes", type=int, default=8)
    parser.add_argument("--radius", type=float, default=3.0)
    parser.add_argument("--tmax", type=float, default=80.0)
    parser.add_argument("--figure", default=None, help="PNG to draw (none: the table only)")
    args = parser.parse_args()

    from mpi4py import MPI

    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.model.operators import largest_omega, scaled_operator
    from solver.packing import jammed
    from solver.transport import packet

    PETSc = petscenv.init([])
    comm = PETSc.COMM_SELF
    if args.dim == 2:
        p = jammed.generate(args.n, 0.9, np.random.SeedSequence([7, 0]), comm=MPI.COMM_SELF)
        model = ContactModel(0.5)
    else:
        p = jammed.generate(args.n, 0.68, np.random.SeedSequence([5, 0]), dim=3, comm=MPI.COMM_SELF)
        model = ContactModel(0.5, rho_roll=0.2, rho_twist=0.1)
    dm = dynmat.assemble(p, model, comm)
    clock = time.perf_counter()
    A = scaled_operator(dm)
    a = dynmat.gather_csr(A).toarray()  # matrix order
    lam, vec = np.linalg.eigh(a)
    keep = lam > 1e-4**2
    omega, v = np.sqrt(lam[keep]), vec[:, keep]
    r = p.positions[dm.order]
    square = np.zeros((omega.size, omega.size))
    for axis in range(p.dim):  # |Y^a_nm|^2 summed over the axes, the definition densely
        sep = r[:, None, axis] - r[None, :, axis]
        sep -= p.box[axis] * np.round(sep / p.box[axis])
        y = v.T @ (a * np.kron(sep, np.ones((dm.dof, dm.dof)))) @ v
        square += y**2
    del y
    wn, wm = omega[:, None], omega[None, :]
    ratio = (wn + wm) ** 2 / (4 * wn * wm)
    d_af = {}
    for eta in ETAS:
        weight = ratio * (eta / math.pi) / ((wn - wm) ** 2 + eta**2)
        np.fill_diagonal(weight, 0.0)
        d_af[eta] = math.pi / (4 * p.dim * omega**2) * (square * weight).sum(axis=1)
    print(f"N = {args.n} ({args.dim}D, {dm.size} DOF, L = {p.box[0]:.2f} d0): modes and route 1 at {len(ETAS)} eta "
          f"in {time.perf_counter() - clock:.1f} s; omega_max = {omega.max():.3f}")

    lam_top = (largest_omega(dm) * (1 + packet.MARGIN)) ** 2
    times = np.linspace(0.0, args.tmax, 161)
    rng = np.random.default_rng(2045)
    centres = [rng.random(p.dim) * p.box for _ in range(args.centres)]
    rows = []
    curves = {}
    print("| band (1/t0) | packet d | spread over regions | window (t0) | t_cross | "
          + " | ".join(f"route 1, eta = {eta}" for eta in ETAS) + " | packet / route 1 (eta = 0.05) |")
    print("|---" * (6 + len(ETAS)) + "|")
    for band in BANDS[args.dim]:
        ours, theirs, msd, local, windows, cross = [], {eta: [] for eta in ETAS}, [], [], [], []
        clock = time.perf_counter()
        for c, centre in enumerate(centres):
            ds, at = packet.spreading(dm, p.positions, p.box, band=band, centre=centre, radius=args.radius,
                                      times=times, seed=c, comm=comm, probes=args.probes)
            starts, _, _ = packet.band_starts(A, dm, p.positions, p.box, band=band, centre=centre,
                                              radius=args.radius, seed=c, probes=args.probes, lam_top=lam_top,
                                              comm=comm)
            energy = np.zeros(omega.size)
            for (q0, _), (_, p0) in zip(starts[::2], starts[1::2]):
                energy += 0.5 * (omega**2 * (v.T @ q0) ** 2 + (v.T @ p0) ** 2)
            ours.append(at["d"])
            for eta in ETAS:
                theirs[eta].append(energy @ d_af[eta] / energy.sum())
            msd.append(ds["msd"])
            local.append(ds["local_d"])
            windows.append(at["window"])
            cross.append(at["t_cross"])
        mean = {eta: float(np.mean(theirs[eta])) for eta in ETAS}
        window = np.mean(windows, axis=0)
        rows.append((band, np.mean(ours), mean[0.05]))
        curves[band] = (np.mean(msd, axis=0), np.mean(local, axis=0), window, at["saturation"], mean[0.05])
        print(f"| {band[0]:g}-{band[1]:g} | {np.mean(ours):.3f} | {np.min(ours):.3f}-{np.max(ours):.3f} | "
              f"{window[0]:.0f}-{window[1]:.0f} | {np.mean(cross):.1f} | "
              + " | ".join(f"{mean[eta]:.3f}" for eta in ETAS) + f" | {np.mean(ours) / mean[0.05]:.3f} |",
              flush=True)

    # the start at rest alone (phase A): the breathing at 2 omega in the exact rate
    band = FIGURE_BAND[args.dim]
    mine = p.positions[dm.order]
    starts, _, _ = packet.band_starts(A, dm, p.positions, p.box, band=band, centre=centres[0], radius=args.radius,
                                      seed=0, probes=args.probes, lam_top=lam_top, comm=comm)
    fine = np.linspace(10.0, 15.0, 401)  # 400 samples over 5 t0: the 2 omega breathing resolved
    both = packet.energy_spread(A, dm.dof, starts, fine, centres[0], mine, p.box, lam_top, comm)
    rest = packet.energy_spread(A, dm.dof, starts[::2], fine, centres[0], mine, p.box, lam_top, comm)

    def wiggle(rate):  # rms of the exact rate about its least-squares line over the 5 t0, d0^2/t0
        return float(np.std(rate - np.polyval(np.polyfit(fine, rate, 1), fine)))

    print(f"band {band}, 10 <= t <= 15: rms of the exact d<dr^2>/dt about its line: both phases "
          f"{wiggle(both['msd_rate']):.4f}, the start at rest alone {wiggle(rest['msd_rate']):.4f} d0^2/t0 "
          f"(mean {np.mean(both['msd_rate']):.4f}); terms {both['terms']}, energy drift "
          f"{np.abs(both['energy'] - 1).max():.2g}")
    A.destroy()

    if args.figure:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
        msd, local, window, saturation, d_ref = curves[FIGURE_BAND[args.dim]]
        middle = (times >= window[0]) & (times <= window[1])
        anchor = np.mean(msd[middle]) - 2 * p.dim * d_ref * np.mean(times[middle])
        left.plot(times, msd, label=r"packet $\langle\Delta r^2\rangle(t)$")
        left.plot(times, anchor + 2 * p.dim * d_ref * times, "--",
                  label=rf"$2 \cdot {p.dim} \cdot d_{{AF}}\, t$ + const, $d_{{AF}}$ = {d_ref:.3f}")
        left.axhline(saturation, color="grey", lw=0.8, label=r"uniform spread $\sum L_a^2/12$")
        left.axvspan(*window, color="C2", alpha=0.15, label="fit window")
        left.set(xlabel=r"$t\ (t_0)$", ylabel=r"$\langle\Delta r^2\rangle\ (d_0^2)$",
                 title=f"band {FIGURE_BAND[args.dim][0]:g} < ω < {FIGURE_BAND[args.dim][1]:g}, N = {args.n}")
        left.legend(fontsize=8)
        for band, (_, local_b, _, _, d_b) in curves.items():
            right.plot(times, local_b / d_b, label=f"{band[0]:g} < ω < {band[1]:g}")
        right.axhline(1.0, color="k", lw=0.8)
        right.set(xlabel=r"$t\ (t_0)$", ylabel=r"local $d(t)\,/\,d_{AF}$ ($\eta$ = 0.05)", ylim=(0, 1.6),
                  title=r"$d(t) = (d\langle\Delta r^2\rangle/dt)\,/\,2D$, exact")
        right.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(args.figure, dpi=120)
        print(f"wrote {args.figure}")
    dm.destroy()


if __name__ == "__main__":
    main()
