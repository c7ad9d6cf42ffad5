"""Standing waves about a stressed frictional packing, integrated by YADE itself, against rotsound's
stressed matrix under YADE's history (``model.history: yade``; docs/stressed_contacts.md §2).

    python -m scripts.crosschecks.crosscheck_yade [--n 64] [--seed 5] [--t-end 10] [--dt 0.002] [--halvings 2]
                                          [--sample 0.1] [--amplitude 1e-6]
LAMMPS referees LAMMPS's history (scripts/crosschecks/crosscheck_stressed.py); YADE's differs in 3D (it turns
a shear force with the pair's mean spin about the normal), so YADE referees its own:

1. YADE makes a 3D packing at rest on its shear forces (scripts/crosschecks/yade_referee.py ``prepare``: kn
   = 1 for every contact, ks = rho kn with rho = 1, mean mass 1, friction angle atan(1e4) so that
   no contact slides, unbalanced force below 1e-10) and saves its scene; rotsound reads the
   spheres and contact files it writes (``packing.contacts_format: yade``, lever ``contact``),
   so that rotsound's units are YADE's with d0 its mean diameter (t0 = sqrt(m0/kn) = 1).
   Seeds are tried until every rattler rotsound finds touches nobody (a rattler left out of D
   but touching in YADE would couple there and not here).
2. One step: YADE's forces and torques after moving every body by a random x (and giving it the
   velocity x / dt, since YADE's shear increment integrates velocities), +-x half difference,
   against -D x: the matrix is YADE's Jacobian to the second order in x.
3. Waves: every run of a mode (``excitation.runs``) starts from rotsound's v(0) at +A and -A
   (rattlers at rest) and is integrated by YADE (``waves``: NewtonIntegrator undamped, from the
   saved scene) at dt, dt/2, dt/4; the half difference of the velocities gives C(k, t), pooled as
   rotsound pools it.  YADE's leapfrog samples v at t - dt/2, so the references are taken there.
4. References: -D x and exp(tJ) (dense, exact) on the same packing and start for D under YADE's
   history, and, to show the checks can fail, under LAMMPS's history and without the stored
   forces.

Writes scripts/crosschecks/records/crosscheck_yade.json (BENCHMARKS.md "crosscheck_yade").  YADE in its own
process (its launcher); about a minute.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import subprocess
import sys
import tempfile
import time

from pathlib import Path

import numpy as np

from scripts.crosschecks.harness import add_wave_arguments, pooled_c, save

BENCH = {"order": 160}  # make bench: its place (scripts/benchmarks/bench_all.py)
REFEREE = Path(__file__).resolve().parent / "yade_referee.py"  # run by YADE's launcher, never imported


def yade(*args) -> None:
    """Run scripts/crosschecks/yade_referee.py under YADE's launcher with ``args``; RuntimeError with its
    output if it fails."""
    done = subprocess.run(["yade", "-n", "-x", str(REFEREE), *map(str, args)], capture_output=True, text=True,
                          timeout=3600)
    if done.returncode != 0:
        raise RuntimeError(f"yade {' '.join(map(str, args))} failed:\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}")


def prepare(folder: str, n: int, seed: int, rho: float):
    """(rotsound's Packing, YADE's report) of a stressed packing YADE makes in ``folder``."""
    from solver.contact_law import ContactModel
    from solver.io import hdf5

    yade("prepare", folder, n, seed, rho)
    with open(os.path.join(folder, "prepare.json"), encoding="utf-8") as f:
        report = json.load(f)
    p = hdf5.read_packings(os.path.join(folder, "packing.spheres"), contacts=os.path.join(folder, "packing.contacts"),
                           contacts_format="yade", model=ContactModel(lever="contact"))[0]
    return p, report


def yade_velocities(folder: str, starts: np.ndarray, dt: float, steps: int, every: int) -> np.ndarray:
    """Velocities (R, S, N, 6) of YADE's runs from ``starts`` (R, N, 6) (YADE units)."""
    np.save(os.path.join(folder, "starts.npy"), starts)
    yade("waves", folder, repr(dt), steps, every)
    return np.load(os.path.join(folder, "samples.npy"))


def yade_forces(folder: str, moves: np.ndarray) -> np.ndarray:
    """YADE's one-step force and torque responses (R, N, 6) to ``moves`` (R, N, 6) (YADE units)."""
    np.save(os.path.join(folder, "moves.npy"), moves)
    yade("forces", folder)
    return np.load(os.path.join(folder, "forces.npy"))


def case(args) -> dict:
    """Every 3D mode: max |C_YADE - C| per dt for D under YADE's history, LAMMPS's, and unstressed."""
    from solver import petscenv
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.packing import geometry
    from solver.references import first_order_flow
    from solver.waves import excitation

    PETSc = petscenv.init([])
    comm = PETSc.COMM_SELF.tompi4py()
    with tempfile.TemporaryDirectory() as folder:
        for seed in range(args.seed, args.seed + 20):
            p, report = prepare(folder, args.n, seed, args.rho)
            found = geometry.find_contacts(p.positions, p.diameters, p.box)
            touching = np.zeros(p.n, bool)
            touching[found.i], touching[found.j] = True, True
            if not np.any(p.rattler & touching):
                break
        else:
            raise SystemExit(f"every seed from {args.seed} gave a rattler that touches")
        model = ContactModel(args.rho, law="harmonic", lever="contact", history="yade")
        matrices = {"yade": dynmat.assemble(p, model, PETSc.COMM_SELF, "density"),
                    "lammps": dynmat.assemble(p, dataclasses.replace(model, history="lammps"), PETSc.COMM_SELF,
                                              "density"),
                    "unstressed": dynmat.assemble(p, dataclasses.replace(model, stored_forces="drop"),
                                                  PETSc.COMM_SELF, "density")}
        dm = matrices["yade"]
        active = ~p.rattler
        d0 = p.info["length_unit"]  # YADE lengths per d0; kn = 1 and mean mass 1 make t0 = 1
        x = p.positions[active]
        k = 2 * np.pi / float(p.box[0])
        count = int(round(args.t_end / args.sample)) + 1
        dts = [args.dt / 2 ** h for h in range(args.halvings + 1)]
        row = {"n": p.n, "seed": seed, "rattlers": int(p.rattler.sum()), "contacts": len(p.tangential),
               "z": p.info["z"], "yade": report, "modes": {}}
        moves = np.zeros((2, p.n, 6))
        moves[:, active] = 1e-7 * np.random.default_rng(seed).normal(size=(2, int(active.sum()), 6))
        moves[:, :, :3] *= d0
        response = yade_forces(folder, moves)[:, active]
        response[..., :3] /= d0      # kn d0
        response[..., 3:] /= d0 ** 2  # kn d0^2
        moved = moves[:, active]
        moved[..., :3] /= d0
        row["one_step"] = {}
        for name, m in matrices.items():
            dense = dynmat.in_packing_order(m, dynmat.gather_csr(m.D).toarray())
            predicted = np.array([-(dense @ x.ravel()).reshape(x.shape) for x in moved])
            row["one_step"][name] = float(np.abs(response - predicted).max() / np.abs(response).max())
        print("one step: " + ", ".join(f"|F_YADE + D_{name} x| / |F| {e:.2e}" for name, e in row["one_step"].items()),
              flush=True)
        for mode in excitation.RUNS[3]:
            runs = excitation.runs(mode, 3)
            starts = [excitation.whole_start(dm, p.positions, c, a, k, args.amplitude, comm) for c, a in runs]

            def pooled(velocities):
                return pooled_c([v[:, :, c] @ np.exp(-1j * k * x[:, a]) for v, (c, a) in zip(velocities, runs)],
                                args.sample)

            full = np.zeros((2 * len(starts), p.n, 6))
            for r, s in enumerate(starts):
                for sign, slot in ((1.0, 2 * r), (-1.0, 2 * r + 1)):
                    full[slot, active, :3] = sign * s[:, :3] * d0  # rotsound d0/t0 -> YADE's length/time
                    full[slot, active, 3:] = sign * s[:, 3:]
            errors = {name: [] for name in matrices}
            curves, seconds = [], 0.0
            for dt in dts:
                t0 = time.perf_counter()
                samples = yade_velocities(folder, full, dt, int(round(args.t_end / dt)), int(round(args.sample / dt)))
                seconds += time.perf_counter() - t0
                half = 0.5 * (samples[0::2] - samples[1::2])[:, :, active]
                half[..., :3] /= d0
                curves.append(pooled(list(half)))
                for name, m in matrices.items():
                    reference = pooled([first_order_flow(m, s, args.sample, count, -0.5 * dt)[:, 1] for s in starts])
                    errors[name].append(float(np.abs(curves[-1] - reference).max()))
            # YADE's C converges at first order in dt here: Richardson's 2 C(dt/2) - C(dt) cancels that
            # term; its reference is the exact C at t (the -dt/2 sampling offsets cancel too)
            extrapolated = 2.0 * curves[-1] - curves[-2]
            richardson = {name: float(np.abs(extrapolated - pooled([first_order_flow(m, s, args.sample, count)[:, 1]
                                                                      for s in starts])).max())
                          for name, m in matrices.items()}
            row["modes"][mode] = {"dt": dts, "errors": errors, "richardson": richardson, "yade_seconds": seconds}
            print(f"{mode}: " + ", ".join(f"|C_YADE - C_{name}| {['%.2e' % e for e in errs]} (Richardson "
                                          f"{richardson[name]:.2e})" for name, errs in errors.items()), flush=True)
        for m in matrices.values():
            m.destroy()
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=64)
    parser.add_argument("--seed", type=int, default=5)
    parser.add_argument("--rho", type=float, default=1.0)
    add_wave_arguments(parser)
    args = parser.parse_args()
    c = case(args)
    table = [{"N": c["n"], "seed": c["seed"], "rattlers": c["rattlers"], "contacts": c["contacts"],
              "z": f"{c['z']:.3f}", "mode": "one step, |F_YADE + D x| / max|F_YADE|",
              **{f"YADE - {name}": f"{e:.2e}" for name, e in c["one_step"].items()}}]
    for mode, m in c["modes"].items():
        row = {"N": c["n"], "seed": c["seed"], "rattlers": c["rattlers"], "contacts": c["contacts"],
               "z": f"{c['z']:.3f}", "mode": mode}
        for name in ("yade", "lammps", "unstressed"):
            for dt, e in zip(m["dt"], m["errors"][name]):
                row[f"YADE - {name}, dt={dt:g}"] = f"{e:.2e}"
            if name == "yade":
                row["order"] = " ".join(f"{np.log2(a / b):.2f}" for a, b in zip(m["errors"][name][:-1],
                                                                                 m["errors"][name][1:]))
            row[f"YADE - {name}, Richardson"] = f"{m['richardson'][name]:.2e}"
        row["YADE s"] = f"{m['yade_seconds']:.1f}"
        table.append(row)
    y = c["yade"]
    notes = (f"First row: YADE's forces and torques one step after moving every body by a random x (1e-7 d0, "
             f"with velocity x / dt), +-x half difference, against -D x. Then C(k, t) of standing waves integrated by YADE {y['version']} (NewtonIntegrator, undamped, from the "
             f"saved scene of a stressed 3D packing it made: kn = 1 per contact, ks = {args.rho:g} kn, friction angle "
             f"atan(1e4), at rest to an unbalanced force of {y['unbalanced']:.1e}) against exp(tJ) of rotsound's "
             f"matrix on the same packing and start, read from YADE's files (contacts_format yade, lever contact): "
             f"D under YADE's history (model.history: yade), under LAMMPS's, and without the stored forces. "
             f"k = 2 pi / L, A = {args.amplitude:g}, +-A half difference, runs of a mode pooled; each column: max "
             f"over t <= {args.t_end:g} (sampled every {args.sample:g}, YADE's at t - dt/2) of abs(C_YADE - C). Order: log2 of "
             f"successive error ratios (2 = dt^2; YADE's is 1 here). Richardson: 2 C(dt_min) - C(2 dt_min), which "
             f"cancels YADE's first-order term, against the exact C.")
    save("crosscheck_yade", "python -m scripts.crosschecks.crosscheck_yade " + " ".join(sys.argv[1:]), table, notes)


if __name__ == "__main__":
    sys.exit(main())
