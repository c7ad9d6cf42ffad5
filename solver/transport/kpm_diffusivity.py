"""The Allen-Feldman diffusivity per omega bin without eigenvectors: the trace form of
docs/diffusivity_trace.md evaluated by the kernel polynomial method (issue 45, route 2; route 1,
the exact d_n of every mode, is ``allen_feldman``).

With A = M^-1/2 D M^-1/2 (A e_n = omega_n^2 e_n, rigid modes left out), the position operators
X^a (``allen_feldman.position_operators``: A times (r_i - r_j)_a per particle block, X^a = -X^a^T)
and Y^a_nm = e_n^T X^a e_m, the diffusivity with the Lorentzian replaced by a box of the bin's
width Delta_b (a mode couples to the modes of its own bin, with weight 1 / Delta_b) summed over
the modes of bin b = [w_b, w_b+1) is

    S_b = sum_{n in b} d_n^box = pi / (4 D Delta_b) sum_{n, m in b} sum_a |Y^a_nm|^2 W_nm / omega_n^2
        ~ pi / (4 D Delta_b) sum_a Tr[X^a^T F_b(A) X^a F_b(A)],   F_b(lambda) = 1_b(lambda) lambda^-1/2,

W_nm = (omega_n + omega_m)^2 / (4 omega_n omega_m) the pair factor, 1_b the indicator of
lambda in [w_b^2, w_b+1^2).  The trace form weighs a pair by 1 / (omega_n omega_m) where the
definition (symmetrised in n, m) has (omega_n + omega_m)^2 (omega_n^2 + omega_m^2) /
(8 omega_n^3 omega_m^3) = (1 + 3 eps^2 / 4 + O(eps^3)) / (omega_n omega_m), omega_m = omega_n
(1 + eps), |eps| < Delta_b / w_b: 0.2 % at most in a bin of width 0.05 at omega = 1.
The count of modes C_b = Tr 1_b(A) gives the vDOS, and d_b = S_b / C_b is the mean d over the
bin's modes (d0^2/t0).

Estimator.  F_b is replaced by its Jackson-damped Chebyshev expansion in B = (A - c) / h,
F_b^K = sum_k g_k c_kb T_k(B) (K moments; c, h the vDOS's, ``chebyshev.kpm_scale``: [lo, hi] =
[-0.01, 1.01] lambda_max; the recursion ``chebyshev.Recursion``), and the traces by Rademacher probes r (``kpm.probe_rows``: rank-layout free) with the
rigid modes projected out (``kpm.project_rigid``, the projector P):

    S_b ~ pi / (4 D Delta_b) mean_r sum_a < F_b^K P X^a r , X^a F_b^K r >,
    E[...] = sum_a Tr[P X^a^T P F_b^K X^a F_b^K P] = sum_{n, m non-zero} |Y^a_nm|^2 f_b(lambda_n) f_b(lambda_m),

and C_b ~ mean_r r^T 1_b^K(A) r from the moments r^T T_k(B) r (``kpm.bin_masses``, the vDOS's own
integral of the expansion over the bin).  P before the second recursion keeps the zero modes out
of the m sum as well (F_b^K(0) is not 0).

Decision: how the bins meet the vectors.  For each block of probes (``block`` columns at once,
one MatMatMult per step) and each pass over a group of bins (``bins_per_pass``; all at once by
default), one recursion on r accumulates phi_b = F_b^K r for every bin of the group into an
(nloc x block, bins) array by BLAS3 (a chunk of ``chunk`` vectors T_k r times the (chunk, bins)
coefficients, dgemm); then for each axis Z^a = X^a [phi_b] (one sparse MatMatMult over all the
columns) and a recursion on P X^a r whose chunks of T_k vectors are dotted with Z^a (one dgemm per
probe and chunk): S_b needs the per-bin vectors on one side only.  (1 + D) recursions of K steps
per probe block and pass.  Memory per rank: 2 nloc x block x bins float64 (phi, Z^a) plus
chunk + 4 blocks of nloc x block; never n^2, never an eigenvector.  The alternative, all (1 + D)
recursions in one block of (1 + D) x block columns, makes fewer and wider MatMatMults but holds
(2 + D) such arrays; memory is what limits the 10^6-disk case, so the recursions run one after
the other.  The pair factor is not carried exactly (three separable terms, three times the
BLAS3 work and memory) for the O(eps^2) above.

Resolution.  The estimator converges, as K -> infinity, to the box-broadened S_b above (with the
1 / (omega_n omega_m) weight) and, as probes -> infinity, to its Jackson-filtered counterpart at
finite K; ``references.allen_feldman_binned_dense`` evaluates both exactly.  Jackson's kernel
smears lambda by ~pi h / K, i.e. omega by sqrt(omega^2 + pi h / K) - omega (~pi h / (2 K omega)),
reported per bin as ``smearing``; the result is a bin average over [w_b, w_b+1) with both edges
smeared so.  Route 1's Lorentzian-eta d_n averaged over the bin differs from the box-broadened
value by a broadening term, second order in max(eta, Delta) where g(omega) d(omega) is smooth
(docs/diffusivity_trace.md gives the measured sizes).

Statistical error: the probes are independent, so ``d_err`` is the standard error of the ratio
estimator S / C from the spread over probes (delta method: sd(S_r - d C_r) / (sqrt(R) C)); it
falls as 1/sqrt(R), and at fixed R as ~1/sqrt(modes per bin) (self-averaging: large packings
need few probes).

Units: d0 = m = kn = 1, t0 = 1; omega in 1/t0, d in d0^2/t0.  Collective on the matrix's
communicator; the same result on any rank count to round-off.
"""

from __future__ import annotations

import math

import numpy as np

from .. import profiling
from ..model.operators import largest_omega
from ..spectrum import chebyshev, kpm
from .allen_feldman import position_operators

# Gauss-Legendre nodes per bin for the filter coefficients: ceil(NODES_PER_RADIAN K dtheta) + NODES_MIN
NODES_PER_RADIAN, NODES_MIN = 1.0, 48


def filter_coefficients(edges: np.ndarray, c: float, h: float, n_moments: int) -> np.ndarray:
    """(n_moments, B): Jackson-damped Chebyshev coefficients g_k c_kb of F_b(lambda) = 1_b(lambda)
    lambda^-1/2, 1_b the indicator of omega in [edges_b, edges_b+1) (1/t0), in x = (lambda - c) / h:
    c_kb = (2 - delta_k0) / pi int F_b T_k(x) / sqrt(1 - x^2) dx, written in omega (lambda = omega^2)
    as (2 - delta_k0) / pi int 2 cos(k theta) / (h sin theta) d omega, x = cos theta: smooth on
    [0, omega_top] (the lambda^-1/2 singularity cancels), by Gauss-Legendre per bin.  omega is cut
    at omega_top = sqrt(c + 0.999 h) (lambda ~ 1.0098 lambda_max: no mode lies above lambda_max).
    Not collective."""
    from scipy.special import roots_legendre

    edges = np.asarray(edges, dtype=float)
    top = math.sqrt(c + 0.999 * h)
    lo, hi = np.minimum(edges[:-1], top), np.minimum(edges[1:], top)
    k = np.arange(n_moments)
    out = np.zeros((n_moments, lo.size))
    for b in np.flatnonzero(hi > lo):  # a loop over bins, each a vectorised quadrature
        theta_span = math.acos((lo[b] ** 2 - c) / h) - math.acos((hi[b] ** 2 - c) / h)
        nodes, weights = roots_legendre(int(math.ceil(NODES_PER_RADIAN * n_moments * theta_span)) + NODES_MIN)
        omega = 0.5 * (hi[b] - lo[b]) * nodes + 0.5 * (hi[b] + lo[b])
        x = (omega**2 - c) / h
        integrand = 2.0 / (h * np.sqrt(1.0 - x**2)) * (0.5 * (hi[b] - lo[b]) * weights)
        out[:, b] = np.cos(np.outer(k, np.arccos(x))) @ integrand
    out *= (2.0 - (k == 0))[:, None] / math.pi
    return kpm.jackson(n_moments)[:, None] * out


def smearing(edges: np.ndarray, h: float, n_moments: int) -> np.ndarray:
    """(B,): Jackson's smearing in omega (1/t0) at each bin's centre w: sqrt(w^2 + pi h / K) - w,
    from its smearing pi h / K in lambda (~pi h / (2 K w) above the lowest bins). Not collective."""
    centre = 0.5 * (edges[1:] + edges[:-1])
    return np.sqrt(centre**2 + math.pi * h / n_moments) - centre


def _times(Xa, D, z: np.ndarray) -> np.ndarray:
    """Xa z (nloc, p) as a new Fortran-ordered array, for a block z (nloc, p) on D's layout; the
    PETSc Mats freed here, also when an exception passes. Collective."""
    block = chebyshev.dense_block(D, z)
    try:
        product = Xa.matMult(block)
        try:
            return np.array(product.getDenseArray(readonly=True), order="F")
        finally:
            product.destroy()
    finally:
        block.destroy()


@profiling.logged("rsAFKPMProbes")
def probe_block(dm, X: list, z: np.ndarray, coef: np.ndarray, c: float, h: float, *, counts: bool = True,
                chunk: int = 64) -> tuple[np.ndarray, np.ndarray | None]:
    """(s (p, B), mu (K, p) or None) of one block of probes ``z`` (this rank's rows (nloc, p), rigid
    modes already projected out; the same rows on every layout): s[r, b] = sum_a < F_b P X^a z_r,
    X^a F_b z_r > with F_b = sum_k coef[k, b] T_k(B) (``coef`` (K, B): :func:`filter_coefficients`,
    B = (A - c) / h) and, with ``counts``, the moments mu[k, r] = z_r^T T_k(B) z_r.  ``X`` the
    position operators.  One recursion on z and one on P X^a z per axis (module docstring), the
    T_k vectors met ``chunk`` at a time by dgemm.  Collective on the matrix's communicator; the
    same arrays on every rank."""
    from mpi4py import MPI
    from scipy.linalg.blas import dgemm

    mpi = dm.D.getComm().tompi4py()
    n_moments, bins = coef.shape
    nloc, p = z.shape
    phi = np.zeros((nloc * p, bins), order="F")  # column b: phi_b of every probe, (nloc, p) in F order
    mu = np.zeros((n_moments, p)) if counts else None
    local_s = np.zeros((p, bins))

    def accumulate(k0: int, block: np.ndarray) -> None:
        dgemm(1.0, block, coef[k0:k0 + block.shape[1]], beta=1.0, c=phi, overwrite_c=True)
        if counts:  # z_r^T T_k z_r for the chunk's k
            mu[k0:k0 + block.shape[1]] = np.einsum("ipk,ip->kp", block.reshape(nloc, p, -1, order="F"), z)

    def dot_with(za: np.ndarray):
        """The flush adding sum_k coef[k, b] <T_k P X^a z_r, za[:, r, b]> to local_s[r, b]."""
        def dot(k0: int, block: np.ndarray) -> None:
            tk = block.reshape(nloc, p, -1, order="F")
            ck = coef[k0:k0 + block.shape[1]]
            for r in range(p):
                local_s[r] += np.einsum("kb,kb->b", ck, tk[:, r, :].T @ za[:, r, :])
        return dot

    with chebyshev.Recursion(dm.D, c, h, p, 1.0 / np.sqrt(dm.M.getArray())) as recursion:
        recursion.chunked(z, n_moments, chunk, accumulate)
        columns = chebyshev.dense_block(dm.D, phi.reshape(nloc, p * bins, order="F"))  # column p' + p b
        try:
            for Xa in X:
                xz = kpm.project_rigid(dm, _times(Xa, dm.D, z))  # P X^a z: the zero modes out of the m sum too
                image = Xa.matMult(columns)
                try:
                    za = image.getDenseArray(readonly=True).reshape(nloc, p, bins, order="F")
                    recursion.chunked(xz, n_moments, chunk, dot_with(za))
                finally:
                    image.destroy()
        finally:
            columns.destroy()
    mpi.Allreduce(MPI.IN_PLACE, local_s, op=MPI.SUM)
    if counts:
        mpi.Allreduce(MPI.IN_PLACE, mu, op=MPI.SUM)
    return local_s, mu


def auto_moments(lam_max: float, edges: np.ndarray, omega_ref: float = 1.0) -> int:
    """Moments so that Jackson's omega smearing at ``omega_ref`` is about half the median bin width
    (``kpm.auto_moments``). Not collective."""
    return kpm.auto_moments(lam_max, float(np.median(np.diff(edges))), omega_ref)


def binned_diffusivity(dm, positions: np.ndarray, box: np.ndarray, edges: np.ndarray, *, moments: int | None,
                       probes: int, seed: int, comm, block: int = 8, bins_per_pass: int | None = None,
                       chunk: int = 64, min_count: float = 1.0) -> tuple[dict, dict]:
    """The Allen-Feldman diffusivity per omega bin by KPM (module docstring) as (datasets, attrs).

    ``positions`` (N, D) in d0, every particle in the packing's order, ``box`` the periodic cell
    (a ``geometry.Cell``, or its (D,) sides), ``edges`` (B+1,) ascending omega bin edges in 1/t0
    (the vDOS's bins); ``moments`` K (None: :func:`auto_moments`), ``probes`` R >= 2 Rademacher
    probes from ``seed``, taken ``block`` at a time, the bins ``bins_per_pass`` at a time (None:
    all; each pass repeats the recursions, to bound memory), T_k vectors ``chunk`` at a time.
    datasets: edges; count (B,) estimated modes per bin; d (B,) mean d over the bin's modes
    (d0^2/t0), NaN where count < ``min_count``; d_err (B,) its standard error over the probes;
    count_err (B,); total (B,) = count x d, the sum of d^box over the bin's modes (unbiased), and
    total_err (B,); smearing (B,) Jackson's omega smearing at the bin centres (1/t0).
    attrs: moments, probes, seed, omega_max (1/t0), lam_scale (c, h), resolution (text), n_modes.
    Symmetric matrices only.  Collective on ``comm`` (the matrix's); the same result on every rank
    and on any number of ranks, to round-off."""
    if not dm.symmetric:
        raise ValueError("the Allen-Feldman diffusivity needs a symmetric dynamical matrix (not a stressed packing's)")
    if probes < 2:
        raise ValueError(f"probes must be >= 2 for a standard error, not {probes}")
    edges = np.asarray(edges, dtype=float)
    if edges.ndim != 1 or edges.size < 2 or np.any(np.diff(edges) <= 0) or edges[0] < 0:
        raise ValueError("edges must be an ascending array of at least two omega >= 0")
    omega_max = largest_omega(dm)
    c, h = chebyshev.kpm_scale(omega_max**2)
    n_moments = int(moments or auto_moments(omega_max**2, edges))
    coef = filter_coefficients(edges, c, h, n_moments)
    bins = edges.size - 1
    per_pass = bins if bins_per_pass is None else max(1, int(bins_per_pass))
    start, stop = dm.D.getOwnershipRange()
    z_all = kpm.project_rigid(dm, np.asfortranarray(kpm.probe_rows(seed, start, stop, probes)))
    X = position_operators(dm, positions, box, comm)
    s = np.zeros((probes, bins))
    mu = np.zeros((n_moments, probes))
    try:
        for first in range(0, probes, block):
            z = np.asfortranarray(z_all[:, first:first + block])
            for b0 in range(0, bins, per_pass):
                part, moments_ = probe_block(dm, X, z, coef[:, b0:b0 + per_pass], c, h, counts=b0 == 0, chunk=chunk)
                s[first:first + z.shape[1], b0:b0 + per_pass] = part
                if b0 == 0:
                    mu[:, first:first + z.shape[1]] = moments_
    finally:
        for Xa in X:
            Xa.destroy()
    width = np.diff(edges)
    s *= math.pi / (4.0 * dm.dim * width)  # per probe: sum over the bin's modes of d^box
    count_r = np.array([kpm.bin_masses(mu[:, r], c, h, edges) for r in range(probes)])  # (R, B)
    total, count = s.mean(axis=0), count_r.mean(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.where(count >= min_count, total / count, np.nan)
        spread = np.std(s - np.nan_to_num(d) * count_r, axis=0, ddof=1)
        d_err = np.where(count >= min_count, spread / (math.sqrt(probes) * count), np.nan)
    count_err = np.std(count_r, axis=0, ddof=1) / math.sqrt(probes)
    total_err = np.std(s, axis=0, ddof=1) / math.sqrt(probes)
    datasets = {"edges": edges, "count": count, "count_err": count_err, "total": total, "total_err": total_err,
                "d": d, "d_err": d_err,
                "smearing": smearing(edges, h, n_moments)}
    attrs = {"moments": n_moments, "probes": probes, "seed": seed, "omega_max": omega_max, "lam_scale": (c, h),
             "n_modes": dm.size - len(dm.rigid_modes()),
             "resolution": (f"bins of edges (box broadening of the bin's width) with each edge smeared by "
                            f"Jackson's kernel: pi h / K = {math.pi * h / n_moments:.4g} / t0^2 in lambda, "
                            f"sqrt(w^2 + pi h / K) - w in omega (dataset smearing)")}
    return datasets, attrs
