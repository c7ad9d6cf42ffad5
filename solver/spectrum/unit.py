"""One unit of the spectrum stage on an assembled matrix: the spectrum of one (rho, packing) by the
method its plan chose (``plan``; ``METHODS``: one function per method), its mode shapes (the
``modes`` section, ``shapes``), and the vDOS of one rho pooled over its packings; each as the
datasets and attributes of its results-file group (docs/results_file.md) and the lines the log
says of it.

The spectrum and mode-shape units time themselves (``seconds``: the slowest rank's), so they are
collective on the matrix's communicator ``comm``.  Units: omega in 1/t0.
"""

from __future__ import annotations

import json
import time

import numpy as np

from .. import parallel
from ..wording import counted
from . import counting, kpm, modes, nonhermitian, pep, shapes, slicing
from .plan import pep_bands, probe_seed


def solve(spec, dm, rho: float, p_index: int, seed: int, comm, between, checkpoint=None
          ) -> tuple[dict, dict, list[str]]:
    """(datasets, attrs, log lines) of the spectrum of ``dm`` (rho = kt/kn, packing ``p_index``)
    by ``spec.method`` (the scene's spectrum section, its method chosen: ``plan.resolve``); run it
    inside the PETSc log stage :func:`log_stage`.  ``seed``: the scene's (kpm's probes,
    ``plan.probe_seed``); ``between(line)``: called on every rank between windows with a progress
    line or None (it may raise, e.g. Interrupted, to stop: finished windows are kept);
    ``checkpoint``: the unit's window checkpoint (``load``, ``save``), for the methods that march
    windows.  Collective."""
    return METHODS[spec.method][0](spec, dm, rho=rho, p_index=p_index, seed=seed, comm=comm, between=between,
                                   checkpoint=checkpoint)


def log_stage(spec) -> str:
    """The PETSc log stage (``profiling.STAGES``) of the units of ``spec.method``."""
    return METHODS[spec.method][1]


def window_label(window) -> str:
    """'full' or 'lo,hi' for the results file."""
    return "full" if window is None else f"{window[0]:g},{window[1]:g}"


def _negative_words(count: int) -> list[str]:
    """The warning that ``count`` > 0 modes have omega^2 < -zero_tol^2 (not an energy minimum), or none."""
    return [f"rotsound: warning: {count} modes with omega^2 < -zero_tol^2: the packing is not a stable "
            f"minimum"] if count else []


def _kpm(spec, dm, *, rho, p_index, seed, comm, **_) -> tuple[dict, dict, list[str]]:
    """Stochastic vDOS (``kpm.solve``)."""
    t = time.perf_counter()
    datasets, attrs = kpm.solve(dm, bin_width=spec.bin_width, moments=spec.moments, probes=spec.probes,
                                with_energies=spec.energies, seed=probe_seed(spec, seed, p_index))
    seconds = parallel.global_max(comm, time.perf_counter() - t)
    attrs = {"rho": rho, "packing": p_index, "method": "kpm", **attrs, "seconds": seconds,
             "solver_settings": json.dumps({"wmax": dm.wmax_settings})}
    return datasets, attrs, [f"kpm vDOS rho = {rho:g}, packing {p_index}: {attrs['moments']} moments x {spec.probes} "
                             f"probes, omega_max = {attrs['omega_max']:.4f}, {seconds:.1f} s"]


def _counting(spec, dm, *, rho, p_index, comm, **_) -> tuple[dict, dict, list[str]]:
    """Exact vDOS by counting (``counting.solve``)."""
    t = time.perf_counter()
    datasets, attrs, settings = counting.solve(dm, bin_width=spec.bin_width, zero_tol=spec.zero_tol,
                                               factor_ranks=spec.factor_ranks)
    seconds = parallel.global_max(comm, time.perf_counter() - t)
    attrs = {"rho": rho, "packing": p_index, "method": "counting", **attrs, "seconds": seconds,
             "solver_settings": json.dumps(settings)}
    lines = [f"counted vDOS rho = {rho:g}, packing {p_index}: {attrs['inertia_count']} modes "
             f"(+{attrs['n_zero_modes']} zero modes, {attrs['n_negative_modes']} negative) in "
             f"{datasets['counts'].size} bins, {attrs['factorisations']} inertias "
             f"({_factor_layout(settings['inertia'])}), omega_max = {attrs['omega_max']:.4f}, {seconds:.1f} s"]
    if not attrs["counts_exact"]:
        lines.append(f"  block low-rank factors (CNTL 7 = {attrs['blr_dropping']:g}): a count may be off by the "
                     f"modes within omega^2 +- {attrs['count_window']:.3g} of a bin edge (counts_exact = False)")
    return datasets, attrs, lines + _negative_words(attrs["n_negative_modes"])


def _factor_layout(inertia: dict) -> str:
    """'a factor per rank' or 'factors shared by 2 ranks, 1 group' (and, chosen by auto, MUMPS's
    estimate of the whole factorisation's memory) for a progress line."""
    ranks, groups = inertia["factor_ranks"], inertia["factor_groups"]
    layout = "a factor per rank" if ranks == 1 else f"factors shared by {ranks} ranks, {groups} group{'s' * (groups > 1)}"
    if "factor_estimate_gib" in inertia:
        layout += (f"; auto: factor {inertia['factor_estimate_gib']:.2g} GiB, a rank may use "
                   f"{inertia['factor_budget_gib']:.2g} GiB")
    return layout


def _slicing(spec, dm, *, rho, p_index, comm, between, checkpoint, **_) -> tuple[dict, dict, list[str]]:
    """Exact eigenvalues by spectrum slicing (``slicing.solve``), windows checkpointed."""
    t = time.perf_counter()

    def progress(done, total, found):  # large spectra take hours: say how far, window by window
        between(f"  spectrum window {done}/{total}: {found} modes, {time.perf_counter() - t:.0f} s"
                if total > 1 else None)

    result = slicing.solve(dm, window=tuple(spec.window) if spec.window else None,
                           vectors=spec.energies, tol=spec.tol, zero_tol=spec.zero_tol,
                           max_window_modes=spec.max_window_modes, progress=progress,
                           checkpoint=checkpoint)
    seconds = parallel.global_max(comm, time.perf_counter() - t)
    datasets = {"omega": result.omega}
    if result.energies is not None:
        datasets.update(result.energies)
    attrs = {"rho": rho, "packing": p_index, "n_zero_modes": result.n_zero_modes,
             "n_negative_modes": result.n_negative, "max_relative_residual": result.max_residual,
             "inertia_count": result.inertia_count, "windows": result.windows, "seconds": seconds,
             "window": window_label(spec.window), "dof": dm.size, "n_disks": int(dm.active.sum()),
             "solver_settings": json.dumps(result.settings)}
    besides = f"(+{result.n_zero_modes} zero modes, {result.n_negative} negative)"
    if result.omega.size:
        found = (f"{result.omega.size} modes {besides}, omega in [{result.omega.min():.4f}, "
                 f"{result.omega.max():.4f}], max relative residual {result.max_residual:.1e}")
    else:  # a window between the modes: a valid result, stored and resumed as any other
        found = f"no modes {_where(spec.window)} {besides}"
    return datasets, attrs, [f"spectrum rho = {rho:g}, packing {p_index}: {found}, {counted(result.windows, 'window')}, "
                             f"{seconds:.1f} s"] + _negative_words(result.n_negative)


def _where(window) -> str:
    """Where a spectrum asked for its modes, for a log line: 'in the window omega in [lo, hi]' or
    'above zero_tol' (the full spectrum)."""
    return "above zero_tol" if window is None else f"in the window omega in [{window[0]:g}, {window[1]:g}]"


def _window_checks(checks: dict) -> dict:
    """The attributes of the windows solver's ``checks`` of nonhermitian and pep (none for dense)."""
    return {"windows": checks["windows"], "max_backward_residual": checks["max_residual"],
            "trace_error": checks["trace_error"], "trace2_error": checks["trace2_error"],
            "solver_settings": json.dumps(checks["settings"])} if checks else {}


def _nonhermitian(spec, dm, *, rho, p_index, comm, between, checkpoint, **_) -> tuple[dict, dict, list[str]]:
    """Every eigenvalue of a matrix, symmetric or not (``nonhermitian.solve``); the windows
    solver's windows checkpointed."""
    t = time.perf_counter()

    def progress(done, accepted, total):  # a large spectrum takes many minutes: say how far
        between(f"  nonhermitian window {done}: {accepted}/{total} eigenvalues, {time.perf_counter() - t:.0f} s"
                if done % 20 == 0 else None)

    result = nonhermitian.solve(dm, spec.zero_tol, vectors=spec.energies, solver=spec.solver, tol=spec.tol,
                                progress=progress, checkpoint=checkpoint)
    seconds = parallel.global_max(comm, time.perf_counter() - t)
    checks = result.checks or {}
    datasets = {"omega": result.omega, "omega2": result.omega2, **(result.energies or {})}
    attrs = {"rho": rho, "packing": p_index, "method": "nonhermitian", "solver": result.solver,
             "n_zero_modes": result.n_zero_modes, "n_complex": result.n_complex, "n_negative_modes": result.n_negative,
             "max_growth": result.max_growth, "symmetric": int(dm.symmetric), "seconds": seconds, "window": "full",
             "dof": dm.size, "n_disks": int(dm.active.sum()), **_window_checks(checks)}
    unstable = result.n_complex + result.n_negative
    how = (f"{counted(checks['windows'], 'window')}, trace errors {checks['trace_error']:.1e} / {checks['trace2_error']:.1e}"
           if checks else "dense")
    return datasets, attrs, [
        f"spectrum rho = {rho:g}, packing {p_index}: {result.omega.size} stable modes "
        f"(+{result.n_zero_modes} zero modes), {unstable} unstable ({result.n_complex} complex, "
        f"{result.n_negative} negative; largest growth rate {result.max_growth:.2e} / t0), {how}, {seconds:.1f} s"]


def _pep(spec, dm, *, rho, p_index, comm, between, checkpoint, **_) -> tuple[dict, dict, list[str]]:
    """Every damped mode of a matrix with dashpots (``pep.solve``), in the bands of ``plan.pep_bands``;
    the windows solver's windows checkpointed."""
    t = time.perf_counter()

    def progress(done, accepted, total):  # a large spectrum takes many minutes: say how far
        between(f"  pep window {done}: {accepted}/{total} eigenvalues, {time.perf_counter() - t:.0f} s"
                if done % 20 == 0 else None)

    bands = pep_bands(spec)
    result = pep.solve(dm, spec.zero_tol, vectors=spec.energies, solver=spec.solver, tol=spec.tol,
                       window=bands, progress=progress, checkpoint=checkpoint)
    seconds = parallel.global_max(comm, time.perf_counter() - t)
    checks = result.checks or {}
    underdamped = int((result.lam.imag > 0).sum())
    datasets = {"lambda": result.lam, **(result.energies or {})}
    attrs = {"rho": rho, "packing": p_index, "method": "pep", "solver": result.solver,
             "n_zero_modes": result.n_zero_modes, "n_overdamped": result.n_overdamped, "n_underdamped": underdamped,
             "seconds": seconds, "window": ";".join(window_label(b) for b in bands) if bands else "full",
             "dof": dm.size, "n_disks": int(dm.active.sum()), **_window_checks(checks)}
    how = (f"{counted(checks['windows'], 'window')}, " + (
        "complete by their sigma bounds" if bands else
        f"trace errors {checks['trace_error']:.1e} / {checks['trace2_error']:.1e}") +
        f", backward error <= {checks['max_residual']:.1e}" if checks else "dense")
    if bands:
        how += ", omega_d in " + " u ".join(f"[{lo:g}, {hi:g})" for lo, hi in bands)
    q = -result.lam.imag / (2 * result.lam.real) if underdamped else np.empty(0)
    return datasets, attrs, [
        f"damped modes rho = {rho:g}, packing {p_index}: {underdamped} underdamped (quality "
        f"factor {np.nanmin(q, initial=np.inf):.3g} to {np.nanmax(q, initial=0.0):.3g}), "
        f"{result.n_overdamped} overdamped roots, {result.n_zero_modes} zero, {how}, {seconds:.1f} s"]


METHODS = {"slicing": (_slicing, "spectrum"), "counting": (_counting, "spectrum"), "kpm": (_kpm, "kpm"),
           "nonhermitian": (_nonhermitian, "spectrum"), "pep": (_pep, "spectrum")}
"""spectrum.method -> (the function that computes one unit by it, its PETSc log stage,
``profiling.STAGES``); each function takes the arguments of :func:`solve` and uses those it needs."""


def mode_shapes(spec, dm, rho: float, p_index: int, comm, spectrum: dict | None) -> tuple[dict, dict, str]:
    """(datasets, attrs, log line) of the mode shapes of ``dm`` (``shapes.solve``) asked by the
    modes section ``spec``: the ``count`` nearest each ``spec.omega``, then with ``spec.localised``
    = n the n modes of lowest participation and the n of highest from ``spectrum`` (the datasets
    of the same (rho, packing)'s spectrum unit), each found at its own omega.  Collective."""
    t = time.perf_counter()
    parts = [shapes.solve(dm, spec.omega, spec.count, tol=spec.tol)] if spec.omega else []
    if spec.localised:
        order = np.argsort(spectrum["participation"], kind="stable")
        picked = np.concatenate((order[:spec.localised], order[::-1][:spec.localised]))
        parts.append(shapes.solve(dm, [float(w) for w in spectrum["omega"][picked]], 1, tol=spec.tol))
    datasets = {key: np.concatenate([part[0][key] for part in parts]) for key in parts[0][0]}
    settings = parts[-1][1]
    seconds = parallel.global_max(comm, time.perf_counter() - t)
    attrs = {"rho": rho, "packing": p_index, "dof": dm.size, "dim": dm.dim, "n_disks": int(dm.active.sum()),
             "localised": spec.localised, "seconds": seconds, "solver_settings": json.dumps(settings)}
    return datasets, attrs, (f"modes rho = {rho:g}, packing {p_index}: omega = "
                             f"{', '.join(f'{w:.4f}' for w in datasets['omega'])}, participation "
                             f"{datasets['participation'].min():.3f} to {datasets['participation'].max():.3f}, "
                             f"residual <= {datasets['residual'].max():.1e}, {seconds:.1f} s")


def vdos(spec, rho: float, spectra: list[tuple[dict, dict]]) -> tuple[dict, dict, str]:
    """(datasets, attrs, log line) of the vDOS and omega_c of one rho from its configurations'
    spectrum units ``spectra`` ((datasets, attrs) each; ``modes.pooled_vdos``) in bins of
    ``spec.bin_width``.  Not collective."""
    edges, density, omega_c, spread = modes.pooled_vdos(spectra, spec.bin_width)
    attrs = {"rho": rho, "omega_c": omega_c, "omega_c_std": spread, "configurations": len(spectra),
             "window": window_label(spec.window)}
    said = (f"omega_c = {omega_c:.4f} +- {spread:.4f}" if np.isfinite(omega_c) else
            f"no modes {_where(spec.window)} (density and omega_c NaN)")
    return {"edges": edges, "density": density}, attrs, f"vDOS rho = {rho:g}: {said} over {counted(len(spectra), 'configuration')}"
