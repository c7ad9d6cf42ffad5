"""Every eigenvalue of a large matrix that need not be symmetric, window by window along the real
axis (``spectrum.method: nonhermitian`` with ``spectrum.solver: windows``): the stressed dynamical
matrix of a frictional packing beyond the dense solver's size (docs/stressed_contacts.md
section 4).

Method [decision]: SLEPc Krylov-Schur on A = M^-1/2 D M^-1/2 (``EPS_NHEP``), shift-and-invert with
a MUMPS LU factorisation of A - sigma I, asking for the ``nev`` eigenvalues nearest a real shift
sigma; the shifts march from the left end of the spectrum to the right.  What inertia gives the
symmetric methods (a count of the eigenvalues below a shift) does not exist for a non-symmetric
matrix; completeness rests instead on four things, all checked:

1. A partition.  Window k accepts exactly the eigenvalues whose real part lies in
   [x_k, x_{k+1}), x_{k+1} <= sigma_k + h_k in the middle of a gap between its eigenvalues (none
   within round-off of a cut, :func:`_cut`): no eigenvalue is counted twice or lost between two.
2. Bendixson's theorem.  With S = (A + A^T)/2 and K = (A - A^T)/2, every eigenvalue has
   lambda_min(S) <= Re lambda <= lambda_max(S) and |Im lambda| <= ||K||_2 <= Y = ||K||_inf.  The
   march starts at x_0 <= lambda_min(S), placed by Sylvester inertias of S (MUMPS Cholesky,
   options prefix ``inertia_``), and never needs to pass ||S||_inf.
   The first shift lies FIRST_OFFSET of the box below x_0: a shift beside the zero modes (at
   x_0 = -zero_tol^2) amplifies them 1e8 times over the rest in shift-and-invert, and the other
   eigenvalues of that window came out with errors of 3e-8 (a 32-disk matrix; 1e-13 with the
   offset).
3. The disk.  The nev eigenvalues nearest sigma fill a disk of radius r (the farthest of them),
   so every eigenvalue with |Im| <= y and Re in [sigma - h, sigma + h], h = sqrt(r^2 - y^2), is
   among them; y = min(Y, r/2).  A window is solved again closer to x_k while sigma - h > x_k.
4. The count and the trace moments.  The march must accept exactly n eigenvalues, and
   sum lambda = tr A, sum lambda^2 = tr A^2 = ||S||_F^2 - ||K||_F^2 must hold to
   TRACE_TOL (relative to sum |lambda| and sum |lambda|^2): a miss (Krylov-Schur not returning
   the nearest eigenvalues, an eigenvalue with |Im| > r/2) breaks the count, a miss traded for a
   spurious copy breaks the moments unless the two lie within TRACE_TOL of each other.
   RuntimeError on every rank otherwise, naming the window option that helps.

Eigenvalues are SLEPc's (back-transformed Ritz values, relative residual <= ``tol``).  Each
window is checkpointed (its accepted eigenvalues, reduced K/Q sums and the march's state), so a
killed solve resumes window by window on any rank count.  Options: the EPS has the prefix
``nonhermitian_`` (``-nonhermitian_eps_nev``, ``-nonhermitian_eps_ncv``,
``-nonhermitian_st_pc_factor_mat_solver_type``...), defaults set in code first; what it used is
read back.  Collective on the matrix's communicator.  Units: lambda = omega^2 in 1/t0^2.
"""

from __future__ import annotations

import json
import math

import numpy as np

from . import modes
from .. import profiling
from ..model.operators import scaled_operator
from ..options import eps_settings, pc_settings
from .slicing import ShiftedInertia

PREFIX = "nonhermitian_"
NEV = 200            # eigenvalues per window (-nonhermitian_eps_nev wins): ~1 s each at 24576 DOF
STEP = 0.8           # next shift at x_k + STEP h_(k-1): the windows overlap by ~10 %
FIRST_OFFSET = 1e-3  # the first shift this far (of the box) below the start: not beside the zero modes
CUT_RANGE = 0.75     # a window's cut lies in the last quarter of the range its disk covers
RETRIES = 8          # a window re-solved closer to x_k at most this often
TRACE_TOL = 1e-10    # relative error allowed in sum lambda and sum lambda^2 (measured ~1e-15)


def _bounds(A, symmetric: bool, zero_tol: float) -> dict:
    """Bendixson's box and the trace moments of A (module docstring, items 2 and 4): lower (a
    number <= every Re lambda), upper (>= every Re lambda), imag (>= every |Im lambda|), trace,
    trace2 (tr A^2), and the inertia factorisation's settings.  Collective."""
    from petsc4py import PETSc

    diagonal = A.getDiagonal()
    trace = diagonal.sum()
    diagonal.destroy()
    if symmetric:
        S, imag, trace2 = A, 0.0, A.norm(PETSc.NormType.FROBENIUS) ** 2
    else:
        At = PETSc.Mat()
        A.transpose(At)  # into a new Mat: petsc4py's A.transpose() transposes A in place
        S = A.copy()
        S.axpy(1.0, At, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        S.scale(0.5)
        K = A.copy()
        K.axpy(-1.0, At, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        K.scale(0.5)
        imag = K.norm(PETSc.NormType.INFINITY)
        trace2 = S.norm(PETSc.NormType.FROBENIUS) ** 2 - K.norm(PETSc.NormType.FROBENIUS) ** 2
        K.destroy()
        At.destroy()
    upper = S.norm(PETSc.NormType.INFINITY)
    counter = ShiftedInertia(S)  # flags its copy of S symmetric for the Cholesky inertia
    try:
        lower = -zero_tol**2
        while counter.count_below(lower) > 0:  # S has eigenvalues below: go down by 4x until none
            lower *= 4.0
            if lower < -4.0 * upper:
                raise RuntimeError(f"nonhermitian windows: the symmetric part has eigenvalues below "
                                   f"-||S||_inf = {-upper:.3e}: the inertia factorisation is wrong")
        used = {"prefix": counter.pc.getOptionsPrefix(), **pc_settings(counter.pc)}
    finally:
        counter.destroy()
        if S is not A:
            S.destroy()
    return {"lower": np.float64(lower), "upper": np.float64(upper), "imag": np.float64(imag),
            "trace": np.float64(trace), "trace2": np.float64(trace2), "inertia": np.bytes_(json.dumps(used))}


def _configure(A, sigma: float, tol: float):
    """The EPS of the window at ``sigma`` on A, prefix ``nonhermitian_``: Krylov-Schur, NHEP,
    nearest the target, shift-and-invert by MUMPS LU; defaults set here, then setFromOptions
    (options win), then the target and shift sigma (the march's, not a setting).  A new EPS per
    window: SLEPc 3.18 keeps the first window's factorisation when the target of a solved EPS is
    moved (measured: the same eigenvalues came back for three shifts).  Collective."""
    from petsc4py import PETSc
    from slepc4py import SLEPc

    eps = SLEPc.EPS().create(A.getComm())
    eps.setOperators(A)
    eps.setProblemType(SLEPc.EPS.ProblemType.NHEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
    eps.setDimensions(nev=NEV)
    eps.setTolerances(tol=tol)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    ksp = st.getKSP()
    ksp.setType(PETSc.KSP.Type.PREONLY)
    ksp.getPC().setType(PETSc.PC.Type.LU)
    ksp.getPC().setFactorSolverType("mumps")
    eps.setOptionsPrefix(PREFIX)
    eps.setFromOptions()
    eps.setTarget(sigma)
    st.setShift(sigma)
    return eps


@profiling.logged("rsNonHermWindow")
def _solve_window(A, sigma: float, tol: float, vectors: bool, dof: int, dim: int):
    """The eigenvalues nearest ``sigma``: (lam (nconv,) complex, radius r of the nearest nev (inf
    when they are all of A's), relative residuals (nconv,), reduced K/Q sums (nconv, W) of the
    normalised real part of each right vector or None, what the EPS used).  Collective."""
    from slepc4py import SLEPc

    n = A.getSize()[0]
    eps = _configure(A, sigma, tol)
    try:
        nev = min(eps.getDimensions()[0], n)
        eps.solve()
        nconv = eps.getConverged()
        if nconv < nev:
            raise RuntimeError(f"nonhermitian windows: {nconv} of {nev} eigenvalues converged near "
                               f"sigma = {sigma:.6g} in {eps.getIterationNumber()} iterations; raise "
                               f"-nonhermitian_eps_max_it or -nonhermitian_eps_ncv")
        lam = np.array([eps.getEigenvalue(i) for i in range(nconv)], dtype=complex)
        residual = np.array([eps.computeError(i, SLEPc.EPS.ErrorType.BACKWARD) for i in range(nconv)])
        radius = math.inf if nconv >= n else float(np.sort(np.abs(lam - sigma))[nev - 1])  # all found: no edge
        sums = None
        if vectors:
            sums = np.empty((nconv, modes.sums_width(dim)))
            vr, vi = A.createVecRight(), A.createVecRight()
            for i in range(nconv):  # one vector at a time: no copy of the window's vectors
                eps.getEigenpair(i, vr, vi)
                vr.scale(1.0 / max(vr.norm(), np.finfo(float).tiny))
                sums[i] = modes.local_sums(vr.getArray()[None, :], dof, dim)[0]
            vr.destroy()
            vi.destroy()
            sums = A.getComm().tompi4py().allreduce(sums)
        used = {**eps_settings(eps), "nev": nev, "ncv": eps.getDimensions()[1]}
    finally:
        eps.destroy()
    return lam, radius, residual, sums, used


def _cut(real: np.ndarray, sigma: float, half: float) -> float:
    """Where the window at ``sigma`` (covering up to sigma + ``half``) ends: the middle of the
    widest gap between the real parts ``real`` of its eigenvalues in the last quarter of that
    range, so that no eigenvalue lies within round-off of a cut.  (At sigma + half itself there is
    often one: the window's farthest, when the box has no height; computed again in the next
    window it fell on either side of the cut, and 31 of 24339 eigenvalues were lost.)  Not
    collective."""
    if not math.isfinite(half):
        return math.inf
    lo, hi = sigma + CUT_RANGE * half, sigma + half
    points = np.concatenate(([lo], np.sort(real[(real > lo) & (real < hi)]), [hi]))
    widest = int(np.argmax(np.diff(points)))
    return float(points[widest] + points[widest + 1]) / 2


def march(solve_window, box: dict, n: int, *, option: str, checkpoint=None, progress=None,
          resumed=None) -> list[dict]:
    """The march of the module docstring (items 1 and 3) over a spectrum of ``n`` eigenvalues in
    Bendixson's ``box`` (lower, upper: bounds on every Re value; imag: on every |Im value|),
    shared by every windowed solver.  ``solve_window(sigma)`` returns the window at a real shift:
    a dict with ``values`` (complex, what the march partitions by real part), ``radius`` (of the
    disk of the nev nearest, inf when they are all), ``residual`` (largest), ``sigma`` (the shift
    it used), optionally ``half`` (the half-width of the range it covers, when the window knows
    it better than the disk with y = min(imag, radius/2) does), ``aligned`` (a dict of arrays
    aligned with ``values``, kept with them) and ``extra`` (a dict kept as it is).  ``option`` names what a failing window should raise (``-nonhermitian_eps_nev``).
    Returns the windows (dicts: ``lam`` the accepted values, the aligned arrays and numbers,
    residual, x_next, h, sigma), checkpointed as they finish (``checkpoint``: ``load``/``save`` of
    dicts) and resumed from it (``resumed(part)`` is called for each window read back).
    Collective as ``solve_window``; ``progress(windows_done, accepted, n)`` on every rank after
    each window."""
    parts = []
    x, h = box["lower"], 0.0
    while checkpoint and (part := checkpoint.load(f"window{len(parts):04d}")) is not None:
        parts.append(part)
        x, h = float(part["x_next"]), float(part["h"])
        if resumed is not None:
            resumed(part)
    accepted = sum(p["lam"].size for p in parts)
    while accepted < n and x <= box["upper"]:
        sigma = x + STEP * h if parts else x - FIRST_OFFSET * (box["upper"] - x)
        for _ in range(RETRIES):
            window = solve_window(sigma)
            sigma, radius = window["sigma"], window["radius"]
            y = min(box["imag"], radius / 2)
            half = window["half"] if "half" in window else math.sqrt(radius**2 - y**2)
            if half <= 0.0:
                raise RuntimeError(f"windows: the eigenvalues nearest {sigma:.6g} are all at it; raise {option}")
            if sigma - half <= x:
                break
            sigma = x + STEP * half  # the disk misses [x, sigma - half): closer to x
        else:
            raise RuntimeError(f"windows: no shift near {x:.6g} gives a disk reaching back to it in "
                               f"{RETRIES} tries; raise {option}")
        values = window["values"]
        cut = _cut(values.real, sigma, half)
        keep = (values.real >= x) & (values.real < cut)
        part = {"lam": values[keep], "residual": np.float64(window["residual"]),
                "x_next": np.float64(cut), "h": np.float64(half), "sigma": np.float64(sigma)}
        part.update({k: v[keep] for k, v in window.get("aligned", {}).items()})
        part.update(window.get("extra", {}))
        if checkpoint:
            checkpoint.save(f"window{len(parts):04d}", part)
        parts.append(part)
        accepted += int(keep.sum())
        x, h = cut, half
        if progress is not None:
            progress(len(parts), accepted, n)
    return parts


def solve(dm, *, zero_tol: float, vectors: bool, tol: float = 1e-12, progress=None,
          checkpoint=None) -> tuple[np.ndarray, np.ndarray | None, dict]:
    """Every eigenvalue of A = M^-1/2 D M^-1/2 of ``dm`` (a
    :class:`~solver.model.dynmat.DynamicalMatrix`), by the march of the module docstring.
    Collective; same result on every rank.

    Returns (lam (n,) complex in the order found, sums (n, W) reduced K/Q sums of each
    eigenvalue's normalised right vector (meaningful for real eigenvalues) or None, checks: the
    windows, the largest relative residual, the trace moments' relative errors, the box and the
    settings used).  ``progress(windows_done, accepted, n)`` is called on every rank after each
    window (it may raise to stop); ``checkpoint`` (``load``/``save`` of dicts, as for slicing)
    keeps each window so a rerun resumes.  RuntimeError (every rank) when a check fails."""
    comm = dm.D.getComm()
    A = scaled_operator(dm)
    n = A.getSize()[0]
    used = {}

    def window(sigma):
        lam, radius, residual, sums, settings = _solve_window(A, sigma, tol, vectors, dm.dof, dm.dim)
        used.update(settings)
        return {"values": lam, "radius": radius, "residual": residual.max(initial=0.0), "sigma": sigma,
                "aligned": {"sums": sums} if vectors else {}}

    try:
        box = checkpoint.load("plan") if checkpoint else None
        if box is None:
            box = _bounds(A, dm.symmetric, zero_tol)
            if checkpoint:
                checkpoint.save("plan", box)
        box = {k: (v if k == "inertia" else float(v)) for k, v in box.items()}
        parts = march(window, box, n, option="-nonhermitian_eps_nev", checkpoint=checkpoint, progress=progress)
    finally:
        A.destroy()
    lam = np.concatenate([p["lam"] for p in parts]) if parts else np.empty(0, complex)
    sums = np.concatenate([p["sums"] for p in parts]) if vectors and parts else None
    checks = _check(lam, n, box)
    checks.update(windows=len(parts), max_residual=max((float(p["residual"]) for p in parts), default=0.0),
                  settings={"spectrum": comm.tompi4py().bcast(used, root=0),
                            "inertia": json.loads(bytes(box["inertia"]))})
    return lam, sums, checks


def _check(lam: np.ndarray, n: int, box: dict) -> dict:
    """The count and the trace moments of the accepted eigenvalues (item 4 of the module
    docstring): their relative errors, or RuntimeError. Not collective (same data everywhere)."""
    if lam.size != n:
        raise RuntimeError(f"nonhermitian windows: {lam.size} eigenvalues accepted for a matrix of size {n} "
                           f"(an eigenvalue {'missed' if lam.size < n else 'counted twice'}); raise "
                           f"-nonhermitian_eps_nev or use spectrum.solver: dense")
    first = abs(lam.sum().real - box["trace"]) / max(np.abs(lam).sum(), np.finfo(float).tiny)
    second = abs((lam**2).sum().real - box["trace2"]) / max((np.abs(lam) ** 2).sum(), np.finfo(float).tiny)
    if max(first, second) > TRACE_TOL:
        raise RuntimeError(f"nonhermitian windows: the eigenvalues found miss tr A by {first:.1e} and tr A^2 "
                           f"by {second:.1e} (relative; allowed {TRACE_TOL:g}): some eigenvalue is wrong")
    return {"trace_error": first, "trace2_error": second, "imag_bound": box["imag"],
            "real_bounds": [box["lower"], box["upper"]]}
