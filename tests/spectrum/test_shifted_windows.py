"""``spectrum.solver: windows`` (solver/spectrum/shifted_windows.py): every eigenvalue of a matrix
that need not be symmetric, by shift-and-invert windows marched along the real axis.  Against the
dense solver (LAPACK, another algorithm) on stressed matrices with complex pairs, negative modes
and many windows, in 2D and 3D and on 1 and 2 ranks; the K/Q shares; a miss is caught by the
count; a killed solve resumes from its checkpointed windows; the scene key and its rules."""

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close, jammed_packing, scene_of, with_random_stored_forces

from solver import pipeline
from solver.contact_law import ContactModel
from solver.errors import InputError
from solver.model import dynmat
from solver.spectrum import nonhermitian, shifted_windows


@pytest.fixture
def small_windows():
    """-nonhermitian_eps_nev 12, as a user's command line would put it: many windows on a small
    matrix."""
    from petsc4py import PETSc

    options = PETSc.Options()
    options.setValue("nonhermitian_eps_nev", "12")
    yield 12
    options.delValue("nonhermitian_eps_nev")


def _stressed(dim, comm, ratio=3.0):
    """A stressed matrix whose stored forces (|f_t| = ratio f_n, not in equilibrium) turn some
    eigenvalues complex and some real negative (ratio 3)."""
    p = with_random_stored_forces(jammed_packing(32 if dim == 2 else 48, 0.9 if dim == 2 else 0.7, 3, dim), 11,
                                  ratio=ratio)
    return dynmat.assemble(p, ContactModel(0.8), comm)


@pytest.mark.parametrize("dim", [2, 3])
def test_windows_find_the_dense_solvers_eigenvalues(comm, small_windows, dim):
    """Same eigenvalues as LAPACK to 1e-9 of max |lambda| (measured 5e-12 on 1 rank, 5e-11 on 2:
    SLEPc's backward residuals ~1e-10 against LAPACK's round-off), the same classification, over
    more than five windows (the trace moments are the solver's own check: 3e-12 here, where the
    stored forces 3 f_n make A far from normal)."""
    dm = _stressed(dim, comm)
    windows = nonhermitian.solve(dm, zero_tol=1e-4, solver="windows")
    dense = nonhermitian.solve(dm, zero_tol=1e-4, solver="dense")
    dm.destroy()
    checks = windows.checks
    assert_all(checks["windows"] > 5 and checks["settings"]["spectrum"]["nev"] == small_windows, str(checks))
    assert_all((windows.n_zero_modes, windows.n_complex, windows.n_negative, windows.omega.size)
               == (dense.n_zero_modes, dense.n_complex, dense.n_negative, dense.omega.size)
               and dense.n_complex > 0,
               f"windows {windows.n_zero_modes, windows.n_complex, windows.n_negative, windows.omega.size}, "
               f"dense {dense.n_zero_modes, dense.n_complex, dense.n_negative, dense.omega.size}")
    scale = np.abs(dense.omega2).max()
    assert_close(windows.omega2.real, dense.omega2.real, rtol=0.0, atol=1e-9 * scale, what="Re lambda")
    assert_close(np.sort(np.abs(windows.omega2.imag)), np.sort(np.abs(dense.omega2.imag)), rtol=0.0,
                 atol=1e-9 * scale, what="|Im lambda|")


def _synthetic(comm, n=60):
    """A dynamical-matrix stand-in (D, unit masses, 3 DOF per particle in 2D) with a known
    spectrum shape: real parts from -2 to 10 (some eigenvalues real negative, the symmetric part
    indefinite) and a skew part of 0.4 that turns close pairs complex.  Rows split as PETSc's
    default layout, whole particles per rank."""
    import types

    from petsc4py import PETSc

    rng = np.random.default_rng(7)
    skew = rng.normal(size=(n, n))
    dense = np.diag(np.linspace(-2.0, 10.0, n)) + 0.4 * (skew - skew.T) / np.sqrt(n) + 0.05 * rng.normal(size=(n, n))
    D = PETSc.Mat().createDense([n, n], comm=comm)
    D.setUp()
    lo, hi = D.getOwnershipRange()
    D.setValues(range(lo, hi), range(n), dense[lo:hi])
    D.assemble()
    D.convert("aij")
    M = D.createVecRight()
    M.set(1.0)
    return types.SimpleNamespace(D=D, M=M, symmetric=False, dof=3, dim=2, size=n,
                                 active=np.ones(n // 3, bool)), dense


def test_windows_on_a_symmetric_matrix_are_slicings(comm, small_windows):
    """A symmetric matrix gives the box no height, so a window's farthest eigenvalue sits at the
    end of the range its disk covers: the cut is moved into a gap, or that eigenvalue, computed
    again by the next window, falls on either side (31 of 24339 were lost at N = 8192 before).
    Every mode of slicing's, to 1e-10 of omega_max, over many windows."""
    from solver.spectrum import slicing

    p = jammed_packing(64, 0.9, 3)
    dm = dynmat.assemble(p, ContactModel(0.5), comm)
    windows = nonhermitian.solve(dm, zero_tol=1e-4, solver="windows")
    sliced = slicing.solve(dm, window=None, vectors=False, tol=1e-12, zero_tol=1e-4)
    dm.destroy()
    assert_all(windows.checks["windows"] > 10 and windows.omega.size == sliced.omega.size
               and windows.n_zero_modes == sliced.n_zero_modes, f"{windows.checks['windows']} windows, "
               f"{windows.omega.size} vs {sliced.omega.size} modes")
    assert_close(windows.omega, sliced.omega, rtol=0.0, atol=1e-10 * sliced.omega.max(), what="omega")


def test_windows_march_from_below_a_negative_symmetric_part(comm, small_windows):
    """On a matrix with real negative eigenvalues and an indefinite symmetric part S, the march
    starts below lambda_min(S) (Bendixson: Re lambda >= lambda_min(S), placed by inertias), and
    the eigenvalues are numpy's (LAPACK) to 1e-10 of max |lambda|."""
    import scipy.linalg as sl

    from solver.model.operators import scaled_operator

    dm, dense = _synthetic(comm)
    A = scaled_operator(dm)
    box = shifted_windows._bounds(A, False, 1e-4)
    A.destroy()
    lam, _, checks = shifted_windows.solve(dm, zero_tol=1e-4, vectors=False)
    dm.D.destroy()
    dm.M.destroy()
    reference = sl.eigvals(dense)
    symmetric = np.linalg.eigvalsh((dense + dense.T) / 2)
    assert_all(box["lower"] <= symmetric.min() < 0 and box["upper"] >= symmetric.max()
               and box["imag"] >= np.abs(reference.imag).max(), f"{box}, S in [{symmetric.min()}, {symmetric.max()}]")
    assert_all((reference.real < 0).sum() >= 5 and (np.abs(reference.imag) > 1e-6).sum() >= 2 and checks["windows"] > 3,
               f"{np.sort_complex(reference)}")
    scale = np.abs(reference).max()
    assert_close(np.sort(lam.real), np.sort(reference.real), rtol=0.0, atol=1e-10 * scale, what="Re lambda")
    assert_close(np.sort(np.abs(lam.imag)), np.sort(np.abs(reference.imag)), rtol=0.0, atol=1e-10 * scale,
                 what="|Im lambda|")


def test_window_energies_are_the_dense_ones(comm, small_windows):
    """K, Q and participation of each stable mode from the windows' right vectors equal the dense
    solver's to 1e-7 of their scale 1/(2N) (a real eigenvalue's vector is unique up to sign)."""
    dm = _stressed(2, comm, ratio=0.3)
    windows = nonhermitian.solve(dm, zero_tol=1e-4, vectors=True, solver="windows")
    dense = nonhermitian.solve(dm, zero_tol=1e-4, vectors=True, solver="dense")
    n = int(dm.active.sum())
    dm.destroy()
    for name in ("Kx", "Ky", "Q", "K"):
        assert_close(windows.energies[name], dense.energies[name], rtol=0.0, atol=1e-7 / (2 * n), what=name)
    assert_close(windows.energies["participation"], dense.energies["participation"], rtol=1e-6, atol=0.0,
                 what="participation")


def test_a_missed_eigenvalue_is_caught(comm, small_windows, monkeypatch):
    """A window that loses its eigenvalue nearest the shift (as Krylov-Schur could) leaves the
    count short: RuntimeError on every rank, not a spectrum with a hole."""
    real = shifted_windows._solve_window

    def lossy(A, sigma, *args):
        lam, radius, residual, sums, used = real(A, sigma, *args)
        keep = np.arange(lam.size) != np.argmin(np.abs(lam - sigma))
        return lam[keep], radius, residual[keep], None if sums is None else sums[keep], used

    monkeypatch.setattr(shifted_windows, "_solve_window", lossy)
    dm = _stressed(2, comm)
    try:
        with pytest.raises(RuntimeError, match="eigenvalues accepted for a matrix of size .* missed"):
            nonhermitian.solve(dm, zero_tol=1e-4, solver="windows")
    finally:
        dm.destroy()


class _Memory:
    """A checkpoint in memory (``load``/``save`` of dicts, as WindowCheckpoint)."""

    def __init__(self):
        self.saved, self.loads = {}, []

    def load(self, name):
        self.loads.append(name)
        return self.saved.get(name)

    def save(self, name, datasets):
        self.saved[name] = {k: np.copy(v) for k, v in datasets.items()}


def test_a_killed_solve_resumes_from_its_windows(comm, small_windows):
    """Stopped after 3 windows (the progress callback raises, as on SIGTERM), the rerun takes
    those 3 from the checkpoint, solves only the rest, and gives the uninterrupted eigenvalues."""
    dm = _stressed(2, comm)
    whole = nonhermitian.solve(dm, zero_tol=1e-4, solver="windows")
    memory = _Memory()

    def stop(done, accepted, total):
        if done == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        nonhermitian.solve(dm, zero_tol=1e-4, solver="windows", progress=stop, checkpoint=memory)
    solved = []
    resumed = nonhermitian.solve(dm, zero_tol=1e-4, solver="windows", checkpoint=memory,
                                 progress=lambda done, accepted, total: solved.append(done))
    dm.destroy()
    assert_all(sorted(memory.saved) == ["plan"] + [f"window{i:04d}" for i in range(whole.checks["windows"])])
    assert_all(solved[0] == 4 and resumed.checks["windows"] == whole.checks["windows"], f"{solved}")
    # bit for bit on 1 rank; on 2, parallel MUMPS reorders sums between runs: 1e-9 of max |lambda|
    assert_close(resumed.omega2.real, whole.omega2.real, rtol=0.0,
                 atol=0.0 if COMM.size == 1 else 1e-9 * np.abs(whole.omega2).max(), what="resumed Re lambda")


def test_the_scene_key_and_its_rule(shared_tmp):
    """spectrum.solver is read by method nonhermitian only; another method with it is refused,
    naming the key; a scene with solver windows records what it did."""
    with pytest.raises(InputError, match="spectrum.solver = 'windows' chooses how methods nonhermitian and pep"):
        scene_of(shared_tmp / "bad.h5", cache="off", packing={"n": 32, "phi": 0.9},
                 spectrum={"method": "counting", "solver": "windows"})
    scene = scene_of(shared_tmp / "windows.h5", cache="off", packing={"n": 32, "phi": 0.9}, model={"rho": 0.5},
                     spectrum={"method": "nonhermitian", "solver": "windows"})
    datasets, attrs = pipeline.run(scene, COMM, [])["units"]["spectra/r00_p0000"]
    assert_all(attrs["solver"] == "windows" and attrs["windows"] >= 1 and attrs["trace_error"] < 1e-12, str(attrs))
    assert_all(datasets["omega"].size + attrs["n_zero_modes"] == attrs["dof"], str(attrs))
