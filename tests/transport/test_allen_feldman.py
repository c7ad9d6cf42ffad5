"""The Allen-Feldman diffusivity of every mode (solver/transport/allen_feldman.py) against the
definition evaluated densely (solver/references.py), in 2D with rotations and in 3D with rolling
and twisting springs; its position operators; the exact scaling of d with the packing's size; and
the closed form of a crystal, whose d comes from its Bloch matrices; a scratch file that one rank
cannot write or read raises on every rank, and neither files nor PETSc objects are left behind.
Every test runs on 1 and 2 ranks against the same rank-free references."""

import math
import pathlib

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close
from diffusivity_cases import case  # noqa: F401 (a fixture)
from lattices import DIAMETER, L, N_X, N_Y, bloch_matrix, crystal

from solver import references
from solver.contact_law import ContactModel
from solver.model import dynmat
from solver.packing import jammed
from solver.transport import allen_feldman as af

ZERO_TOL = 1e-4   # the spectrum's default: omega <= zero_tol are zero modes
ETA = 0.2         # 1/t0: a few mean level spacings of these 94- and 186-mode spectra




def _matrix_rows(dm, whole: np.ndarray) -> np.ndarray:
    """This rank's rows, on ``dm``'s layout, of ``whole`` (n, ...) given in the packing's order of
    the non-rattlers (the inverse of ``dynmat.in_packing_order``)."""
    rows = (np.argsort(dm.order)[:, None] * dm.dof + np.arange(dm.dof)).ravel()
    matrix = np.empty_like(whole)
    matrix[rows] = whole
    start, stop = dm.D.getOwnershipRange()
    return matrix[start:stop]


def test_library_equals_dense_definition(comm, case, shared_tmp):
    """The whole route (slicing windows of ~40 modes written to scratch files, pairs of blocks)
    gives the dense definition's d to 1e-8; omega to 1e-12."""
    name, p, dm = case
    omega, d = af.allen_feldman(dm, p.positions, p.box, ETA, comm, zero_tol=ZERO_TOL, block=40,
                                scratch=shared_tmp / "af")
    ref_omega, ref_d = references.allen_feldman_dense(dm, p.positions, p.box, ETA, zero_tol=ZERO_TOL)
    assert_all(omega.size == ref_omega.size == dm.size - dm.dim, f"{name}: {omega.size} modes, dense {ref_omega.size}")
    assert_close(omega, ref_omega, rtol=1e-12, what=f"{name} omega")
    # atol: 1e-12 of the largest d, for modes whose d is far below the rest (none is zero here)
    assert_close(d, ref_d, rtol=1e-8, atol=1e-12 * ref_d.max(), what=f"{name} d")
    assert_all(not list((shared_tmp / "af").glob("*.npy")), "scratch files removed")


@pytest.mark.parametrize("block", [17, 1000])
def test_block_sums_with_exact_vectors(comm, case, block):
    """The position operators and the block-pair sum alone, fed the dense eigenvectors: the
    definition's d to 1e-11 whatever the block size (17: uneven blocks; 1000: one block)."""
    name, p, dm = case
    lam, vec = references.dense_eigen(dm)
    omega = np.sqrt(np.clip(lam, 0.0, None))
    modes = af.ModeBlocks.from_arrays(omega, _matrix_rows(dm, vec), block, zero_tol=ZERO_TOL)
    X = af.position_operators(dm, p.positions, p.box, comm)
    try:
        d = af.diffusivity(X, modes, ETA, comm)
    finally:
        for Xa in X:
            Xa.destroy()
    ref_omega, ref_d = references.allen_feldman_dense(dm, p.positions, p.box, ETA, zero_tol=ZERO_TOL)
    assert_close(modes.omega, ref_omega, rtol=1e-14, what=f"{name} omega")
    assert_close(d, ref_d, rtol=1e-11, atol=1e-14 * ref_d.max(), what=f"{name} d, blocks of {block}")


def test_position_operators_are_antisymmetric_with_zero_diagonal_blocks(comm, case):
    """X^a = -X^a^T to round-off, its particle-diagonal blocks vanish, it has A's pattern, and an
    off-diagonal block is A's times the minimum-image separation."""
    from solver.model.operators import scaled_operator

    name, p, dm = case
    X = af.position_operators(dm, p.positions, p.box, comm)
    A = scaled_operator(dm)
    a_dense = dynmat.gather_csr(A).toarray()
    a_nnz = A.getInfo()["nz_used"]
    A.destroy()
    r = p.positions[dm.order]  # matrix particles
    for axis, Xa in enumerate(X):
        x = dynmat.gather_csr(Xa).toarray()
        nnz = Xa.getInfo()["nz_used"]
        Xa.destroy()
        assert_all(nnz == a_nnz, f"{name}: X^{axis} has {nnz} entries, A {a_nnz}")
        assert_all(np.abs(x + x.T).max() <= 1e-15 * np.abs(x).max(), f"{name}: X^{axis} not antisymmetric")
        blocks = x.reshape(-1, dm.dof, x.shape[0] // dm.dof, dm.dof)
        diagonal = blocks[np.arange(blocks.shape[0]), :, np.arange(blocks.shape[0]), :]
        assert_all(np.all(diagonal == 0.0), f"{name}: X^{axis} has non-zero diagonal blocks")
        i, j = np.unravel_index(np.argmax(np.abs(x)), x.shape)
        sep = r[i // dm.dof, axis] - r[j // dm.dof, axis]
        sep -= p.box[axis] * np.round(sep / p.box[axis])
        assert_close(x[i, j], a_dense[i, j] * sep, rtol=1e-15, what=f"{name}: X^{axis} entry")


def test_diffusivity_scales_as_size_squared_and_ignores_a_shift(comm, case):
    """The packing magnified by s = 1.7 (positions, diameters, box), shifted by a vector across the
    periodic boundary and listed in a random order has the same A up to the order (harmonic
    springs, I ~ d^2), hence the same modes, and X^a times s: d times s^2 exactly.  In-memory
    blocks of 50 modes."""
    name, p, dm = case
    s = 1.7
    shift = 0.37 * p.box * np.arange(1, p.dim + 1)
    listed = np.random.default_rng(3).permutation(p.n)  # the matrix's order by cells is then not the packing's
    moved = jammed.from_arrays(np.mod(s * p.positions + shift, s * p.box)[listed], s * p.diameters[listed],
                               s * p.box, rattler=p.rattler[listed].copy())
    big = dynmat.assemble(moved, dm.model, comm)
    try:
        omega, d = af.allen_feldman(dm, p.positions, p.box, ETA, comm, zero_tol=ZERO_TOL, block=50)
        omega_s, d_s = af.allen_feldman(big, moved.positions, moved.box, ETA, comm, zero_tol=ZERO_TOL, block=50)
    finally:
        big.destroy()
    assert_close(omega_s, omega, rtol=1e-12, what=f"{name}: omega of the magnified packing")
    assert_close(d_s, s**2 * d, rtol=1e-8, atol=1e-12 * d.max() * s**2, what=f"{name}: d scales as s^2")


@pytest.mark.mpi
def test_two_ranks_equal_one(comm, case):
    """The 2-rank result equals each rank's own 1-rank result (COMM_SELF) to round-off (1e-10)."""
    from conftest import PETSc

    name, p, dm = case
    omega, d = af.allen_feldman(dm, p.positions, p.box, ETA, comm, zero_tol=ZERO_TOL, block=40)
    alone = dynmat.assemble(p, dm.model, PETSc.COMM_SELF)
    try:
        omega_1, d_1 = af.allen_feldman(alone, p.positions, p.box, ETA, PETSc.COMM_SELF, zero_tol=ZERO_TOL, block=40)
    finally:
        alone.destroy()
    assert_close(omega, omega_1, rtol=1e-13, what=f"{name} omega, 2 ranks vs 1")
    assert_close(d, d_1, rtol=1e-10, atol=1e-14 * d_1.max(), what=f"{name} d, 2 ranks vs 1")


def test_eta_must_be_positive_and_finite(comm, case):
    _, p, dm = case
    for eta in (0.0, -0.1, math.nan, math.inf):
        with pytest.raises(ValueError, match="eta"):
            af.allen_feldman(dm, p.positions, p.box, eta, comm)


def _bloch_diffusivity(rho: float, eta: float, h: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """(omega, d) of every non-zero Bloch mode of the crystal of tests/lattices.py: X^a is diagonal
    in k, and between the branches s, s' at one k its element is |u_s'^H dB/dk_a u_s| (Bloch
    matrix B(k) = sum_delta A(delta) exp(i k.delta), so sum_delta (-delta_a) A(delta) exp(i k.delta)
    = i dB/dk_a; Hellmann-Feynman on the diagonal: 2 omega v_a, the group velocity).  The diagonal
    term s' = s is the -k partner of a real mode.  dB/dk by five-point central differences
    (truncation ~h^4 ~ 1e-12, round-off ~1e-16 / h)."""
    omegas, ds = [], []
    for p_ in range(N_X):
        for q in range(N_Y):
            k = 2 * np.pi * np.array([p_, q]) / L
            lam, u = np.linalg.eigh(bloch_matrix(k, rho))
            grads = [(8 * (bloch_matrix(k + h * e, rho) - bloch_matrix(k - h * e, rho))
                      - (bloch_matrix(k + 2 * h * e, rho) - bloch_matrix(k - 2 * h * e, rho))) / (12 * h)
                     for e in np.eye(2)]
            square = sum(np.abs(u.conj().T @ g @ u) ** 2 for g in grads)  # (s', s)
            live = lam > ZERO_TOL**2
            w = np.sqrt(lam[live])
            weight = (w[:, None] + w[None, :]) ** 2 / (4 * w[:, None] * w[None, :]) \
                * (eta / np.pi) / ((w[:, None] - w[None, :]) ** 2 + eta**2)
            omegas.append(w)
            ds.append(np.pi / (4 * 2 * w**2) * (square[np.ix_(live, live)] * weight).sum(axis=0))
    omega, d = np.concatenate(omegas), np.concatenate(ds)
    order = np.argsort(omega, kind="stable")
    return omega[order], d[order]


def test_crystal_diffusivity_is_its_bloch_closed_form(comm):
    """The triangular crystal (rho = 0.5): d summed over each set of equal frequencies (the
    crystal's degenerate modes have no unique basis; such a sum has) equals the Bloch closed form
    to 1e-8.  In a crystal each mode's d is |v|^2 / (D eta) plus the other branches' terms."""
    packing = jammed.from_arrays(crystal(), np.full(N_X * N_Y, DIAMETER), L)
    dm = dynmat.assemble(packing, ContactModel(0.5), comm)
    try:
        omega, d = af.allen_feldman(dm, packing.positions, packing.box, 0.3, comm, zero_tol=ZERO_TOL, block=60)
    finally:
        dm.destroy()
    bloch_omega, bloch_d = _bloch_diffusivity(0.5, 0.3)
    assert_close(omega, bloch_omega, rtol=0.0, atol=1e-10 * bloch_omega.max(), what="crystal omega")
    starts = np.flatnonzero(np.diff(bloch_omega, prepend=-1.0) > 1e-8 * bloch_omega.max())
    assert_all(starts.size < omega.size / 2, f"{starts.size} groups of {omega.size} modes: degenerate as expected")
    group, bloch_group = np.add.reduceat(d, starts), np.add.reduceat(bloch_d, starts)
    assert_close(group, bloch_group, rtol=1e-8, atol=1e-12 * bloch_group.max(), what="crystal d per frequency")


def _scratch_files(folder) -> list:
    """The ``.npy`` files (not folders) in ``folder``, on every rank: rank 0's listing."""
    return COMM.bcast(sorted(path.name for path in folder.glob("*.npy") if path.is_file()), root=0)


def test_a_write_failing_on_one_rank_raises_on_every_rank_and_leaves_no_files(comm, case, shared_tmp):
    """The second window's file of the last rank cannot be written (a folder holds its name): every
    rank raises (they ran into the next window's collectives and hung), and the first window's files
    of every rank are removed (they were left, up to 5 GB at N = 8192)."""
    name, p, dm = case
    folder = shared_tmp / "af"
    if COMM.rank == COMM.size - 1:
        (folder / f"af_window0001_rank{COMM.rank:04d}.npy").mkdir(parents=True)
    COMM.Barrier()
    with pytest.raises(IsADirectoryError):
        af.allen_feldman(dm, p.positions, p.box, ETA, comm, zero_tol=ZERO_TOL, block=40, scratch=folder)
    assert_all(_scratch_files(folder) == [], f"{name}: left {_scratch_files(folder)}")


def test_a_read_failing_on_one_rank_raises_on_every_rank(comm, case, shared_tmp):
    """Blocks in scratch files, the last rank's second one gone: every rank raises (the others ran
    into the block pair's Allreduce and hung)."""
    name, p, dm = case
    lam, vec = references.dense_eigen(dm)
    held = af.ModeBlocks.from_arrays(np.sqrt(np.clip(lam, 0.0, None)), _matrix_rows(dm, vec), 40, zero_tol=ZERO_TOL)
    paths = [str(shared_tmp / f"block{w}_rank{COMM.rank}.npy") for w in range(len(held))]
    for path, local in zip(paths, held.stored):
        np.save(path, local)
    if COMM.rank == COMM.size - 1:
        pathlib.Path(paths[1]).unlink()
    X = af.position_operators(dm, p.positions, p.box, comm)
    try:
        with pytest.raises(FileNotFoundError):
            af.diffusivity(X, af.ModeBlocks(held.omegas, paths), ETA, comm)
    finally:
        for Xa in X:
            Xa.destroy()
    assert_all(len(held) >= 3, f"{name}: {len(held)} blocks")


class _Operator:
    """An X^a that hands out its products and keeps what it was given and made (``seen``,
    ``made``), or raises on its product (``fails``)."""

    def __init__(self, mat, fails: bool):
        self.mat, self.fails, self.seen, self.made = mat, fails, [], []

    def getSize(self):
        return self.mat.getSize()

    def getLocalSize(self):
        return self.mat.getLocalSize()

    def matMult(self, dense):
        self.seen.append(dense)
        if self.fails:
            raise RuntimeError("injected failure of a product")
        self.made.append(self.mat.matMult(dense))
        return self.made[-1]


def test_petsc_objects_are_destroyed_when_a_product_fails(comm, case):
    """The second axis's product fails: the dense block V_P and the first axis's product are
    destroyed there and then (handle 0), not left to the garbage collector."""
    name, p, dm = case
    lam, vec = references.dense_eigen(dm)
    modes = af.ModeBlocks.from_arrays(np.sqrt(np.clip(lam, 0.0, None)), _matrix_rows(dm, vec), 40, zero_tol=ZERO_TOL)
    X = af.position_operators(dm, p.positions, p.box, comm)
    try:
        wrapped = [_Operator(Xa, fails=axis == 1) for axis, Xa in enumerate(X)]
        with pytest.raises(RuntimeError, match="injected"):
            af.diffusivity(wrapped, modes, ETA, comm)
        handles = [mat.handle for mat in wrapped[0].seen + wrapped[0].made + wrapped[1].seen]
    finally:
        for Xa in X:
            Xa.destroy()
    assert_all(len(handles) == 3 and handles == [0, 0, 0], f"{name}: handles {handles}")


ETA_LOW = 0.05  # 1/t0: the low-frequency window's tests; its margin TAIL_ETAS eta = 1/t0 leaves modes to compare
TOP = {"2d": 2.0, "3d_rolling": 2.5}  # omega_top (1/t0): about the median omega of each case


def test_low_window_is_the_sum_truncated_at_its_cut(comm, case):
    """With omega_top, the modes up to omega_top (and no others) come back, each with the dense
    definition's d whose partners stop at omega_top + TAIL_ETAS eta (the window's cut): omega to
    1e-12, d to rtol 1e-8 (atol 1e-12 of the largest d), as the whole route's own check."""
    name, p, dm = case
    report: dict = {}
    omega, d = af.allen_feldman(dm, p.positions, p.box, ETA_LOW, comm, zero_tol=ZERO_TOL, block=17,
                                omega_top=TOP[name], report=report)
    cut = af.window_cut(TOP[name], ETA_LOW)
    ref_omega, ref_d = references.allen_feldman_dense(dm, p.positions, p.box, ETA_LOW, zero_tol=ZERO_TOL,
                                                      partners_to=cut)
    below = ref_omega <= TOP[name]
    assert_all(report["sliced"] == np.count_nonzero(ref_omega <= cut) < ref_omega.size,
               f"{name}: {report['sliced']} modes sliced, {np.count_nonzero(ref_omega <= cut)} up to the cut")
    assert_all(omega.size == np.count_nonzero(below), f"{name}: {omega.size} modes up to omega_top")
    assert_close(omega, ref_omega[below], rtol=1e-12, what=f"{name} omega of the window")
    assert_close(d, ref_d[below], rtol=1e-8, atol=1e-12 * ref_d.max(), what=f"{name} d of the window")


def test_low_window_equals_the_whole_route_a_margin_below_its_top(comm, case):
    """Below omega_top - TAIL_ETAS eta a mode's missing partners are at least 2 TAIL_ETAS eta
    away, a Lorentzian tail of about 1 / (2 pi TAIL_ETAS) = 0.8 % of its mass (more where the
    weight (omega_n + omega_m)^2 / (4 omega_n omega_m) grows): the window's d equals the whole
    route's to rtol 2e-2 (atol 1e-12 of the largest d); 1.1 % measured in both cases.  A window
    cut at omega_top itself misses by 4.4 % (2d) and 5.3 % (3d_rolling), one cut at 10 eta beyond
    it by 2.1 % and 3.8 %: each fails this."""
    name, p, dm = case
    omega, d = af.allen_feldman(dm, p.positions, p.box, ETA_LOW, comm, zero_tol=ZERO_TOL, block=40,
                                omega_top=TOP[name])
    whole_omega, whole_d = af.allen_feldman(dm, p.positions, p.box, ETA_LOW, comm, zero_tol=ZERO_TOL, block=40)
    low = whole_omega <= TOP[name] - af.TAIL_ETAS * ETA_LOW
    assert_all(np.count_nonzero(low) >= 10, f"{name}: {np.count_nonzero(low)} modes to compare")
    assert_close(omega[low[:omega.size]], whole_omega[low], rtol=1e-12, what=f"{name} omega")
    assert_close(d[low[:omega.size]], whole_d[low], rtol=2e-2, atol=1e-12 * whole_d.max(),
                 what=f"{name} d of the window against the whole route")


def test_omega_top_must_be_positive_and_finite(comm, case):
    _, p, dm = case
    for top in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="omega_top"):
            af.allen_feldman(dm, p.positions, p.box, ETA, comm, omega_top=top)
