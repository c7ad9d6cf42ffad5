"""The amplitudes at which contacts open and slide (solver/analysis/thresholds.py, issue 46
point 4): the affine factors in closed form and against the overlaps of a strained packing, the
slacks of both laws, the modulus lost, and the measured crossover on sweeps of known shape."""

import numpy as np
import pytest
from conftest import assert_close, jammed_packing

from solver.analysis import thresholds
from solver.packing import geometry

pytestmark = pytest.mark.serial_only  # arrays only, no communicator: nothing to gain from a second rank


def one_contact(normal):
    """A Slacks of one contact of branch length 1 along ``normal``, opening 0.01, sliding 0.002."""
    n = np.asarray(normal, dtype=float)[None, :] / np.linalg.norm(normal)
    return thresholds.Slacks(n, np.ones(1), np.full(1, 0.01), np.full(1, 0.002), np.ones(1), np.ones(1))


@pytest.mark.parametrize("mode, run, normal, open_factor, slide_factor", [
    ("L", (0, 0), (1, 0), 1.0, 0.0),        # pure stretch along the contact
    ("TR", (0, 1), (1, 0), 0.0, 0.5),       # pure shear across it: E n = e_y / 2
    ("L", (0, 0), (1, 1), 0.5, 0.5),        # 45 degrees: n.E.n = 1/2, E n - (n.E.n) n = (1, -1)/(2 sqrt 2)
    ("TR", (0, 1), (1, 1), 0.5, 0.0),       # shear at 45 degrees is a stretch along n
])
def test_affine_amplitudes_in_closed_form(mode, run, normal, open_factor, slide_factor):
    """A_open = c xi / (|b| |n.E.n|), A_slide = c s / (|b| |E n - (n.E.n) n|) for four
    orientations whose factors are known by hand; speed c = 2."""
    s = one_contact(normal)
    strain = thresholds.unit_strain(mode, *run, 2)
    a_open, a_slide = thresholds.affine_amplitudes(s, strain, 2.0)
    for got, slack, factor in ((a_open, 0.01, open_factor), (a_slide, 0.002, slide_factor)):
        if factor == 0.0:
            assert got[0] > 1e10, got  # inf, or a rounding error's inverse
        else:
            assert_close(got, [2.0 * slack / factor], rtol=1e-12, atol=0.0, what=f"{mode} {normal}")


@pytest.mark.parametrize("mode, run", [("L", (0, 0)), ("TR", (1, 0))])
def test_normal_factor_is_the_overlaps_derivative_under_the_strain(mode, run):
    """Every contact of a jammed packing strained affinely by eps E (positions and box): the
    overlaps change at -eps |b| n.E.n to first order (central differences, eps = 1e-6); the
    module's |n.E.n| |b| is that slope's size, contact by contact."""
    p = jammed_packing(64, 0.9, 1)
    s = thresholds.slacks(p, 1.0, 0.5)
    strain = thresholds.unit_strain(mode, *run, 2)
    normal, _ = thresholds._parts(s, strain)
    found = geometry.find_contacts(p.positions, p.diameters, p.box, ~p.rattler)
    pairs = np.stack((found.i, found.j), axis=1)
    eps = 1e-6

    def overlaps(e):
        # an affine strain of the periodic cell: positions and images move together (box diagonal-sheared
        # only for L; for TR the shear of an orthogonal box is taken on the minimum-image branch vectors)
        delta = geometry.minimum_image(p.positions[pairs[:, 0]] - p.positions[pairs[:, 1]], p.box)
        moved = delta + e * delta @ strain.T
        return 0.5 * (p.diameters[pairs[:, 0]] + p.diameters[pairs[:, 1]]) - np.linalg.norm(moved, axis=1)

    slope = (overlaps(eps) - overlaps(-eps)) / (2 * eps)
    assert_close(np.abs(slope), s.length * normal, rtol=1e-6, atol=1e-9, what=f"{mode} overlap slopes")


@pytest.mark.parametrize("law", ["harmonic", "hertz"])
def test_sliding_slack_is_mu_xi_over_rho_without_stored_forces(law):
    """With f_t = 0: (mu f_n)/k_t = mu xi / rho under both laws (hertz: f_n = kn sqrt(a' xi) xi,
    k_t = rho kn sqrt(a' xi), Mindlin's stiffness as LAMMPS has it)."""
    p = jammed_packing(64, 0.9, 1, law=law)
    s = thresholds.slacks(p, 0.5, 0.3)
    assert_close(s.sliding, 0.3 * s.opening / 0.5, rtol=1e-12, atol=0.0, what=law)
    assert s.opening.min() > 0 and len(s.opening) > 64


def test_lost_share_counts_opened_and_sliding_springs():
    """Two contacts of known weights: along x (normal weight 1, no tangential part under L) and at
    45 degrees (normal 1/4, tangential 1/4 of kt = 2 -> 1/2): the share lost steps at each
    contact's amplitudes, a sliding one losing its tangential weight only."""
    n = np.array([[1.0, 0.0], [1.0, 1.0]]) / np.array([[1.0], [np.sqrt(2.0)]])
    s = thresholds.Slacks(n, np.ones(2), np.array([0.01, 0.04]), np.array([1.0, 0.001]), np.ones(2), np.full(2, 2.0))
    strain = thresholds.unit_strain("L", 0, 0, 2)
    a_open, a_slide = thresholds.affine_amplitudes(s, strain, 1.0)
    assert_close(a_open, [0.01, 0.08], rtol=1e-12, atol=0.0, what="A_open")
    assert_close(a_slide[1:], [0.002], rtol=1e-12, atol=0.0, what="A_slide")
    total = 1.0 + 0.25 + 0.5
    shares = thresholds.lost_share(s, strain, 1.0, [1e-3, 0.005, 0.05, 0.1])
    assert_close(shares, [0.0, 0.5 / total, 1.5 / total, 1.0], rtol=1e-12, atol=0.0, what="shares")
    assert thresholds.predicted_crossover(s, strain, 1.0, share=0.5) == pytest.approx(0.01, rel=1e-12, abs=0.0)


def test_crossover_interpolates_in_log_amplitude_and_ignores_noise():
    """omega departs as 0.004 log(A / 1e-4) above 1e-4 (so by 1 % at A* = 1e-4 e^2.5), gamma never:
    A* is found exactly (the departure is linear in log A), a departure within twice the fits'
    errors is not one, and a k whose reference fit failed gives NaN; against a linear reference
    the same, and 0 when the smallest amplitude already departs."""
    amplitude = np.logspace(-5, -1, 9)
    departure = np.where(amplitude > 1e-4, 0.004 * np.log(amplitude / 1e-4), 0.0)
    omega = np.stack((1.0 - departure, 2.0 * (1.0 - departure), np.full(9, np.nan)), axis=1)
    tight, loose = np.full((9, 3), 1e-5), np.full((9, 3), 0.05)
    found = thresholds.crossover(amplitude, omega, tight)
    assert_close(found[:2], [1e-4 * np.exp(2.5)] * 2, rtol=1e-9, atol=0.0, what="A*")
    assert np.isnan(found[2])
    assert np.isnan(thresholds.crossover(amplitude, omega, loose)[0])  # 1.5 % at the top, errors 7 %
    linear = np.array([1.0, 2.0, 1.0])  # against a linear reference: the same A*, and 0 below the sweep
    shifted = thresholds.crossover(amplitude, omega, tight, reference=linear, reference_error=np.full(3, 1e-5))
    assert_close(shifted[:2], [1e-4 * np.exp(2.5)] * 2, rtol=1e-9, atol=0.0, what="A* against the reference")
    below = thresholds.crossover(amplitude, omega, tight, reference=1.02 * linear, reference_error=np.full(3, 1e-5))
    assert below[0] == 0.0 and below[1] == 0.0, below


def test_linear_run_scales_to_the_first_crossings():
    """A run at 1e-5 whose largest ratios are 0.02 (opening) and 0.5 (coulomb) predicts 5e-4 and
    2e-5; a ratio already at 1 predicts nothing."""
    assert thresholds.from_linear_run(1e-5, np.array([0.0, 0.02]), np.array([0.1, 0.5])) == \
        pytest.approx((5e-4, 2e-5), rel=1e-12, abs=0.0)
    assert np.isnan(thresholds.from_linear_run(1e-5, np.ones(2), np.ones(2))[1])
