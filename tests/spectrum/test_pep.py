"""``spectrum.method: pep`` (solver/spectrum/pep.py, quadratic_windows.py): every damped mode of
(lambda^2 M + lambda C + D) x = 0.  The windows against the dense first-order solve (a thin band of
damping rates, and a wide one with overdamped modes; 2D and 3D; 1 and 2 ranks), both against the
two exact cases C = beta D (every mode on the circle |lambda + 1/beta| = 1/beta) and C = gamma M
(every rate gamma/2) built from slicing's undamped frequencies, the classification's count, and
a scene's datasets, vDOS and resume."""

import functools

import numpy as np
import pytest
from conftest import COMM, PETSc, assert_all, assert_close, jammed_packing, run_stopped_after_windows, scene_of
from figures import assert_readable, capture

from solver import pipeline, plots
from solver.contact_law import ContactModel
from solver.model import damping, dynmat
from solver.spectrum import pep, plan, quadratic_windows, slicing

ZERO_TOL = 1e-4


def _damped(comm, n, phi, seed, gamma_t, dim=2):
    p = jammed_packing(n, phi, seed, dim)
    dm = dynmat.assemble(p, ContactModel(0.5, gamma_n=0.3, gamma_t=gamma_t), comm)
    dm.C = damping.assemble(p, dm)
    return dm


def _nearest(found: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """|lambda - nearest reference| / |lambda| for each found lambda."""
    return np.abs(found[:, None] - reference[None, :]).min(axis=1) / np.maximum(np.abs(found), 1e-300)


def _assert_same_spectrum(a: pep.Result, b: pep.Result, rtol: float, what: str) -> None:
    assert_all(a.lam.size == b.lam.size and a.n_zero_modes == b.n_zero_modes and a.n_overdamped == b.n_overdamped,
               f"{what}: counts {a.lam.size}/{a.n_zero_modes}/{a.n_overdamped} vs "
               f"{b.lam.size}/{b.n_zero_modes}/{b.n_overdamped}")
    error = max(_nearest(a.lam, b.lam).max(), _nearest(b.lam, a.lam).max())
    assert_all(error <= rtol, f"{what}: eigenvalues differ by {error:.2e} (relative), allowed {rtol:g}")


@functools.cache
def _windows_and_dense(gamma_t: float, dim: int) -> tuple[pep.Result, pep.Result]:
    """(windows, dense) with vectors, windows of 40 eigenvalues, of the damped packing of
    test_windows_equal_the_dense_first_order_solve on the suite's communicator.  Collective;
    cached: test_windows_do_not_depend_on_the_rank_count compares the 2D thin band's windows on
    2 ranks with rank 0's alone, and need not solve them again."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(quadratic_windows, "NEV", 40)
        dm = _damped(PETSc.COMM_WORLD, 64 if dim == 2 else 48, 0.86 if dim == 2 else 0.7, 3, gamma_t, dim)
        try:
            return pep.solve(dm, ZERO_TOL, vectors=True, solver="windows"), pep.solve(dm, ZERO_TOL, vectors=True,
                                                                                      solver="dense")
        finally:
            dm.destroy()


# on 2 ranks: the first case (and test_windows_do_not_depend_on_the_rank_count); the others vary the
# damping and the dimension, not the layout
@pytest.mark.parametrize("gamma_t, dim", [(0.15, 2), pytest.param(0.9, 2, marks=pytest.mark.serial_only),
                                          pytest.param(0.15, 3, marks=pytest.mark.serial_only)])
def test_windows_equal_the_dense_first_order_solve(gamma_t, dim):
    """gamma_t = 0.15 puts the rates on a thin band sigma(omega) (C close to 0.15 D), 0.9 spreads
    them from 0.01 to 2.3 at one frequency, with overdamped roots: one disk per column, then many.
    Windows of 40 eigenvalues, so that the march crosses many; every lambda to 1e-8 relative,
    the energies of each mode to 1e-8 (from eigenvectors of two different solvers)."""
    windows, dense = _windows_and_dense(gamma_t, dim)
    _assert_same_spectrum(windows, dense, 1e-8, "windows vs dense")
    checks = windows.checks
    assert_all(checks["windows"] > 3 and checks["max_residual"] < 1e-9, f"{checks['windows']} windows, "
               f"backward error {checks['max_residual']:.1e}")
    assert_all(checks["trace_error"] < 1e-10 and checks["trace2_error"] < 1e-10)
    if gamma_t == 0.9:
        assert_all(dense.n_overdamped > 0, "the wide band has overdamped roots")
    # the same modes in the same order (sorted by Im, then Re): their energies
    assert_close(windows.energies["K"], dense.energies["K"], rtol=1e-8, atol=1e-12, what="K per mode")
    assert_close(windows.energies["Q"], dense.energies["Q"], rtol=1e-8, atol=1e-12, what="Q per mode")


def test_the_count_adds_up_to_2n(comm):
    """n_zero + 2 (complex kept) + (real kept) = 2n: no root lost or doubled by the classification."""
    dm = _damped(comm, 64, 0.86, 3, 0.9)
    result = pep.solve(dm, ZERO_TOL, solver="dense")
    size = dm.size
    dm.destroy()
    complex_ = int((result.lam.imag > 0).sum())
    assert_all(result.n_zero_modes + 2 * complex_ + result.n_overdamped == 2 * size)
    assert_all(np.all(result.lam.real <= 1e-12), "a root with Re lambda > 0 (C and D are positive semi-definite)")


@pytest.mark.serial_only  # arrays only, no communicator
@pytest.mark.parametrize("found, advice", [(5, "raise -pep_eps_nev"), (7, "keep -pep_eps_nev at its default")])
def test_a_wrong_count_of_the_windows_is_refused_with_advice_that_fits_it(found, advice):
    """quadratic_windows._check: a count other than 2n stops the windows, a lost mode asking for
    more eigenvalues per shift, a doubled one for the default (measured: 400 doubles one)."""
    lam = np.full(found, -0.1 + 1.0j)
    with pytest.raises(RuntimeError, match=f"{found} eigenvalues accepted for a problem with 6 .*{advice}"):
        quadratic_windows._check(lam, 6, {"trace": lam.sum()})


def _exact_case(comm, kind: str, solver: str):
    """(result, undamped omega by slicing, coefficient) for C = beta D or C = gamma M."""
    from petsc4py import PETSc

    p = jammed_packing(64, 0.86, 5)
    dm = dynmat.assemble(p, ContactModel(0.5), comm)
    omega = slicing.solve(dm, window=None, vectors=False, tol=1e-12, zero_tol=ZERO_TOL).omega
    coefficient = 0.4 if kind == "beta_D" else 1.2
    if kind == "beta_D":
        dm.C = dm.D.copy()
        dm.C.scale(coefficient)
    else:
        dm.C = PETSc.Mat().createAIJ(dm.D.getSizes(), nnz=1, comm=dm.D.getComm())
        dm.C.setDiagonal(dm.M)
        dm.C.assemble()
        dm.C.scale(coefficient)
    result = pep.solve(dm, ZERO_TOL, solver=solver)
    dm.destroy()
    return result, omega, coefficient


@pytest.mark.parametrize("solver", ["dense", "windows"])
def test_c_proportional_to_d_puts_every_mode_on_the_circle(comm, monkeypatch, solver):
    """C = beta D: lambda^2 + beta omega^2 lambda + omega^2 = 0 for each undamped omega; complex
    roots on |lambda + 1/beta| = 1/beta, modes above omega = 2/beta overdamped (beta = 0.4: from
    omega = 5, none here, so every root is complex) and each lambda the exact root of slicing's
    omega to 1e-9 relative."""
    monkeypatch.setattr(quadratic_windows, "NEV", 40)
    result, omega, beta = _exact_case(comm, "beta_D", solver)
    circle = np.abs(np.abs(result.lam + 1 / beta) - 1 / beta)
    assert_all(circle.max() < 1e-10 / beta, f"off the circle by {circle.max():.1e}")
    exact = (-beta * omega**2 + np.sqrt((beta**2 * omega**4 - 4 * omega**2).astype(complex))) / 2
    exact = np.where(exact.imag < 0, exact.conj(), exact)
    assert_all(result.lam.size == exact.size, f"{result.lam.size} roots kept, {exact.size} undamped modes")
    error = max(_nearest(result.lam, exact).max(), _nearest(exact, result.lam).max())
    assert_all(error < 1e-9, f"roots differ from the exact ones by {error:.1e}")


@pytest.mark.parametrize("solver", ["dense", "windows"])
def test_c_proportional_to_m_damps_every_mode_at_gamma_over_2(comm, monkeypatch, solver):
    """C = gamma M: lambda = -gamma/2 +- i sqrt(omega^2 - gamma^2/4) (gamma = 1.2: the lowest
    undamped omega < gamma/2 give overdamped pairs -gamma/2 +- sqrt(gamma^2/4 - omega^2));
    the rigid modes' pairs are 0 and -gamma."""
    monkeypatch.setattr(quadratic_windows, "NEV", 40)
    result, omega, gamma = _exact_case(comm, "gamma_M", solver)
    under = omega > gamma / 2
    exact = np.concatenate((-gamma / 2 + 1j * np.sqrt(omega[under] ** 2 - gamma**2 / 4),
                            -gamma / 2 + np.sqrt(gamma**2 / 4 - omega[~under] ** 2) + 0j,
                            -gamma / 2 - np.sqrt(gamma**2 / 4 - omega[~under] ** 2) + 0j,
                            np.full(result.n_zero_modes, -gamma + 0j)))  # a rigid mode's roots: 0 and -gamma
    assert_all(np.sum(~under) > 0, "no overdamped mode: lower the packing's phi or raise gamma")
    complex_ = result.lam[result.lam.imag > 0]
    assert_close(complex_.real, np.full(complex_.size, -gamma / 2), rtol=0.0, atol=1e-10, what="Re lambda")
    assert_all(result.lam.size == exact.size, f"{result.lam.size} roots kept, {exact.size} exact")
    error = max(_nearest(result.lam, exact).max(), _nearest(exact, result.lam).max())
    assert_all(error < 1e-9, f"roots differ from the exact ones by {error:.1e}")


@pytest.mark.mpi
def test_windows_do_not_depend_on_the_rank_count(monkeypatch):
    """The same damped spectrum on 2 ranks (test_windows_equal_the_dense_first_order_solve's thin
    band) as on 1 (rank 0 alone, on COMM_SELF), to 1e-10."""
    monkeypatch.setattr(quadratic_windows, "NEV", 40)
    both, _ = _windows_and_dense(0.15, 2)
    alone = None
    if COMM.rank == 0:
        dm = _damped(PETSc.COMM_SELF, 64, 0.86, 3, 0.15)
        try:
            alone = pep.solve(dm, ZERO_TOL, solver="windows")
        finally:
            dm.destroy()
    alone = COMM.bcast(alone, root=0)
    _assert_same_spectrum(both, alone, 1e-10, "2 ranks vs 1")


def test_a_damped_scene_stores_lambda_and_its_vdos(shared_tmp, monkeypatch):
    """spectrum: {} with model.damping chooses pep; the spectrum groups hold every kept lambda
    (Im >= 0), the counts, and the vDOS is that of the damped frequencies; rotsound plot draws
    the damped figures, readable, each titled with what it shows and rho (the file's vDOS too:
    it is of the damped frequencies, not the undamped one's title)."""
    scene = scene_of(shared_tmp / "damped.h5", cache="off", packing={"n": 32, "phi": 0.9, "count": 1},
                     model={"rho": [0.5], "damping": {"gamma_n": 0.3, "gamma_t": 0.15}}, spectrum={"energies": True})
    units = pipeline.run(scene, COMM, [])["units"]
    datasets, attrs = units["spectra/r00_p0000"]
    lam = datasets["lambda"]
    assert_all(attrs["method"] == "pep" and lam.dtype == np.complex128 and np.all(lam.imag >= 0))
    assert_all(attrs["n_zero_modes"] + 2 * attrs["n_underdamped"] + attrs["n_overdamped"] == 2 * attrs["dof"])
    assert_all(datasets["K"].size == lam.size)
    edges, density = units["vdos/r00"][0]["edges"], units["vdos/r00"][0]["density"]
    counts, _ = np.histogram(lam.imag[lam.imag > 0], bins=edges)
    assert_close(density, counts / (counts.sum() * np.diff(edges)), rtol=1e-12, atol=0.0, what="damped vDOS")
    if COMM.size == 1:  # drawing is rank 0's alone, from a file the same on 1 or 2 ranks: once, in the 1-rank pass
        figures = capture(monkeypatch)
        written = plots.plot_results(str(scene.output))
        assert any(path.endswith("_damped_modes.png") for path in written) \
            and any(path.endswith("_damped_vdos.png") for path in written), written
        assert_readable(figures)
        titles = {name: [ax.get_title() for ax in fig.axes if ax.get_title()] for name, fig in figures.items()}
        assert all(r"$\rho$ = 0.5" in title for name in ("damped_damped_modes.png", "damped_damped_vdos.png")
                   for title in titles[name]), titles
        assert "damped" in titles["damped_vdos.png"][0] and len({t[0] for t in titles.values()}) == len(titles), titles


def test_windows_resume_after_a_stop(shared_tmp, monkeypatch):
    """A pep spectrum stopped after 2 windows resumes from them: the windows are not solved again
    and the result equals an uninterrupted run's."""
    monkeypatch.setattr(quadratic_windows, "NEV", 40)
    scene = scene_of(shared_tmp / "resume.h5", cache="off", packing={"n": 64, "phi": 0.86, "count": 1},
                     model={"rho": [0.5], "damping": {"gamma_n": 0.3, "gamma_t": 0.15}}, spectrum={"solver": "windows"})
    calls = run_stopped_after_windows(monkeypatch, scene, 2, quadratic_windows, "_column")
    resumed = pipeline.run(scene, COMM, [])["units"]["spectra/r00_p0000"]
    interrupted_and_resumed = len(calls)
    fresh = pipeline.run(scene, COMM, [], fresh=True)["units"]["spectra/r00_p0000"]
    assert_all(interrupted_and_resumed == len(calls) - interrupted_and_resumed,
               f"{interrupted_and_resumed} columns solved with the stop, {len(calls) - interrupted_and_resumed} "
               f"without: the resumed run solved finished windows again")
    assert_all(resumed[1]["windows"] > 2)
    assert_close(resumed[0]["lambda"], fresh[0]["lambda"], rtol=1e-13, atol=1e-13, what="resumed vs fresh")


@pytest.mark.parametrize("window", [(0.8, 1.6), (0.0, 0.7)])
def test_a_frequency_window_holds_exactly_the_dense_modes_in_it(comm, monkeypatch, window):
    """spectrum.window for pep: the columns from lo to hi alone (no count or trace check) find
    every mode dense finds with omega_d in [lo, hi), to 1e-8, on the wide band (gamma_t = 0.9);
    from lo = 0 the real (overdamped) roots and the zeros too."""
    monkeypatch.setattr(quadratic_windows, "NEV", 40)
    dm = _damped(comm, 64, 0.86, 3, 0.9)
    dense = pep.solve(dm, ZERO_TOL, solver="dense", window=window)
    windows = pep.solve(dm, ZERO_TOL, solver="windows", window=window)
    everything = pep.solve(dm, ZERO_TOL, solver="dense")
    dm.destroy()
    inside = (everything.lam.imag >= window[0]) & (everything.lam.imag < window[1])
    assert_all(dense.lam.size == inside.sum() > 10, f"{dense.lam.size} modes in the window, {inside.sum()} expected")
    _assert_same_spectrum(windows, dense, 1e-8, f"window {window}")
    assert_all((window[0] > 0) == (dense.n_overdamped == 0), "overdamped roots belong to a window from 0 only")


def test_bands_about_given_frequencies_hold_the_dense_modes_in_them(comm, monkeypatch):
    """spectrum.frequencies: one band of +-frequency_width about each (overlapping ones merged),
    each marched on its own; the modes found are dense's in the bands, to 1e-8."""
    from solver.errors import InputError

    scene = scene_of("x.h5", packing={"n": 64, "phi": 0.9}, model={"damping": {"gamma_n": 0.3}},
                     spectrum={"frequencies": [1.5, 0.5, 0.55], "frequency_width": 0.1})
    bands = plan.pep_bands(scene.spectrum)
    assert bands == [(0.4, 0.65), (1.4, 1.6)]
    monkeypatch.setattr(quadratic_windows, "NEV", 40)
    dm = _damped(comm, 64, 0.86, 3, 0.9)
    dense = pep.solve(dm, ZERO_TOL, solver="dense", window=bands)
    windows = pep.solve(dm, ZERO_TOL, solver="windows", window=bands)
    dm.destroy()
    assert_all(dense.lam.size > 10 and np.all(((dense.lam.imag >= 0.4) & (dense.lam.imag < 0.65))
                                               | ((dense.lam.imag >= 1.4) & (dense.lam.imag < 1.6))))
    _assert_same_spectrum(windows, dense, 1e-8, "bands")
    with pytest.raises(InputError, match="bands of damped modes, for method 'pep'"):
        scene_of("x.h5", packing={"n": 64, "phi": 0.9}, spectrum={"method": "slicing", "frequencies": [1.0]})


def test_backward_error_is_that_of_the_accepted_modes(comm, monkeypatch):
    """A disk's Ritz pairs outside its column's omega range are left to other columns (or, beyond
    the box, to none); their vectors need not be converged.  The reported backward error is the
    accepted modes' only: here every disk also returns a spurious pair far above the box with
    backward error 1, which must neither be accepted nor reported (it was, as 0.99 at N = 1024).
    ``checks["shifts"]`` counts the disks solved."""
    real, calls = quadratic_windows._solve_disk, []

    def with_spurious(*args, **kwargs):
        calls.append(1)
        found = real(*args, **kwargs)
        far = 10.0 * (1.0 + float(np.abs(found["lambda"]).max()))
        found["lambda"] = np.append(found["lambda"], [-0.1 + 1j * far, -0.1 - 1j * far])
        found["residual"] = np.append(found["residual"], [1.0, 1.0])
        found["sums"] = np.concatenate((found["sums"], found["sums"][:2]))
        return found

    monkeypatch.setattr(quadratic_windows, "NEV", 40)
    monkeypatch.setattr(quadratic_windows, "_solve_disk", with_spurious)
    dm = _damped(comm, 64, 0.86, 3, 0.15)
    windows = pep.solve(dm, ZERO_TOL, solver="windows")
    dense = pep.solve(dm, ZERO_TOL, solver="dense")
    dm.destroy()
    _assert_same_spectrum(windows, dense, 1e-8, "windows with spurious far pairs vs dense")
    assert_all(windows.checks["max_residual"] < 1e-9, f"backward error {windows.checks['max_residual']:.1e}")
    assert_all(windows.checks["shifts"] == len(calls) > 0, f"{windows.checks['shifts']} shifts, {len(calls)} disks")
