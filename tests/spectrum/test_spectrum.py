"""SLEPc spectrum vs dense eigh, windows, zero modes, K/Q identity; runs on 1 and 2 ranks."""

import numpy as np
import pytest
import scipy.linalg as sl
from conftest import COMM, assert_all, assert_close, jammed_packing

from solver.contact_law import ContactModel
from solver.model import dynmat, operators
from solver.io import hdf5
from solver.spectrum import modes
from solver.packing import jammed
from solver.spectrum import slicing


@pytest.fixture(scope="module")
def packing96():
    return jammed_packing(96, 0.9, 21)


def dense_omegas(dm):
    A = operators.scaled_operator(dm)
    lam = sl.eigh(dynmat.gather_csr(A).toarray(), eigvals_only=True)
    A.destroy()
    return np.sign(lam) * np.sqrt(np.abs(lam))


@pytest.mark.parametrize("rho", [0.0, 0.2, 1.0, 2.0])
def test_full_spectrum_equals_dense_eigh(comm, packing96, rho):
    dm = dynmat.assemble(packing96, ContactModel(rho), comm)
    result = slicing.solve(dm, window=None, vectors=False, max_window_modes=120)
    ref = dense_omegas(dm)
    nonzero = ref[ref > 1e-4]
    assert_all(result.omega.size == dm.size - 2 == nonzero.size, "count = DOF - 2 zero modes")
    assert_all(result.n_zero_modes == 2 and result.n_negative == 0, "zero modes")
    # issue 3 asks 1e-8; Rayleigh quotients give ~1e-14 (Ritz values alone: 1e-8 at rho = 2)
    assert_close(result.omega, nonzero, rtol=1e-11, what="omega vs eigh")
    assert_all(result.windows >= 2, "several windows were exercised")
    dm.destroy()


def test_full_spectrum_survives_a_low_band_top_estimate(comm, packing96):
    """The full spectrum's upper bound comes from the Lanczos omega_max (cached on dm); if that
    were too low, the inertia sees the missing modes and the Gershgorin bound takes over."""
    dm = dynmat.assemble(packing96, ContactModel(1.0), comm)
    ref = dense_omegas(dm)
    dm.omega_max = 0.9 * ref.max()  # the top ~10 % of the band is above the estimate
    result = slicing.solve(dm, window=None, vectors=False)
    assert_all(result.omega.size == dm.size - 2, "every mode found despite the low estimate")
    assert_close(result.omega, ref[ref > 1e-4], rtol=1e-11, what="omega vs eigh")  # measured 2e-15
    dm.destroy()


def test_window_is_subset_of_full(comm, packing96):
    dm = dynmat.assemble(packing96, ContactModel(1.0), comm)
    full = slicing.solve(dm, window=None, vectors=False)
    lo, hi = 2.5, 4.0
    part = slicing.solve(dm, window=(lo, hi), vectors=False)
    expect = full.omega[(full.omega > lo) & (full.omega <= hi)]
    assert_close(part.omega, expect, rtol=1e-11, what="window")  # both within 1e-11 of eigh; measured 4e-16
    assert_all(part.n_zero_modes == 2, "zero modes counted in window mode too")
    dm.destroy()


@pytest.mark.parametrize("rho", [0.4, 1.0])
def test_energies_identity_and_against_dense_vectors(comm, packing96, rho):
    dm = dynmat.assemble(packing96, ContactModel(rho), comm)
    result = slicing.solve(dm, window=None, vectors=True, max_window_modes=100)
    e = result.energies
    n = int(dm.active.sum())
    # holds when the vectors are unit vectors: round-off of sums of squares (measured 2e-15)
    assert_close(e["Kx"] + e["Ky"] + e["Q"], np.full(e["Q"].size, 1 / (2 * n)), rtol=1e-13, what="K/Q normalisation")
    assert_all(np.all((e["participation"] > 1 / n - 1e-12) & (e["participation"] <= 1 + 1e-12)), "PR range")
    # dense reference for K_x, K_y, Q of each mode.  Both eigenvectors are determined to
    # (residual) / gap (Davis-Kahan): SLEPc's to r lambda / gap (r its largest relative
    # residual), eigh's to ~ n eps lambda_max / gap; |e^2 - e'^2| summed <= 2 |e - e'|, so each
    # is held to 2 (r lambda + n eps lambda_max) / gap / 2N (measured <= 1.4e-3 of that bound)
    A = operators.scaled_operator(dm)
    lam, vec = sl.eigh(dynmat.gather_csr(A).toarray())
    A.destroy()
    vec, lam = vec[:, lam > 1e-8], lam[lam > 1e-8]
    gap = np.minimum(np.diff(lam, prepend=0.0), np.diff(lam, append=np.inf))
    bound = 2 * (result.max_residual * lam + lam.size * np.finfo(float).eps * lam.max()) / gap / (2 * n)
    for key, rows in (("Kx", vec[0::3]), ("Ky", vec[1::3]), ("Q", vec[2::3])):
        assert_close(e[key], (rows**2).sum(axis=0) / (2 * n), rtol=0, atol=bound, what=f"{key} vs dense eigenvectors")
    dm.destroy()


def test_loaded_packing_gives_same_spectrum(comm, packing96, shared_tmp):
    path = shared_tmp / "p.h5"
    if COMM.rank == 0:
        hdf5.save_packings(str(path), [packing96])
    COMM.Barrier()
    (loaded,) = hdf5.read_packings(str(path))
    a = slicing.solve(dynmat.assemble(packing96, ContactModel(0.5), comm), window=None, vectors=False)
    b = slicing.solve(dynmat.assemble(loaded, ContactModel(0.5), comm), window=None, vectors=False)
    assert_close(a.omega, b.omega, rtol=1e-12, what="file vs generated")


@pytest.mark.parametrize("option, value", [(None, None),
                                           pytest.param("pc_factor_mat_solver_type", "petsc",
                                                        marks=pytest.mark.serial_only),  # no parallel petsc Cholesky
                                           ("mat_mumps_icntl_24", "0")])
def test_shift_and_invert_factorises_with_mumps_unless_told(comm, packing96, shared_tmp, option, value):
    """MUMPS with ICNTL 13 = 24 = 1 by default (slicing once silently fell back to PETSc's own
    Cholesky, 12x slower per factorisation at N = 32768: SLEPc factorises in an internal EPS
    whose KSP never saw the defaults); a ``-spectrum_st_*`` option wins over each default.  What
    was used is read back from the solver objects after the solve, and the package also from the
    EPS's own view."""
    from petsc4py import PETSc
    from slepc4py import SLEPc

    from solver.options import eps_settings

    options = PETSc.Options()
    if option:  # as the user's command line would put it
        options.setValue(f"spectrum_st_{option}", value)
    dm = dynmat.assemble(packing96, ContactModel(1.0), comm)
    A = operators.scaled_operator(dm)
    eps = SLEPc.EPS().create(comm)
    path = str(shared_tmp / f"eps_{option}.txt")
    try:
        slicing.configure_window(eps, A, [1.0, 4.0], 1e-10)
        eps.solve()
        settings = eps_settings(eps)
        viewer = PETSc.Viewer().createASCII(path, comm=comm)
        eps.view(viewer)
        viewer.destroy()
    finally:
        if option:
            options.delValue(f"spectrum_st_{option}")
        eps.destroy()
        A.destroy()
        dm.destroy()
    package = value if option == "pc_factor_mat_solver_type" else "mumps"
    used = [line.split(":")[1].strip() for line in open(path) if "package used to perform factorization" in line]
    assert_all(used == [package], f"factorisation package in the view {used}")
    assert_all(settings["prefix"] == "spectrum_" and settings["factor_package"] == package
               and settings["pc_type"] == "cholesky" and settings["ksp_type"] == "preonly", f"{settings}")
    if package == "mumps":
        expected = {"13": 1, "24": int(value) if option == "mat_mumps_icntl_24" else 1}
        assert_all(settings["mumps_icntl"] == expected, f"ICNTL {settings['mumps_icntl']} != {expected}")


@pytest.mark.parametrize("option, value", [(None, None),
                                           pytest.param("pc_factor_mat_solver_type", "petsc",
                                                        marks=pytest.mark.serial_only)])
def test_inertia_factorisation_takes_its_prefixed_options(comm, packing96, option, value):
    """count_below's Cholesky has the prefix ``inertia_``: MUMPS with ICNTL 13 and 24 by default,
    ``-inertia_pc_factor_mat_solver_type petsc`` switches it (read back from the PC), and the
    count stays the dense eigh count."""
    from petsc4py import PETSc

    options = PETSc.Options()
    if option:
        options.setValue(f"inertia_{option}", value)
    dm = dynmat.assemble(packing96, ContactModel(1.0), comm)
    A = operators.scaled_operator(dm)
    try:
        count, used = slicing.inertia(A, 4.0)
    finally:
        if option:
            options.delValue(f"inertia_{option}")
        A.destroy()
    expected = int(np.sum(dense_omegas(dm) ** 2 < 4.0))
    dm.destroy()
    assert_all(count == expected, f"inertia {count} != {expected}")
    assert_all(used["prefix"] == "inertia_" and used["factor_package"] == (value or "mumps"), f"{used}")
    if not option:
        assert_all(used["mumps_icntl"] == {"13": 1, "24": 1}, f"{used}")


class DictCheckpoint:
    """In-memory stand-in for the unit store's window checkpoint (arrays, as read back)."""

    def __init__(self):
        self.saved, self.loaded = {}, []

    def load(self, name):
        if name in self.saved:
            self.loaded.append(name)
            return self.saved[name]
        return None

    def save(self, name, datasets):
        self.saved[name] = {k: np.array(v) for k, v in datasets.items()}


def test_checkpointed_windows_resume_to_the_same_spectrum(comm, packing96):
    class Stop(Exception):
        pass

    def stop_after_two(done, total, modes):
        if done == 2:
            raise Stop

    dm = dynmat.assemble(packing96, ContactModel(1.0), comm)
    whole = slicing.solve(dm, window=None, vectors=True, max_window_modes=60)
    checkpoint = DictCheckpoint()
    with pytest.raises(Stop):
        slicing.solve(dm, window=None, vectors=True, max_window_modes=60, checkpoint=checkpoint,
                       progress=stop_after_two)
    assert_all(sorted(checkpoint.saved) == ["plan", "window0000", "window0001"], "saved so far")
    resumed = slicing.solve(dm, window=None, vectors=True, max_window_modes=60, checkpoint=checkpoint)
    assert_all(checkpoint.loaded == ["plan", "window0000", "window0001"], "taken from the checkpoint")
    assert_all(resumed.windows == whole.windows >= 4, "same plan, several windows")
    # the same windows solved the same way on the same ranks: bitwise equal (as test_resume's files)
    assert_all(np.array_equal(resumed.omega, whole.omega), "omega")
    assert_all(all(np.array_equal(resumed.energies[k], whole.energies[k]) for k in whole.energies), "energies")
    dm.destroy()


@pytest.mark.mpi
@pytest.mark.parametrize("first, then", [("world", "self"), ("self", "world")])
def test_checkpointed_spectrum_resumes_on_another_rank_count(packing96, first, then):
    """A spectrum stopped after its first window resumes on 1 rank when it started on 2, and on
    2 when it started on 1 (the saved plan once held one sub-interval per rank of the first
    run, and Krylov-Schur refuses more partitions than ranks).  Each rank keeps its own copy of
    the checkpoint (the windows' contents are the same on every rank)."""
    from petsc4py import PETSc

    class Stop(Exception):
        pass

    def stop_after_one(done, total, modes):
        if done == 1:
            raise Stop

    comms = {"world": PETSc.COMM_WORLD, "self": PETSc.COMM_SELF}
    whole_dm = dynmat.assemble(packing96, ContactModel(1.0), comms[then])
    whole = slicing.solve(whole_dm, window=None, vectors=True, max_window_modes=60)
    checkpoint = DictCheckpoint()
    dm = dynmat.assemble(packing96, ContactModel(1.0), comms[first])
    with pytest.raises(Stop):
        slicing.solve(dm, window=None, vectors=True, max_window_modes=60, checkpoint=checkpoint,
                       progress=stop_after_one)
    dm.destroy()
    assert_all(sorted(checkpoint.saved) == ["plan", "window0000"], "saved so far")
    resumed = slicing.solve(whole_dm, window=None, vectors=True, max_window_modes=60, checkpoint=checkpoint)
    assert_all(checkpoint.loaded == ["plan", "window0000"], "taken from the checkpoint")
    assert_all(resumed.windows == whole.windows >= 4, "same plan, several windows")
    assert_close(resumed.omega, whole.omega, rtol=1e-12, what="omega")
    # The first window was sliced into other sub-intervals (other shifts, other Krylov paths),
    # so its eigenvectors agree only to r lambda / gap (Davis-Kahan, r the relative residual):
    # K_x, K_y, K, Q are held to that bound per mode, as in test_resume's rank-invariance test
    # (the participation ratio follows from the same vectors and is not compared separately).
    lam = whole.omega**2
    gap = np.minimum(np.diff(lam, prepend=-np.inf), np.diff(lam, append=np.inf))
    bound = 2 * (2 * max(resumed.max_residual, whole.max_residual) * lam / gap) / (2 * int(whole_dm.active.sum()))
    for key in ("Kx", "Ky", "K", "Q"):
        error = np.abs(resumed.energies[key] - whole.energies[key])
        assert_all(np.all(error <= bound + 1e-14),  # + round-off of sums of squares of order 1/2N
                   f"{key}: worst error / bound {np.max(error / (bound + 1e-14)):.3g}")
    whole_dm.destroy()


def test_count_below_is_sylvester_inertia(comm, packing96):
    dm = dynmat.assemble(packing96, ContactModel(1.0), comm)
    A = operators.scaled_operator(dm)
    ref = dense_omegas(dm) ** 2 * np.sign(dense_omegas(dm))
    for sigma in (1e-8, 1.0, 7.3, 30.0):
        assert_all(slicing.count_below(A, sigma) == int(np.sum(ref < sigma)), f"inertia at {sigma}")
    A.destroy()
    dm.destroy()


def test_windows_have_balanced_counts(comm, packing96):
    """Every window of the plan holds a window's share of the modes to within a quarter of a
    window per cut, and its stored counts are exact; every sub-interval of a window split for
    p ranks likewise holds a piece's share (the plan refines inertias until it knows so);
    checked with dense eigh."""
    dm = dynmat.assemble(packing96, ContactModel(1.0), comm)
    A = operators.scaled_operator(dm)
    lam = dense_omegas(dm) ** 2
    hi = float(lam.max()) * 1.001
    edges, counts, known = slicing.plan_windows(A, 1e-8, hi, 50)
    total = int(counts[-1] - counts[0])
    exact = np.array([np.sum(lam < e) for e in edges])
    assert_all(np.array_equal(counts, exact), f"counts at the window edges {counts} vs {exact}")
    assert_all(edges.size - 1 == -(-total // 50), "window count")
    step = total / (edges.size - 1)
    assert_all(np.all(np.abs(np.diff(exact) - step) <= step / 2 + 1), f"window counts {np.diff(exact)} vs {step:.1f}")
    for parts in (2, 3):
        for w in range(edges.size - 1):
            sub = slicing.split_window(A, known, float(edges[w]), float(edges[w + 1]), parts)
            pieces = np.diff([np.sum(lam < e) for e in sub])
            share = (exact[w + 1] - exact[w]) / parts
            assert_all(len(sub) == parts + 1 and sub[0] == edges[w] and sub[-1] == edges[w + 1]
                       and np.all(np.diff(sub) > 0), f"window {w} split for {parts}: {sub}")
            assert_all(np.all(np.abs(pieces - share) <= share / 2 + 1), f"window {w}, {parts} parts: {pieces} vs {share:.1f}")
    A.destroy()
    dm.destroy()


def test_count_below_frees_its_factorisation(comm):
    """Repeated inertias must not accumulate MUMPS factors (a leak of one factor per call once
    ran a 300-shift N = 32768 plan out of memory): 40 calls here leaked ~50 MiB."""
    p = jammed.generate(512, 0.9, np.random.SeedSequence([3, 0]))
    dm = dynmat.assemble(p, ContactModel(1.0), comm)
    A = operators.scaled_operator(dm)

    def resident_mib():
        return int(open("/proc/self/statm").read().split()[1]) * 4096 / 2**20

    slicing.count_below(A, 3.0)
    before = resident_mib()
    for i in range(40):
        slicing.count_below(A, 3.0 + 0.01 * i)
    growth = resident_mib() - before
    A.destroy()
    dm.destroy()
    assert_all(growth < 10, f"resident memory grew by {growth:.1f} MiB over 40 inertias")


def test_vdos_pools_configurations_and_cutoff():
    """The pooled vDOS against modes counted here bin by bin (floor(omega / w)), over both
    configurations (its unit area holds by construction and is not what is tested)."""
    rng = np.random.default_rng(0)
    omegas = [rng.uniform(0.1, 3.0, 500), rng.uniform(0.1, 3.2, 400)]
    edges, density = modes.vdos(omegas, 0.05)
    pooled = np.concatenate(omegas)
    assert edges[0] == 0 and edges[-2] <= pooled.max() < edges[-1]
    counts = np.bincount(np.floor(pooled / 0.05).astype(int), minlength=density.size)
    assert_close(density, counts / (pooled.size * 0.05), rtol=1e-13, what="density")
    mean, spread = modes.cutoff(omegas)
    assert_close(mean, 0.5 * (omegas[0].max() + omegas[1].max()), rtol=np.finfo(float).eps, what="omega_c")
    assert_close(spread, abs(omegas[0].max() - omegas[1].max()) / np.sqrt(2), rtol=1e-14, what="omega_c std")
    avg = modes.bin_average(np.array([0.01, 0.02, 0.07]), np.array([1.0, 3.0, 5.0]), np.array([0, 0.05, 0.1, 0.15]))
    np.testing.assert_allclose(avg, [2.0, 5.0, np.nan], rtol=1e-15, atol=0)  # empty bin: NaN
    empty = modes.bin_average(np.array([]), np.array([]), np.array([0, 0.05, 0.1]))
    assert empty.shape == (2,) and np.isnan(empty).all()


@pytest.mark.serial_only  # arrays written by hand, no communicator
def test_pooled_vdos_of_kpm_units_of_different_reach():
    """KPM units share bins but reach different tops: the pooled density is their mean on the
    longest grid (zero beyond a shorter one's top), omega_c the mean of their omega_max; slicing
    units pool their modes.  Numbers written out by hand."""
    a = ({"edges": np.array([0.0, 0.5, 1.0]), "density": np.array([1.0, 1.0])}, {"omega_max": 1.0})
    b = ({"edges": np.array([0.0, 0.5, 1.0, 1.5]), "density": np.array([0.4, 0.8, 0.8])}, {"omega_max": 1.4})
    edges, density, omega_c, spread = modes.pooled_vdos([a, b], 0.5)
    assert_all(np.array_equal(edges, b[0]["edges"]), f"edges {edges}")
    assert_close(density, [0.7, 0.9, 0.4], rtol=1e-15, what="pooled KPM density")
    assert_close([omega_c, spread], [1.2, 0.2 * np.sqrt(2)], rtol=1e-15, what="omega_c and its std")
    sliced = [({"omega": np.array([0.1, 0.3])}, {}), ({"omega": np.array([0.2])}, {})]
    edges, density, omega_c, spread = modes.pooled_vdos(sliced, 0.25)
    assert_close(edges, [0.0, 0.25, 0.5], rtol=0.0, what="slicing edges")
    assert_close(density, [2 / 0.75, 1 / 0.75], rtol=1e-15, what="slicing density (3 modes, w = 0.25)")
    assert_close([omega_c, spread], [0.25, 0.05 * np.sqrt(2)], rtol=1e-15, what="slicing omega_c")
