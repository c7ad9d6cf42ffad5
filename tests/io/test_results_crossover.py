"""results.crossover, the crossover amplitude A* of an amplitude sweep that the manual reports
(docs/finite_amplitude.md; scripts/tools/finite_amplitude_findings.py reads it from here): on a
sweep of known shape it finds omega's and gamma's A* each from its own series and errors, against
the sweep's smallest amplitude or against a linear run's fits."""

import numpy as np
import pytest
from conftest import assert_close

from solver.io import results

pytestmark = pytest.mark.serial_only  # arithmetic on one process


def sweep(omega: np.ndarray, gamma: np.ndarray, gamma_err: float) -> results.Sweep:
    amplitude = np.logspace(-5, -1, 9)
    zeros = np.zeros_like(omega)
    return results.Sweep(amplitude, np.array([0.1, 0.2]), omega, gamma, np.full_like(omega, 1e-6),
                         np.full_like(gamma, gamma_err), zeros, zeros, zeros, zeros, zeros, zeros)


def test_crossover_of_omega_and_gamma():
    """omega departs as 0.004 ln(A / 1e-4) above A = 1e-4, so by 1 % at A* = 1e-4 e^2.5 (the sweep's
    log-linear interpolation is exact for it); gamma departs twice as fast (A* = 1e-4 e^1.25) but
    with errors of 5 % it is never seen; against a linear run 2 % above omega's smallest-amplitude
    value the sweep starts departed (A* 0: below the sweep)."""
    a = np.logspace(-5, -1, 9)
    departure = np.where(a > 1e-4, 0.004 * np.log(a / 1e-4), 0.0)[:, None]
    omega = np.array([1.0, 2.0]) * (1.0 - departure)
    gamma = np.array([0.01, 0.02]) * (1.0 + 2.0 * departure)
    found = results.crossover(sweep(omega, gamma, 1e-9))
    assert_close(found.omega, np.full(2, 1e-4 * np.exp(2.5)), rtol=1e-9, atol=0.0, what="A* of omega")
    assert_close(found.gamma, np.full(2, 1e-4 * np.exp(1.25)), rtol=1e-9, atol=0.0, what="A* of gamma")
    noisy = results.crossover(sweep(omega, gamma, 0.05 * 0.02))
    assert_close(noisy.omega, found.omega, rtol=0.0, atol=0.0, what="omega's A* does not read gamma's errors")
    assert np.isnan(noisy.gamma).all(), noisy.gamma
    linear = {"omega": 1.02 * omega[0], "omega_err": np.full(2, 1e-6), "gamma": gamma[0], "gamma_err": np.full(2, 1e-9)}
    against = results.crossover(sweep(omega, gamma, 1e-9), linear)
    assert (against.omega == 0.0).all(), against.omega
    assert_close(against.gamma, found.gamma, rtol=1e-9, atol=0.0, what="A* of gamma against the linear run")
