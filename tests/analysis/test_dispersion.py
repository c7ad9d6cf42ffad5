"""Lattice model limits and band edges, fitters on synthetic data, k_c (the RT/TR branch exchange)."""

import numpy as np
import pytest
from conftest import assert_close
from scipy import optimize

from solver.analysis import fits
from solver.analysis import lattice

pytestmark = pytest.mark.serial_only  # fits on arrays, no communicator: nothing to gain from a second rank

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
    fit = fits.fit_damped_cosine(t, c)
    assert abs(fit.omega - omega) < max(5 * fit.omega_err, 1e-3)
    assert abs(fit.gamma - gamma) < max(5 * fit.gamma_err, 0.02 * gamma)
    assert fit.omega_err < 0.01 and 0.005 < fit.rms < 0.02
    assert_close(fit.t_max, min(200, 3 / gamma), rtol=0.1, what="t_max")  # 3 / fitted gamma, gamma to ~2 %


def test_lorentzian_agrees_with_time_fit():
    from solver.waves import correlations

    t = np.arange(0, 400, 0.1)
    c = np.exp(-0.05 * t) * np.cos(2.0 * t)
    omega, power = correlations.power_spectrum(c[None], 0.1)
    w0, gamma = fits.fit_lorentzian(omega, power)
    assert_close(w0, 2.0, rtol=1e-3, what="Lorentzian peak")  # half the grid spacing 2 pi / (4 T) = 0.004
    assert_close(gamma, 0.05, rtol=0.05, what="Lorentzian half width")


def test_power_law_exponent():
    k = np.linspace(0.05, 0.4, 8)
    rng = np.random.default_rng(2)
    g = 0.7 * k**3 * np.exp(0.03 * rng.normal(size=k.size))
    p, err = fits.power_law(k, g)
    assert abs(p - 3) < 4 * err + 0.02 and err < 0.1


# k grids of the reproduction scenes: configs/reproduce.yaml (29 k, N = 8192), configs/paper.yaml
# (42 k, N = 32768), and every n of an N = 32768 box (L ~ 150 d0, spacing 2 pi / L = 0.042)
K_COARSE = np.array([0.07, 0.15, 0.22, 0.29, 0.37, 0.44, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.35,
                     1.5, 1.65, 1.8, 1.95, 2.1, 2.25, 2.4, 2.55, 2.7, 2.85, 3.0, 3.15, 3.3, 3.52])
K_PAPER = np.array([0.037, 0.073, 0.11, 0.15, 0.18, 0.22, 0.26, 0.29, 0.33, 0.37, 0.44, 0.5, 0.6, 0.7,
                    0.8, 0.9, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9, 2.0, 2.1, 2.2, 2.3, 2.4,
                    2.5, 2.6, 2.7, 2.8, 2.9, 3.0, 3.1, 3.2, 3.3, 3.4, 3.52])
K_FINE = np.arange(1, 85) * 2 * np.pi / 150
A_EDGE = 0.8  # the acoustic branch RT drops to, a_t beyond k_c (REPRODUCTION.md: 0.83)


def exchanging_branches(k, rho=0.2, k_star=2.3, width=0.1):
    """(omega_RT, omega_TR) of a smooth exchange (Fig. 5b): RT goes from the optical branch (iv),
    the model omega_r, to the acoustic one (ii), omega_t with a_t = A_EDGE; TR from the acoustic
    branch (i), omega_t with a_t = A_T, up to (iii), here omega_r; the switch is a logistic of
    width ``width`` around ``k_star``, spread over ~4 width = 0.4 / d0 (the measured RT drop at
    N = 32768 spread over four k steps of 0.1)."""
    w_t, w_r = lattice.lattice_omega(k, rho, L_PAPER, A_T, A_R)
    w_edge = lattice.lattice_omega(k, rho, L_PAPER, A_EDGE, A_R)[0]
    s = 1 / (1 + np.exp((k - k_star) / width))
    return s * w_r + (1 - s) * w_edge, s * w_t + (1 - s) * w_r


def true_exchange(**kw):
    """The crossing of the continuous branches (brentq to 1e-12)."""
    return optimize.brentq(lambda x: np.subtract(*exchanging_branches(np.array([x]), **kw))[0], 1.5, 3.4,
                           xtol=1e-12)


def test_k_c_is_the_branch_exchange_on_any_k_grid():
    """k_c on the reproduce (29 k), paper (42 k) and N = 32768 (84 k) grids agrees with the
    crossing of the continuous branches and across grids.  The old jump detector (the first RT
    drop > 0.15/t0 and 2.5x the median step) found 2.325 on the coarse grid and nothing on the
    other two: the drop is spread over several finer steps (at most 0.12/t0 on the paper grid)."""
    truth = true_exchange()
    found = {}
    for name, k in (("coarse", K_COARSE), ("paper", K_PAPER), ("fine", K_FINE)):
        found[name] = fits.exchange_k(k, exchanging_branches(k)[0], k, exchanging_branches(k)[1])
        # linear interpolation of the difference across the crossing: measured 3.3e-3, 2.7e-3 and
        # 4.9e-4 off; 0.01 is 1/15 of the coarse grid's spacing (0.15) there
        assert_close(found[name], truth, rtol=0, atol=0.01, what=f"k_c on the {name} grid")
    for name in ("paper", "fine"):  # each within 0.01 of the truth: within 0.02 of each other
        assert_close(found[name], found["coarse"], rtol=0, atol=0.02, what=f"k_c {name} against coarse")


def test_k_c_ignores_a_noisy_dip_before_the_exchange_and_failed_fits():
    truth = true_exchange()
    rt, tr = exchanging_branches(K_PAPER)
    rng = np.random.default_rng(3)
    rt, tr = rt + 0.005 * rng.normal(size=rt.size), tr + 0.005 * rng.normal(size=tr.size)
    below = int(np.searchsorted(K_PAPER, truth)) - 2  # two k (0.2 / d0) below the crossing
    rt[below] = tr[below] - 0.05  # one RT fit dips under TR there
    d = rt - tr
    assert np.count_nonzero((d[:-1] >= 0) & (d[1:] < 0)) == 2  # the data do cross twice
    # noise 0.005 on each branch moves the zero of d (slope -3.3 /t0 per 1/d0) by ~2e-3 (measured 1.5e-3)
    assert_close(fits.exchange_k(K_PAPER, rt, K_PAPER, tr), truth, rtol=0, atol=0.01, what="k_c with a dip")
    rt[below + 2:below + 4] = np.nan  # failed fits at the two k just beyond the crossing
    # the zero of the chord across 0.3 / d0 (instead of 0.1) of a switch 0.4 / d0 wide: measured 0.033 off
    assert_close(fits.exchange_k(K_PAPER, rt, K_PAPER, tr), truth, rtol=0, atol=0.05, what="k_c across NaN")


@pytest.mark.parametrize("k", [K_COARSE, K_PAPER, K_FINE], ids=["coarse", "paper", "fine"])
def test_no_exchange_no_k_c(k):
    for rho in (1.0, 2.0):  # RT above TR at every k: the model branches, with noise
        w_t, w_r = lattice.lattice_omega(k, rho, L_PAPER, A_T, A_R)
        rng = np.random.default_rng(int(10 * rho))
        assert np.isnan(fits.exchange_k(k, w_r + 0.01 * rng.normal(size=k.size), k, w_t))
    rt, tr = exchanging_branches(k)
    assert np.isnan(fits.exchange_k(k, tr, k, rt))  # RT below TR from the first k: no exchange seen
    short = k < 2.0  # a run that stops before the exchange: RT still above TR at its largest k
    assert np.isnan(fits.exchange_k(k[short], rt[short], k[short], tr[short]))
    back = k > 3.0  # RT back above TR at the largest k: not below it for good, so no k_c
    assert np.isnan(fits.exchange_k(k, np.where(back, tr + 0.05, rt), k, tr))


def test_k_c_needs_one_k_grid_for_rt_and_tr():
    rt, tr = exchanging_branches(K_PAPER)
    with pytest.raises(ValueError, match="different k"):
        fits.exchange_k(K_PAPER, rt, K_PAPER * 1.001, tr)
    with pytest.raises(ValueError, match="different k"):
        fits.exchange_k(K_PAPER, rt, K_PAPER[:-1], tr[:-1])


def test_joint_lattice_fit_recovers_parameters():
    rng = np.random.default_rng(4)
    data = []
    for rho in (0.4, 1.0, 2.0):
        k = np.linspace(0.1, np.pi / 2, 10)
        data.append((rho, k, lattice.lattice_omega(k, rho, 0.45, 1.0, 0.72)[1] + 0.005 * rng.normal(size=k.size)))
    a_r, a_err, l, l_err = fits.fit_lattice(data)
    assert abs(a_r - 0.72) < 5 * a_err + 1e-3 and abs(l - 0.45) < 5 * l_err + 1e-3
