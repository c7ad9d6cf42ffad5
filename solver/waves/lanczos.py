"""Lanczos from standing-wave starts, shared by the paths without time steps that read z(t)
(``spectral``: the bilinear form b^H cos(sqrt(A) t) a) and the start's own autocorrelation
(``quadrature``: the quadratic form a^T cos(sqrt(A) t) a): the start block a = M^1/2 v(0) of a
chunk of waves, W plain three-term recurrences on A = M^-1/2 D M^-1/2 side by side
(:class:`Recurrences`), and the eigenpairs of their tridiagonal matrices.
Collective on the matrix's communicator where a function says so.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import numpy as np

from .. import parallel
from ..model.operators import scaled_operator
from .excitation import runs, start_velocity


def scaled_starts(dm, positions, waves: list[tuple[str, int, float]], amplitude: float, mpi) -> tuple[np.ndarray, np.ndarray]:
    """(a (nloc, W), |a| (W,)): a = M^1/2 v(0) of each wave (mode, run of
    ``excitation.runs(mode, dm.dim)``, k) (``excitation.start_velocity``), Fortran order, and its
    global norms.  ``mpi``: the matrix's mpi4py communicator.  Collective."""
    from mpi4py import MPI

    s = 1.0 / np.sqrt(dm.M.getArray())
    a = np.asfortranarray(np.stack([start_velocity(dm, positions, *runs(mode, dm.dim)[run], k, amplitude, mpi) / s
                                    for mode, run, k in waves], axis=1))
    return a, np.sqrt(mpi.allreduce(np.einsum("iw,iw->w", a, a), op=MPI.SUM))


def operator(dm):
    """A = M^-1/2 D M^-1/2 of ``dm``, made once and kept on it (``dm.scaled``). Collective the first time."""
    if dm.scaled is None:
        dm.scaled = scaled_operator(dm)
    return dm.scaled


class Recurrences:
    """W plain three-term Lanczos recurrences on the symmetric PETSc matrix ``A`` side by side,
    from the columns of ``starts`` (nloc, W), each of unit global length: one MatMatMult of A
    with the (nloc, W) block of their current vectors per step (its symbolic product made once),
    one reduction for every recurrence's alpha and read-outs, one for their norms.  ``read_outs``:
    real (nloc, W) blocks r whose projections r_w . q_j on each basis vector are accumulated on
    the way (in the alpha reduction).  A recurrence whose |v| falls below ``floor`` (the round-off
    of A q) has closed its Krylov space: T is exact from then on, its vector becomes 0 and stays 0.
    Memory: (3 + len(read_outs)) (nloc, W) blocks and the product.  Loss of orthogonality is not
    corrected (``spectral`` says why).  :meth:`extend` is collective; :meth:`destroy` frees the
    PETSc objects (the owner calls it in a ``finally``)."""

    def __init__(self, A, starts: np.ndarray, read_outs: tuple[np.ndarray, ...], floor: float):
        from petsc4py import PETSc

        nloc, self.count = starts.shape
        self.A, self.read_outs, self.floor = A, read_outs, floor
        self.mpi = A.getComm().tompi4py()
        self.X = PETSc.Mat().createDense(((nloc, A.getSize()[0]), (PETSc.DECIDE, self.count)),
                                         array=np.zeros((nloc, self.count), order="F"), comm=A.getComm())
        self.X.assemble()
        self.Y = None
        self.q = self.X.getDenseArray()  # the current vectors, in the product's own storage
        self.q[...] = starts
        self.q_prev = np.zeros_like(self.q, order="F")
        self.alpha, self.beta = [], []  # per step: (W,) each
        self.read = [[] for _ in read_outs]  # per read-out, per step: (W,)
        self.length = np.full(self.count, -1)  # steps of a recurrence whose Krylov space closed, -1 while open

    @property
    def steps(self) -> int:
        return len(self.alpha)

    @property
    def closed(self) -> np.ndarray:
        """(W,) bool: the recurrences whose Krylov space closed (their T is exact)."""
        return self.length >= 0

    def extend(self, m_target: int) -> None:
        """Steps until ``m_target`` (or until every Krylov space has closed). Collective."""
        from mpi4py import MPI

        count, q, q_prev = self.count, self.q, self.q_prev
        while self.steps < m_target:
            self.Y = self.A.matMult(self.X) if self.Y is None else self.A.matMult(self.X, self.Y)
            v = self.Y.getDenseArray()
            if self.beta:
                v -= self.beta[-1] * q_prev
            local = np.concatenate([np.einsum("iw,iw->w", q, v)] + [np.einsum("iw,iw->w", r, q) for r in self.read_outs])
            dots = np.empty_like(local)
            self.mpi.Allreduce(local, dots, op=MPI.SUM)  # buffers, not pickles: a step's fixed cost
            self.alpha.append(dots[:count])
            for i, read in enumerate(self.read):
                read.append(dots[(i + 1) * count:(i + 2) * count])
            v -= self.alpha[-1] * q
            nrm = np.einsum("iw,iw->w", v, v)
            self.mpi.Allreduce(MPI.IN_PLACE, nrm, op=MPI.SUM)
            np.sqrt(nrm, out=nrm)
            self.length[(nrm < self.floor) & (self.length < 0)] = self.steps
            if np.all(self.closed):
                return
            done = self.closed  # a closed recurrence's vector becomes 0 and stays 0 (beta 0, never read)
            nrm[done] = 0.0
            self.beta.append(nrm)
            np.copyto(q_prev, q)
            np.divide(v, np.where(done, 1.0, nrm), out=q)
            q[:, done] = 0.0

    def tridiagonals(self) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
        """(alpha (m, W), beta (m' , W) with m' = m or m - 1, read-outs [(m, W)]) so far."""
        return (np.array(self.alpha), np.array(self.beta).reshape(-1, self.count),
                [np.array(read) for read in self.read])

    def size(self, wave: int) -> int:
        """The steps of T that count for recurrence ``wave``: its closing step, else all."""
        return int(self.length[wave] if self.length[wave] >= 0 else self.steps)

    def converge(self, m_target: int, tol: float, evaluate) -> tuple[list, list[int]]:
        """Steps from ``m_target``, grown by a fifth, until every recurrence's estimate is below
        ``tol`` or every Krylov space has closed: ``evaluate(alpha, beta, read_outs, sizes, closed)``
        (:meth:`tridiagonals`, :meth:`size` of each, :attr:`closed`) -> [(value, estimate)] per
        recurrence, run on rank 0 and broadcast, so every rank takes the same branch.  Returns
        (that list, sizes).  Collective."""
        while True:
            self.extend(m_target)
            sizes, closed = [self.size(i) for i in range(self.count)], self.closed
            results = parallel.owner_compute(self.mpi, [0], lambda _: evaluate(*self.tridiagonals(), sizes, closed))[0]
            if all(estimate < tol for _, estimate in results) or np.all(closed):
                return results, sizes
            m_target = int(1.2 * m_target)

    def destroy(self) -> None:
        self.X.destroy()
        if self.Y is not None:
            self.Y.destroy()


def cos_sqrt(theta: np.ndarray, times: np.ndarray) -> np.ndarray:
    """(len(theta), len(times)): cos(sqrt(theta) t), continued as cosh(sqrt(-theta) t) for theta < 0
    (cos(t sqrt(lambda)) is an entire function of lambda: the linear dynamics of a direction of
    negative curvature, which a marginal packing near jamming can hold, and the same function the
    Chebyshev path expands).  Not collective."""
    theta = np.asarray(theta, dtype=float)
    root = np.sqrt(np.abs(theta))
    out = np.cos(np.outer(root, times))
    negative = theta < 0
    out[negative] = np.cosh(np.outer(root[negative], times))
    return out


def refuse_unstable(alpha, beta, t_end: float) -> None:
    """Raise RuntimeError when the m x m tridiagonal T (diagonal ``alpha`` (m,), off-diagonal
    ``beta`` (m - 1,)) has a Ritz value theta < 0 along which the linear dynamics grows by more than
    e within ``t_end``: sqrt(-theta) t_end > 1 (T's lowest eigenvalue by bisection, O(m)).  Such a
    packing is not at an energy minimum (FIRE stopped near a saddle: measured near jamming at
    force_tol 1e-6, docs/crossover.md), and its waves would be the instability's.  Not collective."""
    from scipy.linalg import eigvalsh_tridiagonal

    alpha = np.asarray(alpha, dtype=float)
    low = (eigvalsh_tridiagonal(alpha, np.asarray(beta, dtype=float), select="i", select_range=(0, 0),
                                lapack_driver="stebz")[0] if alpha.size > 1 else alpha[0])
    if low < 0 and np.sqrt(-low) * t_end > 1.0:
        raise RuntimeError(f"waves: the matrix has a direction of negative curvature (Ritz value {low:.3g}/t0^2): "
                           f"a wave grows along it by e^{np.sqrt(-low) * t_end:.1f} within t_end = {t_end:g} t0; "
                           f"the packing is not at an energy minimum: minimise it further (a smaller "
                           f"packing.force_tol, or packing.relax with a packing file)")


def tridiagonal_eigen(alpha, beta) -> tuple[np.ndarray, np.ndarray]:
    """(theta, S): the eigenpairs of the symmetric tridiagonal T with diagonal ``alpha`` (m,) and
    off-diagonal ``beta`` (m - 1,).  MRRR (O(m^2)); it can fail on the clustered Ritz values that
    lost orthogonality makes, and T is then diagonalised densely."""
    from scipy.linalg import eigh_tridiagonal

    alpha, beta = np.asarray(alpha, dtype=float), np.asarray(beta, dtype=float)
    try:
        return eigh_tridiagonal(alpha, beta)
    except np.linalg.LinAlgError:
        return np.linalg.eigh(np.diag(alpha) + np.diag(beta, 1) + np.diag(beta, -1))
