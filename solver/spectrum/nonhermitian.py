"""The full spectrum of a matrix that need not be symmetric (``spectrum.method: nonhermitian``):
the stressed dynamical matrix of a frictional packing (docs/stressed_contacts.md section 4),
whose omega^2 may be complex.

Method [decision]: the eigenvalues lambda = omega^2 of A = M^-1/2 D M^-1/2 (similar to M^-1 D),
all of them, by LAPACK's dense non-symmetric solver (``scipy.linalg.eigvals``: Hessenberg QR,
backward stable) on rank 0, broadcast to every rank.  Dense is the tool for a full spectrum of a
non-normal matrix at the sizes where one is wanted (up to MAX_DOF); a frequency window on a large
non-symmetric matrix (SLEPc Krylov-Schur with shift-and-invert, ``EPS_NHEP``) needs a way to know
that every eigenvalue in it was found, which inertia gave the symmetric methods: not built.

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


def solve(dm, zero_tol: float, vectors: bool = False) -> Result:
    """Every eigenvalue of A = M^-1/2 D M^-1/2 of ``dm`` (a :class:`~solver.model.dynmat.DynamicalMatrix`),
    classified (module docstring); with ``vectors``, also the K, Q and participation of each
    stable mode from its right eigenvector e of A, real for a real eigenvalue, scaled to |e| = 1
    (the definitions of ``modes``; for a non-symmetric A the right eigenvectors are not
    orthogonal, and these are each mode's own shares).  Collective: rank 0 solves
    (``parallel.owner_compute``: its result, or its error, reaches every rank); ValueError above
    MAX_DOF."""
    from .. import parallel
    from ..model import dynmat

    if dm.size > MAX_DOF:
        raise ValueError(f"spectrum.method nonhermitian: {dm.size} DOF > {MAX_DOF}, the dense solver's limit")
    d = dynmat.gather_csr(dm.D)  # collective: every rank takes part
    mass = dynmat.gather_vec(dm.M)
    dense = (d, mass, zero_tol, vectors, dm.dof, dm.dim, int(dm.active.sum()))
    return parallel.owner_compute(dm.D.getComm().tompi4py(), [dense], _dense_solve)[0]


def _dense_solve(task) -> Result:
    """:func:`solve`'s work on one rank: task = (D as CSR, M (n,), zero_tol, vectors, dof, dim,
    particles)."""
    import scipy.linalg as sl

    from . import modes

    d, mass, zero_tol, vectors, dof, dim, particles = task
    scale = 1.0 / np.sqrt(mass)
    a = d.multiply(scale[:, None]).multiply(scale[None, :]).toarray()
    if vectors:
        lam, vec = sl.eig(a, overwrite_a=True, check_finite=False)
    else:
        lam = sl.eigvals(a, overwrite_a=True, check_finite=False)
    zero = np.abs(lam) < zero_tol ** 2
    order = np.flatnonzero(~zero)[np.argsort(lam[~zero].real, kind="stable")]
    rest = lam[order]
    complex_ = np.abs(rest.imag) > IMAG_TOL * np.abs(lam).max()
    negative = ~complex_ & (rest.real < 0.0)
    stable = ~complex_ & ~negative
    shares = None
    if vectors:
        kept = vec[:, order[stable]]
        kept = kept * np.exp(-1j * np.angle(kept[np.argmax(np.abs(kept), axis=0), np.arange(kept.shape[1])]))
        real = kept.real / np.linalg.norm(kept.real, axis=0)  # a real eigenvalue's vector, phase removed
        shares = modes.energies(modes.local_sums(real.T, dof, dim), particles, dim)
    growth = np.sqrt(rest[~stable].astype(complex)).imag
    return Result(omega2=rest.astype(np.complex128), omega=np.sqrt(rest.real[stable]),
                  n_zero_modes=int(zero.sum()), n_complex=int(complex_.sum()), n_negative=int(negative.sum()),
                  max_growth=float(np.abs(growth).max()) if growth.size else 0.0, energies=shares)
