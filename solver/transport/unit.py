"""One unit of the transport stage on an assembled matrix: the diffusivity of one (rho, packing)
by the method of the scene's transport section, and d(omega) of one rho pooled over its
packings on the vDOS's bins; each as the datasets and attributes of its results-file group
(docs/results_file.md) and the lines the log says of it.

Units: omega and eta in 1/t0, d in d0^2/t0 (d0 = m = kn = 1).
"""

from __future__ import annotations

import json
import pathlib
import time

import numpy as np

from .. import parallel
from ..spectrum import modes
from . import allen_feldman
from .rules import bin_width


def solve(spec, dm, positions: np.ndarray, box: np.ndarray, rho: float, p_index: int, comm, scratch
          ) -> tuple[dict, dict, str]:
    """(datasets, attrs, log line) of the diffusivity of ``dm`` (rho = kt/kn, packing ``p_index``,
    whose particles sit at ``positions`` (N, D) in ``box`` (D,)) by ``spec.method`` (exact:
    ``allen_feldman.allen_feldman`` with its eigenvectors in the folder ``scratch``, removed at
    the end).  datasets: ``omega`` (M,) ascending and ``d`` (M,), one entry a non-zero mode.
    Collective on ``comm`` (mpi4py), the matrix's communicator."""
    t = time.perf_counter()
    report: dict = {}
    omega, d = allen_feldman.allen_feldman(dm, positions, box, spec.eta, dm.D.getComm(), zero_tol=spec.zero_tol,
                                           tol=spec.tol, block=spec.block, scratch=scratch, report=report)
    seconds = parallel.global_max(comm, time.perf_counter() - t)  # also: every rank's files are gone
    if scratch is not None and comm.rank == 0:
        pathlib.Path(scratch).rmdir()
    attrs = {"rho": rho, "packing": p_index, "method": spec.method, "eta": spec.eta, "zero_tol": spec.zero_tol,
             "windows": report["windows"], "dof": dm.size, "dim": dm.dim, "n_disks": int(dm.active.sum()),
             "n_zero_modes": dm.size - omega.size, "seconds": seconds,
             "solver_settings": json.dumps(report["settings"])}
    plateau = np.median(d[omega > np.median(omega)]) if d.size else float("nan")
    return {"omega": omega, "d": d}, attrs, (
        f"diffusivity rho = {rho:g}, packing {p_index}: {omega.size} modes (+{attrs['n_zero_modes']} zero), "
        f"eta = {spec.eta:g}, d from {d.min(initial=np.inf):.3g} to {d.max(initial=0.0):.3g} d0^2/t0 (median "
        f"{plateau:.3g} above the median omega), {report['windows']} windows, {seconds:.1f} s")


def binned(spec, spectrum, rho: float, units: list[tuple[dict, dict]], edges: np.ndarray | None
           ) -> tuple[dict, dict, str]:
    """(datasets, attrs, log line) of d(omega) of one rho from its configurations' transport units
    ``units`` ((datasets, attrs) each), the modes of every configuration pooled: on ``edges`` (the
    vDOS's of the same rho; None: bins [0, w), [w, 2w), ... of w = ``rules.bin_width(spec,
    spectrum)``, as the vDOS makes them).  datasets: ``edges`` (B+1,), ``d`` (B,) the mean d of
    the modes in each bin (NaN where none), ``d_std`` (B,) their spread (ddof 0), ``count`` (B,)
    the modes in each.  Not collective."""
    omega = np.concatenate([datasets["omega"] for datasets, _ in units])
    d = np.concatenate([datasets["d"] for datasets, _ in units])
    if edges is None:
        edges = modes.vdos([omega], bin_width(spec, spectrum))[0]
    count = np.histogram(omega, bins=edges)[0]
    mean = modes.bin_average(omega, d, edges)
    spread = np.sqrt(np.maximum(modes.bin_average(omega, d**2, edges) - mean**2, 0.0))
    attrs = {"rho": rho, "eta": spec.eta, "method": spec.method, "configurations": len(units)}
    top = omega > np.median(omega) if omega.size else np.zeros(0, bool)
    return ({"edges": edges, "d": mean, "d_std": spread, "count": count}, attrs,
            f"d(omega) rho = {rho:g}: {omega.size} modes of {len(units)} configurations in {count.size} bins, "
            f"median d above the median omega {np.median(d[top]) if top.any() else float('nan'):.3g} d0^2/t0")
