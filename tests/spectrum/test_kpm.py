"""Stochastic vDOS (KPM): moments against a dense evaluation with the same probes, accuracy, ranks."""

import copy

import numpy as np
import pytest
import scipy.linalg as sl
from scipy.stats import binned_statistic
from conftest import FailingProducts, assert_all, assert_close, jammed_packing

from solver.contact_law import ContactModel
from solver.model import dynmat, operators
from solver.spectrum import kpm


@pytest.fixture(scope="module")
def packing256():
    return jammed_packing(256, 0.9, 41)


def test_moments_equal_dense_chebyshev_with_same_probes(comm, packing256):
    dm = dynmat.assemble(packing256, ContactModel(1.0), comm)
    lam_max = operators.largest_omega(dm) ** 2
    mu, c, h = kpm.moments(dm, lam_max, 41, probes=5, seed=3)
    A = operators.scaled_operator(dm)
    dense = dynmat.gather_csr(A).toarray()
    A.destroy()
    n = dense.shape[0]
    z = kpm.probe_rows(3, 0, n, 5)  # the whole probe array, drawn at once (the ranks draw their rows)
    sq = np.sqrt(dynmat.gather_vec(dm.M))
    for axis in range(2):
        e = np.zeros(n)
        e[axis::3] = sq[axis::3]
        z -= np.outer(e, e @ z) / (e @ e)
    B = (dense - c * np.eye(n)) / h
    t_prev, t_curr, ref = z, B @ z, [np.sum(z * z), np.sum(z * (B @ z))]
    for _ in range(2, 41):
        t_prev, t_curr = t_curr, 2 * B @ t_curr - t_prev
        ref.append(np.sum(z * t_curr))
    ref = np.array(ref) / (5 * (n - 2))
    # |mu_n| <= mu_0 (|T_n| <= 1), so errors are held relative to mu_0 (~1; some mu_n are 2e-4);
    # the three-term recurrence's round-off grows at most ~n^2 eps by n = 40 (measured 1.5e-16)
    assert_close(mu, ref, rtol=0, atol=1e-13 * ref[0], what="moments")
    dm.destroy()


@pytest.mark.parametrize("probes", [5, 256, 300])
def test_probe_rows_are_the_same_in_any_block(probes):
    """Rows drawn block by block (as ranks draw theirs) equal the rows of one whole draw; the signs
    are +-1, balanced, and the columns (probes) differ."""
    whole = kpm.probe_rows(9, 0, 1000, probes)
    blocks = np.concatenate([kpm.probe_rows(9, a, b, probes) for a, b in ((0, 1), (1, 333), (333, 1000))])
    assert np.array_equal(blocks, whole)
    assert set(np.unique(whole)) == {-1.0, 1.0}
    assert abs(whole.mean()) < 5 / np.sqrt(whole.size)  # 5 sigma
    assert len({col.tobytes() for col in whole.T}) == probes


def test_vdos_against_exact_histogram(comm, packing256):
    dm = dynmat.assemble(packing256, ContactModel(1.0), comm)
    w = operators.largest_omega(dm)
    A = operators.scaled_operator(dm)
    lam = sl.eigh(dynmat.gather_csr(A).toarray(), eigvals_only=True)[2:]
    A.destroy()
    edges = np.arange(0, 1.1 * w, 0.25)  # wide bins: the exact histogram of 766 modes is noisy
    ref, _ = np.histogram(np.sqrt(lam), bins=edges, density=True)
    errors = []
    for m in (50, 400):
        g = kpm.vdos(dm, edges, w**2, m, probes=64, seed=0)
        errors.append(np.sum(np.abs(g - ref) * np.diff(edges)))
    assert_all(errors[1] < errors[0] and errors[1] < 0.05, f"L1 errors {errors}")
    dm.destroy()


def test_channel_moments_weigh_modes_by_their_share(comm, packing256):
    """Translation- plus rotation-restricted moments, dense reference: sum_q |P e_q|^2 T_n(x_q)."""
    dm = dynmat.assemble(packing256, ContactModel(1.0), comm)
    lam_max = operators.largest_omega(dm) ** 2
    A = operators.scaled_operator(dm)
    lam, vec = sl.eigh(dynmat.gather_csr(A).toarray())
    A.destroy()
    n = lam.size
    rotation = np.arange(n) % 3 == 2
    for channel, mask in (("translation", ~rotation), ("rotation", rotation)):
        mu, c, h = kpm.moments(dm, lam_max, 31, probes=400, seed=5, channel=channel)
        x = np.clip((lam[2:] - c) / h, -1, 1)
        share = np.sum(vec[mask, 2:] ** 2, axis=0)  # |P e_q|^2 of the non-zero modes
        ref = np.array([np.sum(share * np.cos(k * np.arccos(x))) for k in range(31)]) / (n - 2)
        # the stochastic trace's standard error with 400 probes is ~ sqrt(2 / 400) of a row norm:
        assert_close(mu, ref, rtol=0, atol=0.02, what=channel)
    dm.destroy()


@pytest.mark.parametrize("rho", [0.2, 1.0])
def test_kpm_energies_against_exact_bin_averages(comm, packing256, rho):
    """KPM's bin averages of K and Q, and its vDOS, against exact ones from dense eigenvectors.

    Mode q has translational share w_q = 4N K_q and rotational share 1 - w_q = 2N Q_q.  With R
    Rademacher probes, Hutchinson's estimate of a bin's channel mass has variance
    <= 2 ||F||_F^2 / R <= 2 m / R for a bin of m modes, so the bin's mean share has a standard
    error <= sigma = sqrt(2 / (R m)) per channel.  Both channels enter the ratio: held to 4 sigma
    (the Jackson smearing adds ~0.01, measured with 256 probes; worst seen 0.8 sigma).
    """
    dm = dynmat.assemble(packing256, ContactModel(rho), comm)
    w = operators.largest_omega(dm)
    A = operators.scaled_operator(dm)
    lam, vec = sl.eigh(dynmat.gather_csr(A).toarray())
    A.destroy()
    omega, vec = np.sqrt(lam[2:]), vec[:, 2:]
    n_disks = int(dm.active.sum())
    share_t = (vec[0::3] ** 2 + vec[1::3] ** 2).sum(axis=0)  # 4 N K_q
    share_r = (vec[2::3] ** 2).sum(axis=0)                    # 2 N Q_q
    edges = np.arange(0, 1.1 * w, 0.25)
    ref_k = binned_statistic(omega, share_t / (4 * n_disks), "mean", edges).statistic
    ref_q = binned_statistic(omega, share_r / (2 * n_disks), "mean", edges).statistic
    counts = np.histogram(omega, edges)[0]
    probes = 64
    g, k, q = kpm.energies(dm, edges, w**2, 400, probes=probes, seed=2)
    busy = counts >= 30
    assert_all(busy.sum() >= 8 and np.all(np.isfinite(k[busy]) & np.isfinite(q[busy])), f"busy bins {counts}")
    sigma = np.sqrt(2 / (probes * counts[busy]))
    assert_close(4 * n_disks * k[busy], 4 * n_disks * ref_k[busy], rtol=0, atol=4 * sigma, what="K (share units)")
    assert_close(2 * n_disks * q[busy], 2 * n_disks * ref_q[busy], rtol=0, atol=4 * sigma, what="Q (share units)")
    # g is the sum of the two channels' densities: against the exact histogram (L1 0.013-0.02 measured)
    exact = np.histogram(omega, edges, density=True)[0]
    error = np.sum(np.abs(g - exact) * np.diff(edges))
    assert_all(error < 0.05, f"vDOS L1 error {error}")
    dm.destroy()


def test_kpm_moments_free_their_mats_when_an_exception_passes(comm, packing256):
    """kpm.moments with an error in the third product of its recursion leaves no Mat alive (it
    used to keep the block and the product until the garbage collector found them)."""
    dm = dynmat.assemble(packing256, ContactModel(1.0), comm)
    proxy = copy.copy(dm)
    proxy.D = FailingProducts(dm.D, fail_at=3)
    with pytest.raises(RuntimeError, match="injected"):
        kpm.moments(proxy, 20.0, 20, 3, 1)
    dm.destroy()
    assert len(proxy.D.seen) >= 2 and proxy.D.live() == 0, f"{proxy.D.live()} Mats left alive"
