"""Every damped mode of a large packing, window by window (``spectrum.method: pep`` with
``spectrum.solver: windows``; docs/damping.md section 6).

The damped modes are the eigenvalues lambda of (lambda^2 + lambda C^ + A) x = 0, with
A = M^-1/2 D M^-1/2 and C^ = M^-1/2 C M^-1/2, i.e. of the first-order matrix
L = [[0, I], [-A, -C^]] (2n x 2n): lambda = -sigma +- i omega_d, Re lambda <= 0.

Method [decision]: SLEPc Krylov-Schur (``EPS_NHEP``, largest magnitude) on the real operator
    T = Im (L - s)^-1 / w = ((L + a)^2 + w^2)^-1,   s = -a + i w  (w > 0),
(Parlett and Saad's complex shift in real arithmetic), whose eigenvalues
1 / ((lambda - s)(lambda - conj s)) are largest for the lambda nearest s and its conjugate.  One
application of T is one solve with Q(s) = A + s C^ + s^2, written as the real system of size 2n
    G = [[Qr, -Qi], [Qi, Qr]],   Qr = A - a C^ + (a^2 - w^2),   Qi = w (C^ - 2a),
factorised once per shift (MUMPS LU, options prefix ``pep_shift_``).  The lambda are the Ritz
values of L on the invariant subspace SLEPc converged (``_solve_disk``).  A shift's guaranteed
disk: with R = 1/|theta| of its nev-th eigenvalue, every lambda with
|lambda - s| <= rho = sqrt(w^2 + R) - w has |lambda - s||lambda - conj s| <= R, so it is among
them.

Columns and the march: at one w, shifts are stacked in sigma (``_column``) until at a common
half-width h their disks cover the rectangle omega_d in [w - h, w + h] x sigma in [lo, hi], where
[lo, hi] bounds the damping rate of any mode there: with |x| = 1, lambda^2 + c lambda + a = 0 for
(a, c) = (x^H A x, x^H C^ x) in the joint numerical range of A and C^, so an underdamped mode has
(sigma^2 + omega_d^2, 2 sigma) in it; 24 half-planes cos t a + sin t c <= lambda_max(cos t A +
sin t C^) (Lanczos) contain that range (``_range_planes``, ``_rate_bounds``).  A column that
reaches the real axis also covers the real roots, sigma in [0, c_max].  The columns march along
omega_d = |Im lambda| as the stressed windows march along the real axis (``shifted_windows.march``:
cells in a gap, checkpoints).  Each column is complete by construction (up to the Lanczos
tolerance); the full spectrum is checked again as the stressed windows are (their item 4): the
march must accept exactly 2n eigenvalues, with sum lambda = tr L = -tr C^ and
sum lambda^2 = tr L^2 = -2 tr A + ||C^||_F^2 to TRACE_TOL.  A frequency window (lo, hi) marches
from lo to hi only and has no count to check.  The rigid modes (Jordan blocks of L at 0: their
lambda come out ~1e-8) are set to 0 below ``zero_tol``.  Residuals: the backward error
||L z - lambda z|| / ((||L|| + |lambda|) ||z||), ||L|| <= 1 + ||A||_inf + ||C^||_inf, of every mode.
Symmetric D only: ``pep`` refuses a stressed D before.

Why not SLEPc's PEP object: in a real-scalar PETSc build (the one the rest of rotsound runs on)
PEP's shift-and-invert takes only real targets, i.e. the modes nearest a point of the real axis,
which for underdamped modes near -sigma +- i omega are the lowest frequencies only; its spectrum
slicing (STOAR) counts real eigenvalues only (hyperbolic problems); a complex-scalar build is
another petsc4py, which cannot live in the same process.

Options: the EPS has the prefix ``pep_`` (``-pep_eps_nev``, ``-pep_eps_ncv``, ``-pep_eps_tol``),
the factorisation ``pep_shift_`` (``-pep_shift_pc_factor_mat_solver_type``); defaults set in
code first, what they used read back.  Collective on the matrix's communicator.  Units: lambda
in 1/t0.
"""

from __future__ import annotations

import math

import numpy as np

from . import modes, shifted_windows
from .. import profiling
from ..model.operators import largest_damping_rate, largest_omega, scaled_damping, scaled_operator
from ..options import eps_settings, ksp_settings

PREFIX = "pep_"
SHIFT_PREFIX = "pep_shift_"
NEV = 200          # eigenvalues of T per shift (-pep_eps_nev wins)
BOX_MARGIN = 1e-6  # relative margin on the Lanczos estimates of omega_max and c_max (tol 1e-8)
FIRST = 0.01       # the lowest shift's w, as a fraction of omega_max: not beside the rigid modes at 0
HALF_MIN = 0.5     # a column's half-width at least this times its smallest disk's radius (else more disks)
OVERLAP = 0.1      # neighbouring disks' segments overlap by at least this times the smallest radius
DIRECTIONS = 24    # half-planes bounding the numerical range of (A, C^): the damping rates' bounds
RANGE_MARGIN = 1e-6  # each half-plane moved out by this share of its Lanczos value (tol 1e-8)
RATE_GRID = 2001   # grid of sigma in [0, c_max / 2] on which the bounds are found
OMEGA_GRID = 17    # ... and of omega across a column
MAX_DISKS = 64     # disks in one column at most
TRACE_TOL = shifted_windows.TRACE_TOL


def _shifted_system(A, C, a: float, w: float):
    """G of the module docstring for the shift s = -a + i w (2n x 2n AIJ, rows per rank: the
    rank's rows of the real part, then of the imaginary part, as PETSc's MatNest lays them
    out). Collective."""
    from petsc4py import PETSc

    real = A.copy()
    real.axpy(-a, C, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
    real.shift(a * a - w * w)          # Qr = A - a C^ + a^2 - w^2
    imag = C.copy()
    imag.shift(-2.0 * a)
    imag.scale(w)                      # Qi = w (C^ - 2a)
    minus = imag.copy()
    minus.scale(-1.0)
    nest = PETSc.Mat().createNest([[real, minus], [imag, real]], comm=A.getComm())
    G = PETSc.Mat()
    nest.convert(PETSc.Mat.Type.AIJ, G)
    for mat in (nest, real, imag, minus):
        mat.destroy()
    return G


class _Inverse:
    """Shell-matrix context of T = Im (L - s)^-1 / w (module docstring) on the layout of G: each
    rank holds its u rows, then its v rows."""

    def __init__(self, A, C, a: float, w: float):
        from petsc4py import PETSc

        self.A, self.C, self.a, self.w = A, C, a, w
        self.G = _shifted_system(A, C, a, w)
        self.ksp = PETSc.KSP().create(A.getComm())
        self.ksp.setOperators(self.G)
        self.ksp.setType(PETSc.KSP.Type.PREONLY)
        pc = self.ksp.getPC()
        pc.setType(PETSc.PC.Type.LU)
        pc.setFactorSolverType("mumps")
        self.ksp.setOptionsPrefix(SHIFT_PREFIX)
        self.ksp.setFromOptions()
        self.ksp.setUp()
        self.f, self.cf = A.createVecRight(), A.createVecRight()
        self.rhs, self.sol = self.G.createVecs()
        self.nloc = A.getLocalSize()[0]

    def mult(self, mat, x, y):
        """y = T x: (L - s) (u, v) = (f, g) gives Q(s) u = -g - (C^ + s) f, v = f + s u."""
        n, a, w = self.nloc, self.a, self.w
        xa = x.getArray(readonly=True)
        f = xa[:n]
        self.f.setArray(f)
        self.C.mult(self.f, self.cf)
        rhs = self.rhs.getArray()
        rhs[:n] = -xa[n:] - self.cf.getArray(readonly=True) + a * f
        rhs[n:] = -w * f
        self.ksp.solve(self.rhs, self.sol)
        s = self.sol.getArray(readonly=True)
        out = y.getArray()
        out[:n] = s[n:] / w                   # Im u / w
        out[n:] = s[:n] - a * s[n:] / w       # Im v / w = Im(s u) / w

    def free(self):
        """Destroy the factorisation and work vectors (not ``destroy``: PETSc calls that of a
        shell's context with the Mat)."""
        for obj in (self.ksp, self.G, self.f, self.cf, self.rhs, self.sol):
            obj.destroy()


def _configure(T, tol: float):
    """The window's EPS on the shell T, prefix ``pep_``: Krylov-Schur, NHEP, largest magnitude,
    NEV; defaults set here, then setFromOptions (options win). Collective."""
    from slepc4py import SLEPc

    eps = SLEPc.EPS().create(T.getComm())
    eps.setOperators(T)
    eps.setProblemType(SLEPc.EPS.ProblemType.NHEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_MAGNITUDE)
    eps.setDimensions(nev=NEV)
    eps.setTolerances(tol=tol)
    eps.setOptionsPrefix(PREFIX)
    eps.setFromOptions()
    return eps


def _first_order(A, C, V: np.ndarray) -> np.ndarray:
    """L V for the local rows V (2 nloc, k) of real 2n-vectors: L (u, v) = (v, -A u - C^ v), as two
    sparse-times-dense products (PETSc MatMatMult).  Collective."""
    from petsc4py import PETSc

    nloc, k = V.shape[0] // 2, V.shape[1]
    out = np.empty_like(V)
    out[:nloc] = V[nloc:]
    out[nloc:] = 0.0
    for mat, half in ((A, V[:nloc]), (C, V[nloc:])):
        block = np.asfortranarray(half)  # PETSc's dense storage: kept alive until X is destroyed
        X = PETSc.Mat().createDense(((nloc, None), (None, k)), array=block, comm=A.getComm())
        product = mat.matMult(X)
        out[nloc:] -= product.getDenseArray()
        for obj in (X, product):
            obj.destroy()
    return out


@profiling.logged("rsPepDisk")
def _solve_disk(A, C, norms, a: float, w: float, tol: float, zero_tol: float, dof: int, dim: int) -> dict:
    """The lambda nearest s = -a + i w and its conjugate: a dict of lambda, residual (per mode),
    sums (K/Q sums of each mode), a, radius rho (of the guaranteed disk), settings.  Collective.

    The lambda are the Ritz values of L on the invariant subspace of T that SLEPc converged (an
    orthonormal basis V: B = V^T L V, eigenvalues and vectors y of B by LAPACK, modes x = V y):
    exact eigenvalues of L for an exact subspace, with no root of 1/theta to choose, not even where
    theta is double (a mode on the line Re lambda = -a has theta(lambda) = theta(conj lambda))."""
    import scipy.linalg as sl
    from petsc4py import PETSc

    comm = A.getComm()
    mpi = comm.tompi4py()
    nloc = A.getLocalSize()[0]
    inverse = _Inverse(A, C, a, w)
    T = PETSc.Mat().createPython(((2 * nloc, None), (2 * nloc, None)), inverse, comm=comm)
    T.setUp()
    eps = _configure(T, tol)
    try:
        n2 = T.getSize()[0]
        nev = min(eps.getDimensions()[0], n2)
        eps.solve()
        nconv = eps.getConverged()
        if nconv < nev:
            raise RuntimeError(f"pep windows: {nconv} of {nev} eigenvalues converged near {-a:.4g} + {w:.4g}i in "
                               f"{eps.getIterationNumber()} iterations; raise -pep_eps_max_it or -pep_eps_ncv")
        theta = np.array([eps.getEigenvalue(i) for i in range(nconv)], dtype=complex)
        basis = eps.getInvariantSubspace()
        V = np.stack([v.getArray(readonly=True) for v in basis], axis=1)
        for v in basis:
            v.destroy()
        settings = {**eps_settings(eps), "nev": nev, "ncv": eps.getDimensions()[1],
                    "shift": {"prefix": SHIFT_PREFIX, **ksp_settings(inverse.ksp)}}
    finally:
        eps.destroy()
        T.destroy()
        inverse.free()
    LV = _first_order(A, C, V)
    B = mpi.allreduce(V.T @ LV)
    lam, Y = sl.eig(B, check_finite=False)
    Z, LZ = V @ Y, LV @ Y
    r = LZ - Z * lam[None, :]
    rr, uu, zz = mpi.allreduce(np.stack(((np.abs(r) ** 2).sum(axis=0), (np.abs(Z[:nloc]) ** 2).sum(axis=0),
                                          (np.abs(Z) ** 2).sum(axis=0))))
    length = np.sqrt(np.maximum(uu, np.finfo(float).tiny))
    # ||L|| <= 1 + ||A|| + ||C^|| (inf-norms); per ||z||: a rigid mode's Jordan vector (0, x) has no u
    residual = np.sqrt(rr) / ((1.0 + norms[0] + norms[1] + np.abs(lam)) * np.sqrt(np.maximum(zz, np.finfo(float).tiny)))
    sums = mpi.allreduce(modes.local_sums(np.abs(Z[:nloc]).T / length[:, None], dof, dim))
    lam = np.where(np.abs(lam) < zero_tol, 0.0, lam)  # rigid modes: Jordan blocks of L, ~1e-8 in round-off
    far = math.inf if nconv >= n2 else float(np.sort(1.0 / np.abs(theta))[nev - 1])
    radius = math.sqrt(w * w + far) - w
    return {"lambda": lam, "residual": residual, "sums": sums, "a": a, "radius": radius, "settings": settings}


def _segments(disks: list[dict], h: float) -> np.ndarray:
    """(len(disks), 2): the range of sigma each disk (sorted by a) surely covers over
    omega in [w - h, w + h]: a -+ sqrt(rho^2 - h^2) (empty, (a, a), when rho <= h)."""
    a = np.array([d["a"] for d in disks])
    v = np.sqrt(np.maximum(np.array([d["radius"] for d in disks]) ** 2 - h * h, 0.0))
    return np.stack((a - v, a + v), axis=1)


def _covers(disks: list[dict], h: float, lo: float, hi: float) -> bool:
    """Whether the disks' segments at half-width ``h`` join into one covering [lo, hi], each
    overlapping the next by OVERLAP of the smallest radius (room for the cut between their cells)."""
    seg = _segments(disks, h)
    overlap = OVERLAP * min(d["radius"] for d in disks)
    return bool(seg[0, 0] <= lo and seg[-1, 1] >= hi and np.all(seg[1:, 0] <= seg[:-1, 1] - overlap))


def _widest(disks: list[dict], lo: float, hi: float) -> float:
    """The largest half-width h at which the disks cover [lo, hi] (bisection; 0 if none)."""
    top = min(d["radius"] for d in disks)
    if not _covers(disks, 0.0, lo, hi):
        return 0.0
    low = 0.0
    for _ in range(60):
        mid = (low + top) / 2
        low, top = (mid, top) if _covers(disks, mid, lo, hi) else (low, mid)
    return low


def _next_disk(disks: list[dict], h: float, lo: float, hi: float) -> float:
    """Where to add a disk so that the column covers [lo, hi] at half-width ``h``: below the
    lowest, in the first gap, or above the highest (a guess of the same size beside it)."""
    seg = _segments(disks, h)
    if seg[0, 0] > lo:
        return max(lo, seg[0, 0] - (seg[0, 1] - seg[0, 0]) / 2)
    gaps = np.flatnonzero(seg[1:, 0] > seg[:-1, 1] - OVERLAP * min(d["radius"] for d in disks))
    if gaps.size:
        j = gaps[0]
        return float(seg[j, 1] + seg[j + 1, 0]) / 2
    return min(hi, seg[-1, 1] + (seg[-1, 1] - seg[-1, 0]) / 2)


def _cuts(disks: list[dict], h: float, sigma: np.ndarray) -> np.ndarray:
    """Boundaries between the disks' cells in sigma: in the overlap of neighbouring segments,
    the middle of the widest gap between the damping rates ``sigma`` found there."""
    seg = _segments(disks, h)
    cuts = []
    for j in range(len(disks) - 1):
        lo, hi = seg[j + 1, 0], seg[j, 1]
        points = np.concatenate(([lo], np.sort(sigma[(sigma > lo) & (sigma < hi)]), [hi]))
        widest = int(np.argmax(np.diff(points)))
        cuts.append((points[widest] + points[widest + 1]) / 2)
    return np.array(cuts)


def _column(solve_disk, w: float, start: float, bound) -> dict:
    """The march's window at w (``shifted_windows.march``): disks s_j = -a_j + i w, the first at
    a = ``start``, stacked in sigma until, at a common half-width h >= HALF_MIN min rho_j, they
    cover every lambda with omega in [w - h, w + h] and sigma in ``bound(w, r)`` = (lo, hi) (the
    damping rates a mode with omega within r of w can have, r = min rho_j >= h); each mode taken
    from the one disk whose cell (sigma between ``_cuts``) holds it.  Collective (as
    ``solve_disk(a, w)``)."""
    disks = [solve_disk(start, w)]
    while True:
        radius = min(d["radius"] for d in disks)
        lo, hi = bound(w, radius)
        h = _widest(disks, lo, hi)
        goal = HALF_MIN * radius
        if h >= goal:
            break
        if len(disks) >= MAX_DISKS:
            raise RuntimeError(f"pep windows: {MAX_DISKS} disks at omega = {w:.4g} do not cover the damping rates "
                               f"[{lo:.3g}, {hi:.3g}]: raise -pep_eps_nev, or use spectrum.solver: dense")
        disks.append(solve_disk(_next_disk(disks, goal, lo, hi), w))
        disks.sort(key=lambda d: d["a"])
    cuts = _cuts(disks, h, np.concatenate([-d["lambda"].real for d in disks]))
    keep = []
    for j, d in enumerate(disks):
        sigma = -d["lambda"].real
        keep.append((sigma >= (cuts[j - 1] if j else -math.inf)) & (sigma < (cuts[j] if j < cuts.size else math.inf)))
    lam = np.concatenate([d["lambda"][k] for d, k in zip(disks, keep)])
    return {"values": np.abs(lam.imag) + 0j, "half": h, "sigma": w, "radius": min(d["radius"] for d in disks),
            "residual": max((d["residual"][k].max(initial=0.0) for d, k in zip(disks, keep)), default=0.0),
            "aligned": {"lambda": lam, "sums": np.concatenate([d["sums"][k] for d, k in zip(disks, keep)]),
                        "residuals": np.concatenate([d["residual"][k] for d, k in zip(disks, keep)])},
            "extra": {"disks": np.int64(len(disks)), "centre": np.float64(_centre(lam)),
                      "radius": np.float64(min(d["radius"] for d in disks))}}


def _centre(lam: np.ndarray) -> float:
    """The median damping rate of the quarter of the modes above the real axis nearest in omega to
    the highest of them (where the next column starts: its first disk's a).  Not collective."""
    upper = lam[lam.imag > 0]
    if not upper.size:
        return 0.0
    near = upper[np.argsort(np.abs(upper.imag - upper.imag.max()))[:max(1, upper.size // 4)]]
    return float(np.median(-near.real))


def _range_planes(A, C) -> np.ndarray:
    """(DIRECTIONS, 3) rows (cos t, sin t, m(t)), m(t) = lambda_max(cos t A + sin t C^) for t
    around the circle: every (a, c) = (x^H A x, x^H C^ x), |x| = 1, has cos t a + sin t c <= m(t)
    (the joint numerical range of A and C^ lies in these half-planes).  m by Lanczos (``wmax_``
    options; Gershgorin's ||.||_inf where it does not converge), raised by RANGE_MARGIN of the
    largest |m|.  Collective."""
    from petsc4py import PETSc

    from ..model.operators import largest_eigenvalue

    rows = []
    for t in 2 * np.pi * (np.arange(DIRECTIONS) + 0.5) / DIRECTIONS:
        mixed = A.copy()
        mixed.scale(math.cos(t))
        mixed.axpy(math.sin(t), C, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        try:
            top = largest_eigenvalue(mixed, True)[0].real
        except RuntimeError:  # Lanczos did not converge (clustered top): Gershgorin's bound, looser but sure
            top = mixed.norm(PETSc.NormType.INFINITY)
        finally:
            mixed.destroy()
        rows.append((math.cos(t), math.sin(t), top))
    rows = np.array(rows)
    rows[:, 2] += RANGE_MARGIN * np.abs(rows[:, 2]).max()
    return rows


def _rate_bounds(planes: np.ndarray, omega_max: float, c_max: float, w: float, r: float) -> tuple[float, float]:
    """(lo, hi): bounds on the damping rate sigma of a mode lambda = -sigma +- i omega with omega in
    [w - r, w + r]: (a, c) = (sigma^2 + omega^2, 2 sigma) lies in the numerical range
    (``_range_planes``; a <= omega_max^2, c <= c_max), checked on a grid of sigma and omega (one
    grid step added on either side); a column that reaches the real axis (w <= r) also holds the
    real roots, sigma in [0, c_max].  Not collective."""
    if w <= r:
        return 0.0, c_max * (1 + BOX_MARGIN)
    step = c_max / 2 / (RATE_GRID - 1)
    sigma = np.linspace(0.0, c_max / 2, RATE_GRID)[:, None]
    feasible = np.zeros(RATE_GRID, dtype=bool)
    for omega in np.linspace(w - r, w + r, OMEGA_GRID):
        a, c = sigma**2 + omega**2, 2 * sigma
        feasible |= ((planes[:, 0] * a + planes[:, 1] * c <= planes[:, 2]).all(axis=1)
                     & (a[:, 0] <= omega_max**2 * (1 + BOX_MARGIN)))
    if not feasible.any():
        return 0.0, 0.0
    index = np.flatnonzero(feasible)
    return max(sigma[index[0], 0] - step, 0.0), min(sigma[index[-1], 0] + step, c_max / 2)


def solve(dm, *, zero_tol: float, tol: float = 1e-12, window: tuple[float, float] | None = None, progress=None,
          checkpoint=None) -> tuple[np.ndarray, np.ndarray, dict]:
    """Every eigenvalue lambda of L (all 2n, module docstring) of ``dm`` (a symmetric
    :class:`~solver.model.dynmat.DynamicalMatrix` with dashpots ``dm.C``).  Collective; the same
    result on every rank.

    Returns (lam (2n,) complex, in the order found, those below ``zero_tol`` 0; sums
    (2n, W) reduced K/Q sums of each mode's normalised displacement |x|; checks: windows, the
    largest backward error, the trace moments' relative errors, the box, the settings used).
    ``window`` = (lo, hi): only the modes with |Im lambda| in [lo, hi) (the real roots too when
    lo = 0), by the columns from lo to hi, complete by their sigma bounds alone (no count, no
    trace moments: checks say so).  ``progress`` and ``checkpoint`` as ``shifted_windows.solve``.
    ``checks["shifts"]``: the complex shifts factorised and solved by this call (:func:`_solve_disk`;
    none for the columns read back from ``checkpoint``), the cost a benchmark reports
    (scripts/benchmarks/bench_damped.py).  RuntimeError (every rank) when a check fails."""
    from petsc4py import PETSc

    comm = dm.D.getComm()
    A, C = scaled_operator(dm), scaled_damping(dm)
    n2 = 2 * A.getSize()[0]
    used = {}
    try:
        box = checkpoint.load("plan") if checkpoint else None
        if box is None:
            omega, rate = largest_omega(dm), largest_damping_rate(dm)
            diag_a, diag_c = A.getDiagonal(), C.getDiagonal()
            box = {"lower": np.float64(window[0] if window else 0.0),
                   "upper": np.float64(window[1] if window else max(omega, rate) * (1 + BOX_MARGIN)),
                   "imag": np.float64(rate), "omega": np.float64(omega),
                   "trace": np.float64(-diag_c.sum()),
                   "trace2": np.float64(-2.0 * diag_a.sum() + C.norm(PETSc.NormType.FROBENIUS) ** 2),
                   "norm_a": np.float64(A.norm(PETSc.NormType.INFINITY)),
                   "norm_c": np.float64(C.norm(PETSc.NormType.INFINITY))}
            diag_a.destroy()
            diag_c.destroy()
            if checkpoint:
                checkpoint.save("plan", box)
        box = {k: float(v) for k, v in box.items()}
        norms = (box["norm_a"], box["norm_c"])
        if dm.range_planes is None:  # once per matrix: every band of pep_bands shares them
            dm.range_planes = _range_planes(A, C)
        planes = dm.range_planes
        state = {"centre": 0.0, "radius": 0.0, "shifts": 0}

        def bounds(w, r):
            return _rate_bounds(planes, box["omega"], box["imag"], w, r)

        def disk(a, w):
            state["shifts"] += 1
            found = _solve_disk(A, C, norms, a, w, tol, zero_tol, dm.dof, dm.dim)
            used.update(found.pop("settings"))
            return found

        def column(w):
            w = max(w, FIRST * box["omega"])  # w > 0: the first window's shift is below 0
            start = state["centre"]
            if state["radius"] > 0.0:  # the middle of the rates to cover, if a disk like the last one reaches both ends
                lo, hi = bounds(w, state["radius"])
                if hi - lo <= 2 * state["radius"] * math.sqrt(1 - HALF_MIN**2):
                    start = (lo + hi) / 2
            found = _column(disk, w, start, bounds)
            state["centre"], state["radius"] = float(found["extra"]["centre"]), float(found["radius"])
            return found

        def resumed(part):
            state["centre"], state["radius"] = float(part["centre"]), float(part["radius"])

        parts = shifted_windows.march(column, box, n2 if window is None else math.inf, option="-pep_eps_nev",
                                      checkpoint=checkpoint, progress=progress, resumed=resumed)
    finally:
        A.destroy()
        C.destroy()
    lam = np.concatenate([p["lambda"] for p in parts]) if parts else np.empty(0, complex)
    sums = np.concatenate([p["sums"] for p in parts]) if parts else np.empty((0, modes.sums_width(dm.dim)))
    residuals = np.concatenate([p["residuals"] if "residuals" in p else np.full(len(p["lambda"]), p["residual"])
                                for p in parts]) if parts else np.empty(0)  # a window checkpointed before it
    if window is not None:  # the last column reaches past hi
        inside = np.abs(lam.imag) < window[1]
        lam, sums, residuals = lam[inside], sums[inside], residuals[inside]
        checks = {"trace_error": math.nan, "trace2_error": math.nan, "imag_bound": box["imag"],
                  "real_bounds": [box["lower"], box["upper"]], "complete_by": "the columns' sigma bounds"}
    else:
        checks = _check(lam, n2, box)
    # the accepted modes' backward errors: a column's disks also return Ritz pairs outside its
    # omega range, which the march leaves to the next column (their vectors need not be converged)
    checks.update(windows=len(parts), shifts=state["shifts"], max_residual=float(residuals.max(initial=0.0)),
                  settings=comm.tompi4py().bcast(used, root=0))
    return lam, sums, checks


def _check(lam: np.ndarray, n2: int, box: dict) -> dict:
    """The count and the trace moments (module docstring): their relative errors, or
    RuntimeError. Not collective (same data everywhere)."""
    if lam.size != n2:
        advice = ("raise -pep_eps_nev" if lam.size < n2 else
                  f"keep -pep_eps_nev at its default {NEV} (measured: 400 counts a mode twice at N = 512)")
        raise RuntimeError(f"pep windows: {lam.size} eigenvalues accepted for a problem with {n2} (an "
                           f"eigenvalue {'missed' if lam.size < n2 else 'counted twice'}); {advice} or "
                           f"use spectrum.solver: dense")
    tiny = np.finfo(float).tiny
    first = abs(lam.sum() - box["trace"]) / max(np.abs(lam).sum(), tiny)
    second = abs((lam**2).sum() - box["trace2"]) / max((np.abs(lam) ** 2).sum(), tiny)
    if max(first, second) > TRACE_TOL:
        raise RuntimeError(f"pep windows: the eigenvalues found miss tr L by {first:.1e} and tr L^2 by "
                           f"{second:.1e} (relative; allowed {TRACE_TOL:g}): some eigenvalue or a root's sign "
                           f"is wrong")
    return {"trace_error": first, "trace2_error": second, "imag_bound": box["imag"],
            "real_bounds": [box["lower"], box["upper"]]}
