"""Gauss quadrature of the start's autocorrelation against the bilinear z(t) of today's spectral
path, at equal reported error (issue 60 point 1; docs/waves_theory.md, "Gauss quadrature and
what the waves read").

    python -m scripts.benchmarks.bench_quadrature [N ...] [--referee-max 2048]
    (default N = 32768: the paper's waves; ``make bench`` runs that)
Per N, in a fresh 2-rank mpirun job, on benchlib.load_packing(N) at rho = 1, omega_max computed once
and not timed: the waves of one chunk pair of the paper's programme, L and TR, both runs, k =
2 pi n / L for n = 1, 2 (8 waves, two chunks of spectral.BATCH), samples every 0.1 t0 to
t_end = 300 (configs/paper.yaml), tol 1e-8:
  bilinear    spectral.spectral_all (today's path: z(t), degree m - 1);
  quadrature  quadrature.start_correlations (C_a(t), degree 2m - 1).
Columns: wall time per wave, Lanczos steps per wave (= MatMatMults per chunk of four: one per step),
the largest reported estimate; "smallest_*": the fewest steps whose estimate (the change from
dropping the last 10 steps) is below tol, scanned every 5 steps on one chunk's recurrences run to
the bilinear count, so that the starting counts do not decide the ratio; "rest": max_t |C - C_a|
(C the paper's C from the bilinear z, pooled over the two runs of each k, C_a pooled alike), the
part of C the quadrature does not give.  N <= ``--referee-max``: the dense eigendecomposition
referees both (errors of z relative to max |z|, and of C_a).
Writes scripts/benchmarks/records/quadrature.json (rows merged by N).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from scripts.benchmarks.benchlib import PY, load_packing, mpirun, run_json, save

BENCH = {"order": 91}  # make bench: its place (scripts/benchmarks/bench_all.py)
ME = ["-m", __spec__.name]  # this benchmark again, in a fresh process (run_json runs it from the repository root)
T_END, SAMPLE, TOL, MODES, NS = 300.0, 0.1, 1e-8, ("L", "TR"), (1, 2)


def _smallest(first: int, count: int, estimate) -> int:
    """The fewest steps m (every 5, from ``first``, to ``count``) with ``estimate(m)`` < TOL, or
    ``count`` + 1 if none."""
    return next((m for m in range(max(first, 25), count + 1, 5) if estimate(m) < TOL), count + 1)


def _scan(dm, positions, waves, times, omega_max: float, steps: int) -> tuple[list[int], list[int]]:
    """(smallest Gauss steps, smallest bilinear steps) of each of ``waves`` (one chunk), from one set
    of recurrences run to ``steps`` with the channel read out.  Collective; the scan on every rank."""
    from solver.waves import excitation, lanczos, quadrature, spectral

    mpi = dm.D.getComm().tompi4py()
    s = 1.0 / np.sqrt(dm.M.getArray())
    a, norm_a = lanczos.scaled_starts(dm, positions, waves, 1e-3, mpi)
    channels = np.stack([excitation.channel(dm, positions, *excitation.runs(m, dm.dim)[r], k) * s for m, r, k in waves], axis=1)
    recurrences = lanczos.Recurrences(lanczos.operator(dm), a / norm_a,
                                      (np.asfortranarray(channels.real), np.asfortranarray(channels.imag)),
                                      1e-13 * omega_max**2)
    try:
        recurrences.extend(steps)
        alpha, beta, (w_re, w_im) = recurrences.tridiagonals()
    finally:
        recurrences.destroy()
    m, degree = len(alpha), omega_max * times[-1]  # below: Gauss from 0.2, bilinear from 0.4 omega_max t_end
    gauss, bilinear = [], []
    for i in range(len(waves)):
        gauss.append(_smallest(int(0.2 * degree), m, lambda size: quadrature.gauss_correlation(alpha[:size, i], beta[:size - 1, i],
                                                                                  times)[1]))
        w = w_re[:, i] - 1j * w_im[:, i]
        bilinear.append(_smallest(int(0.4 * degree), m, lambda size: spectral._z_and_estimate(
            alpha[:, i], beta[:, i], w, norm_a[i], times, size, False, omega_max**2 * (1 + 1e-6))[1]))
    return gauss, bilinear


def case(n: int, referee: bool) -> None:
    """Both paths on COMM_WORLD; rank 0 prints one JSON line."""
    from solver import petscenv

    PETSc = petscenv.init([])
    from mpi4py import MPI

    from solver import references
    from solver.analysis import fits
    from solver.contact_law import ContactModel
    from solver.model import dynmat, operators
    from solver.waves import correlations, quadrature, spectral
    from solver.waves.excitation import runs

    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    p = load_packing(n)
    dm = dynmat.assemble(p, ContactModel(1.0), comm)
    omega_max = operators.largest_omega(dm)
    waves = [(mode, run, 2 * np.pi * k / float(p.box[0])) for mode in MODES for k in NS for run in (0, 1)]
    times = np.arange(0.0, T_END + 1e-9, SAMPLE)
    out = {"N": n, "omega_max": omega_max, "waves": len(waves)}
    for name, run in (("bilinear", spectral.spectral_all), ("quadrature", quadrature.start_correlations)):
        mpi.Barrier()
        start = time.perf_counter()
        results = run(dm, p.positions, waves, amplitude=1e-3, times=times, tol=TOL, omega_max=omega_max)
        seconds = mpi.allreduce(time.perf_counter() - start, op=MPI.MAX)
        out.update({f"{name}_s_per_wave": seconds / len(waves), f"{name}_steps": max(r.steps for r in results),
                    f"{name}_estimate": max(r.error_estimate for r in results)})
        if name == "bilinear":
            z = np.array([r.z for r in results]).reshape(len(MODES) * len(NS), 2, -1)  # (mode, k) x runs
        else:
            gauss = results
    out["steps_ratio"] = out["quadrature_steps"] / out["bilinear_steps"]
    out["time_ratio"] = out["quadrature_s_per_wave"] / out["bilinear_s_per_wave"]
    smallest_gauss, smallest_bilinear = _scan(dm, p.positions, waves[:spectral.BATCH], times, omega_max,
                                              out["bilinear_steps"])
    out.update(smallest_quadrature=max(smallest_gauss), smallest_bilinear=max(smallest_bilinear),
               smallest_ratio=max(smallest_gauss) / max(smallest_bilinear))
    rest, omega_shift, gamma_shift = [], [], []
    for i in range(len(MODES) * len(NS)):
        pair = gauss[2 * i:2 * i + 2]
        start_c = sum(g.weight * g.c for g in pair) / sum(g.weight for g in pair)
        paper = correlations.vaf(z[i])
        rest.append(np.abs(paper - start_c).max())
        fit, fit_start = fits.fit_damped_cosine(times, paper), fits.fit_damped_cosine(times, start_c)
        omega_shift.append(abs(fit_start.omega / fit.omega - 1))
        gamma_shift.append(abs(fit_start.gamma - fit.gamma) / fit.gamma_err)
    out.update(rest=float(max(rest)), omega_shift=float(max(omega_shift)), gamma_shift=float(max(gamma_shift)))
    if referee:
        eig = references.dense_eigen(dm)
        flat = z.reshape(len(waves), -1)
        out["bilinear_error"] = max(
            float(np.abs(zi - references.exact_z_fixed(p, dm, eig, runs(mode, dm.dim)[run], k, times, 1e-3)).max()
                  / np.abs(zi).max()) for zi, (mode, run, k) in zip(flat, waves))
        out["quadrature_error"] = max(
            float(np.abs(g.c - references.exact_start_correlation(p, dm, eig, runs(mode, dm.dim)[run], k, times)).max()) for g, (mode, run, k) in zip(gauss, waves))
    dm.destroy()
    if mpi.rank == 0:
        print(json.dumps(out))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("n", type=int, nargs="*", default=[32768])
    parser.add_argument("--referee-max", type=int, default=2048)
    parser.add_argument("--case", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--referee", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case:
        case(args.case, args.referee)
        return
    table = []
    for n in args.n:
        load_packing(n)
        referee = ["--referee"] if n <= args.referee_max else []
        row = run_json(mpirun(2) + [PY, *ME, "--case", str(n), *referee], timeout=4 * 3600)
        table.append({k: float(f"{v:.4g}") if isinstance(v, float) else v for k, v in row.items()})
        save("quadrature", "python -m scripts.benchmarks.bench_quadrature " + " ".join(sys.argv[1:]), table,
             notes="", merge_by=("N",))
        print(json.dumps(table[-1]), flush=True)


if __name__ == "__main__":
    main()
