"""Operators built from the dynamical matrix D and the mass vector M (the paper's eq:motion
M u'' = -D u), shared by the spectrum, the KPM vDOS and the standing waves.

    A = M^-1/2 D M^-1/2           (symmetric standard form: eigenvalues omega^2 of M^-1 D)
    C^ = M^-1/2 C M^-1/2          (the dashpots' damping matrix in the same form)
    omega_max = sqrt(lambda_max(A))  (Lanczos, SLEPc EPS with options prefix ``wmax_``)
    J = [[0, I], [-M^-1 D, -M^-1 C]]  (first-order form X' = J X of eq:motion, X = (u, v);
                                       C the dashpots' damping matrix, docs/damping.md, if any)
    c_max = lambda_max(M^-1/2 C M^-1/2)  (the fastest damping rate, for step limits)

Collective on the matrix's communicator.  Units: omega in 1/t0.
"""

from __future__ import annotations

import numpy as np

from .. import profiling
from ..options import eps_settings

WMAX_PREFIX = "wmax_"


def _mass_scaled(dm, mat, symmetric: bool):
    """M^-1/2 ``mat`` M^-1/2 as a new PETSc Mat, flagged ``symmetric``. Collective."""
    from petsc4py import PETSc

    scale = dm.M.copy()
    scale.sqrtabs()
    scale.reciprocal()
    out = mat.copy()
    out.diagonalScale(scale, scale)
    out.setOption(PETSc.Mat.Option.SYMMETRIC, symmetric)
    out.setOption(PETSc.Mat.Option.SYMMETRY_ETERNAL, True)
    scale.destroy()
    return out


def scaled_operator(dm):
    """A = M^-1/2 D M^-1/2 as a new PETSc Mat (flagged symmetric when D is). Collective."""
    return _mass_scaled(dm, dm.D, dm.symmetric)


def scaled_damping(dm):
    """C^ = M^-1/2 C M^-1/2 of the dashpots' C (``dm.C``) as a new PETSc Mat. Collective."""
    return _mass_scaled(dm, dm.C, True)


def largest_eigenvalue(A, symmetric: bool) -> tuple[complex, dict]:
    """(lambda, settings): the eigenvalue of largest real part (symmetric ``A``) or magnitude of
    ``A`` by SLEPc (options prefix ``wmax_``: Krylov-Schur, tol 1e-8 as defaults in code, then
    ``-wmax_eps_*``), and what the EPS used. Collective."""
    from slepc4py import SLEPc

    eps = SLEPc.EPS().create(A.getComm())
    try:
        eps.setOperators(A)
        eps.setProblemType(SLEPc.EPS.ProblemType.HEP if symmetric else SLEPc.EPS.ProblemType.NHEP)
        eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_REAL if symmetric else SLEPc.EPS.Which.LARGEST_MAGNITUDE)
        eps.setDimensions(nev=1)
        eps.setTolerances(tol=1e-8)
        eps.setOptionsPrefix(WMAX_PREFIX)
        eps.setFromOptions()
        eps.solve()
        if eps.getConverged() < 1:
            raise RuntimeError("could not compute the largest eigenvalue (wmax_ EPS did not converge)")
        return eps.getEigenvalue(0), {**eps_settings(eps), "iterations": eps.getIterationNumber()}
    finally:
        eps.destroy()


@profiling.logged("rsOmegaMax")
def largest_omega(dm) -> float:
    """omega_max of M^-1 D by a cheap Lanczos solve, cached on ``dm``. Collective.

    What the ``wmax_`` EPS used is kept in ``dm.wmax_settings``.  A non-symmetric D (a stressed
    packing) has complex omega^2 in general: then the eigenvalue of largest magnitude
    (non-Hermitian problem), omega_max = sqrt(|lambda|), the scale a time step must resolve.
    """
    if dm.omega_max is not None:
        return dm.omega_max
    A = scaled_operator(dm)
    try:
        lam, dm.wmax_settings = largest_eigenvalue(A, dm.symmetric)
    finally:
        A.destroy()
    dm.omega_max = float(np.sqrt(lam.real if dm.symmetric else abs(lam)))
    return dm.omega_max


def largest_damping_rate(dm) -> float:
    """c_max = lambda_max(M^-1/2 C M^-1/2) (1/t0) of the dashpots' C (``dm.C``; 0 without),
    cached on ``dm``.  Every damped mode lambda of M lambda^2 + C lambda + D (symmetric D) lies in
    the left half-disk |lambda| <= max(omega_max, c_max): with x^H M x = 1, lambda^2 + c lambda + k
    = 0, c = x^H C x in [0, c_max], k = x^H D x in [0, omega_max^2].  Collective."""
    if dm.C is None:
        return 0.0
    if dm.damping_max is None:
        scaled = scaled_damping(dm)
        try:
            lam, _ = largest_eigenvalue(scaled, True)
        finally:
            scaled.destroy()
        dm.damping_max = float(lam.real)
    return dm.damping_max


def first_order_matrix(dm, minv):
    """J = [[0, I], [-M^-1 D, -M^-1 C]] (AIJ; C = ``dm.C``, the dashpots, if any) on the state
    X = (u_loc, v_loc) laid out per rank.

    ``minv``: the PETSc Vec M^-1.  Rank r owns rows [2 s_r, 2 e_r) of X, where [s_r, e_r) are
    its rows of D: first its u, then its v.  X' = J X is the first-order form of eq:motion.
    Collective.
    """
    import scipy.sparse as sp
    from petsc4py import PETSc

    comm = dm.D.getComm()
    ranges = np.array(dm.D.getOwnershipRanges())
    start, stop = dm.D.getOwnershipRange()
    nloc = stop - start
    indptr, indices, values = dm.D.getValuesCSR()
    owner = np.searchsorted(ranges, indices, side="right") - 1
    u_col = indices + ranges[owner]             # global column of u_g in X
    rows_v = sp.csr_matrix((-np.repeat(minv.getArray(), np.diff(indptr)) * values, u_col, indptr),
                           shape=(nloc, 2 * dm.size))
    if dm.C is not None:  # v' = ... - M^-1 C v: C's column g is v_g, after its owner's u block in X
        c_ptr, c_indices, c_values = dm.C.getValuesCSR()
        c_owner = np.searchsorted(ranges, c_indices, side="right") - 1
        v_col = c_indices + ranges[c_owner] + np.diff(ranges)[c_owner]
        rows_v = rows_v + sp.csr_matrix((-np.repeat(minv.getArray(), np.diff(c_ptr)) * c_values, v_col, c_ptr),
                                        shape=(nloc, 2 * dm.size))
    v_cols = 2 * start + nloc + np.arange(nloc)  # u' = v
    rows_u = sp.csr_matrix((np.ones(nloc), v_cols, np.arange(nloc + 1)), shape=(nloc, 2 * dm.size))
    # explicit zero diagonal: TS forms shift I - J in place (MatShift needs the entries)
    diagonal = sp.coo_matrix((np.zeros(2 * nloc), (np.arange(2 * nloc), 2 * start + np.arange(2 * nloc))),
                             shape=(2 * nloc, 2 * dm.size))
    stacked = sp.vstack([rows_u, rows_v]).tocoo()
    local = sp.coo_matrix((np.concatenate((stacked.data, diagonal.data)),
                           (np.concatenate((stacked.row, diagonal.row)),
                            np.concatenate((stacked.col, diagonal.col)))), shape=stacked.shape).tocsr()
    local.sort_indices()
    J = PETSc.Mat().createAIJ(size=((2 * nloc, 2 * dm.size),) * 2,
                              csr=(local.indptr.astype(PETSc.IntType), local.indices.astype(PETSc.IntType),
                                   local.data), comm=comm)
    J.assemble()
    return J
