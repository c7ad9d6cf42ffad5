"""Standing waves without time stepping: z(t) = b^H cos(sqrt(A) t) a by Lanczos (the model,
eq:motion, is linear).  See :func:`spectral`.  Collective on the matrix's communicator.
Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import numpy as np

from .. import profiling
from ..model.operators import largest_omega, scaled_operator
from .excitation import channel, runs, start_velocity
from .sampling import WaveSeries


@profiling.logged("rsLanczosWave")
def spectral(dm, positions, mode: str, run: int, k: float, *, amplitude: float, times: np.ndarray,
             tol: float = 1e-8, omega_max: float | None = None) -> WaveSeries:
    """A standing wave without time stepping: z(t) = b^H cos(sqrt(A) t) a by Lanczos, for run
    ``run`` of ``excitation.runs(mode, dm.dim)``. Collective.

    With r_i(0) in the phase the dynamics is exactly linear (PHYSICS.md section 4):
    a = M^1/2 v0, b = M^-1/2 (exp(i k r_i(0)) in the channel), A = M^-1/2 D M^-1/2.  m Lanczos
    steps from a give A ~ Q T Q^T; w = Q^T b is accumulated on the way (one dot per step), so
    z(t) = |a| sum_j (w . s_j) s_j[0] cos(sqrt(theta_j) t) over the eigenpairs of T.
    Loss of orthogonality: none is corrected, on purpose.  The plain three-term recurrence keeps
    three vectors (memory O(n), cost one MatMult and two reductions per step); in floating point its
    basis loses orthogonality and T grows spurious copies of converged Ritz values, but the
    Lanczos approximation |a| Q f(T) e_1 of f(A) a stays as accurate as the best polynomial
    approximation of f on a slightly enlarged spectral interval (Musco, Musco & Sidford, SODA
    2018), and |b^H (f(A) a - approx)| <= |b| |f(A) a - approx|, so the bilinear form inherits
    that bound.  Full reorthogonalisation costs m^2 n: it measured 23x slower at N = 8192
    (8 waves to t = 200: 89.6 s against 3.9 s) for the same answer.
    Steps: z is a bilinear form, so T_m must resolve cos(sqrt(lambda) t) as a polynomial of
    degree m - 1 (not 2m - 1 as a Gauss quadrature would): start at omega_max t_end / 2 + 40 and
    grow by a fifth until z from T_m and from its leading (m - 10) block agree to ``tol``
    relative -- the error estimate that is reported.  (Measured: 0.55-0.7 omega_max t_end steps
    reach 1e-8 for t_end = 100-300.)
    Returns samples at ``times`` with z = z_fixed (the r_i(t) phase needs the trajectory) and a
    constant energy (exactly conserved).
    """
    from mpi4py import MPI
    from scipy.linalg import eigh_tridiagonal

    from .. import parallel

    mpi = dm.D.getComm().tompi4py()
    component, axis = runs(mode, dm.dim)[run]
    s = 1.0 / np.sqrt(dm.M.getArray())
    v0 = start_velocity(dm, positions, component, axis, k, amplitude, mpi)
    a = v0 / s
    b = channel(dm, positions, component, axis, k) * s  # z = b^H v = (M^-1/2 b)^H (M^1/2 v)
    if dm.scaled is None:
        dm.scaled = scaled_operator(dm)
    A = dm.scaled
    # PETSc vectors: one MatMult and two reductions per step (alpha with b.q, then |v|)
    q, v = A.createVecs()
    q_prev = q.duplicate()
    b_local = np.ascontiguousarray(np.stack([b.real, b.imag]))
    sq = mpi.allreduce(float(a @ a), op=MPI.SUM)
    norm_a, energy = np.sqrt(sq), 0.5 * sq
    if omega_max is None:
        omega_max = largest_omega(dm)
    m_target = int(np.ceil(0.5 * omega_max * times[-1])) + 40
    q.setArray(a / norm_a)
    q_prev.zeroEntries()
    alpha, beta, w = [], [], []
    exhausted = False
    while True:
        while len(alpha) < m_target:
            A.mult(q, v)
            if beta:
                v.axpy(-beta[-1], q_prev)
            local = q.getArray(readonly=True)
            dots = np.empty(3)  # q.v and b^H q (as its real and imaginary parts) in one reduction
            mpi.Allreduce(np.array([local @ v.getArray(readonly=True), *(b_local @ local)]), dots, op=MPI.SUM)
            alpha.append(float(dots[0]))
            w.append(complex(dots[1], -dots[2]))
            v.axpy(-alpha[-1], q)
            nrm = v.norm()
            # invariant subspace found, T is exact: |v| at the round-off of A q (~1e-16 ||A||,
            # ||A|| = omega_max^2); relative to the last alpha, a small one missed it
            if nrm < 1e-13 * omega_max**2:
                exhausted = True
                break
            beta.append(nrm)
            q_prev, q, v = q, v, q_prev  # rotate the three vectors, no copies
            q.scale(1.0 / nrm)
        m = len(alpha)

        def z_of(size):
            a, b_ = np.array(alpha[:size]), np.array(beta[:size - 1])
            try:  # MRRR: O(size^2); it can fail on the clustered Ritz values lost orthogonality makes
                theta, S = eigh_tridiagonal(a, b_)
            except np.linalg.LinAlgError:
                theta, S = np.linalg.eigh(np.diag(a) + np.diag(b_, 1) + np.diag(b_, -1))
            weights = (np.array(w[:size]) @ S) * S[0]
            return norm_a * (weights @ np.cos(np.outer(np.sqrt(np.clip(theta, 0, None)), times)))

        def evaluate():
            z = z_of(m)
            return z, 0.0 if exhausted else (np.abs(z - z_of(m - 10)).max() / np.abs(z).max() if m > 20 else np.inf)

        # rank 0 evaluates and broadcasts, so every rank takes the same branch below
        z, estimate = parallel.owner_compute(mpi, [0], lambda _: evaluate())[0]
        if estimate < tol or exhausted:
            break
        m_target = int(1.2 * m_target)
    for vec in (q, v, q_prev):
        vec.destroy()
    settings = {"method": "lanczos", "tol": tol, "steps": m, "omega_max": omega_max}
    return WaveSeries(np.asarray(times), z, z, np.full(len(times), energy), m, float(estimate), settings)
