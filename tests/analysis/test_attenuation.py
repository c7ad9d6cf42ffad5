"""Attenuation regimes (solver.analysis.attenuation) against closed forms."""

import numpy as np
import pytest

from solver.analysis import attenuation

pytestmark = pytest.mark.serial_only  # arrays and figures, no communicator: nothing to gain from a second rank


def test_resolved_is_gamma_t_end_at_least_one():
    gamma = np.array([1e-4, 1e-3, 2e-3, np.nan, -1e-2, 0.0, 0.5])
    assert attenuation.resolved(gamma, 1000.0).tolist() == [False, True, True, False, False, False, True]


def test_local_exponent_of_a_power_law_is_its_power():
    k = np.geomspace(0.05, 1.5, 9)
    k_mid, p = attenuation.local_exponents(k, 0.04 * k**3.0)
    np.testing.assert_allclose(p, 3.0, rtol=1e-12, atol=0)
    np.testing.assert_allclose(k_mid, np.sqrt(k[1:] * k[:-1]), rtol=1e-12, atol=0)


def test_local_exponent_crosses_from_rayleigh_to_diffusive():
    """gamma = a k^3 + b k^2: p -> 2 well below k* = b / a, -> 3 well above, and at k* exactly
    d ln gamma / d ln k = (3 a k^3 + 2 b k^2) / (a k^3 + b k^2) = 5/2."""
    a, b = 1.0, 0.01  # k* = 0.01
    k = np.array([1e-5, 1.0001e-5, 0.01 / 1.0001, 0.01 * 1.0001, 10.0, 10.001])
    _, p = attenuation.local_exponents(k, a * k**3 + b * k**2)
    assert p[0] == pytest.approx(2.0, abs=2e-3)
    assert p[2] == pytest.approx(2.5, abs=1e-4)
    assert p[4] == pytest.approx(3.0, abs=2e-3)


@pytest.mark.parametrize("k, gamma", [([0.1, 0.1], [1.0, 2.0]), ([0.2, 0.1], [1.0, 2.0]),
                                      ([0.1, 0.2], [1.0, 0.0]), ([0.1, 0.2, 0.3], [1.0, 2.0])])
def test_local_exponents_refuses_bad_input(k, gamma):
    with pytest.raises(ValueError, match="increasing k > 0"):
        attenuation.local_exponents(k, gamma)


def test_ioffe_regel_of_power_laws_is_their_closed_form():
    """omega = c k, gamma = a k^3: omega = 2 pi gamma at k_IR = sqrt(c / (2 pi a)); log-log
    interpolation of two power laws is exact."""
    c, a = 1.05, 0.05
    k = np.geomspace(0.1, 3.0, 7)
    k_ir, omega_ir = attenuation.ioffe_regel(k, c * k, a * k**3)
    assert k_ir == pytest.approx(np.sqrt(c / (2 * np.pi * a)), rel=1e-12)
    assert omega_ir == pytest.approx(c * np.sqrt(c / (2 * np.pi * a)), rel=1e-12)


def test_ioffe_regel_skips_failed_fits_and_reports_no_crossing():
    k = np.array([0.1, 0.2, 0.4, 0.8])
    omega = np.array([0.1, np.nan, 0.4, 0.8])
    gamma = np.array([1e-4, 0.1, -1.0, 1.0])  # the last point is past Ioffe-Regel: 0.8 / 2 pi < 1
    # kept points k = 0.1, 0.8: ratios 159 and 0.127, so the crossing lies between them
    k_ir, omega_ir = attenuation.ioffe_regel(k, omega, gamma)
    r0, r1 = 0.1 / (2 * np.pi * 1e-4), 0.8 / (2 * np.pi)
    share = np.log(r0) / (np.log(r0) - np.log(r1))
    assert k_ir == pytest.approx(np.exp(np.log(0.1) + np.log(8) * share), rel=1e-12)
    assert omega_ir == pytest.approx(np.exp(np.log(0.1) + np.log(8) * share), rel=1e-12)  # omega = k here
    assert np.isnan(attenuation.ioffe_regel(k[:1], omega[:1], gamma[:1])[0])
    assert np.isnan(attenuation.ioffe_regel(k, k, 1e-6 * k)[1])  # always below Ioffe-Regel
    assert np.isnan(attenuation.ioffe_regel(k, k, 10 * k)[0])  # past it from the first point


def test_regimes_figure_draws_acoustic_fits_only(tmp_path, monkeypatch):
    from figures import assert_readable, capture
    from solver.plots.attenuation import plot_attenuation_regimes

    k = np.geomspace(0.05, 1.5, 8)
    fit = {"k": k, "omega": 1.05 * k, "gamma": 0.05 * k**3, "t_end": 300.0}
    figures = capture(monkeypatch)
    paths = plot_attenuation_regimes({(1.0, "L"): fit, (2 / 7, "TR"): dict(fit, omega=0.7 * k), (1.0, "RT"): fit},
                                     str(tmp_path / "a"))
    assert paths == [str(tmp_path / "a.png"), str(tmp_path / "a.pdf")]
    assert all((tmp_path / name).stat().st_size > 1000 for name in ("a.png", "a.pdf"))
    assert_readable(figures)
    assert plot_attenuation_regimes({(1.0, "RT"): fit}, str(tmp_path / "b")) == []
    assert not (tmp_path / "b.png").exists()


@pytest.mark.parametrize("low, high", [(0.4, 4.5), (0.06, 0.9), (20.0, 400.0), (1.5, 15.0), (3.0, 6.0), (2.1, 2.9),
                                       (2e-3, 1.0), (1e-6, 3e-6)])
def test_log_axes_label_at_least_two_ticks(low, high):
    """common.log_ticks where matplotlib alone labels one power of ten (the first three ranges: the
    participation and Q(omega_d) axes of issue 43), on ranges under a decade, and on wider ones."""
    import matplotlib.pyplot as plt
    from figures import labelled_ticks
    from solver.plots.common import log_ticks

    fig, ax = plt.subplots()
    ax.set(xscale="log", xlim=(low, high))
    log_ticks(ax.xaxis)
    fig.canvas.draw()
    labels = labelled_ticks(ax.xaxis)
    plt.close(fig)
    assert len(labels) >= 2, labels
