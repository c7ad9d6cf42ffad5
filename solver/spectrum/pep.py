"""Damped modes (``spectrum.method: pep``): every eigenvalue lambda of the quadratic eigenproblem
(lambda^2 M + lambda C + D) x = 0 of a packing with contact dashpots C (docs/damping.md section 6).

Each mode is lambda = -sigma + i omega_d: damped frequency omega_d, damping rate sigma, quality
factor Q = omega_d / (2 sigma); a real lambda is overdamped.  The problem has 2n eigenvalues (n
DOF), those of the first-order matrix L = [[0, I], [-A, -C^]], A = M^-1/2 D M^-1/2,
C^ = M^-1/2 C M^-1/2: the complex ones in conjugate pairs, the real ones <= 0.

Methods [decision] (``spectrum.solver``):
  dense    LAPACK's non-symmetric solver (``scipy.linalg.eig``) on L, on rank 0, broadcast;
           up to MAX_DOF (L is 2n x 2n), time ~ (2n)^3;
  windows  windows in mu = lambda^2 by SLEPc (``quadratic_windows``), checked complete by the
           count and the trace moments; sparse, any size; symmetric D only;
  auto     dense up to AUTO_DENSE_DOF, windows above (scripts/benchmarks/bench_damped.py).

What is kept (``lam``): every eigenvalue with Im lambda > 0 once (the other of its pair is its
conjugate), every real one (both of an overdamped pair), sorted by Im then Re; the zeros
(|lambda| < zero_tol: two per rigid-body mode) only counted, so that
    n_zero_modes + 2 (complex kept) + (real kept) = 2n.
Collective on the matrix's communicator.  Units: lambda in 1/t0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_DOF = 8000          # L is 16000 x 16000: a dense complex eigensolve of ~1 h and 8 GiB with vectors
AUTO_DENSE_DOF = 4000   # scripts/benchmarks/bench_damped.py: dense 205 s, windows 265 s at 3033 DOF; ~DOF^3.3 and ^2.1 cross near 3800
IMAG_TOL = 1e-10        # |Im lambda| below this times max |lambda| is real (LAPACK's round-off ~1e-15)


@dataclass
class Result:
    """lam (m,) complex128 the kept eigenvalues (module docstring); n_zero_modes; n_overdamped
    (real lam kept); energies: K, Q and participation of each kept mode from |x| (``modes``),
    or None; solver; checks (windows: their number, shifts: the complex shifts solved, residual, trace
    errors, settings)."""

    lam: np.ndarray
    n_zero_modes: int
    n_overdamped: int
    energies: dict | None = None
    solver: str = "dense"
    checks: dict | None = None


def chosen_solver(solver: str, size: int) -> str:  # solver: one of plan.SOLVERS
    """dense or windows for ``spectrum.solver`` on a matrix of ``size`` DOF."""
    if solver == "auto":
        return "dense" if size <= AUTO_DENSE_DOF else "windows"
    return solver


def solve(dm, zero_tol: float, vectors: bool = False, solver: str = "auto", tol: float = 1e-12,
          window: tuple[float, float] | None = None, progress=None, checkpoint=None) -> Result:
    """The damped modes of ``dm`` (a :class:`~solver.model.dynmat.DynamicalMatrix` with ``dm.C``),
    classified (module docstring); with ``vectors`` also the K, Q and participation of each kept
    mode.  ``window`` = (lo, hi), or a list of such bands (disjoint): only the modes with
    Im lambda in them (and the real ones when a band starts at 0; the counts then of those only).  ``solver``: dense, windows or auto; ``tol``,
    ``progress`` and ``checkpoint`` are the windows'.  Collective: dense solves on rank 0 (``parallel.owner_compute``).  ValueError for
    dense above MAX_DOF or windows on a non-symmetric D."""
    from .. import parallel
    from ..model import dynmat
    from . import quadratic_windows

    particles = int(dm.active.sum())
    bands = [tuple(window)] if window is not None and np.ndim(window[0]) == 0 else window
    if chosen_solver(solver, dm.size) == "windows":
        if not dm.symmetric:
            raise ValueError("spectrum.method pep with solver windows needs a symmetric D; a stressed "
                             "packing's damped modes: spectrum.solver dense")
        found = []
        for index, band in enumerate(bands or [None]):  # each band its own march, its own checkpoints
            found.append(quadratic_windows.solve(
                dm, zero_tol=zero_tol, tol=tol, window=band, progress=progress,
                checkpoint=_Prefixed(checkpoint, f"band{index:03d}_") if checkpoint and bands else checkpoint))
        lam = np.concatenate([f[0] for f in found])
        sums = np.concatenate([f[1] for f in found])
        checks = {**found[0][2], "windows": sum(f[2]["windows"] for f in found),
                  "shifts": sum(f[2]["shifts"] for f in found),
                  "max_residual": max(f[2]["max_residual"] for f in found)}
        return _classify(lam, sums if vectors else None, zero_tol, particles, dm.dim, "windows", checks, bands)
    if dm.size > MAX_DOF:
        raise ValueError(f"spectrum.method pep: {dm.size} DOF > {MAX_DOF}, the dense solver's limit")
    task = (dynmat.gather_csr(dm.D), dynmat.gather_csr(dm.C), dynmat.gather_vec(dm.M), vectors, dm.dof, dm.dim)
    lam, sums = parallel.owner_compute(dm.D.getComm().tompi4py(), [task], _dense_solve)[0]
    return _classify(lam, sums, zero_tol, particles, dm.dim, "dense", None, bands)


class _Prefixed:
    """A window checkpoint (``load``/``save``/``clear``) whose names carry ``prefix``: one per band."""

    def __init__(self, checkpoint, prefix: str):
        self.checkpoint, self.prefix = checkpoint, prefix

    def load(self, name: str):
        return self.checkpoint.load(self.prefix + name)

    def save(self, name: str, datasets: dict) -> None:
        self.checkpoint.save(self.prefix + name, datasets)


def first_order_dense(d, c, mass) -> np.ndarray:
    """L = [[0, I], [-A, -C^]] (2n, 2n) from D and C (scipy sparse) and the masses M (n,). Not
    collective."""
    scale = 1.0 / np.sqrt(mass)
    n = mass.size
    L = np.zeros((2 * n, 2 * n))
    L[:n, n:] = np.eye(n)
    L[n:, :n] = -d.multiply(scale[:, None]).multiply(scale[None, :]).toarray()
    L[n:, n:] = -c.multiply(scale[:, None]).multiply(scale[None, :]).toarray()
    return L


def _dense_solve(task) -> tuple[np.ndarray, np.ndarray | None]:
    """The dense solve on one rank: task = (D, C as CSR, M (n,), vectors, dof, dim) -> (lam (2n,),
    the reduced K/Q sums (2n, W) of each eigenvector's normalised displacement |x|, or None)."""
    import scipy.linalg as sl

    from . import modes

    d, c, mass, vectors, dof, dim = task
    L = first_order_dense(d, c, mass)
    if not vectors:
        return sl.eigvals(L, overwrite_a=True, check_finite=False), None
    lam, vec = sl.eig(L, overwrite_a=True, check_finite=False)
    x = vec[: mass.size]
    x = np.abs(x) / np.linalg.norm(x, axis=0)
    return lam, modes.local_sums(x.T, dof, dim)


def _classify(lam: np.ndarray, sums: np.ndarray | None, zero_tol: float, particles: int, dim: int,
              solver: str, checks: dict | None, bands: list | None = None) -> Result:
    """Keep, sort and count the eigenvalues ``lam`` (module docstring; within the ``bands``
    [(lo, hi), ...] of |Im lambda| only); the kept modes' energies from their rows of ``sums``.
    RuntimeError when the complex ones are not in pairs.  Not collective."""
    from . import modes

    if bands is not None:
        inside = np.zeros(lam.size, dtype=bool)
        for lo, hi in bands:
            inside |= (np.abs(lam.imag) >= lo) & (np.abs(lam.imag) < hi)
        lam, sums = lam[inside], None if sums is None else sums[inside]
    zero = np.abs(lam) < zero_tol
    real = ~zero & (np.abs(lam.imag) <= IMAG_TOL * np.abs(lam).max(initial=0.0))
    upper = ~zero & ~real & (lam.imag > 0)
    if 2 * upper.sum() != (~zero & ~real).sum():
        raise RuntimeError(f"pep: {upper.sum()} eigenvalues above the real axis and "
                           f"{(~zero & ~real).sum() - upper.sum()} below: not conjugate pairs")
    keep = np.flatnonzero(real | upper)
    keep = keep[np.lexsort((lam[keep].real, np.where(real[keep], 0.0, lam[keep].imag)))]
    kept = np.where(real[keep], lam[keep].real + 0j, lam[keep])
    shares = None if sums is None else modes.energies(sums[keep], particles, dim)
    return Result(lam=kept.astype(np.complex128), n_zero_modes=int(zero.sum()), n_overdamped=int(real.sum()),
                  energies=shares, solver=solver, checks=checks)
