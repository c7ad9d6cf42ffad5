"""``waves.method: spectral`` with dashpots (solver/waves/chebyshev.py): the Chebyshev-Bessel
series of exp(tJ) in blocks, against a dense exp(tJ) of the damped first-order system built in
conftest (2D and 3D, strong and weak dashpots, 1 and 2 ranks); its error bound holds and
tightens with tol; the plan's pieces against closed forms."""

import math

import numpy as np
import pytest
from conftest import assert_all, assert_close, jammed_packing

from solver.contact_law import ContactModel
from solver.model import damping, dynmat
from solver.waves import chebyshev, excitation
from solver.references import first_order_flow

AMPLITUDE = 1e-3
TIMES = np.arange(0.0, 20.0 + 1e-9, 0.1)


def _damped(dim, comm, gamma_n, gamma_t):
    p = jammed_packing(48 if dim == 2 else 40, 0.86 if dim == 2 else 0.68, 9, dim)
    dm = dynmat.assemble(p, ContactModel(0.6, gamma_n=gamma_n, gamma_t=gamma_t), comm, "density")
    dm.C = damping.assemble(p, dm, "density")
    return p, dm


@pytest.mark.parametrize("dim, mode, gammas", [(2, "L", (0.5, 0.2)), (2, "RT", (0.05, 0.02)), (2, "TR", (2.0, 1.0)),
                                               (3, "TR", (0.5, 0.2)), (3, "R", (0.1, 0.05))])
def test_damped_spectral_equals_dense_expm(comm, dim, mode, gammas):
    """z (= z_fixed, the r_i(0) phase) against dense exp(tJ) to within the reported bound and to
    1e-10 of max |z| (tol 1e-10); energy at the block ends equals the dense one to 1e-10 of E(0)
    and NaN between them."""
    p, dm = _damped(dim, comm, *gammas)
    component, axis = excitation.runs(mode, dim)[0]
    k = 2 * np.pi / float(p.box[axis])
    series = chebyshev.damped_spectral(dm, p.positions, mode, 0, k, amplitude=AMPLITUDE, times=TIMES, tol=1e-10)
    start = excitation.start_velocity(dm, p.positions, component, axis, k, AMPLITUDE, comm.tompi4py())
    whole = np.concatenate(comm.tompi4py().allgather(start))  # every rank's part, the matrix's order
    flow = first_order_flow(dm, whole, TIMES[1] - TIMES[0], len(TIMES), order="matrix")
    d = dynmat.gather_csr(dm.D).toarray()
    mass = dynmat.gather_vec(dm.M)
    dm.destroy()
    r0 = p.positions[~p.rattler]
    u, v = flow[:, 0].reshape(len(TIMES), -1), flow[:, 1]
    z_fixed = v[:, :, component] @ np.exp(-1j * k * r0[:, axis])
    scale = np.abs(z_fixed).max()
    assert_all(series.error_estimate <= 1e-10, f"bound {series.error_estimate}")
    assert_close(series.z_fixed, z_fixed, rtol=0.0, atol=1e-10 * scale, what=f"z_fixed, {dim}D {mode}")
    assert_all(np.array_equal(series.z, series.z_fixed), "z is z_fixed on this path")
    v_flat = v.reshape(len(TIMES), -1)
    exact_energy = 0.5 * (np.einsum("si,i,si->s", v_flat, mass, v_flat) + np.einsum("si,ij,sj->s", u, d, u))
    ends = ~np.isnan(series.energy)
    block = series.settings["block_samples"]
    assert_all(np.array_equal(np.flatnonzero(ends), np.unique(np.r_[0:len(TIMES):block, len(TIMES) - 1])),
               f"energies at block ends only (blocks of {block})")
    assert_close(series.energy[ends], exact_energy[ends], rtol=0.0, atol=1e-10 * exact_energy[0], what="energy")


def test_the_bound_follows_tol_and_holds(comm):
    """At tol 1e-4, 1e-7 and 1e-11 the error against dense exp(tJ), relative to |M^-1/2 b| |X(0)|_E,
    stays below the reported bound, the bound below tol, and fewer terms are taken for looser tol."""
    p, dm = _damped(2, comm, 0.5, 0.2)
    component, axis = excitation.runs("L", 2)[0]
    k = 2 * np.pi * 2 / float(p.box[axis])
    start = excitation.start_velocity(dm, p.positions, component, axis, k, AMPLITUDE, comm.tompi4py())
    whole = np.concatenate(comm.tompi4py().allgather(start))  # every rank's part, the matrix's order
    flow = first_order_flow(dm, whole, TIMES[1] - TIMES[0], len(TIMES), order="matrix")
    r0 = p.positions[~p.rattler]
    z_exact = flow[:, 1, :, component] @ np.exp(-1j * k * r0[:, axis])
    mass = dynmat.gather_vec(dm.M).reshape(-1, dm.dof)[:, component]
    weight = np.linalg.norm(1.0 / np.sqrt(mass)) * np.sqrt(np.sum(mass * flow[0, 1, :, component] ** 2))
    products = []
    for tol in (1e-4, 1e-7, 1e-11):
        series = chebyshev.damped_spectral(dm, p.positions, "L", 0, k, amplitude=AMPLITUDE, times=TIMES, tol=tol)
        error = np.abs(series.z - z_exact).max() / weight
        assert_all(error <= series.error_estimate <= tol, f"tol {tol}: error {error}, bound {series.error_estimate}")
        products.append(series.steps / len(TIMES))
    dm.destroy()
    assert_all(products[0] < products[1] < products[2], f"products per sample {products}")


@pytest.mark.serial_only  # closed forms on numbers, no communicator
def test_the_ellipse_holds_the_numerical_range_rectangle():
    """The ellipses of chebyshev.ellipse pass through the rectangle's corner (-c_max, omega_max)
    (up to MARGIN) for every focal stretch and reduce to the segment (rho = 1) without dashpots; the coefficients at
    t = 0 are (1, 0, 0, ...) and sum to e^(lambda t) P_k(lambda) at a point lambda = -0.3 + 2.1 i."""
    omega, rate = 3.0, 1.2
    for stretch in chebyshev.STRETCHES:
        c, f, rho = chebyshev.ellipse(omega, rate, stretch)
        alpha = f * (rho - 1 / rho) / 2
        beta = f * (rho + 1 / rho) / 2
        corner = ((-rate - c) / alpha) ** 2 + (omega / beta) ** 2
        assert_close(corner, 1.0, rtol=0.0, atol=5 * chebyshev.MARGIN, what=f"corner on the ellipse, {stretch}")
        assert_close(f, stretch * omega, rtol=2 * chebyshev.MARGIN, atol=0.0, what="focal half-distance")
    c, f, rho = chebyshev.ellipse(omega, rate)
    assert_close(chebyshev.ellipse(omega, 0.0)[2], 1.0, rtol=0.0, atol=1e-15, what="rho without dashpots")
    coef = chebyshev.coefficients(60, c, f, np.array([0.0, 1.7]))
    assert_close(coef[:, 0], np.eye(61)[0], rtol=0.0, atol=0.0, what="t = 0")
    lam = -0.3 + 2.1j
    beta_point = (lam - c) / f
    terms = [1.0 + 0j, beta_point]
    for _ in range(59):
        terms.append(2 * beta_point * terms[-1] + terms[-2])
    assert_close(np.array(terms) @ coef[:, 1], np.exp(1.7 * lam), rtol=1e-13, atol=0.0, what="series at a point")
    assert_all(math.isfinite(rho) and rho > 1, f"rho {rho}")
