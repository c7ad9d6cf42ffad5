"""Standing waves integrated by LAMMPS itself against rotsound's C(k, t) (issue 19, item 5).

    python -m scripts.crosschecks.crosscheck_lammps [--n2 128] [--n3 128] [--seed 1] [--t-end 50] [--dt 0.1]
                                            [--halvings 2] [--sample 0.1] [--amplitude 1e-6] [--wave 1]
For 2D disks (phi = 0.9) and 3D spheres (phi = 0.7), each contact law (harmonic: LAMMPS's
``gran/hooke/history``; hertz: ``gran/hertz/history``) and each mode (2D: L, TR, RT; 3D: L, TR,
RT, R), on one jammed packing made by rotsound (``jammed.generate(n, phi, SeedSequence([seed, 0]),
dim, law)``): every run of the mode (``excitation.runs``) starts from rotsound's v(0)
(``excitation.start_velocity``: A sin(k r_i,a) in the excited velocity or angular velocity, its
rigid part removed) with k = 2 pi wave / L, and is integrated by LAMMPS (velocity Verlet of
``fix nve/sphere``, ``disc`` in 2D) with kn = 1, kt = rho kn (rho = 1), no damping, friction
coefficient 1e4 (Debian's LAMMPS refuses more; it never binds here), masses 1, radius d/2, in
rotsound's periodic box from the origin.  Each run goes at +A and -A and the half difference of
the velocities is kept (even orders in A cancel, among them the motion the packing's residual
forces, max|F| ~ 1e-6, cause on their own); then
z(t) = sum_i v_i,c(t) exp(-i k r_i,a(0)) (rotsound's z_fixed) and C(k, t) pooled over the runs
(``correlations.pooled``).  References on the same packing and start: the exact C from the full
eigendecomposition of M^-1/2 D M^-1/2 (``references.exact_z_fixed``, D from
``dynmat.assemble`` with the same law), and rotsound's own Verlet (``integrate_block``) at the
same dt.  Each LAMMPS wave runs twice: as above, and "held" -- a constant external force
(``fix external``) equal to minus LAMMPS's net force at the start, which makes the start an exact
equilibrium without changing the Hessian (a constant force has none), so LAMMPS's linear
dynamics is then exactly rotsound's D.  Without it the packing creeps under its residual forces
(up to ~1e-5 d0 here), which +-A does not cancel in a term A x F: it changes a Hertzian contact's
stiffness, kn sqrt(a' xi), at its smallest overlaps (~1e-4).  LAMMPS runs at dt, dt/2, dt/4 (--halvings), sampled every
--sample t0 to --t-end.

Rattlers [choice]: removed from the LAMMPS run, not frozen.  rotsound's D leaves out the rattlers
and every contact they make; a frozen rattler would still push on its neighbours through those
contacts (fixed springs that D does not have), a removed one does not.  (The packings here have
none at seed 1: the table says how many were removed; the test's 2D packing has 2.)

Writes scripts/crosschecks/records/crosscheck.json, results/bench/crosscheck_details.json (the unrounded
errors per dt, each packing's smallest overlap and residual force), docs/crosscheck_lammps_2d.png
and _3d.png.  One process (LAMMPS and PETSc on COMM_SELF); about two minutes.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from scripts.benchmarks.benchlib import REPO, SCRATCH
from scripts.crosschecks.harness import PACKINGS, lammps_z, pooled_c, save

BENCH = {"order": 140, "record": "crosscheck"}  # make bench: its place, record (scripts/benchmarks/bench_all.py)


def case(dim: int, law: str, n: int, seed: int, args, details: list) -> tuple[list[dict], dict]:
    """Every mode of one (dimension, law): table rows and the curves for the figure; appends the
    unrounded errors and the packing's numbers to ``details``."""
    from solver import petscenv
    from solver.model import dynmat
    from solver.contact_law import ContactModel
    from solver.packing import geometry, jammed
    from solver.references import dense_eigen, exact_z_fixed, verlet_eigen
    from solver.waves import excitation, integrators
    from solver.waves.schedule import resolve_schedule

    PETSc = petscenv.init([])
    comm = PETSc.COMM_SELF.tompi4py()
    p = jammed.generate(n, PACKINGS[dim], np.random.SeedSequence([seed, 0]), dim=dim, law=law)
    dm = dynmat.assemble(p, ContactModel(1.0, law=law), PETSc.COMM_SELF)
    eig = dense_eigen(dm)
    contacts = geometry.find_contacts(p.positions, p.diameters, p.box, dm.active)
    k = 2 * np.pi * args.wave / float(p.box[0])
    times = np.arange(0.0, args.t_end + 1e-9, args.sample)
    dts = [args.dt / 2**h for h in range(args.halvings + 1)]
    rows, curves = [], {"t": times, "modes": {}}
    for mode in excitation.RUNS[dim]:
        runs = excitation.runs(mode, dim)
        exact = pooled_c([exact_z_fixed(p, dm, eig, run, k, times, args.amplitude) for run in runs], args.sample)
        errors = {key: [] for key in ("pm", "held", "pm_verlet", "held_closed", "rotsound_closed")}
        mine = {}
        seconds = 0.0
        for dt in dts:
            every, steps = int(round(args.sample / dt)), int(round(args.t_end / dt))
            if abs(every * dt - args.sample) > 1e-9 * args.sample:
                raise SystemExit(f"--sample {args.sample} is not a multiple of dt = {dt}")
            t0 = time.perf_counter()
            c_pm, c_held = (pooled_c([lammps_z(p, dm, law, run, k, args.amplitude, dt, steps, every, comm, hold)
                                      for run in runs], args.sample) for hold in (False, True))
            seconds += time.perf_counter() - t0
            schedule = resolve_schedule(integrator="verlet", dt=dt, t_end=args.t_end, sample_every=every)
            series = integrators.integrate_block(dm, p.positions, [(mode, r, k) for r in range(len(runs))],
                                                 amplitude=args.amplitude, schedule=schedule)
            c_verlet = pooled_c([s.z_fixed for s in series], args.sample)
            closed = pooled_c([exact_z_fixed(p, dm, verlet_eigen(eig, dt), run, k, times, args.amplitude)
                               for run in runs], args.sample)
            for key, a, b in (("pm", c_pm, exact), ("held", c_held, exact), ("pm_verlet", c_pm, c_verlet),
                              ("held_closed", c_held, closed), ("rotsound_closed", c_verlet, closed)):
                errors[key].append(float(np.abs(a - b).max()))
            mine[dt] = {"pm": c_pm, "held": c_held, "verlet": c_verlet}
        curves["modes"][mode] = {"exact": exact, "dts": dts, **{key: {dt: mine[dt][key] for dt in dts}
                                                             for key in ("pm", "held", "verlet")}}

        def series_text(values):
            return " / ".join(f"{v:.1e}" for v in values)

        def orders(values):
            return ", ".join(f"{np.log2(a / b):.2f}" for a, b in zip(values, values[1:]))

        rows.append({
            "case": f"{dim}D {law}", "mode": mode, "runs": len(runs), "N (rattlers removed)":
                f"{int(dm.active.sum())} ({int(p.rattler.sum())})",
            "k d0": f"{k:.3f}", "dt [t0]": " / ".join(f"{dt:g}" for dt in dts),
            "LAMMPS - exact, +-A": series_text(errors["pm"]), "order": orders(errors["pm"]),
            "LAMMPS - exact, held": series_text(errors["held"]), "order, held": orders(errors["held"]),
            "LAMMPS - rotsound Verlet, +-A": series_text(errors["pm_verlet"]),
            "LAMMPS - Verlet closed form, held": series_text(errors["held_closed"]),
            "LAMMPS [s]": f"{seconds:.1f}",
        })
        details.append({"case": f"{dim}D {law}", "mode": mode, "dts": dts, **errors,
                        "min_overlap": float(contacts.overlap.min()), "max_residual_force": float(p.info["max_force"]),
                        "omega_max": float(np.sqrt(eig[0].max())), "lammps_seconds": seconds})
        print(json.dumps(rows[-1]), flush=True)
    dm.destroy()
    return rows, curves


def figure(dim: int, curves: dict, path) -> None:
    """For each mode (rows) and law (pairs of columns): C(k, t) of LAMMPS (+-A) and of rotsound's
    Verlet at the largest and smallest dt against the exact C; and the running maximum over
    s <= t of |C_LAMMPS - C_exact| at every dt (+-A solid, held dotted), with LAMMPS against
    rotsound's Verlet at the same dt (grey, +-A)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    laws = list(curves)
    modes = list(curves[laws[0]]["modes"])
    fig, axes = plt.subplots(len(modes), 2 * len(laws), figsize=(4.2 * 2 * len(laws), 2.3 * len(modes) + 0.6),
                             squeeze=False)
    colours = ["tab:red", "tab:blue", "tab:green", "tab:purple", "tab:orange"]

    def envelope(a, b):
        return np.maximum.accumulate(np.abs(a - b))[1:]

    for j, law in enumerate(laws):
        t = curves[law]["t"]
        for i, mode in enumerate(modes):
            c = curves[law]["modes"][mode]
            dts = c["dts"]
            left, right = axes[i, 2 * j], axes[i, 2 * j + 1]
            left.plot(t, c["exact"], "k-", lw=1.2, label="rotsound, exact")
            for dt in (dts[0], dts[-1]):
                colour = colours[dts.index(dt)]
                left.plot(t, c["verlet"][dt], "-", lw=0.6, color=colour, label=f"rotsound Verlet, dt = {dt:g}")
                left.plot(t, c["pm"][dt], "o", ms=1.2, color=colour, label=f"LAMMPS, dt = {dt:g}")
            for dt, colour in zip(dts, colours):
                right.semilogy(t[1:], envelope(c["pm"][dt], c["exact"]), "-", lw=1.0, color=colour,
                               label=f"LAMMPS - exact, dt = {dt:g}")
                right.semilogy(t[1:], envelope(c["held"][dt], c["exact"]), ":", lw=1.2, color=colour,
                               label=f"LAMMPS held - exact, dt = {dt:g}")
                right.semilogy(t[1:], envelope(c["pm"][dt], c["verlet"][dt]), "-", lw=0.6, color="0.6",
                               label="LAMMPS - rotsound Verlet, same dt" if dt == dts[0] else None)
            left.set(ylabel="C(k, t)", title=f"{dim}D {law}, {mode}", ylim=(-1.05, 1.05))
            right.set(ylabel="max over s <= t of |dC|", title=f"{dim}D {law}, {mode}: error", ylim=(1e-9, 2))
            if i == len(modes) - 1:
                left.set(xlabel="t [t0]")
                right.set(xlabel="t [t0]")
    handles = [h for ax in axes[0, :2] for h in ax.get_legend_handles_labels()[0]]
    labels = [lab for ax in axes[0, :2] for lab in ax.get_legend_handles_labels()[1]]
    fig.legend(handles, labels, loc="lower center", ncol=6, fontsize=7, frameon=False)
    fig.tight_layout(rect=(0, 0.06 if dim == 2 else 0.045, 1, 1))
    path.parent.mkdir(exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n2", type=int, default=128, help="disks in the 2D packing (phi 0.9)")
    parser.add_argument("--n3", type=int, default=128, help="spheres in the 3D packing (phi 0.7)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--t-end", type=float, default=50.0)
    parser.add_argument("--dt", type=float, default=0.1, help="largest LAMMPS time step (t0)")
    parser.add_argument("--halvings", type=int, default=2, help="also dt/2, ..., dt/2^halvings")
    parser.add_argument("--sample", type=float, default=0.1, help="sampling interval (t0)")
    parser.add_argument("--amplitude", type=float, default=1e-6)
    parser.add_argument("--wave", type=int, default=1, help="k = 2 pi wave / L")
    args = parser.parse_args()
    table, details = [], []
    for dim, n in ((2, args.n2), (3, args.n3)):
        curves = {}
        for law in ("harmonic", "hertz"):
            rows, curves[law] = case(dim, law, n, args.seed, args, details)
            table += rows
        figure(dim, curves, REPO / "docs" / f"crosscheck_lammps_{dim}d.png")
    command = "python -m scripts.crosschecks.crosscheck_lammps " + " ".join(sys.argv[1:])
    save("crosscheck", command.strip(), table,
         f"C(k, t) of standing waves integrated by LAMMPS (fix nve/sphere, gran/hooke/history or "
         f"gran/hertz/history, kt = kn, no damping) against rotsound's exact C (full eigendecomposition) "
         f"on the same packing and start, k = 2 pi {args.wave} / L, A = {args.amplitude:g}, runs of a mode pooled. "
         f"Each 'a - b' column: max over t <= {args.t_end:g} t0 (sampled every {args.sample:g} t0) of "
         f"abs(C_a - C_b) at each dt; exact: rotsound's eigendecomposition; rotsound Verlet: its "
         f"integrate_block at the same dt; Verlet closed form: velocity Verlet's exact solution on rotsound's D "
         f"at the same dt. +-A: half the difference of the runs at +A and -A; held: the same with LAMMPS's "
         f"net start forces cancelled by a constant external force. Order: log2 of successive error ratios "
         f"(2 = dt^2). Plots: "
         f"![2D](docs/crosscheck_lammps_2d.png) ![3D](docs/crosscheck_lammps_3d.png)")
    SCRATCH.mkdir(parents=True, exist_ok=True)
    SCRATCH.joinpath("crosscheck_details.json").write_text(json.dumps(details, indent=1))


if __name__ == "__main__":
    main()
