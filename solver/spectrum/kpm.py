"""Stochastic vDOS by the kernel polynomial method (KPM): no factorisation, no eigenvectors.

Moments mu_n = tr T_n(B) / n_modes of B = (A - c I) / h, A = M^-1/2 D M^-1/2 (c, h map
[-0.01, 1.01] lambda_max onto [-1, 1]: ``chebyshev.kpm_scale``; the recursion is
``chebyshev.Recursion``'s), estimated with R
Rademacher probe vectors from which the exact zero modes of ``dm.rigid_modes()`` (the uniform
translations; and the uniform spins when there are rotations but no tangential springs) are
projected out, so the density counts exactly the non-zero modes.  One MatMatMult per two
moments (mu_2n = 2 <T_n, T_n> - mu_0, mu_2n+1 = 2 <T_n+1, T_n> - mu_1), Jackson kernel.
The mass of every omega bin [w_a, w_b) is the exact integral of the expansion over
lambda in [w_a^2, w_b^2) (with x = cos theta, int T_n(x) / (pi sqrt(1 - x^2)) dx is
sin(n theta) / (n pi)), so the result is a histogram comparable bin by bin with the exact one.
Resolution: Jackson's kernel smears x by ~pi/M, i.e. lambda by ~pi h/M and omega by
~pi h / (2 M omega): poor at low omega (PHYSICS.md section 4), reported in BENCHMARKS.md.
Collective on the matrix's communicator.  Units: omega in 1/t0.
"""

from __future__ import annotations

import numpy as np

from . import chebyshev, modes
from .. import profiling
from ..model.operators import largest_omega


def jackson(m: int) -> np.ndarray:
    """Jackson damping factors g_n, n = 0..m-1."""
    n = np.arange(m)
    q = np.pi / (m + 1)
    return ((m - n + 1) * np.cos(q * n) + np.sin(q * n) / np.tan(q)) / (m + 1)


def probe_rows(seed: int, start: int, stop: int, probes: int) -> np.ndarray:
    """Rows [start, stop) (stop - start, probes) of one global array of Rademacher signs (+-1).

    Row i is made from Philox counter blocks [i w, (i + 1) w), w = ceil(probes / 256) (each block
    is 4 x 64 random bits), so every rank draws only its own rows and any block of rows is the
    same whatever the layout: the probes are rank-free without a whole-problem array anywhere.
    Not collective."""
    width = -(-probes // 256)
    bits = np.random.Philox(np.random.SeedSequence([seed, 7]))
    bits.advance(start * width)
    raw = bits.random_raw((stop - start) * width * 4).reshape(stop - start, width * 4)
    signs = np.unpackbits(raw.view(np.uint8), axis=1, bitorder="little")[:, :probes]
    return 1.0 - 2.0 * signs


def project_rigid(dm, z: np.ndarray) -> np.ndarray:
    """Remove from the columns of ``z`` (this rank's rows (nloc, k) on D's layout, in place) their
    parts along the exact zero modes of A = M^-1/2 D M^-1/2 listed by ``dm.rigid_modes()``: slot
    s of every particle is M^1/2 (1 in slot s) in A's space (e_x ~ M^1/2 (1, 0, 0, ...));
    different slots, so they are orthogonal to each other.  Returns ``z``.  Collective on D's
    communicator."""
    mpi = dm.D.getComm().tompi4py()
    nloc = dm.D.getLocalSize()[0]
    s = (1.0 / np.sqrt(dm.M.getArray()))[:, None]
    for slot, _ in dm.rigid_modes():
        e = np.zeros(nloc)
        e[slot::dm.dof] = 1.0 / s[slot::dm.dof, 0]
        norm2 = mpi.allreduce(float(e @ e))
        z -= np.outer(e, mpi.allreduce(e @ z) / norm2)
    return z


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """sum(a * b) of two equal-layout arrays without a temporary (BLAS dot). Not collective."""
    return float(np.dot(a.ravel(order="K"), b.ravel(order="K")))


@profiling.logged("rsKPMMoments")
def moments(dm, lam_max: float, n_moments: int, probes: int, seed: int, channel: str | None = None
            ) -> tuple[np.ndarray, float, float]:
    """Stochastic Chebyshev moments (n_moments,) of the non-zero modes; also (c, h). Collective.

    ``channel`` "translation" or "rotation" restricts the probes to those DOF (slots 0..dim-1 or
    dim..dof-1 of every particle), so the moments weigh mode q by |P e_q|^2 (its translational or
    rotational share, PHYSICS.md section 3); the two channels add up to the unrestricted moments
    in expectation.  Memory per rank: five (nloc, probes) blocks (probes: :func:`probe_rows`).
    One MatMatMult per step (``chebyshev.Recursion`` on D with s = M^-1/2; c, h of
    ``chebyshev.kpm_scale``).
    """
    mpi = dm.D.getComm().tompi4py()
    c, h = chebyshev.kpm_scale(lam_max)
    nloc, n = dm.D.getLocalSize()[0], dm.size
    start = dm.D.getOwnershipRange()[0]
    z = np.asfortranarray(probe_rows(seed, start, start + nloc, probes))
    if channel is not None:
        rotation = (np.arange(start, start + nloc) % dm.dof) >= dm.dim
        z[rotation if channel == "translation" else ~rotation] = 0.0
    project_rigid(dm, z)
    n_modes = n - len(dm.rigid_modes())
    half = (n_moments + 1) // 2
    local = []  # (<T_n, T_n>, <T_n+1, T_n>) for n = 0..half-1
    with chebyshev.Recursion(dm.D, c, h, probes, 1.0 / np.sqrt(dm.M.getArray())) as recursion:
        previous = None
        for t in recursion.terms(z, half + 1, overwrite=True):  # T_n-1 is intact beside T_n
            if previous is not None:
                local += [_dot(previous, previous), _dot(t, previous)]
            previous = t
    sums = mpi.allreduce(np.array(local))
    mu = np.empty(2 * half)
    mu[0::2] = 2 * sums[0::2] - sums[0]  # mu_2n = 2 <T_n, T_n> - mu_0 (n = 0: mu_0 itself)
    mu[1::2] = 2 * sums[1::2] - sums[1]  # mu_2n+1 = 2 <T_n+1, T_n> - mu_1
    return mu[:n_moments] / (probes * n_modes), c, h


def bin_masses(mu: np.ndarray, c: float, h: float, edges: np.ndarray) -> np.ndarray:
    """Fraction of modes in each omega bin [edges_i, edges_i+1) from the moments (Jackson kernel)."""
    g = jackson(mu.size) * mu
    x = np.clip((edges**2 - c) / h, -1.0, 1.0)
    theta = np.arccos(x)  # decreasing in omega
    n = np.arange(1, mu.size)
    primitive = (g[0] * theta + 2 * np.sum(g[1:] * np.sin(np.outer(theta, n)) / n, axis=1)) / np.pi
    return primitive[:-1] - primitive[1:]


def vdos(dm, edges: np.ndarray, lam_max: float, n_moments: int, probes: int, seed: int) -> np.ndarray:
    """g(omega) (B,) on ``edges``, unit area over the non-zero modes. Collective."""
    mu, c, h = moments(dm, lam_max, n_moments, probes, seed)
    masses = np.clip(bin_masses(mu, c, h, edges), 0.0, None)
    return masses / np.diff(edges) / masses.sum()


def energies(dm, edges: np.ndarray, lam_max: float, n_moments: int, probes: int, seed: int
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(g (B,), K (B,), Q (B,)): the vDOS and the bin averages of K and Q over its modes (Fig. 6)
    from translation- and rotation-restricted probes. Collective; needs rotations (``dm.rotations``).

    With K and Q the per-component means of ``modes`` (D translations, r = 1 (2D) or 3 (3D)
    rotation components), mode q carries w_T = sum over translational DOF of e_q^2 = 2 D N K_q
    (2D: 4 N K_q, 3D: 6 N K_q) and w_R = 2 r N Q_q (2D: 2 N Q_q, 3D: 6 N Q_q), and w_T + w_R = 1;
    so the two restricted densities add up to the vDOS (used as such: g costs nothing extra), and
    K = mass_T / (2 D N mass), Q = mass_R / (2 r N mass) per bin.  Bins holding less than 1e-4 of
    the modes are NaN (a ratio of two noisy small numbers).
    """
    masses = []
    for index, channel in enumerate(("translation", "rotation")):
        mu, c, h = moments(dm, lam_max, n_moments, probes, seed + 1000 * index, channel)
        masses.append(bin_masses(mu, c, h, edges))
    total = np.clip(masses[0] + masses[1], 0.0, None)
    n_disks = int(dm.active.sum())
    k_weight, q_weight = 2 * dm.dim * n_disks, 2 * modes.rotation_components(dm.dim) * n_disks
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(total > 1e-4 * total.sum(), masses[0] / (k_weight * total), np.nan)
        q = np.where(total > 1e-4 * total.sum(), masses[1] / (q_weight * total), np.nan)
    return total / np.diff(edges) / total.sum(), k, q


def auto_moments(lam_max: float, bin_width: float, omega_ref: float = 1.0) -> int:
    """Moments so that Jackson's omega smearing at omega_ref is about half a bin."""
    h = chebyshev.kpm_scale(lam_max)[1]
    return int(np.ceil(2 * np.pi * h / (2 * omega_ref * bin_width)))


def solve(dm, *, bin_width: float, moments: int | None, probes: int, with_energies: bool, seed: int
          ) -> tuple[dict, dict]:
    """The KPM counterpart of ``slicing.solve``: the vDOS of ``dm`` as (datasets, attrs). Collective.

    Bins [0, w), [w, 2w), ... of width ``bin_width`` up to 1.1 omega_max (omega_max from the
    Lanczos solve, ``model.operators.largest_omega``); ``moments`` (None: :func:`auto_moments`).
    datasets: edges (B+1,), density (B,) and, ``with_energies``, K and Q (B,): from channel-restricted
    probes (:func:`energies`) when the matrix has rotations; without (frictionless) every mode
    has K = 1/(2 D N) (2D: 1/4N) and Q = 0, and those are filled in without probes (NaN where the
    density is 0).
    attrs: omega_max (1/t0), moments, probes, n_zero_modes (the modes left out: those of
    ``dm.rigid_modes()``, projected out of every probe; the only zero modes of a jammed packing
    with its rattlers removed), dof, n_disks.
    """
    omega_max = largest_omega(dm)
    edges = np.arange(0.0, bin_width * (np.ceil(1.1 * omega_max / bin_width) + 1), bin_width)
    n_moments = moments or auto_moments(omega_max**2, bin_width)
    n_disks = int(dm.active.sum())
    datasets = {"edges": edges}
    if with_energies and dm.rotations:  # K and Q from channel-restricted probes (same cost x 2)
        datasets["density"], datasets["K"], datasets["Q"] = energies(dm, edges, omega_max**2, n_moments,
                                                                     probes, seed)
    else:
        datasets["density"] = vdos(dm, edges, omega_max**2, n_moments, probes, seed)
        if with_energies:
            populated = datasets["density"] > 0
            datasets["K"] = np.where(populated, 1.0 / (2 * dm.dim * n_disks), np.nan)
            datasets["Q"] = np.where(populated, 0.0, np.nan)
    return datasets, {"omega_max": omega_max, "moments": n_moments, "probes": probes,
                      "n_zero_modes": len(dm.rigid_modes()), "dof": dm.size, "n_disks": n_disks}
