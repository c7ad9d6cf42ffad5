"""The three routes to the diffusivity on the same packing (issue 45, "the three routes agree
where they should"): route 1, every mode's d_n (``transport.allen_feldman``); route 2, d per bin
by KPM (``transport.kpm_diffusivity``); route 3, a spreading energy packet
(``transport.packet``); time and agreement, band by band.

    python -m scripts.benchmarks.bench_transport_routes [--dim 2] [--n 2048] [--bands 1 1.5 2 2.5 3]

The packing: rotsound's FIRE at phi = 0.9 (2D, rho = 0.5) or 0.7 (3D, rho = 0.5, rho_roll = 0.2,
rho_twist = 0.1), seed 5.  Each band [lo, hi) gets one number per route, every one an average
over the packet's spectral weight w(omega) (``packet.band_weight``: the energy a random start
puts in a mode of frequency omega):
- route 1 at ``--eta``: sum w(omega_n) d_n / sum w(omega_n);
- route 2 on bins of ``--width``: sum_b w(omega_b) total_b / sum_b w(omega_b) count_b (its
  estimate of the same weighted mean, broadened by the bin instead of eta), with its standard
  error from the probes (sqrt(sum (w_b count_b d_err_b)^2) / sum w_b count_b);
- route 3: the mean of the packet's fitted d over ``--centres`` start regions of radius 3 d0
  (``--probes`` starts each), and their standard error (spread / sqrt(regions)); NaN where the
  packet has no diffusive window (module ``packet``: the ballistic start reaches the box).
The ratios of routes 2 and 3 to route 1 say how well they agree; docs/diffusivity_routes.md
reads the table.  One process, one BLAS thread.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads OpenBLAS: one core, as a rank
import numpy as np  # noqa: E402

from scripts.benchmarks.benchlib import peak_rss_gib, save  # noqa: E402

BENCH = {"order": 245, "record": "transport_routes_2d", "also": ["transport_routes_3d"]}  # make bench (bench_all.py)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dim", type=int, choices=(2, 3), default=2)
    parser.add_argument("--n", type=int, default=2048)
    parser.add_argument("--bands", type=float, nargs="+", default=[1.0, 1.5, 2.0, 2.5, 3.0],
                        help="band edges (1/t0)")
    parser.add_argument("--eta", type=float, default=0.02, help="route 1's Lorentzian half-width (1/t0)")
    parser.add_argument("--width", type=float, default=0.05, help="route 2's bins (1/t0)")
    parser.add_argument("--probes", type=int, default=32, help="route 2's probes")
    parser.add_argument("--centres", type=int, default=4, help="route 3's start regions")
    parser.add_argument("--packet-probes", type=int, default=8, help="route 3's starts per region")
    args = parser.parse_args()

    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.model.operators import largest_omega
    from solver.packing import jammed
    from solver.transport import allen_feldman, kpm_diffusivity, packet

    PETSc = petscenv.init([])
    comm = PETSc.COMM_SELF
    phi, model = (0.9, ContactModel(0.5)) if args.dim == 2 else (0.7, ContactModel(0.5, 0.2, 0.1))
    p = jammed.generate(args.n, phi, np.random.SeedSequence([5, 0]), dim=args.dim)
    dm = dynmat.assemble(p, model, comm)
    t0 = time.perf_counter()
    omega, d_n = allen_feldman.allen_feldman(dm, p.positions, p.box, args.eta, comm)
    seconds = {"route 1": time.perf_counter() - t0}
    t0 = time.perf_counter()
    top = largest_omega(dm)
    edges = np.arange(0.0, args.width * (np.ceil(1.1 * top / args.width) + 1), args.width)
    kpm, attrs = kpm_diffusivity.binned_diffusivity(dm, p.positions, p.box, edges, moments=None, probes=args.probes,
                                                    seed=1, comm=comm)
    seconds["route 2"] = time.perf_counter() - t0
    centres_b = 0.5 * (edges[1:] + edges[:-1])
    times = np.linspace(0.0, 0.07 * args.n + 20.0, 161)
    rng = np.random.default_rng(2045)
    starts = rng.random((args.centres, args.dim)) * p.box
    table = []
    seconds["route 3"] = 0.0
    for lo, hi in zip(args.bands[:-1], args.bands[1:]):
        band = (lo, hi)
        w = packet.band_weight(omega, band)
        d1 = float(w @ d_n / w.sum())
        wb = packet.band_weight(centres_b, band) * kpm["count"]
        d2 = float(packet.band_weight(centres_b, band) @ kpm["total"] / wb.sum())
        e2 = float(np.sqrt(np.nansum((wb * kpm["d_err"]) ** 2)) / wb.sum())
        t0 = time.perf_counter()
        found, drift, windows = [], 0.0, []
        for c, centre in enumerate(starts):
            _, at = packet.spreading(dm, p.positions, p.box, band=band, centre=centre, radius=3.0, times=times,
                                     seed=c, comm=comm, probes=args.packet_probes)
            found.append(at["d"])
            drift = max(drift, at["energy_drift"])
            windows.append(at["window"])
        seconds["route 3"] += time.perf_counter() - t0
        found = np.array(found)
        d3 = float(np.mean(found)) if np.all(np.isfinite(found)) else float("nan")
        e3 = float(np.std(found, ddof=1) / np.sqrt(found.size)) if np.isfinite(d3) else float("nan")
        row = {"band (1/t0)": f"{lo:g}-{hi:g}", "route 1 d": f"{d1:.4f}", "route 2 d": f"{d2:.4f} +- {e2:.4f}",
               "route 2 / 1": f"{d2 / d1:.3f}", "route 3 d": f"{d3:.4f} +- {e3:.4f}",
               "route 3 / 1": f"{d3 / d1:.3f}", "route 3 window (t0)": ", ".join(
                   f"{a:.0f}-{b:.0f}" for a, b in windows) if np.isfinite(d3) else "none",
               "route 3 energy drift": f"{drift:.0e}"}
        table.append(row)
        print(row, flush=True)
    dm.destroy()
    notes = (f"{args.dim}D FIRE packing of N = {args.n} at phi = {phi} (seed 5), {model.rho=}, "
             f"{model.rho_roll=}, {model.rho_twist=} ({dm.size} DOF); route 1 at eta = {args.eta:g}/t0 "
             f"({seconds['route 1']:.1f} s), route 2 on bins of {args.width:g}/t0 with {args.probes} probes and "
             f"{attrs['moments']} moments ({seconds['route 2']:.1f} s), route 3 with {args.centres} regions x "
             f"{args.packet_probes} starts per band ({seconds['route 3']:.1f} s in all); peak RSS "
             f"{peak_rss_gib():.2f} GiB; every d weighted by the packet's spectral weight over the band.")
    print(notes)
    save(f"transport_routes_{args.dim}d", "python -m scripts.benchmarks.bench_transport_routes " + " ".join(
        ["--dim", str(args.dim), "--n", str(args.n), "--bands", *map(lambda b: f"{b:g}", args.bands), "--eta",
         f"{args.eta:g}", "--width", f"{args.width:g}", "--probes", str(args.probes), "--centres",
         str(args.centres), "--packet-probes", str(args.packet_probes)]), table, notes)


if __name__ == "__main__":
    main()
