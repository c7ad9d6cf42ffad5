"""The diffusivity as a spreading energy packet (``transport.packet``, issue 45 point 3) against
route 1 (``transport.allen_feldman``): time and agreement, N disks.

    python -m scripts.benchmarks.bench_transport_packet [--ns 256 512 1024] [--eta 0.05] [--band 2 3]
For each N, a FIRE packing at phi = 0.9 (seed 5), D at rho = 0.5 (translations and rotations).
The packet: ``--centres`` start regions of radius 3 d0 (fixed random centres), ``--probes``
random starts each, 161 samples over t_max = 0.07 N + 20 t0 (long enough to reach the default
window's end, 0.3 of the uniform spread), the default fit window; its d is the mean over the
regions.  Route 1: the library's d_n of every mode at ``--eta``, weighted by the packet's
spectral weight ``packet.band_weight`` (the band alone: the start region's own weights on the
modes need eigenvectors; tests/transport/test_packet.py uses them).  Columns: seconds of each
(the packet: all regions), the packet's Chebyshev terms (propagation, filter), its largest energy
drift, both d and their ratio, the spread of d over the regions.  One process, one BLAS thread.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads OpenBLAS: one core, as a rank
import numpy as np  # noqa: E402

from scripts.benchmarks.benchlib import peak_rss_gib, save  # noqa: E402

BENCH = {"order": 235}  # make bench: its place (scripts/benchmarks/bench_all.py)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ns", type=int, nargs="+", default=[256, 512, 1024])
    parser.add_argument("--eta", type=float, default=0.05, help="route 1's Lorentzian half-width (1/t0)")
    parser.add_argument("--band", type=float, nargs=2, default=[2.0, 3.0], help="the packet's band (1/t0)")
    parser.add_argument("--centres", type=int, default=4)
    parser.add_argument("--probes", type=int, default=8)
    args = parser.parse_args()

    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.packing import jammed
    from solver.transport import allen_feldman, packet

    PETSc = petscenv.init([])
    comm = PETSc.COMM_SELF
    band = tuple(args.band)
    table = []
    for n in args.ns:
        p = jammed.generate(n, 0.9, np.random.SeedSequence([5, 0]))
        dm = dynmat.assemble(p, ContactModel(0.5), comm)
        times = np.linspace(0.0, 0.07 * n + 20.0, 161)
        rng = np.random.default_rng(2045)
        t0 = time.perf_counter()
        ours, drift = [], 0.0
        for c in range(args.centres):  # a handful of start regions
            _, at = packet.spreading(dm, p.positions, p.box, band=band, centre=rng.random(2) * p.box, radius=3.0,
                                     times=times, seed=c, comm=comm, probes=args.probes)
            ours.append(at["d"])
            drift = max(drift, at["energy_drift"])
        seconds = time.perf_counter() - t0
        t0 = time.perf_counter()
        omega, d_n = allen_feldman.allen_feldman(dm, p.positions, p.box, args.eta, comm)
        af_seconds = time.perf_counter() - t0
        weight = packet.band_weight(omega, band)
        d_af = float(weight @ d_n / weight.sum())
        row = {"N": n, "DOF": dm.size, "L (d0)": f"{p.box[0]:.1f}", "packet s": f"{seconds:.1f}",
               "terms (propagation, filter)": f"{at['terms']}, {at['filter_terms']}",
               "energy drift": f"{drift:.0e}", "packet d": f"{np.mean(ours):.3f}",
               "d over regions": f"{min(ours):.3f}-{max(ours):.3f}", "window (t0, last region)":
               f"{at['window'][0]:.0f}-{at['window'][1]:.0f}", "route 1 d (band-weighted)": f"{d_af:.3f}",
               "packet / route 1": f"{np.mean(ours) / d_af:.3f}", "route 1 s": f"{af_seconds:.1f}",
               "peak RSS GiB": f"{peak_rss_gib():.2f}"}
        table.append(row)
        print(row, flush=True)
        dm.destroy()
    notes = (f"2D FIRE packings at phi = 0.9 (seed 5), N = {', '.join(map(str, args.ns))}; D at rho = 0.5; band "
             f"{band[0]:g}-{band[1]:g}/t0; {args.centres} start regions of radius 3 d0 x {args.probes} probes; "
             f"route 1 at eta = {args.eta:g}/t0 (the library), weighted by the band's spectral weight; one process.")
    save("transport_packet", "python -m scripts.benchmarks.bench_transport_packet " + " ".join(
        ["--ns", *map(str, args.ns), "--eta", f"{args.eta:g}", "--band", *[f"{b:g}" for b in band],
         "--centres", str(args.centres), "--probes", str(args.probes)]), table, notes, merge_by=("N",))


if __name__ == "__main__":
    main()
