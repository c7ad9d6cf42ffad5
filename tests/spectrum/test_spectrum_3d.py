"""The spectrum stage in 3D (issue 18): zero modes, slicing, counting, KPM, K and Q of spheres.

Oracles: dense LAPACK ``eigh`` of the assembled A = M^-1/2 D M^-1/2 (eigenvalues, eigenvectors and
the null space), on a jammed 64-sphere packing at phi = 0.7 (z ~ 7.9, no rattlers) and a 64-disk
one for the 2D case.  Runs on 1 and 2 ranks.
"""

import numpy as np
import pytest
import scipy.linalg as sl
from scipy.stats import binned_statistic
from conftest import assert_all, assert_close, jammed_packing

from solver.contact_law import ContactModel
from solver.model import dynmat, operators
from solver.spectrum import counting, kpm, modes, slicing

BIN = 0.05
ZERO = 1e-8  # |lambda| below this is a zero mode of eigh (measured: zero modes ~1e-14, the
#              smallest non-zero lambda 0.02 at rho = 0, 0.7 at rho = 0.5)


@pytest.fixture(scope="module")
def spheres():
    return jammed_packing(64, 0.7, 5, dim=3)


@pytest.fixture(scope="module")
def disks():
    return jammed_packing(64, 0.9, 5)


def dense(dm) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A dense, its eigenvalues, eigenvectors) by LAPACK, the same on every rank. Collective."""
    A = operators.scaled_operator(dm)
    try:
        a = dynmat.gather_csr(A).toarray()
    finally:
        A.destroy()
    lam, vec = sl.eigh(a)
    return a, lam, vec


def rigid_vectors(dm) -> np.ndarray:
    """(size, R) orthonormal columns: ``dm.rigid_modes()`` in A's space, M^1/2 (1 in slot s)."""
    sq = np.sqrt(dynmat.gather_vec(dm.M))
    out = np.zeros((dm.size, len(dm.rigid_modes())))
    for column, (slot, _) in enumerate(dm.rigid_modes()):
        out[slot::dm.dof, column] = sq[slot::dm.dof]
    return out / np.linalg.norm(out, axis=0)


# (packing, rho, rho_roll, rho_twist, expected zero modes, why)
ZERO_MODE_CASES = [
    ("spheres", 0.5, 0.0, 0.0, 3, "3 translations; tangential springs restrain every rotation"),
    ("spheres", 0.5, 0.3, 0.2, 3, "3 translations; all four springs on"),
    ("spheres", 0.0, 0.3, 0.2, 6, "3 translations + 3 uniform spins: rolling and twisting act on "
                                  "theta_i - theta_j only"),
    ("spheres", 0.0, 0.3, 0.0, 6, "rolling only: uniform spins free; a relative twist about n is "
                                  "free per contact, but z ~ 7.9 contacts restrain it"),
    ("spheres", 0.0, 0.0, 0.3, 6, "twisting only: likewise"),
    ("spheres", 0.0, 0.0, 0.0, 3, "frictionless: translations only (rotations not in the matrix)"),
    ("disks", 0.0, 0.3, 0.0, 3, "2D rolling only: 2 translations + the uniform spin"),
    ("disks", 0.5, 0.0, 0.0, 2, "2D frictional: 2 translations"),
]


@pytest.mark.parametrize("name, rho, rho_roll, rho_twist, expected, why", ZERO_MODE_CASES,
                         ids=[f"{c[0]}-rho{c[1]}-roll{c[2]}-twist{c[3]}" for c in ZERO_MODE_CASES])
def test_zero_modes_counted_from_the_inertia_and_explained(comm, request, name, rho, rho_roll,
                                                           rho_twist, expected, why):
    """Counting's inertia and eigh find the same number of zero modes, ``dm.rigid_modes()``
    names that many, and its vectors span eigh's whole null space (so each zero mode is one
    of them: no unexplained floppy mode, none missing)."""
    packing = request.getfixturevalue(name)
    dm = dynmat.assemble(packing, ContactModel(rho, rho_roll=rho_roll, rho_twist=rho_twist), comm)
    try:
        _, attrs, _ = counting.solve(dm, bin_width=BIN, zero_tol=1e-4)
        a, lam, vec = dense(dm)
        rigid = rigid_vectors(dm)
        names = [n for _, n in dm.rigid_modes()]
    finally:
        dm.destroy()
    zero = np.abs(lam) < ZERO
    assert_all(attrs["n_zero_modes"] == zero.sum() == len(names) == expected and
               attrs["n_negative_modes"] == 0 and not np.any(lam < -ZERO),
               f"{why}: inertia {attrs['n_zero_modes']}, eigh {zero.sum()}, rigid_modes {names}, "
               f"expected {expected}")
    scale = np.abs(lam).max()
    # each named mode is a zero mode: |A v| at round-off of ||A|| (measured ~1e-15 ||A||)
    assert_close(np.linalg.norm(a @ rigid, axis=0), np.zeros(len(names)), rtol=0,
                 atol=1e-12 * scale, what=f"|A v| of {names}")
    # eigh's null vectors lie in their span (equal dimensions: the spaces are equal); they are
    # accurate to n eps ||A|| / (smallest non-zero lambda) (Davis-Kahan; ~5e-11, measured 1e-14)
    outside = vec[:, zero] - rigid @ (rigid.T @ vec[:, zero])
    bound = lam.size * np.finfo(float).eps * scale / np.abs(lam[~zero]).min()
    assert_close(np.linalg.norm(outside, axis=0), np.zeros(zero.sum()), rtol=0, atol=bound,
                 what="null space outside span(rigid_modes)")


@pytest.mark.parametrize("rho, rho_roll, rho_twist", [(0.0, 0.0, 0.0), (0.5, 0.0, 0.0), (2.0, 0.3, 0.2),
                                                      (0.0, 0.3, 0.2)])
def test_counts_equal_dense_histogram_3d(comm, spheres, rho, rho_roll, rho_twist):
    dm = dynmat.assemble(spheres, ContactModel(rho, rho_roll=rho_roll, rho_twist=rho_twist), comm)
    try:
        datasets, attrs, _ = counting.solve(dm, bin_width=BIN, zero_tol=1e-4)
        _, lam, _ = dense(dm)
    finally:
        dm.destroy()
    zero = np.abs(lam) < ZERO
    expected, _ = np.histogram(np.sqrt(lam[~zero]), datasets["edges"])
    assert_all(np.array_equal(datasets["counts"], expected),
               f"counts differ from eigh in bins {np.nonzero(datasets['counts'] != expected)[0]}")
    assert_all(datasets["counts"].sum() == lam.size - zero.sum() and datasets["edges"][-1] > np.sqrt(lam.max()),
               "every non-zero mode in a bin")


@pytest.mark.parametrize("rho, rho_roll, rho_twist", [(0.0, 0.0, 0.0), (0.4, 0.0, 0.0), (1.0, 0.3, 0.2),
                                                      (0.0, 0.3, 0.2)])
def test_slicing_omega_and_energies_equal_dense_3d(comm, spheres, rho, rho_roll, rho_twist):
    """omega to 1e-11 relative (as in 2D); K_nu, Q_nu per mode against eigh's eigenvectors; and
    the normalisation K and Q imply in 3D (module ``modes``): each unit eigenvector has
    sum e^2 = 1 over its 6N DOF, so 3 K + 3 Q = 1/(2N) (frictionless: Q = 0, 3 K = 1/(2N))."""
    dm = dynmat.assemble(spheres, ContactModel(rho, rho_roll=rho_roll, rho_twist=rho_twist), comm)
    try:
        result = slicing.solve(dm, window=None, vectors=True, max_window_modes=150)
        _, lam, vec = dense(dm)
        n, dof, expected_zero = int(dm.active.sum()), dm.dof, len(dm.rigid_modes())
    finally:
        dm.destroy()
    nonzero = lam > ZERO
    assert_all(result.n_zero_modes == expected_zero and result.n_negative == 0 and result.windows >= 2,
               f"zero {result.n_zero_modes}, negative {result.n_negative}, windows {result.windows}")
    assert_close(result.omega, np.sqrt(lam[nonzero]), rtol=1e-11, what="omega vs eigh")
    e = result.energies
    expected_keys = {"Kx", "Ky", "Kz", "Qx", "Qy", "Qz", "K", "Q", "participation"}
    assert_all(set(e) == expected_keys, f"keys {sorted(e)}")
    # unit vectors: round-off of sums of squares (as in 2D, measured ~2e-15)
    assert_close(3 * e["K"] + 3 * e["Q"], np.full(e["K"].size, 1 / (2 * n)), rtol=1e-13,
                 what="3 K + 3 Q = 1/(2N)")
    lam, vec = lam[nonzero], vec[:, nonzero]
    # Davis-Kahan as in the 2D test (tests/spectrum/test_spectrum.py): each sum of squares over N
    # particles is held to 2 (r lambda + n eps lambda_max) / gap / 2N
    gap = np.minimum(np.diff(lam, prepend=0.0), np.diff(lam, append=np.inf))
    bound = 2 * (result.max_residual * lam + lam.size * np.finfo(float).eps * lam.max()) / gap / (2 * n)
    for slot, key in enumerate(("Kx", "Ky", "Kz", "Qx", "Qy", "Qz")):
        ref = (vec[slot::dof] ** 2).sum(axis=0) / (2 * n) if slot < dof else np.zeros(lam.size)
        assert_close(e[key], ref, rtol=0, atol=bound, what=f"{key} vs dense eigenvectors")
    ref_k = (vec[0::dof] ** 2 + vec[1::dof] ** 2 + vec[2::dof] ** 2).sum(axis=0) / (6 * n)
    assert_close(e["K"], ref_k, rtol=0, atol=3 * bound, what="K = (Kx + Ky + Kz)/3")


def test_energies_keep_the_2d_definitions():
    """2D sums (modes, 4) give K = (K_x + K_y)/2 and Q = K_theta as before issue 18, bit for bit,
    and the same keys; 3D sums (modes, 7) the per-component means."""
    rng = np.random.default_rng(3)
    vectors = rng.normal(size=(5, 3 * 10))
    s2 = modes.local_sums(vectors, 3, 2)
    e2 = modes.energies(s2, 10, 2)
    assert list(e2) == ["Kx", "Ky", "Q", "K", "participation"]
    assert np.array_equal(e2["K"], (s2[:, 0] + s2[:, 1]) / (4 * 10))  # the 2D formula, unchanged
    assert np.array_equal(e2["Q"], s2[:, 2] / (2 * 10))
    vectors3 = rng.normal(size=(5, 6 * 10))
    e3 = modes.energies(modes.local_sums(vectors3, 6, 3), 10, 3)
    per = (vectors3.reshape(5, 10, 6) ** 2).sum(axis=1)
    assert_close(e3["K"], per[:, :3].sum(axis=1) / 60, rtol=1e-15, what="3D K")
    assert_close(e3["Q"], per[:, 3:].sum(axis=1) / 60, rtol=1e-15, what="3D Q")


@pytest.mark.parametrize("rho, rho_roll, rho_twist", [(0.0, 0.3, 0.2), (1.0, 0.3, 0.2)])
def test_kpm_moments_project_out_every_zero_mode(comm, spheres, rho, rho_roll, rho_twist):
    """KPM's moments against dense Chebyshev recurrences with the same probes, projected on the
    complement of eigh's own null space (not on the code's rigid-mode vectors) and normalised by
    its non-zero mode count.  At rho = 0 the three uniform spins are zero modes too: leaving any
    in the probes shifts the moments by ~1e-2, far above the tolerance."""
    dm = dynmat.assemble(spheres, ContactModel(rho, rho_roll=rho_roll, rho_twist=rho_twist), comm)
    try:
        lam_max = operators.largest_omega(dm) ** 2
        mu, c, h = kpm.moments(dm, lam_max, 41, probes=5, seed=3)
        a, lam, vec = dense(dm)
    finally:
        dm.destroy()
    n = lam.size
    null = vec[:, np.abs(lam) < ZERO]
    z = kpm.probe_rows(3, 0, n, 5)  # kpm's probes, drawn whole (the ranks draw their rows)
    z -= null @ (null.T @ z)
    B = (a - c * np.eye(n)) / h
    t_prev, t_curr, ref = z, B @ z, [np.sum(z * z), np.sum(z * (B @ z))]
    for _ in range(2, 41):
        t_prev, t_curr = t_curr, 2 * B @ t_curr - t_prev
        ref.append(np.sum(z * t_curr))
    ref = np.array(ref) / (5 * (n - null.shape[1]))
    # as in 2D (tests/spectrum/test_kpm.py): errors relative to mu_0 (measured 3e-16); eigh's null
    # vectors are accurate to ~1e-14 here (the zero-mode test), so the two projections agree
    assert_close(mu, ref, rtol=0, atol=1e-13 * ref[0], what="moments")


@pytest.mark.parametrize("rho, rho_roll, rho_twist", [(0.5, 0.0, 0.0), (0.0, 0.3, 0.2)])
def test_kpm_vdos_agrees_with_exact_counts_3d(comm, spheres, rho, rho_roll, rho_twist):
    """KPM bin masses against counting's exact counts, within a statistical tolerance.

    The KPM mass of a bin is Hutchinson's estimate, over R Rademacher probes, of tr F / n_modes
    with F = (Jackson-smoothed bin indicator)(A) on the non-zero modes, 0 <= F <= 1: its standard
    error is <= sigma = sqrt(2 ||F||_F^2 / R) / n_modes <= sqrt(2 m / R) / n_modes for a bin of m
    modes.  The kernel's smoothing moves ~ pi h / (2 M omega) in omega across each edge, small
    with M = 400 moments and bins of 0.5 (half a mode allowed for it).  Measured with seeds 0-3:
    at most 2.5 modes off in bins whose 4 sigma is 4-8 modes.  (Zero modes left in the probes
    would add about one mode each to the first bin: the moments test above is what catches that.)"""
    dm = dynmat.assemble(spheres, ContactModel(rho, rho_roll=rho_roll, rho_twist=rho_twist), comm)
    try:
        w = operators.largest_omega(dm)
        edges = np.arange(0.0, 1.1 * w + 0.5, 0.5)
        exact, attrs, _ = counting.solve(dm, bin_width=0.5, zero_tol=1e-4)
        probes = 64
        g = kpm.vdos(dm, edges, w**2, 400, probes=probes, seed=0)
        n_modes = dm.size - len(dm.rigid_modes())
        datasets, kattrs = kpm.solve(dm, bin_width=BIN, moments=50, probes=2, with_energies=False, seed=0)
    finally:
        dm.destroy()
    counts = np.zeros(edges.size - 1)
    counts[:exact["counts"].size] = exact["counts"]
    assert_all(counts.sum() == n_modes and kattrs["n_zero_modes"] == attrs["n_zero_modes"],
               f"KPM leaves out {kattrs['n_zero_modes']} modes, the inertia counts {attrs['n_zero_modes']}")
    masses = g * np.diff(edges)
    sigma = np.sqrt(2 * counts / probes) / n_modes
    assert_close(masses, counts / n_modes, rtol=0, atol=4 * sigma + 0.5 / n_modes,
                 what="KPM bin masses vs exact counts")  # atol: 4 sigma and half a mode of smoothing


@pytest.mark.parametrize("rho, rho_roll, rho_twist", [(0.5, 0.0, 0.0), (0.0, 0.3, 0.2)])
def test_kpm_energies_against_exact_bin_averages_3d(comm, spheres, rho, rho_roll, rho_twist):
    """Mode q has w_T = 6 N K_q and w_R = 6 N Q_q in 3D (w_T + w_R = 1): KPM's bin averages of K
    and Q in those share units against dense eigenvectors, held to 4 sigma, sigma = sqrt(2/(R m))
    per channel (tests/spectrum/test_kpm.py's argument)."""
    dm = dynmat.assemble(spheres, ContactModel(rho, rho_roll=rho_roll, rho_twist=rho_twist), comm)
    try:
        w = operators.largest_omega(dm)
        _, lam, vec = dense(dm)
        n = int(dm.active.sum())
        edges = np.arange(0, 1.1 * w, 0.5)
        probes = 64
        g, k, q = kpm.energies(dm, edges, w**2, 400, probes=probes, seed=2)
    finally:
        dm.destroy()
    nonzero = lam > ZERO
    omega, vec = np.sqrt(lam[nonzero]), vec[:, nonzero]
    share_t = sum((vec[s::6] ** 2).sum(axis=0) for s in range(3))  # 6 N K_q
    ref_k = binned_statistic(omega, share_t, "mean", edges).statistic
    ref_q = binned_statistic(omega, 1 - share_t, "mean", edges).statistic
    counts = np.histogram(omega, edges)[0]
    busy = counts >= 30
    assert_all(busy.sum() >= 4 and np.all(np.isfinite(k[busy]) & np.isfinite(q[busy])), f"busy bins {counts}")
    sigma = np.sqrt(2 / (probes * counts[busy]))
    assert_close(6 * n * k[busy], ref_k[busy], rtol=0, atol=4 * sigma, what="K (share units)")
    assert_close(6 * n * q[busy], ref_q[busy], rtol=0, atol=4 * sigma, what="Q (share units)")
