"""Per-mode diagnostics and the vDOS (numpy only; no PETSc).

For an orthonormal eigenvector e of A = M^-1/2 D M^-1/2 the physical mode is u = M^-1/2 e and,
with du/dt = u / t0 (PHYSICS.md section 3, N = disks in the matrix),
    K_nu = (1/2N) sum_i m u_i,nu^2 = (1/2N) sum_i e_i,nu^2   (nu = x, y),
    Q    = (1/2N) sum_i I_i th_i^2 = (1/2N) sum_i e_i,th^2,
so K_x + K_y + Q = 1/(2N) for every mode; K = (K_x + K_y)/2.  The participation ratio is
P = (sum_i |e_i|^2)^2 / (N sum_i |e_i|^4), |e_i|^2 summed over the disk's DOF (1 for a mode
spread evenly over all disks, 1/N for a mode on one disk).
"""

from __future__ import annotations

import numpy as np
from scipy import stats


def local_sums(vectors: np.ndarray, dof: int) -> np.ndarray:
    """Rank-local partial sums (modes, 4): sum e_x^2, sum e_y^2, sum e_th^2, sum |e_i|^4.

    ``vectors`` is (modes, local DOF) with whole disks per rank.  Not collective.
    """
    per_disk = vectors.reshape(vectors.shape[0], -1, dof) ** 2
    sums = np.zeros((vectors.shape[0], 4))
    sums[:, :dof] = per_disk.sum(axis=1)
    sums[:, 3] = (per_disk.sum(axis=2) ** 2).sum(axis=1)
    return sums


def energies(sums: np.ndarray, n_disks: int) -> dict[str, np.ndarray]:
    """K_x, K_y, Q, K and participation (each (modes,)) from reduced :func:`local_sums`."""
    norm = sums[:, :3].sum(axis=1)
    return {"Kx": sums[:, 0] / (2 * n_disks), "Ky": sums[:, 1] / (2 * n_disks),
            "Q": sums[:, 2] / (2 * n_disks), "K": (sums[:, 0] + sums[:, 1]) / (4 * n_disks),
            "participation": norm**2 / (n_disks * sums[:, 3])}


def vdos(omegas: list[np.ndarray], bin_width: float) -> tuple[np.ndarray, np.ndarray]:
    """g(omega) of the pooled modes of several configurations, unit area.

    Returns (edges (B+1,), density (B,)); bins [0, w), [w, 2w), ... up to the largest mode.
    """
    pooled = np.concatenate(omegas)
    top = max(float(pooled.max()), bin_width) if pooled.size else bin_width
    edges = np.arange(0.0, top + bin_width, bin_width)
    if edges[-1] <= top:
        edges = np.append(edges, edges[-1] + bin_width)
    density, _ = np.histogram(pooled, bins=edges, density=True)
    return edges, density


def bin_average(omega: np.ndarray, values: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Mean of ``values`` over the modes in each bin of ``edges`` (B,), NaN for empty bins.

    Bins as ``np.histogram``'s: [e_i, e_i+1), the last one closed; ``scipy.stats.binned_statistic``.
    """
    if np.size(omega) == 0:  # binned_statistic cannot take an empty sample
        return np.full(np.size(edges) - 1, np.nan)
    return stats.binned_statistic(omega, values, statistic="mean", bins=edges).statistic


def cutoff(omegas: list[np.ndarray]) -> tuple[float, float]:
    """omega_c: mean over configurations of the largest eigenfrequency, and its std."""
    tops = np.array([w.max() for w in omegas if w.size])
    return float(tops.mean()), float(tops.std(ddof=1)) if tops.size > 1 else 0.0


def pooled_vdos(spectra: list[tuple[dict, dict]], bin_width: float
                ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """vDOS and omega_c of one rho from its configurations' spectrum units (datasets, attrs).

    Slicing units (dataset ``omega``): the histogram of the pooled modes (:func:`vdos`) and
    :func:`cutoff`.  KPM units (datasets ``edges``, ``density``; attribute ``omega_max``): all
    share the bins [0, w), [w, 2w), ... and differ only in how far they reach, so their densities
    are averaged on the longest grid (zero beyond a shorter one's top; unit area kept), and omega_c
    is the mean of the omega_max.  Returns (edges (B+1,), density (B,), omega_c, its std over
    configurations).  Counting units (also ``counts``) pool their integer counts instead, so their
    vDOS equals the slicing histogram of the same modes.
    """
    if "omega" in spectra[0][0]:
        omegas = [datasets["omega"] for datasets, _ in spectra]
        return (*vdos(omegas, bin_width), *cutoff(omegas))
    edges = max((datasets["edges"] for datasets, _ in spectra), key=len)
    density = np.zeros(edges.size - 1)
    if "counts" in spectra[0][0]:  # counting: pool the modes themselves, as the slicing histogram does
        for datasets, _ in spectra:
            density[: datasets["counts"].size] += datasets["counts"]
        density /= density.sum() * bin_width
    else:
        for datasets, _ in spectra:
            density[: datasets["density"].size] += datasets["density"] / len(spectra)
    tops = np.array([float(attrs["omega_max"]) for _, attrs in spectra])
    return edges, density, float(tops.mean()), float(tops.std(ddof=1)) if tops.size > 1 else 0.0
