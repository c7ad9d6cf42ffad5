"""Per-mode diagnostics and the vDOS (numpy only; no PETSc).

For an orthonormal eigenvector e of A = M^-1/2 D M^-1/2 the physical mode is u = M^-1/2 e and,
with du/dt = u / t0 (PHYSICS.md section 3, N = particles in the matrix, D = 2 or 3 dimensions),
    K_nu = (1/2N) sum_i m u_i,nu^2   = (1/2N) sum_i e_i,nu^2    (nu = x, y[, z]),
    Q_nu = (1/2N) sum_i I_i th_i,nu^2 = (1/2N) sum_i e_i,th_nu^2  (2D: the one rotation, about z),
and K, Q are the per-component means: 2D K = (K_x + K_y)/2, Q = Q_z (the paper's); 3D
K = (K_x + K_y + K_z)/3, Q = (Q_x + Q_y + Q_z)/3 (issue 18).  Since |e| = 1, every mode has
    2D: K_x + K_y + Q = 1/(2N), i.e. 2 K + Q = 1/(2N);   3D: 3 K + 3 Q = 1/(2N),
so in both K = Q at equipartition (each DOF carrying the same share).  Without rotational DOF
(frictionless) Q = 0.  The participation ratio is P = (sum_i |e_i|^2)^2 / (N sum_i |e_i|^4),
|e_i|^2 summed over the particle's DOF (1 for a mode spread evenly over all particles, 1/N for a
mode on one particle).
"""

from __future__ import annotations

import numpy as np
from scipy import stats


def rotation_components(dim: int) -> int:
    """Rotational components of a particle in ``dim`` dimensions: 1 (2D, about z) or 3 (3D)."""
    return dim * (dim - 1) // 2


def sums_width(dim: int) -> int:
    """Columns of :func:`local_sums`: one per translation, one per rotation component, |e_i|^4."""
    return dim + rotation_components(dim) + 1


def local_sums(vectors: np.ndarray, dof: int, dim: int) -> np.ndarray:
    """Rank-local partial sums (modes, :func:`sums_width`): sum e_nu^2 per DOF slot (the
    translations x, y[, z], then the rotation components; zero columns where the matrix has no
    rotations, ``dof`` = ``dim``), and sum |e_i|^4 last.  2D: (modes, 4) = e_x^2, e_y^2, e_th^2,
    |e_i|^4.

    ``vectors`` is (modes, local DOF) with whole particles per rank.  Not collective.
    """
    per_particle = vectors.reshape(vectors.shape[0], -1, dof) ** 2
    sums = np.zeros((vectors.shape[0], sums_width(dim)))
    sums[:, :dof] = per_particle.sum(axis=1)
    sums[:, -1] = (per_particle.sum(axis=2) ** 2).sum(axis=1)
    return sums


def energies(sums: np.ndarray, n_disks: int, dim: int) -> dict[str, np.ndarray]:
    """Per-mode energies (each (modes,)) from reduced :func:`local_sums` of ``n_disks`` particles.

    2D: K_x, K_y, Q, K, participation; 3D: K_x, K_y, K_z, Q_x, Q_y, Q_z, K, Q, participation
    (K, Q the per-component means, see the module docstring).
    """
    rot = rotation_components(dim)
    names = "xyz"[:dim]
    out = {f"K{nu}": sums[:, a] / (2 * n_disks) for a, nu in enumerate(names)}
    if dim == 2:
        out["Q"] = sums[:, 2] / (2 * n_disks)
    else:
        out.update({f"Q{nu}": sums[:, dim + a] / (2 * n_disks) for a, nu in enumerate(names)})
        out["Q"] = sums[:, dim:dim + rot].sum(axis=1) / (2 * rot * n_disks)
    out["K"] = sums[:, :dim].sum(axis=1) / (2 * dim * n_disks)
    norm = sums[:, :dim + rot].sum(axis=1)
    out["participation"] = norm**2 / (n_disks * sums[:, -1])
    return out


def vdos(omegas: list[np.ndarray], bin_width: float) -> tuple[np.ndarray, np.ndarray]:
    """g(omega) of the pooled modes of several configurations, unit area.

    Returns (edges (B+1,), density (B,)); bins [0, w), [w, 2w), ... up to the largest mode; NaN
    densities without modes (a window between the modes).
    """
    pooled = np.concatenate(omegas)
    top = max(float(pooled.max()), bin_width) if pooled.size else bin_width
    edges = np.arange(0.0, top + bin_width, bin_width)
    if edges[-1] <= top:
        edges = np.append(edges, edges[-1] + bin_width)
    if not pooled.size:
        return edges, np.full(edges.size - 1, np.nan)
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
    """omega_c: mean over configurations of the largest eigenfrequency, and its std (NaN and 0
    without modes)."""
    tops = np.array([w.max() for w in omegas if w.size])
    if not tops.size:
        return float("nan"), 0.0
    return float(tops.mean()), float(tops.std(ddof=1)) if tops.size > 1 else 0.0


def pooled_vdos(spectra: list[tuple[dict, dict]], bin_width: float
                ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """vDOS and omega_c of one rho from its configurations' spectrum units (datasets, attrs).

    Slicing units (dataset ``omega``): the histogram of the pooled modes (:func:`vdos`) and
    :func:`cutoff`; pep units (dataset ``lambda``) likewise with the underdamped modes' damped
    frequencies Im lambda (the damped vDOS; overdamped modes have none).  KPM units (datasets ``edges``, ``density``; attribute ``omega_max``): all
    share the bins [0, w), [w, 2w), ... and differ only in how far they reach, so their densities
    are averaged on the longest grid (zero beyond a shorter one's top; unit area kept), and omega_c
    is the mean of the omega_max.  Returns (edges (B+1,), density (B,), omega_c, its std over
    configurations).  Counting units (also ``counts``) pool their integer counts instead, so their
    vDOS equals the slicing histogram of the same modes.
    """
    if "omega" in spectra[0][0]:
        omegas = [datasets["omega"] for datasets, _ in spectra]
        return (*vdos(omegas, bin_width), *cutoff(omegas))
    if "lambda" in spectra[0][0]:  # damped modes (pep): the damped frequencies omega_d = Im lambda > 0
        omegas = [datasets["lambda"].imag[datasets["lambda"].imag > 0] for datasets, _ in spectra]
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
