"""Lattice model limits and band edges, fitters on synthetic data, the k_c detector."""

import numpy as np
import pytest
from conftest import assert_close

from solver.analysis import fits as dp
from solver.analysis import lattice

L_PAPER, A_R, A_T = 0.446, 0.73, 0.55


@pytest.mark.parametrize("rho", [0.05, 1 / 7, 0.2, 0.4, 1.0, 2.0])
def test_lattice_model_limits(rho):
    k_max = np.pi / (2 * L_PAPER)
    wt0, wr0 = lattice.lattice_omega(0.0, rho, L_PAPER, A_T, A_R)
    wtm, wrm = lattice.lattice_omega(k_max, rho, L_PAPER, A_T, A_R)
    # omega_t(0) = a_t sqrt(f - sqrt g) with sqrt g = f at k = 0: the cancellation can leave
    # a_t sqrt(a few eps f) ~ 1e-7 a_t (0 here), hence an absolute tolerance
    assert_close(wt0, 0.0, rtol=0, atol=1e-7 * A_T, what="omega_t(0)")
    assert_close(wr0, A_R * np.sqrt(40 * rho), rtol=1e-12, what="omega_r(0)")
    assert_close(wrm, 2 * A_R * np.sqrt(3 * rho + 1), rtol=1e-12, what="omega_r(k_max)")
    assert_close(wtm, A_T * np.sqrt(10 * rho), rtol=1e-12, what="omega_t(k_max)")
    k = 1e-4
    wt, _ = lattice.lattice_omega(k, rho, L_PAPER, A_T, A_R)
    # O(k^2) = 1e-8 truncation, and the cancellation in f - sqrt g ~ (k l)^2 costs ~eps f / (k l)^2
    # ~ 1e-7 in omega_t (measured 1.2e-7)
    assert_close(wt, 2 * A_T * L_PAPER * k * np.sqrt(1 + rho), rtol=1e-6, what="long-wave omega_t")


def test_band_edges_cross_at_one_seventh():
    k_max = np.pi / (2 * L_PAPER)
    rho = 1 / 7
    assert_close(lattice.lattice_omega(0.0, rho, L_PAPER, A_T, A_R)[1],
                 lattice.lattice_omega(k_max, rho, L_PAPER, A_T, A_R)[1], rtol=1e-12, what="model")
    assert_close(lattice.omega_r_zero(lattice.RHO_CROSSING, A_R),
                 lattice.omega_r_kmax(lattice.RHO_CROSSING, A_R), rtol=1e-12, what="closed forms")


def test_band_edge_formulas_are_the_model_at_zero_and_zone_edge():
    """The closed-form band edges (used by the report's claims and Fig. 7) agree with
    eq:omega_t(k), eq:omega_r(k) evaluated at k = 0 and k_max, for every rho (one call on an array)."""
    rho = np.array([0.05, 1 / 7, 0.2, 0.4, 1.0, 2.0, 5.0])
    k_max = lattice.k_max(L_PAPER)
    assert_close(k_max, np.pi / (2 * L_PAPER), rtol=1e-15, what="k_max")
    _, wr0 = lattice.lattice_omega(0.0, rho, L_PAPER, A_T, A_R)
    wtm, wrm = lattice.lattice_omega(k_max, rho, L_PAPER, A_T, A_R)
    np.testing.assert_allclose(lattice.omega_r_zero(rho, A_R), wr0, rtol=1e-12, atol=0)
    np.testing.assert_allclose(lattice.omega_r_kmax(rho, A_R), wrm, rtol=1e-12, atol=0)
    np.testing.assert_allclose(lattice.omega_t_kmax(rho, A_T), wtm, rtol=1e-12, atol=0)


def test_edge_a_t_prefers_the_fit_beyond_k_c():
    assert lattice.edge_a_t({"a_t": 0.55, "a_t_edge": 0.8}) == 0.8
    assert lattice.edge_a_t({"a_t": 0.55, "a_t_edge": np.nan}) == 0.55
    assert lattice.edge_a_t({"a_t": 0.55}) == 0.55


def test_printed_coefficient_would_break_acoustic_branch(monkeypatch):
    monkeypatch.setattr(lattice, "G_COEFFICIENT", 300.0)
    wt0, _ = lattice.lattice_omega(0.0, 1.0, L_PAPER, A_T, A_R)
    # g(0) = (X + 1) rho^2, so the printed X = 300 leaves omega_t(0) = a_t sqrt(20 - sqrt(301)) != 0
    assert_close(wt0, A_T * np.sqrt(20 - np.sqrt(301)), rtol=1e-12, what="omega_t(0)")
    assert wt0 > 0.5


@pytest.mark.parametrize("omega, gamma", [(0.8, 0.02), (2.3, 0.1), (4.2, 0.4)])
def test_damped_cosine_fit_recovers_parameters(omega, gamma):
    rng = np.random.default_rng(1)
    t = np.arange(0, 200, 0.05)
    c = np.exp(-gamma * t) * np.cos(omega * t) + 0.01 * rng.normal(size=t.size)
    fit = dp.fit_damped_cosine(t, c)
    assert abs(fit.omega - omega) < max(5 * fit.omega_err, 1e-3)
    assert abs(fit.gamma - gamma) < max(5 * fit.gamma_err, 0.02 * gamma)
    assert fit.omega_err < 0.01 and 0.005 < fit.rms < 0.02
    assert_close(fit.t_max, min(200, 3 / gamma), rtol=0.1, what="t_max")  # 3 / fitted gamma, gamma to ~2 %


def test_lorentzian_agrees_with_time_fit():
    from solver.analysis import correlations

    t = np.arange(0, 400, 0.1)
    c = np.exp(-0.05 * t) * np.cos(2.0 * t)
    omega, power = correlations.power_spectrum(c[None], 0.1)
    w0, gamma = dp.fit_lorentzian(omega, power)
    assert_close(w0, 2.0, rtol=1e-3, what="Lorentzian peak")  # half the grid spacing 2 pi / (4 T) = 0.004
    assert_close(gamma, 0.05, rtol=0.05, what="Lorentzian half width")


def test_power_law_exponent():
    k = np.linspace(0.05, 0.4, 8)
    rng = np.random.default_rng(2)
    g = 0.7 * k**3 * np.exp(0.03 * rng.normal(size=k.size))
    p, err = dp.power_law(k, g)
    assert abs(p - 3) < 4 * err + 0.02 and err < 0.1


def test_transition_detector_on_two_branches():
    k = np.linspace(0.1, 3.0, 30)
    rng = np.random.default_rng(3)
    wt, wr = lattice.lattice_omega(k, 0.2, L_PAPER, 0.8, A_R)
    k_c = 1.7
    data = np.where(k < k_c, wr, wt) + 0.01 * rng.normal(size=k.size)
    found = dp.transition_k(k, data)
    assert found is not None and abs(found - k_c) <= (k[1] - k[0])
    assert dp.transition_k(k, wr + 0.01 * rng.normal(size=k.size)) is None  # rho > 1-like: no jump


def test_joint_lattice_fit_recovers_parameters():
    rng = np.random.default_rng(4)
    data = []
    for rho in (0.4, 1.0, 2.0):
        k = np.linspace(0.1, np.pi / 2, 10)
        data.append((rho, k, lattice.lattice_omega(k, rho, 0.45, 1.0, 0.72)[1] + 0.005 * rng.normal(size=k.size)))
    a_r, a_err, l, l_err = dp.fit_lattice(data)
    assert abs(a_r - 0.72) < 5 * a_err + 1e-3 and abs(l - 0.45) < 5 * l_err + 1e-3
