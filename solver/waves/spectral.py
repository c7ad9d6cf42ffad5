"""Standing waves without time stepping: z(t) = b^H cos(sqrt(A) t) a by Lanczos (the model,
eq:motion, is linear).  See :func:`spectral`.  Collective on the matrix's communicator.
Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import numpy as np

from .. import profiling
from ..model.operators import largest_omega
from .excitation import channel, runs, start_velocity
from .lanczos import Recurrences, cos_sqrt, operator, refuse_unstable, scaled_starts, tridiagonal_eigen
from .sampling import WaveSeries


def spectral(dm, positions, mode: str, run: int, k: float | np.ndarray, *, amplitude: float, times: np.ndarray,
             tol: float = 1e-8, omega_max: float | None = None) -> WaveSeries:
    """One standing wave (run ``run`` of ``excitation.runs(mode, dm.dim)`` at ``k``):
    :func:`spectral_all` of that wave alone. Collective."""
    return spectral_all(dm, positions, [(mode, run, k)], amplitude=amplitude, times=times, tol=tol,
                        omega_max=omega_max)[0]


BATCH = 4
"""Waves run side by side at most.  Measured (scripts/benchmarks/bench_lanczos_batch.py, N = 131072, 2 ranks,
24 waves): 5.14 s per wave one at a time with MatMult (the code before), 3.12 in chunks of 1,
2.09 in chunks of 4, 2.41 of 12, 2.59 of 24, 2.84 of 48: past a few columns the per-step work on
the (nloc, W) blocks outgrows what the shared reads of A save.  Memory: five (nloc, BATCH) blocks."""


def spectral_all(dm, positions, waves: list[tuple[str, int, float]], *, amplitude: float, times: np.ndarray,
                 tol: float = 1e-8, omega_max: float | None = None) -> list[WaveSeries]:
    """Standing waves without time stepping: one WaveSeries per wave (mode, run of
    ``excitation.runs(mode, dm.dim)``, k), :func:`_side_by_side` in chunks of :data:`BATCH`. Collective."""
    if omega_max is None:
        omega_max = largest_omega(dm)
    return [series for i in range(0, len(waves), BATCH)
            for series in _side_by_side(dm, positions, waves[i:i + BATCH], amplitude=amplitude, times=times, tol=tol,
                                        omega_max=omega_max)]


@profiling.logged("rsLanczosWave")
def _side_by_side(dm, positions, waves: list[tuple[str, int, float]], *, amplitude: float, times: np.ndarray,
                  tol: float, omega_max: float) -> list[WaveSeries]:
    """Standing waves without time stepping: z(t) = b^H cos(sqrt(A) t) a by Lanczos, one
    WaveSeries per wave (mode, run of ``excitation.runs(mode, dm.dim)``, k). Collective.

    With r_i(0) in the phase the dynamics is exactly linear (PHYSICS.md section 4):
    a = M^1/2 v0, b = M^-1/2 (exp(i k r_i(0)) in the channel), A = M^-1/2 D M^-1/2.  m Lanczos
    steps from a give A ~ Q T Q^T; w = Q^T b is accumulated on the way (one dot per step), so
    z(t) = |a| sum_j (w . s_j) s_j[0] cos(sqrt(theta_j) t) over the eigenpairs of T.
    The W waves run as W independent recurrences side by side: one MatMatMult of A with the
    (nloc, W) block of their current vectors per step (whose symbolic product is made once), and
    one reduction for every wave's dots, then one for their norms -- the same arithmetic per wave
    as W separate runs, with A's entries read once per step instead of W times.
    Loss of orthogonality: none is corrected, on purpose.  The plain three-term recurrence keeps
    three vectors per wave (memory O(n W), cost one product and two reductions per step); in
    floating point its basis loses orthogonality and T grows spurious copies of converged Ritz
    values, but the Lanczos approximation |a| Q f(T) e_1 of f(A) a stays as accurate as the best
    polynomial approximation of f on a slightly enlarged spectral interval (Musco, Musco & Sidford,
    SODA 2018), and |b^H (f(A) a - approx)| <= |b| |f(A) a - approx|, so the bilinear form
    inherits that bound.  Full reorthogonalisation costs m^2 n: it measured 23x slower at
    N = 8192 (8 waves to t = 200: 89.6 s against 3.9 s) for the same answer.
    Steps: z is a bilinear form, so T_m must resolve cos(sqrt(lambda) t) as a polynomial of
    degree m - 1 (not 2m - 1 as a Gauss quadrature would): start at omega_max t_end / 2 + 40 and
    grow by a fifth until, for every wave, z from T_m and from its leading (m - 10) block agree to
    ``tol`` relative -- the error estimate that is reported (a wave whose Krylov space closes
    early, |v| at round-off, is exact from then on: estimate 0).  (Measured: 0.55-0.7
    omega_max t_end steps reach 1e-8 for t_end = 100-300.)
    Returns samples at ``times`` with z = z_fixed (the r_i(t) phase needs the trajectory) and a
    constant energy (exactly conserved).
    """
    mpi = dm.D.getComm().tompi4py()
    s = 1.0 / np.sqrt(dm.M.getArray())
    a, norm_a = scaled_starts(dm, positions, waves, amplitude, mpi)
    energy = 0.5 * norm_a**2
    channels = [channel(dm, positions, *runs(mode, dm.dim)[run], k) * s for mode, run, k in waves]  # z = b^H v = (M^-1/2 b)^H (M^1/2 v)
    b_re = np.asfortranarray(np.stack([c.real for c in channels], axis=1))
    b_im = np.asfortranarray(np.stack([c.imag for c in channels], axis=1))
    del channels
    floor = 1e-13 * omega_max**2  # |v| at the round-off of A q (~1e-16 ||A||, ||A|| = omega_max^2)
    recurrences = Recurrences(operator(dm), a / norm_a, (b_re, b_im), floor)
    del a  # from here on: q, q_prev, the product and b, five (nloc, W) blocks
    lam_max = omega_max**2 * (1 + 1e-6)  # above the Lanczos estimate's error

    def evaluate(alphas, betas, reads, sizes, closed):
        ws = reads[0] - 1j * reads[1]
        return [_z_and_estimate(alphas[:, i], betas[:, i], ws[:, i], norm_a[i], times, sizes[i], closed[i], lam_max)
                for i in range(len(waves))]

    try:
        results, sizes = recurrences.converge(int(np.ceil(0.5 * omega_max * times[-1])) + 40, tol, evaluate)
    finally:
        recurrences.destroy()
    out = []
    for i, (z, estimate) in enumerate(results):
        steps = sizes[i]
        settings = {"method": "lanczos", "tol": tol, "steps": steps, "omega_max": omega_max, "batch": len(waves)}
        out.append(WaveSeries(np.asarray(times), z, z, np.full(len(times), energy[i]), steps, float(estimate),
                              settings))
    return out


def _z_chebyshev(alpha, beta, w, norm_a: float, times, lam_max: float) -> np.ndarray:
    """z(t) = norm_a w^T cos(sqrt(T) t) e_1 without eigenvectors, O(m^2 + S m log m) for the m x m
    tridiagonal T (diagonal ``alpha`` (m,), off-diagonal ``beta`` (m - 1,)): the Chebyshev series of
    cos(t sqrt(lambda)) (``lanczos.cos_sqrt``: cosh below 0) on [lo, hi] to degree m - 1 (the
    degrees m Lanczos steps make exact for the bilinear form), with [lo, hi] = [0, ``lam_max``]
    widened to T's own extreme Ritz values (bisection, O(m) each) where they fall outside: a
    marginal packing's negative-curvature direction, or a Ritz value above the ``wmax_`` estimate,
    would otherwise make the moments grow.  Coefficients by a DCT at m + 64 nodes; negligible past
    n ~ sqrt(hi) t / 2, where the step count starts.  Moments mu_n = w^T T_n(X) e_1,
    X = (2 T - (hi + lo)) / (hi - lo), by the three-term recurrence (|mu_n| <= |w|: checked).
    (:func:`_z_and_estimate` has refused a T whose negative Ritz value grows by more than e.)"""
    from scipy.fft import dct
    from scipy.linalg import eigvalsh_tridiagonal

    m = alpha.size
    alpha, beta = np.asarray(alpha, dtype=float), np.asarray(beta, dtype=float)
    ends = [eigvalsh_tridiagonal(alpha, beta, select="i", select_range=(i, i), lapack_driver="stebz")[0]
            for i in (0, m - 1)] if m > 1 else [alpha[0], alpha[0]]
    lo, hi = min(0.0, ends[0]), max(lam_max, ends[1])
    lo, hi = lo - 1e-12 * (hi - lo), hi + 1e-12 * (hi - lo)  # bisection's own error
    diag, off = (2.0 * alpha - (hi + lo)) / (hi - lo), 2.0 * beta / (hi - lo)

    def x_times(v):
        out = diag * v
        out[:-1] += off * v[1:]
        out[1:] += off * v[:-1]
        return out

    mu = np.empty(m, dtype=complex)
    previous, current = np.zeros(m), np.zeros(m)
    current[0] = 1.0
    mu[0] = w[0]
    for n in range(1, m):  # degree n of T_n(X) e_1: one tridiagonal product each (m ~ omega_max t_end / 2)
        nxt = x_times(current) if n == 1 else 2.0 * x_times(current) - previous
        previous, current = current, nxt
        mu[n] = w @ current
    if np.abs(mu).max() > 10.0 * np.linalg.norm(w):
        raise RuntimeError(f"spectral: the Chebyshev moments of T on [{lo:.6g}, {hi:.6g}] grow")
    nodes = m + 64
    lam = lo + 0.5 * (hi - lo) * (1.0 + np.cos(np.pi * (np.arange(nodes) + 0.5) / nodes))  # lambda at the nodes
    z = np.empty(len(times), dtype=complex)
    for start in range(0, len(times), 256):  # (256, nodes) samples at a time
        block = np.asarray(times[start:start + 256])
        c = dct(cos_sqrt(lam, block).T, type=2, axis=1)[:, :m] / nodes
        c[:, 0] *= 0.5
        z[start:start + 256] = norm_a * (c @ mu)
    return z


def _z_and_estimate(alpha, beta, w, norm_a: float, times, size: int, exact: bool,
                    lam_max: float) -> tuple[np.ndarray, float]:
    """(z at ``times`` from the leading ``size`` steps of one wave's T, its error estimate: the
    largest change of z from dropping the last 10 steps, relative to max |z|; 0 when ``exact``).
    z from T's eigenpairs (MRRR); where MRRR fails on the clustered Ritz values of a long open run,
    from Chebyshev moments (:func:`_z_chebyshev`, T's spectrum in [0, ``lam_max``]) instead of a
    dense O(m^3) eigensolver: at m ~ 8600 (t_end = 3000, omega_max = 4.75) the dense one had not
    finished one chunk of four waves in 45 min (docs/rayleigh.md)."""
    from scipy.linalg import eigh_tridiagonal

    def z_of(m):
        if exact:  # a closed Krylov space: T_m is exact at every degree, the eigenpairs are needed
            theta, S = tridiagonal_eigen(alpha[:m], beta[:m - 1])
        else:
            try:
                theta, S = eigh_tridiagonal(np.asarray(alpha[:m], dtype=float), np.asarray(beta[:m - 1], dtype=float))
            except np.linalg.LinAlgError:
                return _z_chebyshev(alpha[:m], beta[:m - 1], w[:m], norm_a, times, lam_max)
        weights = (w[:m] @ S) * S[0]
        return norm_a * (weights @ cos_sqrt(theta, times))

    refuse_unstable(alpha[:size], beta[:size - 1], float(np.max(times)))
    z = z_of(size)
    if exact:
        return z, 0.0
    return z, (np.abs(z - z_of(size - 10)).max() / np.abs(z).max() if size > 20 else np.inf)


def _lanczos_pass(A, start, steps: int, floor: float, visit=None) -> tuple[list, list]:
    """``steps`` steps of the plain three-term recurrence from the PETSc vector ``start`` (unit
    length) on the symmetric ``A``: (alpha, beta) of T; ``visit(j, q)`` sees each basis vector q_j
    (a PETSc vector, valid during the call).  The same operations in the same order, so a second
    pass rebuilds the very same basis.  Stops early on an invariant subspace (|v| < ``floor``,
    the round-off of A q).  Collective."""
    q, v = A.createVecs()
    q_prev = q.duplicate()
    start.copy(q)
    q_prev.zeroEntries()
    alpha, beta = [], []
    try:
        for j in range(steps):
            if visit is not None:
                visit(j, q)
            A.mult(q, v)
            if beta:
                v.axpy(-beta[-1], q_prev)
            alpha.append(q.dot(v))
            v.axpy(-alpha[-1], q)
            nrm = v.norm()
            if j == steps - 1 or nrm < floor:
                break
            beta.append(nrm)
            q_prev, q, v = q, v, q_prev
            q.scale(1.0 / nrm)
    finally:
        for vec in (q, v, q_prev):
            vec.destroy()
    return alpha, beta


@profiling.logged("rsLanczosField")
def velocity_field(dm, positions, mode: str, run: int, k: float | np.ndarray, *, amplitude: float, times: np.ndarray,
                   tol: float = 1e-8, omega_max: float | None = None) -> tuple[np.ndarray, float]:
    """The whole velocity field of one standing wave (run ``run`` of ``mode`` at ``k``, as
    :func:`spectral` excites it) at ``times``: v(t) = M^-1/2 cos(sqrt(A) t) M^1/2 v(0), local rows
    (T, nloc), and its error estimate relative to max |v(0)|.  Collective.

    Lanczos in two passes: the first builds T_m, the second rebuilds the same basis and sums
    v(t) = |a| sum_j q_j [S cos(sqrt(Theta) t) S^T e_1]_j, with the coefficients of T_m and of
    its leading (m - 10) block side by side; their largest difference is the estimate, and m grows
    by a fifth until it is below ``tol`` (m starts at 0.7 omega_max t_max + 60: the vector needs
    the polynomial degree the bilinear form z needs, measured 0.55-0.7 omega_max t).  Symmetric
    matrices without dashpots only (the caller checks)."""
    from mpi4py import MPI

    mpi = dm.D.getComm().tompi4py()
    times = np.asarray(times, dtype=float)
    component, axis = runs(mode, dm.dim)[run]
    s = 1.0 / np.sqrt(dm.M.getArray())
    v0 = start_velocity(dm, positions, component, axis, k, amplitude, mpi)
    a = v0 / s
    norm_a = float(np.sqrt(mpi.allreduce(float(a @ a))))
    largest = mpi.allreduce(float(np.abs(v0).max(initial=0.0)), op=MPI.MAX)
    A = operator(dm)
    start = A.createVecRight()
    start.setArray(a / norm_a)
    omega_max = largest_omega(dm) if omega_max is None else omega_max
    steps = int(np.ceil(0.7 * omega_max * times.max())) + 60
    try:
        while True:
            alpha, beta = _lanczos_pass(A, start, steps, 1e-13 * omega_max**2)
            m = len(alpha)
            refuse_unstable(alpha, beta[:m - 1], float(times.max()))  # alpha, beta: the same on every rank
            coefficients = []
            for size in (m, max(m - 10, 1)):
                theta, S = tridiagonal_eigen(alpha[:size], beta[:size - 1])
                c = np.zeros((len(times), m))
                c[:, :size] = norm_a * (cos_sqrt(theta, times).T * S[0]) @ S.T
                coefficients.append(c)
            fields = np.zeros((2, len(times), len(a)))

            def visit(j, q):
                local = q.getArray(readonly=True)
                for f, c in zip(fields, coefficients):
                    f += np.outer(c[:, j], local)

            _lanczos_pass(A, start, m, 1e-13 * omega_max**2, visit)
            difference = np.abs(fields[0] - fields[1]) * s
            estimate = mpi.allreduce(float(difference.max(initial=0.0)), op=MPI.MAX) / largest
            if estimate < tol or m < steps:  # converged, or an invariant subspace (T exact)
                return fields[0] * s, (0.0 if m < steps else estimate)
            steps = int(1.2 * steps)
    finally:
        start.destroy()
