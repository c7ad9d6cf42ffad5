"""The full spectrum of a matrix that need not be symmetric (``spectrum.method: nonhermitian``):
the stressed dynamical matrix of a frictional packing (docs/stressed_contacts.md section 4),
whose omega^2 may be complex.

Methods [decision] (``spectrum.solver``): the eigenvalues lambda = omega^2 of
A = M^-1/2 D M^-1/2 (similar to M^-1 D), all of them,
  dense    by LAPACK's dense non-symmetric solver (``scipy.linalg.eigvals``: Hessenberg QR,
           backward stable) on rank 0, broadcast to every rank; up to MAX_DOF, time ~ n^3;
  windows  by SLEPc shift-and-invert windows marched along the real axis, checked complete by
           the count and the trace moments (``shifted_windows``); sparse, any size;
  auto     dense up to AUTO_DENSE_DOF, windows above (scripts/benchmarks/bench_nonhermitian.py: the
           windows overtake dense near there).

Classification of the eigenvalues (``zero_tol`` as the other methods: omega below it is zero):
  zero      |lambda| < zero_tol^2 (the rigid modes);
  complex   |Im lambda| > IMAG_TOL * max |lambda| (a conjugate pair: oscillatory instability,
            growth rate Im sqrt(lambda));
  negative  real, Re lambda < 0 (static instability, growth rate sqrt(-lambda));
  stable    real, Re lambda > 0: omega = sqrt(Re lambda), the modes the vDOS counts.
Collective on the matrix's communicator.  Units: omega in 1/t0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_DOF = 20000   # a dense n x n complex eigensolve: 20000 DOF take ~1 h and 6 GiB
AUTO_DENSE_DOF = 3000  # scripts/benchmarks/bench_nonhermitian.py, one core each: they cross near 2900 DOF (dense 1.08x windows)
IMAG_TOL = 1e-9   # relative to max |lambda|: LAPACK's round-off is ~1e-15 of it


@dataclass
class Result:
    """omega2 (n,) complex128, every non-zero eigenvalue sorted by real part; omega (m,) the
    stable ones' frequencies, ascending; counts n_zero_modes, n_complex (eigenvalues, both
    members of each pair), n_negative; max_growth: the largest growth rate of an unstable mode
    (1/t0; 0 when none); energies: K, Q and participation of each stable mode (aligned with
    ``omega``; ``modes.energies``), or None."""

    omega2: np.ndarray
    omega: np.ndarray
    n_zero_modes: int
    n_complex: int
    n_negative: int
    max_growth: float
    energies: dict | None = None
    solver: str = "dense"
    checks: dict | None = None  # windows: their number, residual, trace errors, settings


def chosen_solver(solver: str, size: int) -> str:  # solver: one of plan.SOLVERS
    """dense or windows for ``spectrum.solver`` on a matrix of ``size`` DOF (auto: dense up to
    AUTO_DENSE_DOF)."""
    if solver == "auto":
        return "dense" if size <= AUTO_DENSE_DOF else "windows"
    return solver


def solve(dm, zero_tol: float, vectors: bool = False, solver: str = "auto", tol: float = 1e-12,
          progress=None, checkpoint=None) -> Result:
    """Every eigenvalue of A = M^-1/2 D M^-1/2 of ``dm`` (a :class:`~solver.model.dynmat.DynamicalMatrix`),
    classified (module docstring); with ``vectors``, also the K, Q and participation of each
    stable mode from its right eigenvector e of A, real for a real eigenvalue, scaled to |e| = 1
    (the definitions of ``modes``; for a non-symmetric A the right eigenvectors are not
    orthogonal, and these are each mode's own shares).  ``solver``: dense, windows or auto
    (module docstring); ``tol``, ``progress`` and ``checkpoint`` are the windows' (as for
    slicing).  Collective: dense solves on rank 0 (``parallel.owner_compute``: its result, or
    its error, reaches every rank); ValueError for dense above MAX_DOF."""
    from .. import parallel
    from ..model import dynmat
    from . import shifted_windows

    particles = int(dm.active.sum())
    if chosen_solver(solver, dm.size) == "windows":
        lam, sums, checks = shifted_windows.solve(dm, zero_tol=zero_tol, vectors=vectors, tol=tol,
                                                  progress=progress, checkpoint=checkpoint)
        return _classify(lam, sums, zero_tol, particles, dm.dim, "windows", checks)
    if dm.size > MAX_DOF:
        raise ValueError(f"spectrum.method nonhermitian: {dm.size} DOF > {MAX_DOF}, the dense solver's limit")
    d = dynmat.gather_csr(dm.D)  # collective: every rank takes part
    mass = dynmat.gather_vec(dm.M)
    dense = (d, mass, vectors, dm.dof, dm.dim)
    lam, sums = parallel.owner_compute(dm.D.getComm().tompi4py(), [dense], _dense_solve)[0]
    return _classify(lam, sums, zero_tol, particles, dm.dim, "dense", None)


def _dense_solve(task) -> tuple[np.ndarray, np.ndarray | None]:
    """The dense solve on one rank: task = (D as CSR, M (n,), vectors, dof, dim) -> (lam (n,)
    complex, the reduced K/Q sums (n, W) of each eigenvector's real part after its phase is
    removed, scaled to unit length (a real eigenvalue's vector), or None)."""
    import scipy.linalg as sl

    from . import modes

    d, mass, vectors, dof, dim = task
    scale = 1.0 / np.sqrt(mass)
    a = d.multiply(scale[:, None]).multiply(scale[None, :]).toarray()
    if not vectors:
        return sl.eigvals(a, overwrite_a=True, check_finite=False), None
    lam, vec = sl.eig(a, overwrite_a=True, check_finite=False)
    vec = vec * np.exp(-1j * np.angle(vec[np.argmax(np.abs(vec), axis=0), np.arange(vec.shape[1])]))
    real = vec.real / np.linalg.norm(vec.real, axis=0)
    return lam, modes.local_sums(real.T, dof, dim)


def _classify(lam: np.ndarray, sums: np.ndarray | None, zero_tol: float, particles: int, dim: int,
              solver: str, checks: dict | None) -> Result:
    """Sort and classify the eigenvalues ``lam`` (module docstring); the stable modes' energies
    from their rows of ``sums`` (aligned with ``lam``). Not collective."""
    from . import modes

    zero = np.abs(lam) < zero_tol ** 2
    order = np.flatnonzero(~zero)[np.argsort(lam[~zero].real, kind="stable")]
    rest = lam[order]
    complex_ = np.abs(rest.imag) > IMAG_TOL * np.abs(lam).max(initial=0.0)
    negative = ~complex_ & (rest.real < 0.0)
    stable = ~complex_ & ~negative
    shares = None if sums is None else modes.energies(sums[order[stable]], particles, dim)
    growth = np.sqrt(rest[~stable].astype(complex)).imag
    return Result(omega2=rest.astype(np.complex128), omega=np.sqrt(rest.real[stable]),
                  n_zero_modes=int(zero.sum()), n_complex=int(complex_.sum()), n_negative=int(negative.sum()),
                  max_growth=float(np.abs(growth).max()) if growth.size else 0.0, energies=shares,
                  solver=solver, checks=checks)
