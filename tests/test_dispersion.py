"""Lattice model limits, fitters on synthetic data, the k_c detector."""

import numpy as np
import pytest

from solver.analysis import fits as dp

L_PAPER, A_R, A_T = 0.446, 0.73, 0.55


@pytest.mark.parametrize("rho", [0.05, 1 / 7, 0.2, 0.4, 1.0, 2.0])
def test_lattice_model_limits(rho):
    k_max = np.pi / (2 * L_PAPER)
    wt0, wr0 = dp.lattice_omega(0.0, rho, L_PAPER, A_T, A_R)
    wtm, wrm = dp.lattice_omega(k_max, rho, L_PAPER, A_T, A_R)
    assert wt0 == pytest.approx(0.0, abs=1e-6)
    assert wr0 == pytest.approx(A_R * np.sqrt(40 * rho), rel=1e-12)
    assert wrm == pytest.approx(2 * A_R * np.sqrt(3 * rho + 1), rel=1e-12)
    assert wtm == pytest.approx(A_T * np.sqrt(10 * rho), rel=1e-12)
    k = 1e-4
    wt, _ = dp.lattice_omega(k, rho, L_PAPER, A_T, A_R)
    assert wt == pytest.approx(2 * A_T * L_PAPER * k * np.sqrt(1 + rho), rel=1e-6)


def test_band_edges_cross_at_one_seventh():
    k_max = np.pi / (2 * L_PAPER)
    rho = 1 / 7
    assert dp.lattice_omega(0.0, rho, L_PAPER, A_T, A_R)[1] == pytest.approx(
        dp.lattice_omega(k_max, rho, L_PAPER, A_T, A_R)[1], rel=1e-12)


def test_printed_coefficient_would_break_acoustic_branch(monkeypatch):
    monkeypatch.setattr(dp, "G_COEFFICIENT", 300.0)
    wt0, _ = dp.lattice_omega(0.0, 1.0, L_PAPER, A_T, A_R)
    # g(0) = (X + 1) rho^2, so the printed X = 300 leaves omega_t(0) = a_t sqrt(20 - sqrt(301)) != 0
    assert wt0 == pytest.approx(A_T * np.sqrt(20 - np.sqrt(301)), rel=1e-12) and wt0 > 0.5


@pytest.mark.parametrize("omega, gamma", [(0.8, 0.02), (2.3, 0.1), (4.2, 0.4)])
def test_damped_cosine_fit_recovers_parameters(omega, gamma):
    rng = np.random.default_rng(1)
    t = np.arange(0, 200, 0.05)
    c = np.exp(-gamma * t) * np.cos(omega * t) + 0.01 * rng.normal(size=t.size)
    fit = dp.fit_damped_cosine(t, c)
    assert abs(fit.omega - omega) < max(5 * fit.omega_err, 1e-3)
    assert abs(fit.gamma - gamma) < max(5 * fit.gamma_err, 0.02 * gamma)
    assert fit.omega_err < 0.01 and 0.005 < fit.rms < 0.02
    assert fit.t_max == pytest.approx(min(200, 3 / gamma), rel=0.1)


def test_lorentzian_agrees_with_time_fit():
    from solver.analysis import correlations

    t = np.arange(0, 400, 0.1)
    c = np.exp(-0.05 * t) * np.cos(2.0 * t)
    omega, power = correlations.power_spectrum(c[None], 0.1)
    w0, gamma = dp.fit_lorentzian(omega, power)
    assert w0 == pytest.approx(2.0, abs=2e-3) and gamma == pytest.approx(0.05, rel=0.05)


def test_power_law_exponent():
    k = np.linspace(0.05, 0.4, 8)
    rng = np.random.default_rng(2)
    g = 0.7 * k**3 * np.exp(0.03 * rng.normal(size=k.size))
    p, err = dp.power_law(k, g)
    assert abs(p - 3) < 4 * err + 0.02 and err < 0.1


def test_transition_detector_on_two_branches():
    k = np.linspace(0.1, 3.0, 30)
    rng = np.random.default_rng(3)
    wt, wr = dp.lattice_omega(k, 0.2, L_PAPER, 0.8, A_R)
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
        data.append((rho, k, dp.lattice_omega(k, rho, 0.45, 1.0, 0.72)[1] + 0.005 * rng.normal(size=k.size)))
    a_r, a_err, l, l_err = dp.fit_lattice(data)
    assert abs(a_r - 0.72) < 5 * a_err + 1e-3 and abs(l - 0.45) < 5 * l_err + 1e-3
