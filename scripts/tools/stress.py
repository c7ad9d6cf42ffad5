"""Numerical stress cases (issue 7); writes STRESS.md.   .venv/bin/python -m scripts.tools.stress

Each case says what happened and what the code did about it.  Serial, about 3-4 minutes.
"""

import datetime
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

from scripts.benchmarks.benchlib import machine
from solver import petscenv, references
from solver.contact_law import ContactModel
from solver.errors import InputError
from solver.model import dynmat, operators
from solver.packing import jammed
from solver.spectrum import slicing
from solver.waves import integrators
from solver.waves.schedule import check_schedule, resolve_schedule, stability_limit

REPO = Path(__file__).resolve().parents[2]
PETSc = petscenv.init([])
COMM = PETSc.COMM_WORLD
ROWS = []


def row(case, happened, did):
    ROWS.append((case, happened, did))
    print(f"{case}: {happened} | {did}", flush=True)


def dense_check(dm, result):
    lam = references.dense_eigenvalues(dm)
    ref = np.sqrt(lam[lam > 1e-8])
    return float(np.max(np.abs(result.omega - ref) / ref)) if ref.size == result.omega.size else float("nan")


def stiffness_ratios():
    p = jammed.generate(256, 0.9, np.random.SeedSequence([1, 0]))
    for rho in (0.0, 1e-6, 100.0):
        dm = dynmat.assemble(p, ContactModel(rho), COMM)
        r = slicing.solve(dm, window=None, vectors=True)
        err = dense_check(dm, r)
        row(f"rho = {rho:g} (N = 256)", f"{r.omega.size} modes of {dm.size} DOF, {r.n_zero_modes} zero, "
            f"{r.n_negative} negative; omega in [{r.omega.min():.3g}, {r.omega.max():.4g}]; max relative "
            f"residual {r.max_residual:.1e}; max error vs eigh {err:.1e}",
            {0.0: "rotations dropped (2N' block), so no spurious zero modes",
             1e-6: "the rotational band sits near sqrt(4 z rho) ~ 4e-3 > zero_tol = 1e-4: counted as modes, "
                   "not zero modes (a scene with rho < ~1e-9 would need a smaller spectrum.zero_tol)",
             100.0: "omega_max ~ 47: the Gershgorin upper bound and the inertia windows scale with it"}[rho]
            + "; count checked against the inertia")
        dm.destroy()


def area_fractions():
    for phi in (0.85, 0.95):
        t = time.perf_counter()
        p = jammed.generate(1024, phi, np.random.SeedSequence([2, 0]))
        sec = time.perf_counter() - t
        dm = dynmat.assemble(p, ContactModel(1.0), COMM)
        r = slicing.solve(dm, window=None, vectors=False)
        row(f"phi = {phi} (N = 1024)", f"FIRE {p.info['fire_steps']} steps in {sec:.1f} s to max|F| "
            f"{p.info['max_force']:.1e}; z = {p.info['z']:.2f}, rattlers {100 * p.info['rattler_fraction']:.1f} %, "
            f"pressure {p.info['pressure']:.2e}; {r.omega.size} modes, {r.n_negative} negative",
            "near jamming rattlers are many and are removed iteratively; spectrum count = DOF - 2 "
            "checked against the inertia")
        dm.destroy()


def sizes():
    for n in (16, 64, 2048, 32768):
        t = time.perf_counter()
        p = jammed.generate(n, 0.9, np.random.SeedSequence([3, 0]))
        sec = time.perf_counter() - t
        dm = dynmat.assemble(p, ContactModel(1.0), COMM)
        if n <= 2048:
            r = slicing.solve(dm, window=None, vectors=False)
            what = f"{r.omega.size} modes, {r.n_zero_modes} zero, {r.n_negative} negative, residual {r.max_residual:.0e}"
        else:
            from solver.spectrum import kpm

            w = operators.largest_omega(dm)
            edges = np.arange(0, 1.1 * w, 0.05)
            g = kpm.vdos(dm, edges, w**2, kpm.auto_moments(w**2, 0.05), 16, 0)
            what = f"KPM vDOS area {np.sum(g) * 0.05:.6f}, omega_max {w:.4f}"
        row(f"N = {n}", f"packing in {sec:.1f} s (z = {p.info['z']:.2f}, {int(p.rattler.sum())} rattlers); {what}",
            "N = 16 is the smallest allowed (box > 2 diameters); N = 32768 uses the stochastic vDOS "
            "(the exact spectrum takes hours here, BENCHMARKS.md)")
        dm.destroy()


def stability_edge():
    p = jammed.generate(64, 0.9, np.random.SeedSequence([4, 0]))
    dm = dynmat.assemble(p, ContactModel(1.0), COMM)
    limit = stability_limit("verlet", operators.largest_omega(dm))
    for factor in (0.99, 1.01):
        schedule = resolve_schedule(integrator="verlet", dt=factor * limit, t_end=2000 * factor * limit,
                                    sample_every=10)
        try:
            check_schedule(schedule, operators.largest_omega(dm), 1.0)
            s = integrators.integrate(dm, p.positions, "RT", 0, 2 * np.pi / p.box_length, amplitude=1e-3,
                                      schedule=schedule)
            drift = np.abs(s.energy / s.energy[0] - 1).max()
            row(f"dt = {factor} x limit ({factor * limit:.4f})", f"ran 2000 steps; energy oscillates by up to "
                f"{drift:.2f} (bounded: Verlet's shadow energy near the limit)", "accepted: below 2/omega_max; the "
                "energy stays below the tenfold blow-up guard, but results this close to the limit are "
                "inaccurate: the limit is a stability bound, not an accuracy target")
        except InputError as exc:
            row(f"dt = {factor} x limit ({factor * limit:.4f})", "refused before integrating", f"InputError: {exc}")
    dm.destroy()


def million_steps():
    p = jammed.generate(64, 0.9, np.random.SeedSequence([5, 0]))
    dm = dynmat.assemble(p, ContactModel(1.0), COMM)
    t = time.perf_counter()
    s = integrators.integrate(dm, p.positions, "RT", 0, 2 * np.pi / p.box_length, amplitude=1e-3,
                              schedule=resolve_schedule(integrator="verlet", dt=0.05, t_end=50_000.0,
                                                        sample_every=1000))
    sec = time.perf_counter() - t
    dev = np.abs(s.energy / s.energy[0] - 1)
    row("10^6 Verlet steps (N = 64, dt = 0.05, t = 50000)", f"{s.steps} steps in {sec:.0f} s; max relative "
        f"energy deviation {dev.max():.2e}, in the last tenth {dev[-len(dev) // 10:].max():.2e}",
        "symplectic scheme: bounded energy error, no secular drift")
    dm.destroy()


def square_lattice():
    import scipy.linalg as sl

    side = 8
    spacing = 0.98
    x, y = np.meshgrid(np.arange(side), np.arange(side))
    pos = np.stack([x.ravel(), y.ravel()], axis=1) * spacing + 0.5
    p = jammed.from_arrays(pos, np.ones(side * side), side * spacing)
    dm = dynmat.assemble(p, ContactModel(1.0), COMM)
    r = slicing.solve(dm, window=None, vectors=True, max_window_modes=40)
    A = operators.scaled_operator(dm)
    lam = sl.eigh(dynmat.gather_csr(A).toarray(), eigvals_only=True)
    A.destroy()
    distinct = np.unique(np.round(lam, 8)).size
    err = dense_check(dm, r)
    row("near-degenerate spectrum: 8 x 8 square lattice, rho = 1", f"{lam.size} eigenvalues, only {distinct} "
        f"distinct (multiplicities up to {np.max(np.unique(np.round(lam, 8), return_counts=True)[1])}); "
        f"slicing found {r.omega.size} modes + {r.n_zero_modes} zero modes (two translations and the "
        f"counter-rotating 'gear' mode of a bipartite lattice of equal disks) in {r.windows} windows, max error vs eigh {err:.1e}, "
        f"K+Q identity {np.abs(r.energies['Kx'] + r.energies['Ky'] + r.energies['Q'] - 1 / 128).max():.1e}",
        "window edges are placed between eigenvalues by the inertia; counts checked against Sylvester; "
        "degenerate eigenvectors are any basis of their space (K/Q per mode not unique, sums are)")
    dm.destroy()


def datasets(path) -> dict:
    """Every dataset of a results file by its path in the file (attributes, which hold timings,
    left out)."""
    out = {}
    with h5py.File(path) as f:
        f.visititems(lambda name, obj: out.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
    return out


def repeatability():
    with tempfile.TemporaryDirectory() as tmp:
        scene = Path(tmp) / "s.yaml"
        outs = []
        for i in range(2):
            out = Path(tmp) / f"r{i}.h5"
            scene.write_text(f"output: {out}\nseed: 9\npacking: {{n: 128, phi: 0.9, count: 2}}\n"
                             f"model: {{rho: [0.3, 1]}}\nspectrum: {{energies: true}}\nwaves: {{n: [1, 2], t_end: 30}}\n")
            subprocess.run([sys.executable, "-m", "solver", "run", str(scene)], check=True, cwd=REPO,
                           capture_output=True)
            outs.append(out)
        a, b = datasets(outs[0]), datasets(outs[1])
        same = a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
        row("repeated runs, same seed (N = 128, 2 configurations, spectra + waves)",
            f"{len(a)} datasets, bit-identical: {same}",
            "all randomness comes from SeedSequence([seed, i]); no rank- or time-dependent input")


def main():
    t0 = time.perf_counter()
    for case in (stiffness_ratios, area_fractions, sizes, stability_edge, million_steps, square_lattice,
                 repeatability):
        case()
    lines = ["# Numerical stress cases", "",
             f"`.venv/bin/python -m scripts.tools.stress`, {datetime.date.today()}, {machine()}, "
             f"{time.perf_counter() - t0:.0f} s in all.", "",
             "| case | what happened | what the code did |", "|---|---|---|"]
    lines += [f"| {c} | {h} | {d} |" for c, h, d in ROWS]
    (REPO / "STRESS.md").write_text("\n".join(lines) + "\n")
    print("wrote STRESS.md")


if __name__ == "__main__":
    main()
