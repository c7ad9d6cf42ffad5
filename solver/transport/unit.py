"""One unit of the transport stage on an assembled matrix: the diffusivity of one (rho, packing)
by the method of the scene's transport section (``METHODS``: one function per method), and
d(omega) of one rho pooled over its packings on the vDOS's bins; each as the datasets and
attributes of its results-file group (docs/results_file.md) and the lines the log says of it.

Units: omega and eta in 1/t0, d in d0^2/t0 (d0 = m = kn = 1).
"""

from __future__ import annotations

import errno
import json
import pathlib
import shutil
import time

import numpy as np

from .. import parallel
from ..wording import counted
from ..model.operators import largest_omega
from ..spectrum import modes
from . import allen_feldman, kpm_diffusivity
from .rules import bin_width


def solve(spec, dm, positions: np.ndarray, box: np.ndarray, rho: float, p_index: int, seed: int, comm, scratch,
          spectrum=None) -> tuple[dict, dict, str]:
    """(datasets, attrs, log line) of the diffusivity of ``dm`` (rho = kt/kn, packing ``p_index``,
    whose particles sit at ``positions`` (N, D) in ``box``, the packing's ``geometry.Cell`` or its
    (D,) sides) by ``spec.method`` (``METHODS``;
    ``seed``: the scene's, kpm's probes draw from ``seed + p_index``; ``scratch``: the folder of
    exact's eigenvectors or None, removed however the unit ends, and its parent if left empty
    (:func:`_remove_scratch`); ``spectrum``: the scene's spectrum section or None, for kpm's
    bins).  Collective on ``comm`` (mpi4py), the matrix's communicator."""
    t = time.perf_counter()
    try:
        datasets, attrs, said = METHODS[spec.method](spec, dm, positions, box, seed=seed + p_index, scratch=scratch,
                                                     spectrum=spectrum)
    finally:
        if scratch is not None:
            _remove_scratch(scratch, comm)
    seconds = parallel.global_max(comm, time.perf_counter() - t)
    attrs = {"rho": rho, "packing": p_index, "method": spec.method, **attrs, "dof": dm.size, "dim": dm.dim,
             "n_disks": int(dm.active.sum()), "seconds": seconds}
    return datasets, attrs, f"diffusivity rho = {rho:g}, packing {p_index}: {said}, {seconds:.1f} s"


def _remove_scratch(folder, comm) -> None:
    """Remove the scratch folder ``folder`` whole, with whatever it holds (a run on another rank
    count leaves files that no rank of this one removes), once every rank of ``comm`` (mpi4py) is
    done with it; then its parent (the units folder's ``transport_scratch/``) if that is left
    empty: another group's unit may still use it.  Rank 0 removes; its error is raised on every
    rank.  Collective."""
    comm.Barrier()

    def remove(_):
        path = pathlib.Path(folder)
        if path.is_dir():  # kpm makes none
            shutil.rmtree(path)
        try:
            path.parent.rmdir()
        except OSError as exc:  # not empty (another group's unit) or not there: left as it is
            if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST, errno.ENOENT):
                raise

    parallel.owner_compute(comm, [0], remove)


def _exact(spec, dm, positions, box, *, scratch, **_) -> tuple[dict, dict, str]:
    """Every mode's d_n (``allen_feldman.allen_feldman``, its eigenvectors in the folder ``scratch``,
    removed at the end), or with ``spec.omega_top`` those of the low-frequency window: datasets
    ``omega`` (M,) ascending and ``d`` (M,); with omega_top also the attrs ``omega_top``,
    ``omega_cut`` (the highest omega sliced) and ``sliced`` (the modes summed)."""
    report: dict = {}
    omega, d = allen_feldman.allen_feldman(dm, positions, box, spec.eta, dm.D.getComm(), zero_tol=spec.zero_tol,
                                           tol=spec.tol, block=spec.block, scratch=scratch, report=report,
                                           omega_top=spec.omega_top)
    attrs = {"eta": spec.eta, "zero_tol": spec.zero_tol, "windows": report["windows"],
             "n_zero_modes": report["zero"], "solver_settings": json.dumps(report["settings"])}
    window = ""
    if spec.omega_top is not None:
        attrs.update(omega_top=spec.omega_top, omega_cut=allen_feldman.window_cut(spec.omega_top, spec.eta),
                     sliced=report["sliced"])
        window = f" up to omega_top = {spec.omega_top:g} (of {report['sliced']} sliced to {attrs['omega_cut']:g})"
    plateau = np.median(d[omega > np.median(omega)]) if d.size else float("nan")
    return {"omega": omega, "d": d}, attrs, (
        f"{omega.size} modes{window} (+{attrs['n_zero_modes']} zero), eta = {spec.eta:g}, d from "
        f"{d.min(initial=np.inf):.3g} to {d.max(initial=0.0):.3g} d0^2/t0 (median {plateau:.3g} above the median "
        f"omega), {counted(report['windows'], 'window')}")


def kpm_edges(omega_max: float, width: float) -> np.ndarray:
    """Bins [0, w), [w, 2w), ... of width ``width`` up to 1.1 ``omega_max`` (1/t0): those of the
    kpm vDOS (``spectrum.kpm.solve``) on the same matrix. Not collective."""
    return np.arange(0.0, width * (np.ceil(1.1 * omega_max / width) + 1), width)


def _kpm(spec, dm, positions, box, *, seed, spectrum, **_) -> tuple[dict, dict, str]:
    """d(omega) per bin without eigenvectors (``kpm_diffusivity.binned_diffusivity``) on
    :func:`kpm_edges` of the bin width ``rules.bin_width`` gives: datasets ``edges``, ``count``,
    ``count_err``, ``total``, ``total_err``, ``d``, ``d_err``, ``smearing``."""
    edges = kpm_edges(largest_omega(dm), bin_width(spec, spectrum))
    datasets, attrs = kpm_diffusivity.binned_diffusivity(dm, positions, box, edges, moments=spec.moments or None,
                                                         probes=spec.probes, seed=seed, comm=dm.D.getComm())
    held = np.isfinite(datasets["d"]) & (datasets["count"] >= 0.01 * attrs["n_modes"])
    relative = datasets["d_err"][held] / datasets["d"][held]
    attrs = {key: value for key, value in attrs.items() if key != "lam_scale"}
    return datasets, attrs, (
        f"kpm, {attrs['moments']} moments x {spec.probes} probes, {edges.size - 1} bins, {attrs['n_modes']} modes "
        f"(counted {datasets['count'].sum():.1f}), d_err / d {np.median(relative):.2g} (median over the bins with "
        f"1 % of the modes or more)")


METHODS = {"exact": _exact, "kpm": _kpm}
"""transport.method -> the function that computes one unit by it; each takes the arguments of
:func:`solve` that it needs."""


def binned(spec, spectrum, rho: float, units: list[tuple[dict, dict]], edges: np.ndarray | None
           ) -> tuple[dict, dict, str]:
    """(datasets, attrs, log line) of d(omega) of one rho from its configurations' transport units
    ``units`` ((datasets, attrs) each), pooled.  Per-mode units (exact): every configuration's
    modes on ``edges`` (the vDOS's of the same rho; None: bins [0, w), [w, 2w), ... of w =
    ``rules.bin_width(spec, spectrum)``, as the vDOS makes them): datasets ``edges`` (B+1,), ``d``
    (B,) the mean d of each bin's modes (NaN where none), ``d_std`` (B,) their spread (ddof 0),
    ``count`` (B,) their number; with ``spec.omega_top`` (the low-frequency window) the bins not
    wholly below omega_top hold no mode (count 0, d NaN): the window's modes stop at omega_top.
    Binned units (kpm: bins [0, w), [w, 2w), ... of one width, which differ only in how far they
    reach): on the longest grid, ``count`` the summed estimated counts,
    ``d`` = summed totals / summed counts (NaN where the bins hold less than one mode per
    configuration, as a unit's own d is NaN below one mode), ``d_err`` = sqrt(sum (count_i
    d_err_i)^2) / sum count_i (independent configurations).  Not collective."""
    attrs = {"rho": rho, "eta": np.nan if spec.eta is None else spec.eta, "method": spec.method,
             "configurations": len(units)}
    if "omega" not in units[0][0]:
        return _pooled_bins(units, attrs)
    omega = np.concatenate([datasets["omega"] for datasets, _ in units])
    d = np.concatenate([datasets["d"] for datasets, _ in units])
    if edges is None:
        edges = modes.vdos([omega], bin_width(spec, spectrum))[0]
    if spec.omega_top is not None:
        attrs["omega_top"] = spec.omega_top
        last = np.searchsorted(edges, spec.omega_top, side="right") - 1
        if last < edges.size - 1:  # the bin that straddles omega_top holds only some of its modes: dropped
            kept = omega < edges[last]
            omega, d = omega[kept], d[kept]
    count = np.histogram(omega, bins=edges)[0]
    mean = modes.bin_average(omega, d, edges)
    spread = np.sqrt(np.maximum(modes.bin_average(omega, d**2, edges) - mean**2, 0.0))
    top = omega > np.median(omega) if omega.size else np.zeros(0, bool)
    return ({"edges": edges, "d": mean, "d_std": spread, "count": count}, attrs,
            f"d(omega) rho = {rho:g}: {counted(omega.size, 'mode')} of {counted(len(units), 'configuration')} in {counted(count.size, 'bin')}, "
            f"median d above the median omega {np.median(d[top]) if top.any() else float('nan'):.3g} d0^2/t0")


def _pooled_bins(units: list[tuple[dict, dict]], attrs: dict) -> tuple[dict, dict, str]:
    """:func:`binned` of binned (kpm) units."""
    edges = max((datasets["edges"] for datasets, _ in units), key=len)
    count, total, error = (np.zeros(edges.size - 1) for _ in range(3))
    for datasets, _ in units:
        size = datasets["count"].size
        count[:size] += datasets["count"]
        total[:size] += datasets["total"]
        error[:size] += np.nan_to_num(datasets["count"] * datasets["d_err"]) ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.where(count >= len(units), total / count, np.nan)
        d_err = np.where(np.isfinite(d), np.sqrt(error) / count, np.nan)
    return ({"edges": edges, "d": d, "d_err": d_err, "count": count}, attrs,
            f"d(omega) rho = {attrs['rho']:g}: {counted(len(units), 'configuration')} in {counted(count.size, 'bin')} "
            f"({int(np.isfinite(d).sum())} with a d), median d_err / d {np.nanmedian(d_err / d):.2g}")
