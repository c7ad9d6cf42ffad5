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
-lambda_lo (an unstable packing) are counted separately.  The full interval ends just above
the Lanczos estimate of lambda_max, checked by the inertia there (Gershgorin ||A||_inf if it
misses any mode).  Eigenvalues are Rayleigh quotients of the converged vectors.

Bounded memory: slicing keeps every eigenvector of its interval, so the interval is cut into
windows of at most ``max_window_modes`` modes, placed from Sylvester inertias (refined until
every cut is known to a quarter of a window piece), and solved one after another; each window's
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


def largest_omega(dm) -> float:
    """omega_max of M^-1 D by a cheap SLEPc solve (prefix ``wmax_``), cached on ``dm``. Collective."""
    from slepc4py import SLEPc

    if dm.omega_max is not None:
        return dm.omega_max
    A = scaled_operator(dm)
    eps = SLEPc.EPS().create(A.getComm())
    eps.setOperators(A)
    eps.setProblemType(SLEPc.EPS.ProblemType.HEP)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_REAL)
    eps.setDimensions(nev=1)
    eps.setTolerances(tol=1e-8)
    eps.setOptionsPrefix("wmax_")
    eps.setFromOptions()
    eps.solve()
    if eps.getConverged() < 1:
        raise RuntimeError("could not compute the largest eigenfrequency (wmax_ EPS did not converge)")
    lam = eps.getEigenvalue(0).real
    eps.destroy()
    A.destroy()
    dm.omega_max = float(np.sqrt(lam))
    return dm.omega_max


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
    factor.destroy()  # the wrapper holds a reference: without this each call leaked the factor
    pc.destroy()
    shifted.destroy()
    return int(negative)


def plan_windows(A, lo: float, hi: float, max_modes: int, parts: int
                 ) -> tuple[list[list[float]], int, int]:
    """Cut (lo, hi] into windows of at most ~``max_modes`` modes, each window into ``parts``
    sub-intervals (one per rank) of about equal count.

    Cut points come from Sylvester inertias, refined where needed: the count between two known
    shifts is interpolated linearly only once it is below a quarter of a piece (new shifts are
    placed by safeguarded interpolation, about three factorisations per cut), so a steep vDOS
    cannot put several times the intended modes into one window (it once did at the low end of
    an N = 32768 spectrum, and the run ran out of memory).  Collective; every rank makes the same
    choices, since inertias are global.  Returns (sub-interval edges per window, count below lo,
    count below hi).
    """
    known = {lo: count_below(A, lo), hi: count_below(A, hi)}
    below_lo, below_hi = known[lo], known[hi]
    total = below_hi - below_lo
    windows = max(1, -(-total // max_modes))
    pieces = windows * parts
    if pieces == 1:
        return [[lo, hi]], below_lo, below_hi
    step = total / pieces
    targets = below_lo + step * np.arange(1, pieces)
    slack, min_width = max(1.0, step / 4), 1e-12 * max(abs(hi), 1.0)
    while True:
        xs = np.array(sorted(known))
        cs = np.array([known[x] for x in xs], dtype=float)
        right = np.searchsorted(cs, targets, side="right")  # cs[right - 1] <= target < cs[right]
        new = set()
        for r, t in zip(right, targets):
            x0, x1, c0, c1 = xs[r - 1], xs[r], cs[r - 1], cs[r]
            if c1 - c0 > slack and x1 - x0 > min_width:
                frac = min(max((t - c0) / (c1 - c0), 0.1), 0.9)  # safeguard: always shrink
                new.add(float(x0 + frac * (x1 - x0)))
        if not new:
            break
        for x in sorted(new):
            known[x] = count_below(A, x)
    cuts = [lo] + [float(xs[r - 1] + (t - cs[r - 1]) / (cs[r] - cs[r - 1]) * (xs[r] - xs[r - 1]))
                   for r, t in zip(right, targets)] + [hi]
    plan = [cuts[w * parts:(w + 1) * parts + 1] for w in range(windows)]
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


def _solve_window(A, edges, tol: float, vectors: bool, dof: int) -> dict:
    """Eigenvalues (and reduced K/Q sums) of one window. Collective; same result on every rank.

    Returns {"lam": (M,), "sums": (M, 4) or (0, 4), "residual": max relative residual}.
    Each eigenvalue is the Rayleigh quotient of its converged vector (one MatMult per mode):
    its error is ~ residual^2 / gap, where the back-transformed Ritz value carried errors up to
    the residual itself (omega off by 1e-8 relative at rho = 2, residuals 1e-7 from the shift at
    zero_tol^2 beside the zero modes; 1e-14 with the quotient).
    """
    from slepc4py import SLEPc

    comm = A.getComm()
    eps = SLEPc.EPS().create(comm)
    _configure(eps, A, edges, tol)
    eps.solve()
    nconv = eps.getConverged()
    lam, local, residual = np.empty(nconv), np.empty((nconv if vectors else 0, 4)), 0.0
    vec, image = A.createVecRight(), A.createVecLeft()
    for i in range(nconv):  # one vector at a time: no extra copy of the window's vectors
        eps.getEigenpair(i, vec)
        A.mult(vec, image)
        lam[i] = image.dot(vec) / vec.dot(vec)
        residual = max(residual, eps.computeError(i, SLEPc.EPS.ErrorType.RELATIVE))
        if vectors:
            local[i] = modes.local_sums(vec.getArray()[None, :], dof)[0]
    vec.destroy()
    image.destroy()
    eps.destroy()
    return {"lam": lam, "sums": comm.tompi4py().allreduce(local), "residual": np.float64(residual)}


def solve(dm, *, window: tuple[float, float] | None, vectors: bool, tol: float = 1e-12,
          zero_tol: float = 1e-4, max_window_modes: int = 2000, progress=None,
          checkpoint=None) -> Spectrum:
    """Eigenfrequencies of ``dm`` (a :class:`~solver.model.dynmat.DynamicalMatrix`). Collective.

    window : (omega_lo, omega_hi) in 1/t0, or None for the full spectrum above ``zero_tol``.
    vectors : also compute K_x, K_y, Q, K and the participation ratio per mode.
    progress : optional callable(windows_done, windows, modes_so_far), called on every rank
        after each window (long full spectra take hours: it lets the caller report how far;
        it may raise to stop, e.g. on SIGTERM: finished windows are already checkpointed).
    checkpoint : optional object with collective ``load(name) -> dict | None`` and
        ``save(name, dict)``: the window plan and every finished window are saved there and
        taken from there on a rerun, so a killed full spectrum resumes window by window.
    Raises RuntimeError on every rank if the count disagrees with the inertia.
    """
    from petsc4py import PETSc

    comm = dm.D.getComm()
    A = scaled_operator(dm)
    n = A.getSize()[0]
    lam_zero = zero_tol**2
    lo = lam_zero if window is None else max(window[0] ** 2, lam_zero)
    # Full spectrum: top of the band from the cheap Lanczos solve. A Ritz value never exceeds
    # lambda_max and is within 1e-8 of it, so 1e-6 above it is a safe bound; the Gershgorin bound
    # ||A||_inf is ~1.9 lambda_max, and slicing that empty top took 318 s instead of ~120 s for
    # the last window of the N = 32768 spectrum. The inertia at hi checks it (fallback below).
    hi = largest_omega(dm) ** 2 * (1 + 1e-6) if window is None else window[1] ** 2
    max_modes = max(1, min(max_window_modes, INT32_LIMIT // (2 * n)))
    saved_plan = checkpoint.load("plan") if checkpoint else None
    if saved_plan is None:
        plan, below_lo, below_hi = plan_windows(A, lo, hi, max_modes, comm.size)
        if window is None and below_hi < n:  # modes above the Lanczos estimate: use Gershgorin
            hi = A.norm(PETSc.NormType.INFINITY) * (1 + 1e-9)
            plan, below_lo, below_hi = plan_windows(A, lo, hi, max_modes, comm.size)
        if checkpoint:
            checkpoint.save("plan", {"edges": np.concatenate(plan), "sizes": [len(e) for e in plan],
                                     "below": [below_lo, below_hi]})
    else:
        bounds = np.cumsum(np.concatenate(([0], saved_plan["sizes"])))
        plan = [list(saved_plan["edges"][a:b]) for a, b in zip(bounds[:-1], bounds[1:])]
        below_lo, below_hi = (int(c) for c in saved_plan["below"])
    n_zero = count_below(A, lam_zero) if window is not None else below_lo
    n_negative = count_below(A, -lam_zero)
    parts = []
    try:
        for w, edges in enumerate(plan):
            part = checkpoint.load(f"window{w:04d}") if checkpoint else None
            if part is None:
                part = _solve_window(A, edges, tol, vectors, dm.dof)
                if checkpoint:
                    checkpoint.save(f"window{w:04d}", part)
            parts.append(part)
            if progress is not None:
                progress(len(parts), len(plan), sum(p["lam"].size for p in parts))
    finally:
        A.destroy()
    lam = np.concatenate([p["lam"] for p in parts])
    order = np.argsort(lam, kind="stable")
    omega = np.sqrt(lam[order])
    residual = max(float(p["residual"]) for p in parts)
    if omega.size != below_hi - below_lo:
        raise RuntimeError(f"spectrum: {omega.size} eigenvalues converged in the interval but the "
                           f"inertia counts {below_hi - below_lo}")
    energies = None
    if vectors:
        sums = np.concatenate([p["sums"] for p in parts])[order]
        energies = modes.energies(sums, int(dm.active.sum()))
    return Spectrum(omega, n_zero, n_negative, residual, below_hi - below_lo, len(plan), energies)
