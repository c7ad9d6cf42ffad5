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
    """Mean of ``values`` over the modes in each bin of ``edges`` (NaN for empty bins)."""
    index = np.digitize(omega, edges) - 1
    ok = (index >= 0) & (index < edges.size - 1)
    total = np.bincount(index[ok], values[ok], minlength=edges.size - 1)
    count = np.bincount(index[ok], minlength=edges.size - 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def cutoff(omegas: list[np.ndarray]) -> tuple[float, float]:
    """omega_c: mean over configurations of the largest eigenfrequency, and its std."""
    tops = np.array([w.max() for w in omegas if w.size])
    return float(tops.mean()), float(tops.std(ddof=1)) if tops.size > 1 else 0.0
