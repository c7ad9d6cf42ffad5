"""Eigenfrequencies (and per-mode energies) of the dynamical matrix with SLEPc.

Problem [decision]: the symmetric standard form A e = omega^2 e, A = M^-1/2 D M^-1/2.  It has
the same sparsity as D, orthonormal eigenvectors (so K and Q are plain sums of squares,
see ``modes``), and the Cholesky inertia of A - sigma I that spectrum slicing needs; the
generalised form with a diagonal M offers nothing more.

Method: Krylov-Schur spectrum slicing (EPS ``which=ALL`` on an interval, shift-and-invert
with a MUMPS Cholesky factorisation; the matrix is flagged symmetric and MUMPS ICNTL(13)=1
so that parallel inertias are right).  The interval starts at lambda_lo = zero_tol^2 > 0:
zero modes (``dm.rigid_modes()``: the uniform translations, and the uniform spins when there
are rotations but no tangential springs) then lie below the first shift and never make a
factorisation singular; their number is the inertia at lambda_lo, and modes below
-lambda_lo (an unstable packing) are counted separately.  The full interval ends just above
the Lanczos estimate of lambda_max, checked by the inertia there (Gershgorin ||A||_inf if it
misses any mode).  Eigenvalues are Rayleigh quotients of the converged vectors.

Bounded memory: slicing keeps every eigenvector of its interval, so the interval is cut into
windows of at most ``max_window_modes`` modes, placed from Sylvester inertias (refined until
every cut is known to a quarter of a window), and solved one after another; each window's
vectors are reduced to K, Q and the participation ratio and freed.  This also keeps
n x nconv below 2^31 for the 32-bit-index PETSc build.  The windows do not depend on the
number of ranks (a checkpointed spectrum resumes on any rank count): when a window is solved
on p ranks, it is split into p sub-intervals with equal mode counts, again from inertias
(``krylovschur_partitions``), each solved by one rank with a sequential factorisation.

Options: the slicing EPS has the prefix ``spectrum_`` (``-spectrum_eps_*``, ``-spectrum_st_*``,
``-spectrum_st_mat_mumps_icntl_*``), the inertia factorisations ``inertia_``
(``-inertia_pc_factor_mat_solver_type``, ``-inertia_mat_mumps_icntl_*``), the lambda_max solve
``wmax_`` (``model.operators``).  Defaults are set on the objects in code, then setFromOptions,
so options win; nothing is written into the options database.  What each object used is read
back into ``Spectrum.settings``.
Units: omega in 1/t0.  Collective on the matrix's communicator.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass

import numpy as np

from . import modes
from .. import profiling
from ..model.operators import largest_omega, scaled_operator
from ..options import eps_settings, pc_settings

SLICING_PREFIX = "spectrum_"
INERTIA_PREFIX = "inertia_"

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
    settings: dict | None = None  # what the solver objects used: {"spectrum": EPS, "inertia": PC}


def _mumps_defaults(pc) -> None:
    """ICNTL(13) = 1 (the root node is not factorised by ScaLAPACK, so parallel inertias are
    right) and ICNTL(24) = 1 (null pivots detected instead of failing) on a PC that factorises
    with MUMPS; a no-op for another package.  The ordering is MUMPS's automatic choice (ICNTL 7 =
    7): with the PT-Scotch build (``petscenv.mumps_build``) it takes SCOTCH's nested dissection
    for the larger matrices (measured: 12,273 DOF and up) and AMF for small ones, PORD and AMF with
    Debian's build (BENCHMARKS "orderings").  Called after setFromOptions: the factor matrix reads
    its own options (``-<prefix>mat_mumps_icntl_*``) when it is factorised, so those still win.
    Collective."""
    if pc.getType() in ("cholesky", "lu") and pc.getFactorSolverType() == "mumps":
        pc.setFactorSetUpSolverType()
        factor = pc.getFactorMatrix()
        factor.setMumpsIcntl(13, 1)
        factor.setMumpsIcntl(24, 1)


MUMPS_MEMORY_ERRORS = (-8, -9, -11, -13, -14, -15, -17, -19, -20)  # MUMPS 5 user guide, section 8


def _check_mumps(factor, pc, sigma: float) -> None:
    """Raise if MUMPS failed to factorise (INFOG(1) < 0): PETSc then leaves the factor's inertia
    at whatever MUMPS last wrote (0 measured after error -19), a silent wrong count otherwise.
    The message says what MUMPS estimated (INFOG 16: MB on the largest rank; INFOG 17: summed over
    the ranks).  A no-op for another package.  INFOG is global on the factor's communicator, so
    every rank raises alike.  Collective-safe (no communication)."""
    if pc.getFactorSolverType() != "mumps":
        return
    code = factor.getMumpsInfog(1)
    if code >= 0:
        return
    detail = factor.getMumpsInfog(2)
    what = ("it ran out of memory" if code in MUMPS_MEMORY_ERRORS else "see the MUMPS user guide for this code")
    raise RuntimeError(
        f"MUMPS failed to factorise A - sigma I at sigma = {sigma:.6g} (INFOG(1) = {code}, INFOG(2) = {detail}: "
        f"{what}); it estimated {factor.getMumpsInfog(16)} MB on the largest rank and {factor.getMumpsInfog(17)} MB "
        "in all. Share the factor over more ranks (spectrum.factor_ranks), or ask for the vDOS by "
        "spectrum.method: kpm, which needs no factor")


class ShiftedInertia:
    """Inertias of A - sigma I for many sigma with one factorisation object on A's communicator:
    the symbolic analysis is done at the first shift, later shifts refactorise numerically only
    (same pattern: A's values copied in place, then the diagonal shifted).  PC options prefix
    ``inertia_`` (MUMPS Cholesky with ICNTL 13 and 24 by default, :func:`_mumps_defaults`).
    ``refactor_flops``, ``refactor_seconds`` and ``refactor_cpu_seconds`` add up, over the numeric
    refactorisations (every count after the first, whose time includes the analysis), MUMPS's
    flops of the elimination (RINFOG 3, the whole factor's on its communicator; 0 for another
    package), this rank's wall time in them and its process's CPU time (all its threads): flops
    over time is the factorisation's rate (BENCHMARKS "counts_rate"), over CPU time the rate per
    core actually given, which other jobs on the node do not dilute.
    Collective on A's communicator; call :meth:`destroy` when done."""

    def __init__(self, A):
        from petsc4py import PETSc

        self.A = A
        self.shifted = A.duplicate(copy=True)
        self.shifted.setOption(PETSc.Mat.Option.SYMMETRIC, True)
        self.pc = PETSc.PC().create(A.getComm())
        self.pc.setOperators(self.shifted)
        self.pc.setType(PETSc.PC.Type.CHOLESKY)
        self.pc.setFactorSolverType("mumps")
        self.pc.setOptionsPrefix(INERTIA_PREFIX)
        self.pc.setFromOptions()
        _mumps_defaults(self.pc)
        self.factorisations = 0
        self.refactor_flops, self.refactor_seconds, self.refactor_cpu_seconds = 0.0, 0.0, 0.0

    @profiling.logged("rsInertia")
    def count_below(self, sigma: float) -> int:
        """Number of eigenvalues of A below ``sigma``. Collective on A's communicator."""
        from petsc4py import PETSc

        self.A.copy(self.shifted, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        self.shifted.shift(-sigma)
        start, cpu = time.perf_counter(), time.process_time()
        self.pc.setUp()  # same nonzero pattern: numeric factorisation only after the first
        seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
        factor = self.pc.getFactorMatrix()
        try:
            _check_mumps(factor, self.pc, sigma)
            negative = int(factor.getInertia()[0])
            if self.factorisations:
                self.refactor_seconds += seconds
                self.refactor_cpu_seconds += cpu
                if self.pc.getFactorSolverType() == "mumps":
                    self.refactor_flops += factor.getMumpsRinfog(3)
        finally:
            factor.destroy()  # drops the wrapper's reference only; the PC keeps its factor
        self.factorisations += 1
        return negative

    def settings(self) -> dict:
        """What the factorisation used, read back from the PC. Not collective."""
        return {"prefix": INERTIA_PREFIX, **pc_settings(self.pc)}

    def destroy(self) -> None:
        self.pc.destroy()
        self.shifted.destroy()


def inertia(A, sigma: float) -> tuple[int, dict]:
    """(number of eigenvalues of A below ``sigma``, what the factorisation used), from a fresh
    :class:`ShiftedInertia` freed at once (no factor is kept between calls). Collective."""
    counter = ShiftedInertia(A)
    try:
        return counter.count_below(sigma), counter.settings()
    finally:
        counter.destroy()


def count_below(A, sigma: float) -> int:
    """Number of eigenvalues of A below ``sigma`` (Sylvester inertia of A - sigma I). Collective."""
    return inertia(A, sigma)[0]


CLUSTER_WIDTH = 1e-9
"""Relative width (of max(|hi|, 1)) below which a bracket holding more modes than the slack is
taken to be one cluster of (nearly) equal eigenvalues and is no longer narrowed."""
CLUSTER_MARGIN = 1e-5
"""Relative distance kept between a cut and such a cluster: a slicing edge within round-off of an
eigenvalue makes SLEPc's own inertia disagree with the modes it finds (error 77, raised on one
rank only).  A cut is also a shift of SLEPc's: a relative distance delta amplifies the cluster by
1/delta in shift-and-invert, and at delta <~ 1e-6 Lanczos returned a spurious extra copy of a
12-fold eigenvalue below the cut (the FCC crystal of tests/model/test_crystal_fcc.py on 2 ranks, with
20-fold clusters: 1e-7, 3e-7 and 8e-7 failed, 1e-6 to 1e-3 all passed).  1e-5 is far from both
that and the eigenvalues' accuracy (~1e-14), and far below any bin."""


def place_cuts(A, known: dict, targets: np.ndarray, slack: float, scale: float) -> list[float]:
    """Shifts where the eigenvalue count of A reaches each of ``targets`` (ascending, strictly
    between the counts of the first and last shift of ``known``).

    ``known`` maps shift -> Sylvester inertia and gains the shifts factorised here: the count
    between two known shifts is interpolated linearly only once it is below ``slack`` (new
    shifts are placed by safeguarded interpolation, about three factorisations per target).
    A bracket narrower than CLUSTER_WIDTH x ``scale`` that still holds more than ``slack``
    modes is a cluster of equal eigenvalues (a crystal's degenerate modes): the cut is never put
    inside it but CLUSTER_MARGIN x ``scale`` below or above it, whichever count is nearer the
    target, so the cluster stays whole in one piece.
    Collective; every rank makes the same choices, since inertias are global.  Public, so that a
    benchmark cuts its windows as :func:`solve` does (scripts/benchmarks/bench_ciss.py).
    """
    width, margin = CLUSTER_WIDTH * scale, CLUSTER_MARGIN * scale
    while True:
        xs = np.array(sorted(known))
        cs = np.array([known[x] for x in xs], dtype=float)
        right = np.searchsorted(cs, targets, side="right")  # cs[right - 1] <= target < cs[right]
        new, cuts = set(), []
        for r, t in zip(right, targets):
            x0, x1, c0, c1 = xs[r - 1], xs[r], cs[r - 1], cs[r]
            if c1 - c0 <= slack:
                cuts.append(float(x0 + (t - c0) / (c1 - c0) * (x1 - x0)))
            elif x1 - x0 > width:
                frac = min(max((t - c0) / (c1 - c0), 0.1), 0.9)  # safeguard: always shrink
                new.add(float(x0 + frac * (x1 - x0)))
            else:  # a cluster: cut beside it, inside the outer interval (an edge there merges away)
                cut = x0 - margin if t - c0 <= c1 - t else x1 + margin
                cuts.append(float(min(max(cut, xs[0]), xs[-1])))
                if xs[0] < cut < xs[-1] and cut not in known:
                    new.add(cuts[-1])
        if not new:
            return cuts
        for x in sorted(new):
            known[x] = count_below(A, x)


def plan_windows(A, lo: float, hi: float, max_modes: int) -> tuple[np.ndarray, np.ndarray, dict]:
    """Cut (lo, hi] into windows of at most ~``max_modes`` modes each; the plan does not depend
    on the number of ranks (a checkpointed spectrum resumes on any rank count).

    Cut points come from Sylvester inertias, refined until every cut is known to a quarter of a
    window (:func:`place_cuts`), so a steep vDOS cannot put several times the intended modes into one
    window (it once did at the low end of an N = 32768 spectrum, and the run ran out of memory);
    then the inertia at every cut is computed, so each window's mode count is exact.
    Collective.  Returns (edges (W+1,), counts (W+1,) of eigenvalues below each edge, every
    inertia known: shift -> count), for :func:`split_window`.
    """
    known = {lo: count_below(A, lo), hi: count_below(A, hi)}
    total = known[hi] - known[lo]
    windows = max(1, -(-total // max_modes))
    step = total / windows
    cuts = place_cuts(A, known, known[lo] + step * np.arange(1, windows), max(1.0, step / 4),
                  max(abs(hi), 1.0))
    edges = np.unique([lo, *cuts, hi])
    for x in edges:
        if x not in known:
            known[float(x)] = count_below(A, float(x))
    return edges, np.array([known[x] for x in edges], dtype=np.int64), known


def split_window(A, known: dict, lo: float, hi: float, parts: int) -> list[float]:
    """Edges of ``parts`` sub-intervals of the window (lo, hi] with about equal mode counts (one
    per rank: Krylov-Schur partitions), placed from the inertias in ``known``
    (which must hold lo and hi; refined as in :func:`plan_windows`, to a quarter of a piece).
    Fewer sub-intervals if the window holds fewer modes than ``parts``.  Collective."""
    inside = {x: c for x, c in known.items() if lo <= x <= hi}
    pieces = max(1, min(parts, inside[hi] - inside[lo]))
    if pieces == 1:
        return [lo, hi]
    step = (inside[hi] - inside[lo]) / pieces
    cuts = place_cuts(A, inside, inside[lo] + step * np.arange(1, pieces), max(1.0, step / 4),
                  max(abs(hi), 1.0))
    known.update(inside)
    return [float(x) for x in np.unique([lo, *cuts, hi])]


def configure_window(eps, A, edges, tol, prefix: str = SLICING_PREFIX):
    """Slicing EPS on the interval (edges[0], edges[-1]], one partition per sub-interval, options
    prefix ``prefix`` (``spectrum_``; the diffusivity's windows: ``transport_``): defaults in code,
    then setFromOptions (options win). Collective.  Public, so
    that a benchmark times the very solver each window of :func:`solve` runs
    (scripts/benchmarks/bench_ciss.py: Krylov-Schur against CISS).

    SLEPc factorises in an internal child EPS that copies only the ST type from ``eps``: the
    KSP/PC of ``eps``'s own ST are never used (setting MUMPS there left PETSc's Cholesky in
    charge, 12x slower per factorisation at N = 32768).  The defaults therefore go on the child's
    KSP (``getKrylovSchurKSP``, after the prefix and the partitions are set), before
    setFromOptions, which configures that KSP with ``-spectrum_st_ksp_*``/``-spectrum_st_pc_*``.
    The MUMPS ICNTLs go on the factor the child creates first (parallel when a window has fewer
    sub-intervals than ranks: ICNTL 13 is kept, measured); with one sub-interval per rank SLEPc may
    re-create a sequential factor when the shift moves, which then has MUMPS's own ICNTL 13 and 24
    (irrelevant on one rank, and null pivots only at an exactly singular shift).
    """
    from petsc4py import PETSc
    from slepc4py import SLEPc

    eps.setOperators(A)
    eps.setProblemType(SLEPc.EPS.ProblemType.HEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.ALL)
    eps.setInterval(edges[0], edges[-1])
    eps.setTolerances(tol=tol)
    eps.getST().setType(SLEPc.ST.Type.SINVERT)
    if len(edges) > 2:
        eps.setKrylovSchurPartitions(len(edges) - 1)
        eps.setKrylovSchurSubintervals(edges)
    eps.setOptionsPrefix(prefix)
    ksp = eps.getKrylovSchurKSP()
    ksp.setType(PETSc.KSP.Type.PREONLY)
    ksp.getPC().setType(PETSc.PC.Type.CHOLESKY)
    ksp.getPC().setFactorSolverType("mumps")
    eps.setFromOptions()
    _mumps_defaults(eps.getKrylovSchurKSP().getPC())


@profiling.logged("rsWindowSolve")
def _solve_window(A, edges, tol: float, vectors: bool, dof: int, dim: int) -> dict:
    """Eigenvalues (and reduced K/Q sums) of one window, ``dof`` DOF per particle in ``dim``
    dimensions. Collective; same result on every rank.

    Returns {"lam": (M,), "sums": (M, W) or (0, W) (W = ``modes.sums_width(dim)``: 4 in 2D, 7 in
    3D), "residual": max relative residual,
    "settings": what the EPS used (:func:`~solver.options.eps_settings`, JSON as bytes, so that it
    is checkpointed with the window)}.
    Each eigenvalue is the Rayleigh quotient of its converged vector (one MatMult per mode):
    its error is ~ residual^2 / gap, where the back-transformed Ritz value carried errors up to
    the residual itself (omega off by 1e-8 relative at rho = 2, residuals 1e-7 from the shift at
    zero_tol^2 beside the zero modes; 1e-14 with the quotient).
    """
    from slepc4py import SLEPc

    comm = A.getComm()
    eps = SLEPc.EPS().create(comm)
    configure_window(eps, A, edges, tol)
    eps.solve()
    nconv = eps.getConverged()
    lam, residual = np.empty(nconv), 0.0
    local = np.empty((nconv if vectors else 0, modes.sums_width(dim)))
    vec, image = A.createVecRight(), A.createVecLeft()
    for i in range(nconv):  # one vector at a time: no extra copy of the window's vectors
        eps.getEigenpair(i, vec)
        A.mult(vec, image)
        lam[i] = image.dot(vec) / vec.dot(vec)
        residual = max(residual, eps.computeError(i, SLEPc.EPS.ErrorType.RELATIVE))
        if vectors:
            local[i] = modes.local_sums(vec.getArray()[None, :], dof, dim)[0]
    vec.destroy()
    image.destroy()
    used = comm.tompi4py().bcast(eps_settings(eps), root=0)  # rank 0's partition speaks for all
    eps.destroy()
    return {"lam": lam, "sums": comm.tompi4py().allreduce(local), "residual": np.float64(residual),
            "settings": np.bytes_(json.dumps(used))}


def solve(dm, *, window: tuple[float, float] | None, vectors: bool, tol: float = 1e-12,
          zero_tol: float = 1e-4, max_window_modes: int = 2000, progress=None,
          checkpoint=None) -> Spectrum:
    """Eigenfrequencies of ``dm`` (a :class:`~solver.model.dynmat.DynamicalMatrix`). Collective.

    window : (omega_lo, omega_hi) in 1/t0, or None for the full spectrum above ``zero_tol``.
    vectors : also compute K_x, K_y[, K_z], Q[_x, Q_y, Q_z], K, Q and the participation ratio
        per mode (``modes.energies``).
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
    max_modes = max(1, min(max_window_modes, INT32_LIMIT // (2 * n)))
    parts = []
    try:
        saved_plan = checkpoint.load("plan") if checkpoint else None
        if saved_plan is None:
            # Full spectrum: top of the band from the cheap Lanczos solve. A Ritz value never
            # exceeds lambda_max and is within 1e-8 of it, so 1e-6 above it is a safe bound; the
            # Gershgorin bound ||A||_inf is ~1.9 lambda_max, and slicing that empty top took 318 s
            # instead of ~120 s for the last window of the N = 32768 spectrum. The inertia at hi
            # checks it (fallback below).
            hi = largest_omega(dm) ** 2 * (1 + 1e-6) if window is None else window[1] ** 2
            edges, counts, known = plan_windows(A, lo, hi, max_modes)
            if window is None and counts[-1] < n:  # modes above the Lanczos estimate: use Gershgorin
                hi = A.norm(PETSc.NormType.INFINITY) * (1 + 1e-9)
                edges, counts, known = plan_windows(A, lo, hi, max_modes)
            if checkpoint:  # rank-free: window edges and inertias, split per rank count below
                shifts = np.array(sorted(known))
                checkpoint.save("plan", {"edges": edges, "counts": counts, "shifts": shifts,
                                         "shift_counts": np.array([known[x] for x in shifts], dtype=np.int64)})
        else:
            edges, counts = np.asarray(saved_plan["edges"]), np.asarray(saved_plan["counts"])
            known = dict(zip(saved_plan["shifts"].tolist(), saved_plan["shift_counts"].tolist()))
        below_lo, below_hi = int(counts[0]), int(counts[-1])
        windows = edges.size - 1
        n_negative, inertia_used = inertia(A, -lam_zero)  # |omega^2| <= zero_tol^2 are the zero modes:
        n_zero = (count_below(A, lam_zero) if window is not None else below_lo) - n_negative
        for w in range(windows):
            part = checkpoint.load(f"window{w:04d}") if checkpoint else None
            if part is None:
                sub = split_window(A, known, float(edges[w]), float(edges[w + 1]), comm.size)
                part = _solve_window(A, sub, tol, vectors, dm.dof, dm.dim)
                if checkpoint:
                    checkpoint.save(f"window{w:04d}", part)
            parts.append(part)
            if progress is not None:
                progress(len(parts), windows, sum(p["lam"].size for p in parts))
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
        energies = modes.energies(sums, int(dm.active.sum()), dm.dim)
    used = [json.loads(bytes(p["settings"])) for p in parts if "settings" in p]
    settings = {"spectrum": {**used[0], "partitions": [u.get("partitions") for u in used]} if used else None,
                "inertia": inertia_used}
    return Spectrum(omega, n_zero, n_negative, residual, below_hi - below_lo, windows, energies, settings)
