"""Eigenfrequencies (and per-mode energies) of the dynamical matrix with SLEPc.

Problem [decision]: the symmetric standard form A e = omega^2 e, A = M^-1/2 D M^-1/2.  It has
the same sparsity as D, orthonormal eigenvectors (so K and Q are plain sums of squares,
see ``modes``), and the Cholesky inertia of A - sigma I that spectrum slicing needs; the
generalised form with a diagonal M offers nothing more.

Method: Krylov-Schur spectrum slicing (EPS ``which=ALL`` on an interval, shift-and-invert
with a MUMPS Cholesky factorisation; the matrix is flagged symmetric and MUMPS ICNTL(13)=1
so that parallel inertias are right).  The interval starts at lambda_lo = zero_tol^2 > 0:
zero modes (the two translations) then lie below the first shift and never make a
factorisation singular; their number is the inertia at lambda_lo, and modes below
-lambda_lo (an unstable packing) are counted separately.  The full interval ends at
||A||_inf >= lambda_max (Gershgorin).

Bounded memory: slicing keeps every eigenvector of its interval, so the interval is cut into
windows of at most ``max_window_modes`` modes, placed from inertias at a few trial shifts
(linear interpolation of the eigenvalue count), and solved one after another; each window's
vectors are reduced to K, Q and the participation ratio and freed.  This also keeps
n x nconv below 2^31 for the 32-bit-index PETSc build.  On p ranks each window is split
into p sub-intervals with equal mode counts (``-eps_krylovschur_partitions``), each solved
by one rank with a sequential factorisation.

Options: the EPS has no prefix, so ``-eps_*``, ``-st_*``, ``-mat_mumps_*`` work from the
scene's ``petsc:`` block and the command line (set in code first, then setFromOptions).
Units: omega in 1/t0.  Collective on the matrix's communicator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import modes

INT32_LIMIT = 2**31 - 1


@dataclass
class Spectrum:
    """Result for one matrix: ascending omega (M,), zero-mode count, checks, optional energies."""

    omega: np.ndarray
    n_zero_modes: int
    n_negative: int
    max_residual: float
    inertia_count: int
    windows: int
    energies: dict | None = None


def scaled_operator(dm):
    """A = M^-1/2 D M^-1/2 as a new PETSc Mat (flagged symmetric). Collective."""
    from petsc4py import PETSc

    scale = dm.M.copy()
    scale.sqrtabs()
    scale.reciprocal()
    A = dm.D.copy()
    A.diagonalScale(scale, scale)
    A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    A.setOption(PETSc.Mat.Option.SYMMETRY_ETERNAL, True)
    scale.destroy()
    return A


def count_below(A, sigma: float) -> int:
    """Number of eigenvalues of A below ``sigma`` (Sylvester inertia of A - sigma I). Collective."""
    from petsc4py import PETSc

    shifted = A.copy()
    shifted.shift(-sigma)
    shifted.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    pc = PETSc.PC().create(A.getComm())
    pc.setOperators(shifted)
    pc.setType(PETSc.PC.Type.CHOLESKY)
    pc.setFactorSolverType("mumps")
    pc.setFactorSetUpSolverType()
    factor = pc.getFactorMatrix()
    factor.setMumpsIcntl(13, 1)  # inertia must include the root node on several ranks
    factor.setMumpsIcntl(24, 1)  # detect null pivots instead of failing
    pc.setUp()
    negative, _, _ = factor.getInertia()
    pc.destroy()
    shifted.destroy()
    return int(negative)


def plan_windows(A, lo: float, hi: float, max_modes: int, parts: int
                 ) -> tuple[list[list[float]], int, int]:
    """Cut (lo, hi] into windows of about equal mode count (<= max_modes each), and each
    window into ``parts`` sub-intervals of about equal count (one per rank).

    Counts between trial shifts are interpolated linearly from Sylvester inertias.
    Returns (list of sub-interval edges per window, count below lo, count below hi). Collective.
    """
    below_lo, below_hi = count_below(A, lo), count_below(A, hi)
    total = below_hi - below_lo
    windows = max(1, -(-total // max_modes))
    pieces = windows * parts
    if pieces == 1:
        return [[lo, hi]], below_lo, below_hi
    trial = np.linspace(lo, hi, 2 * pieces + 1)
    counts = np.array([below_lo] + [count_below(A, s) for s in trial[1:-1]] + [below_hi], dtype=float)
    targets = below_lo + total * np.arange(1, pieces) / pieces
    cuts = np.concatenate(([lo], np.interp(targets, counts, trial), [hi]))  # counts non-decreasing
    plan = [list(cuts[w * parts:(w + 1) * parts + 1]) for w in range(windows)]
    return [list(np.unique(edges)) if len(np.unique(edges)) > 1 else [edges[0], edges[-1]]
            for edges in plan], below_lo, below_hi


def _configure(eps, A, edges, tol):
    from petsc4py import PETSc
    from slepc4py import SLEPc

    eps.setOperators(A)
    eps.setProblemType(SLEPc.EPS.ProblemType.HEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.ALL)
    eps.setInterval(edges[0], edges[-1])
    eps.setTolerances(tol=tol)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    ksp = st.getKSP()
    ksp.setType(PETSc.KSP.Type.PREONLY)
    pc = ksp.getPC()
    pc.setType(PETSc.PC.Type.CHOLESKY)
    pc.setFactorSolverType("mumps")
    if len(edges) > 2:
        eps.setKrylovSchurPartitions(len(edges) - 1)
        eps.setKrylovSchurSubintervals(edges)
    options = PETSc.Options()
    # The solver type must also sit in the options database: eps.setFromOptions() otherwise
    # resets it to PETSc's own Cholesky (measured: 12x slower factorisations at N = 32768).
    for name, value in (("st_pc_factor_mat_solver_type", "mumps"),
                        ("st_mat_mumps_icntl_13", "1"), ("st_mat_mumps_icntl_24", "1")):
        if not options.hasName(name):
            options.setValue(name, value)
    eps.setFromOptions()


def solve(dm, *, window: tuple[float, float] | None, vectors: bool, tol: float = 1e-12,
          zero_tol: float = 1e-4, max_window_modes: int = 2000, progress=None) -> Spectrum:
    """Eigenfrequencies of ``dm`` (a :class:`~solver.dynmat.DynamicalMatrix`). Collective.

    window : (omega_lo, omega_hi) in 1/t0, or None for the full spectrum above ``zero_tol``.
    vectors : also compute K_x, K_y, Q, K and the participation ratio per mode.
    progress : optional callable(windows_done, windows, modes_so_far), called on every rank
        after each window (long full spectra take hours: it lets the caller report how far).
    Raises RuntimeError on every rank if the count disagrees with the inertia.
    """
    from petsc4py import PETSc
    from slepc4py import SLEPc

    comm = dm.D.getComm()
    A = scaled_operator(dm)
    n = A.getSize()[0]
    lam_zero = zero_tol**2
    lo = lam_zero if window is None else max(window[0] ** 2, lam_zero)
    hi = A.norm(PETSc.NormType.INFINITY) * (1 + 1e-9) if window is None else window[1] ** 2
    max_modes = max(1, min(max_window_modes, INT32_LIMIT // (2 * n)))
    plan, below_lo, below_hi = plan_windows(A, lo, hi, max_modes, comm.size)
    n_zero = count_below(A, lam_zero) if window is not None else below_lo
    n_negative = count_below(A, -lam_zero)
    omegas, sums, residual = [], [], 0.0
    for edges in plan:
        eps = SLEPc.EPS().create(comm)
        _configure(eps, A, edges, tol)
        eps.solve()
        nconv = eps.getConverged()
        lam = np.empty(nconv)
        vec = A.createVecRight()
        local = np.empty((nconv, vec.getLocalSize())) if vectors else None
        for i in range(nconv):
            lam[i] = eps.getEigenpair(i, vec).real
            residual = max(residual, eps.computeError(i, SLEPc.EPS.ErrorType.RELATIVE))
            if vectors:
                local[i] = vec.getArray()
        if vectors:
            sums.append(comm.tompi4py().allreduce(modes.local_sums(local, dm.dof)))
        omegas.append(np.sqrt(lam))
        vec.destroy()
        eps.destroy()
        if progress is not None:
            progress(len(omegas), len(plan), sum(o.size for o in omegas))
    A.destroy()
    order = np.argsort(np.concatenate(omegas), kind="stable")
    omega = np.concatenate(omegas)[order]
    if omega.size != below_hi - below_lo:
        raise RuntimeError(f"spectrum: {omega.size} eigenvalues converged in the interval but the "
                           f"inertia counts {below_hi - below_lo}")
    energies = None
    if vectors:
        energies = {k: v[order] for k, v in modes.energies(np.concatenate(sums), int(dm.active.sum())).items()}
    return Spectrum(omega, n_zero, n_negative, residual, below_hi - below_lo, len(plan), energies)
