"""The Allen-Feldman diffusivity d_n of every mode, exactly, from the eigenvectors (issue 45,
point 1; derivation in docs/diffusivity.md).

With A = M^-1/2 D M^-1/2 (``model.operators.scaled_operator``: translations and rotations,
rattlers removed), A e_n = omega_n^2 e_n, |e_n| = 1, and for each axis a the position operator

    X^a = A with its (particle i, particle j) block times (r_i - r_j)_a   (minimum image; X^a = -X^a^T),
    Y^a_nm = e_n^T X^a e_m,
    d_n = pi / (4 D omega_n^2) sum_{m != n} sum_a |Y^a_nm|^2 (omega_n + omega_m)^2 / (4 omega_n omega_m)
          L_eta(omega_n - omega_m),      L_eta(x) = (eta / pi) / (x^2 + eta^2),

both sums over the modes with omega > zero_tol (the spectrum's rule: slicing's interval starts at
zero_tol^2, so the rigid modes and, on an unstable packing, negative ones are left out).
Units: d0 = m = kn = 1, t0 = 1; omega and eta in 1/t0, d in d0^2/t0.  Allen & Feldman, PRB 48,
12581 (1993); the rotations sit at their particle's centre.

Decision: how the eigenvectors meet in the double sum.  The modes are taken in blocks (the
windows of spectrum slicing, at most ``block`` modes each, placed by Sylvester inertias exactly as
``spectrum.slicing.solve`` places them, :func:`sliced_modes`), each window solved once.  A
window's vectors are written to a scratch file per rank (this rank's rows, ``nloc x b`` float64,
``.npy``) and read back when needed; without a scratch directory they stay in memory (small N,
tests: n^2 memory then).  The sum runs over pairs of blocks P <= Q only: X^a is antisymmetric, so
|Y^a_nm| = |Y^a_mn| and the pair weight is symmetric in (n, m), and one product serves both
blocks (row sums to d of P, column sums to d of Q).  For each P: Z^a_P = X^a V_P (PETSc
MatMatMult, AIJ x dense, D of them), then for each Q >= P: Y^a_PQ = -(Z^a_P)^T V_Q as one local
dgemm per rank and an Allreduce of the (D, b_P, b_Q) block.  The slicing interval starts at a
shift clear of the zero modes with the same count below it as zero_tol^2 (:func:`_clear_start`):
from zero_tol^2 itself the first sub-interval's vectors had residuals of 1e-8 on 2 ranks.

Cost, n DOF, M non-zero modes (M ~ n), block b, p ranks:
  flops     D n M^2 (the dgemms: 2 n b_P b_Q per axis and pair, over M^2/2 pairs of modes),
            plus D nnz(A) M for the sparse products, plus the spectrum slicing itself;
  memory    (2 + D) n b / p float64 per rank (V_P, Z^a_P, V_Q) plus 2 D b^2 (the reduced block):
            O(n b), never n^2;  N = 8192 disks (n = 24576), b = 1000: ~0.4 GB per rank on 2 ranks;
  disk      8 n M bytes in all (4.8 GB at N = 8192), split over the ranks, read W (W + 1) / 2
            blocks' worth in the pair loop (W = M / b windows), mostly from the page cache;
  messages  one Allreduce of 8 D b_P b_Q bytes per pair of blocks.
Recomputing each window when needed instead of storing it would cost W / 2 spectrum solves.

The low-frequency window (``omega_top``): only the modes up to omega_top + TAIL_ETAS eta are
sliced, M_w of them, and d is returned for those up to omega_top; the cost falls to D n M_w^2 and
8 n M_w bytes, the spectrum slicing of M_w modes included.  It truncates the Lorentzian's tails at
TAIL_ETAS eta from omega_top (bounded in :data:`TAIL_ETAS`); without it nothing is truncated.

Collective on the matrix's communicator ``comm``; every rank returns the same arrays, equal on
1 and 2 ranks to round-off.
"""

from __future__ import annotations

import math
import pathlib
from dataclasses import dataclass, field

import numpy as np

from .. import parallel, profiling
from ..options import eps_settings
from ..model.operators import largest_omega, scaled_operator
from ..packing.geometry import minimum_image
from ..spectrum import slicing


def position_operators(dm, positions: np.ndarray, box: np.ndarray, comm) -> list:
    """X^a (a = 0 .. D-1) of ``dm`` as PETSc AIJ Mats on ``comm`` (the matrix's communicator) with
    A's sparsity, row layout and block size ``dm.dof``: every entry of A = M^-1/2 D M^-1/2 between
    matrix particles i and j times the minimum-image (r_i - r_j)_a (d0; diagonal blocks are kept
    as explicit zeros).  ``positions`` (N, D) in d0 of every particle in the packing's order,
    ``box`` the periodic cell (a ``geometry.Cell``, or its (D,) sides); the matrix's own particle
    order (``dm.order``) is applied here.  Collective; the caller destroys the Mats (destroyed here if one fails)."""
    from petsc4py import PETSc

    A = scaled_operator(dm)
    try:
        indptr, indices, values = A.getValuesCSR()
        start, stop = A.getOwnershipRange()
        sizes = A.getSizes()
    finally:
        A.destroy()
    dof = dm.dof
    rows = start + np.repeat(np.arange(stop - start), np.diff(indptr))
    particles = np.asarray(positions, dtype=float)[dm.order]  # matrix particle -> position
    delta = minimum_image(particles[rows // dof] - particles[indices // dof], box)
    mats = []
    try:
        for axis in range(dm.dim):
            mats.append(PETSc.Mat().createAIJ(size=sizes, bsize=dof, csr=(indptr, indices, values * delta[:, axis]),
                                              comm=comm))
            mats[-1].assemble()
    except BaseException:
        for X in mats:
            X.destroy()
        raise
    return mats


@dataclass
class ModeBlocks:
    """Non-zero modes of A in blocks of ascending omega: ``omegas[w]`` (b_w,) in 1/t0 and
    ``stored[w]``, this rank's rows (nloc, b_w) of the block's orthonormal eigenvectors on A's
    layout, as an array (Fortran order) or the path of this rank's ``.npy`` scratch file;
    ``settings``: what the windows' EPS used (``options.eps_settings`` of the first window, after
    setFromOptions; empty for blocks made from arrays); ``zero``: the modes with omega^2 <=
    zero_tol^2 (zero and negative) that slicing left out (0 for blocks made from arrays)."""

    omegas: list
    stored: list
    settings: dict = field(default_factory=dict)
    zero: int = 0

    def __len__(self) -> int:
        return len(self.omegas)

    @property
    def omega(self) -> np.ndarray:
        """Every mode's omega (M,), ascending."""
        return np.concatenate(self.omegas) if self.omegas else np.empty(0)

    def vectors(self, w: int, comm) -> np.ndarray:
        """This rank's rows (nloc, b_w) of block ``w``, read from its scratch file if stored there;
        a read that fails on one rank raised on every rank of ``comm`` (mpi4py).  Collective."""
        item = self.stored[w]
        if not isinstance(item, np.ndarray):
            item = parallel.on_every_rank(comm, lambda: np.load(item))
        return np.asfortranarray(item)

    def remove_files(self) -> None:
        """Delete this rank's scratch files (those half written too). Not collective."""
        for item in self.stored:
            if not isinstance(item, np.ndarray):
                pathlib.Path(item).unlink(missing_ok=True)

    @classmethod
    def from_arrays(cls, omega: np.ndarray, local: np.ndarray, block: int, zero_tol: float = 1e-4) -> ModeBlocks:
        """Blocks of at most ``block`` modes from all eigenpairs at once: ``omega`` (M,) in 1/t0 and
        this rank's rows ``local`` (nloc, M) of the eigenvectors; modes with omega <= ``zero_tol``
        dropped.  In memory (n M float64 in all): tests, small N.  Not collective."""
        omega = np.asarray(omega, dtype=float)
        keep = np.flatnonzero(omega > zero_tol)
        keep = keep[np.argsort(omega[keep], kind="stable")]
        pieces = [keep[i:i + block] for i in range(0, keep.size, block)]
        return cls([omega[p] for p in pieces], [np.asfortranarray(local[:, p]) for p in pieces])


def _window_vectors(A, eps, vec, image) -> tuple[np.ndarray, np.ndarray]:
    """(lam (b,), this rank's rows (nloc, b) of the normalised vectors) of a solved slicing ``eps``,
    lam the Rayleigh quotients (as ``slicing``), ascending. Collective."""
    nconv = eps.getConverged()
    lam = np.empty(nconv)
    local = np.empty((vec.getLocalSize(), nconv), order="F")
    for i in range(nconv):  # one vector at a time into the block
        eps.getEigenpair(i, vec)
        vec.normalize()
        A.mult(vec, image)
        lam[i] = image.dot(vec)
        local[:, i] = vec.getArray(readonly=True)
    order = np.argsort(lam, kind="stable")
    return lam[order], np.asfortranarray(local[:, order])


def _clear_start(A, lam_zero: float, hi: float, zero: int) -> float:
    """A shift s with the count of ``lam_zero`` (``zero`` eigenvalues below it) and lambda_1 / 4 <= s
    < lambda_1 / 2 (lambda_1 the first eigenvalue above ``lam_zero``, below ``hi``; s = ``lam_zero``
    itself when lambda_1 < 2 ``lam_zero``), by bisection
    in log(s) on Sylvester inertias (about log2 log2(hi / lam_zero) factorisations).  Slicing from
    lam_zero itself factorises A - lam_zero I beside the zero modes (relative distance ~1e-10):
    the vectors of the first sub-interval then had residuals of 1e-8 on 2 ranks (1e-13 from this
    shift), which the diffusivity inherits.  Collective."""
    low, high = lam_zero, hi
    while high > 2.0 * low:
        mid = math.sqrt(low * high)
        if slicing.count_below(A, mid) == zero:
            low = mid
        else:
            high = mid
    return max(0.5 * low, lam_zero)


PREFIX = "transport_"
"""Options prefix of the diffusivity's slicing windows (-transport_eps_*, -transport_st_*)."""


@profiling.logged("rsAFModes")
def sliced_modes(dm, comm, *, zero_tol: float = 1e-4, tol: float = 1e-12, block: int = 1000,
                 scratch=None, omega_cut: float | None = None) -> ModeBlocks:
    """Every mode of ``dm`` with omega > ``zero_tol`` (and omega <= ``omega_cut``, 1/t0, if given:
    the slicing interval then ends at omega_cut^2) in slicing windows of at most ~``block``
    modes from a start clear of the zero modes (:func:`_clear_start`), each window solved once
    (``spectrum.slicing``'s plan, split and EPS, options prefix :data:`PREFIX`; ``tol`` the default
    that -transport_eps_tol overrides) and its vectors written to ``scratch`` (a directory, rank 0's name used by all;
    one ``.npy`` per window and rank) or, with ``scratch`` None, kept in memory.  omega are
    Rayleigh quotients.  Collective; RuntimeError on every rank if a window's converged count
    differs from its inertia count; a folder or file that one rank cannot write raised on every
    rank.  On an error this rank's files written so far are removed."""
    from petsc4py import PETSc
    from slepc4py import SLEPc

    mpi = comm.tompi4py()
    if scratch is not None:
        scratch = pathlib.Path(mpi.bcast(str(scratch), root=0))
        parallel.on_every_rank(mpi, lambda: _make_folder(scratch))
    modes = ModeBlocks([], [])
    A = scaled_operator(dm)
    vec = image = None
    try:
        vec, image = A.createVecRight(), A.createVecLeft()
        hi = largest_omega(dm) ** 2 * (1 + 1e-6)  # as slicing.solve: Lanczos top, Gershgorin if it misses modes
        if slicing.count_below(A, hi) < A.getSize()[0]:
            hi = A.norm(PETSc.NormType.INFINITY) * (1 + 1e-9)
        if omega_cut is not None:
            hi = min(hi, omega_cut**2)
        zero = modes.zero = slicing.count_below(A, zero_tol**2)
        if zero == slicing.count_below(A, hi):  # no mode in (zero_tol^2, hi]
            return modes
        edges, counts, known = slicing.plan_windows(A, _clear_start(A, zero_tol**2, hi, zero), hi, block)
        for w in range(edges.size - 1):
            sub = slicing.split_window(A, known, float(edges[w]), float(edges[w + 1]), comm.getSize())
            eps = SLEPc.EPS().create(comm)
            try:
                slicing.configure_window(eps, A, sub, tol, PREFIX)
                eps.solve()
                if not modes.settings:  # what the windows use, read back after setFromOptions; rank 0's
                    modes.settings = mpi.bcast(eps_settings(eps), root=0)
                expected = int(counts[w + 1] - counts[w])
                if eps.getConverged() != expected:
                    raise RuntimeError(f"allen_feldman: window {w} converged {eps.getConverged()} modes, "
                                       f"its inertia counts {expected}")
                lam, local = _window_vectors(A, eps, vec, image)
            finally:
                eps.destroy()
            modes.omegas.append(np.sqrt(lam))
            if scratch is None:
                modes.stored.append(local)
            else:
                path = scratch / f"af_window{w:04d}_rank{mpi.rank:04d}.npy"
                modes.stored.append(str(path))  # before the write: a half-written file is removed too
                parallel.on_every_rank(mpi, lambda: np.save(path, local))
    except BaseException:  # the windows written so far: up to 8 n M bytes over the ranks (4.8 GB at N = 8192)
        modes.remove_files()
        raise
    finally:
        for owned in (vec, image, A):
            if owned is not None:
                owned.destroy()
    return modes


def _make_folder(folder: pathlib.Path) -> None:
    """``mkdir -p folder``, tried once more if a parent vanished meanwhile: the transport unit of
    another group of ranks removes their shared parent when it is left empty.  Not collective."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileNotFoundError:
        folder.mkdir(parents=True, exist_ok=True)


def pair_weights(omega_n: np.ndarray, omega_m: np.ndarray, eta: float) -> np.ndarray:
    """(b_n, b_m): (omega_n + omega_m)^2 / (4 omega_n omega_m) L_eta(omega_n - omega_m), in t0.
    Not collective."""
    wn, wm = omega_n[:, None], omega_m[None, :]
    return (wn + wm) ** 2 / (4.0 * wn * wm) * (eta / math.pi) / ((wn - wm) ** 2 + eta**2)


@profiling.logged("rsAFSum")
def diffusivity(X: list, modes: ModeBlocks, eta: float, comm) -> np.ndarray:
    """d (M,) in d0^2/t0 of every mode of ``modes`` (ascending omega, as ``modes.omega``) from the
    position operators ``X`` (:func:`position_operators`, one per axis) at Lorentzian half-width
    ``eta`` (1/t0), by pairs of blocks P <= Q (module docstring).  Collective on ``comm`` (the
    matrix's); the same array on every rank."""
    from mpi4py import MPI

    if not (math.isfinite(eta) and eta > 0):
        raise ValueError(f"eta must be finite and > 0, not {eta!r}")
    mpi = comm.tompi4py()
    sums = [np.zeros(w.size) for w in modes.omegas]
    for p in range(len(modes)):
        v_p = modes.vectors(p, mpi)
        z_p = _products(X, v_p, comm)
        for q in range(p, len(modes)):
            v_q = v_p if q == p else modes.vectors(q, mpi)
            block = np.stack([za.T @ v_q for za in z_p])  # -Y^a_PQ, this rank's rows' share
            mpi.Allreduce(MPI.IN_PLACE, block, op=MPI.SUM)
            weighted = np.einsum("anm,anm->nm", block, block) * pair_weights(modes.omegas[p], modes.omegas[q], eta)
            if q == p:
                np.fill_diagonal(weighted, 0.0)  # m != n (Y_nn = 0 anyway: X^a is antisymmetric)
                sums[p] += weighted.sum(axis=1)
            else:
                sums[p] += weighted.sum(axis=1)
                sums[q] += weighted.sum(axis=0)
    omega = modes.omega
    dim = len(X)
    return math.pi / (4.0 * dim * omega**2) * (np.concatenate(sums) if sums else np.empty(0))


def _products(X: list, v: np.ndarray, comm) -> list[np.ndarray]:
    """This rank's rows (nloc, b) of Z^a = X^a V (a = 0 .. D-1; Fortran order) for this rank's rows
    ``v`` (nloc, b) of V: the only sparse products.  Collective on ``comm`` (petsc4py)."""
    from petsc4py import PETSc

    dense = PETSc.Mat().createDense(((v.shape[0], X[0].getSize()[0]), (None, v.shape[1])), array=v, comm=comm)
    try:
        dense.assemble()
        z = []
        for Xa in X:
            product = Xa.matMult(dense)
            try:
                z.append(np.array(product.getDenseArray(readonly=True), order="F"))
            finally:
                product.destroy()
        return z
    finally:
        dense.destroy()


TAIL_ETAS = 20.0
"""The low-frequency window's margin in Lorentzian half-widths: with ``omega_top`` the modes up to
omega_top + TAIL_ETAS eta are summed, so a reported mode (omega_n <= omega_top) misses only
partners at least TAIL_ETAS eta away, whose Lorentzian weight is at most 1 / (pi TAIL_ETAS^2 eta)
each and, over a smooth spectrum, 1 / (pi TAIL_ETAS) = 1.6 % of the Lorentzian's mass on one side
(docs/diffusivity.md, section 5)."""


def window_cut(omega_top: float, eta: float) -> float:
    """The highest omega (1/t0) the low-frequency window slices: omega_top + :data:`TAIL_ETAS` eta.
    Not collective."""
    return omega_top + TAIL_ETAS * eta


def allen_feldman(dm, positions: np.ndarray, box: np.ndarray, eta: float, comm, *, zero_tol: float = 1e-4,
                  tol: float = 1e-12, block: int = 1000, scratch=None, report: dict | None = None,
                  omega_top: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(omega (M,) ascending in 1/t0, d (M,) in d0^2/t0) of every mode of ``dm`` with omega >
    ``zero_tol``: :func:`position_operators` of ``positions`` (N, D, packing order) in ``box``,
    :func:`sliced_modes` (windows of ~``block`` modes, EPS tolerance ``tol``, vectors in
    ``scratch`` or in memory; the scratch files are removed at the end, also on an error), :func:`diffusivity` at
    half-width ``eta``.  With ``omega_top`` (1/t0) only the modes up to :func:`window_cut` are
    sliced and summed, and only those with omega <= omega_top are returned (the low-frequency
    window: the modes above lack their partners beyond the cut).  ``report``, a dict, receives
    ``windows`` (their count), ``settings`` (what their EPS used), ``sliced`` (the modes summed)
    and ``zero`` (the modes with omega <= zero_tol, left out).
    Symmetric matrices only (ValueError for a stressed packing's).  Collective on ``comm``, the
    matrix's communicator."""
    if not dm.symmetric:
        raise ValueError("the Allen-Feldman diffusivity needs a symmetric dynamical matrix (not a stressed packing's)")
    if not (math.isfinite(eta) and eta > 0):
        raise ValueError(f"eta must be finite and > 0, not {eta!r}")
    if omega_top is not None and not (math.isfinite(omega_top) and omega_top > 0):
        raise ValueError(f"omega_top must be finite and > 0, not {omega_top!r}")
    cut = None if omega_top is None else window_cut(omega_top, eta)
    X = position_operators(dm, positions, box, comm)
    modes = None
    try:
        modes = sliced_modes(dm, comm, zero_tol=zero_tol, tol=tol, block=block, scratch=scratch, omega_cut=cut)
        omega, d = modes.omega, diffusivity(X, modes, eta, comm)
        if report is not None:
            report.update(windows=len(modes), settings=modes.settings, sliced=omega.size, zero=modes.zero)
        if omega_top is None:
            return omega, d
        kept = omega <= omega_top
        return omega[kept], d[kept]
    finally:
        if modes is not None:
            modes.remove_files()
        for Xa in X:
            Xa.destroy()
