"""Stochastic vDOS (KPM): moments against a dense evaluation with the same probes, accuracy, ranks."""

import numpy as np
import pytest
import scipy.linalg as sl
from conftest import assert_all

from solver.model import dynmat
from solver.spectrum import kpm
from solver.packing import jammed as packing
from solver.spectrum import slicing as spectrum


@pytest.fixture(scope="module")
def packing256():
    return packing.generate(256, 0.9, np.random.SeedSequence([41, 0]))


def test_moments_equal_dense_chebyshev_with_same_probes(comm, packing256):
    dm = dynmat.assemble(packing256, 1.0, comm)
    lam_max = spectrum.largest_omega(dm) ** 2
    mu, c, h = kpm.moments(dm, lam_max, 41, probes=5, seed=3)
    A = spectrum.scaled_operator(dm)
    dense = dynmat.gather_csr(A).toarray()
    A.destroy()
    n = dense.shape[0]
    rng = np.random.default_rng(np.random.SeedSequence([3, 7]))  # the documented probe stream
    z = rng.choice([-1.0, 1.0], size=(n, 5))
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
    assert_all(np.abs(mu - ref).max() < 1e-10, f"moments {np.abs(mu - ref).max()}")
    dm.destroy()


def test_vdos_against_exact_histogram(comm, packing256):
    dm = dynmat.assemble(packing256, 1.0, comm)
    w = spectrum.largest_omega(dm)
    A = spectrum.scaled_operator(dm)
    lam = sl.eigh(dynmat.gather_csr(A).toarray(), eigvals_only=True)[2:]
    A.destroy()
    edges = np.arange(0, 1.1 * w, 0.25)  # wide bins: the exact histogram of 766 modes is noisy
    ref, _ = np.histogram(np.sqrt(lam), bins=edges, density=True)
    errors = []
    for m in (50, 400):
        g = kpm.vdos(dm, edges, w**2, m, probes=64, seed=0)
        assert_all(abs(np.sum(g * np.diff(edges)) - 1) < 1e-12, "unit area")
        errors.append(np.sum(np.abs(g - ref) * np.diff(edges)))
    assert_all(errors[1] < errors[0] and errors[1] < 0.05, f"L1 errors {errors}")
    dm.destroy()


def test_channel_moments_weigh_modes_by_their_share(comm, packing256):
    """Translation- plus rotation-restricted moments, dense reference: sum_q |P e_q|^2 T_n(x_q)."""
    dm = dynmat.assemble(packing256, 1.0, comm)
    lam_max = spectrum.largest_omega(dm) ** 2
    A = spectrum.scaled_operator(dm)
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
        assert_all(np.abs(mu - ref).max() < 0.02, f"{channel}: {np.abs(mu - ref).max()}")
    dm.destroy()


def test_kpm_energies_against_exact_bin_averages(comm, packing256):
    dm = dynmat.assemble(packing256, 1.0, comm)
    w = spectrum.largest_omega(dm)
    A = spectrum.scaled_operator(dm)
    lam, vec = sl.eigh(dynmat.gather_csr(A).toarray())
    A.destroy()
    omega, vec = np.sqrt(lam[2:]), vec[:, 2:]
    n_disks = int(dm.active.sum())
    k_exact = (vec[0::3] ** 2 + vec[1::3] ** 2).sum(axis=0) / (4 * n_disks)
    edges = np.arange(0, 1.1 * w, 0.25)
    from solver.spectrum.modes import bin_average

    ref_k = bin_average(omega, k_exact, edges)
    counts = np.histogram(omega, edges)[0]
    g, k, q = kpm.energies(dm, edges, w**2, 400, probes=64, seed=2)
    full = np.isfinite(k)
    assert_all(np.allclose(2 * k[full] + q[full], 1 / (2 * n_disks), rtol=1e-12), "2K + Q = 1/2N per bin")
    assert_all(abs(np.sum(g * np.diff(edges)) - 1) < 1e-12, "unit area")
    busy = (counts >= 30) & full
    rel = np.abs(k[busy] / ref_k[busy] - 1)
    assert_all(busy.sum() >= 8 and rel.max() < 0.1, f"K relative errors {rel}")
    dm.destroy()
