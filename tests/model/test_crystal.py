"""A perfect crystal whose spectrum is known in closed form: equal disks on a (uniformly strained)
triangular lattice, slightly compressed (``tests/lattices.py``).  The project's full spectrum
(packing -> model.dynmat -> spectrum.slicing) must equal the Bloch frequencies to 1e-10 of omega_max.

"""

import numpy as np
import pytest
from conftest import assert_all, assert_close
from lattices import A, B, DIAGONAL, DIAMETER, L, N_X, N_Y, bloch_omegas, crystal

from solver.contact_law import ContactModel
from solver.model import dynmat
from solver.packing import geometry
from solver.packing import jammed
from solver.packing import mechanics
from solver.spectrum import slicing

ZERO_TOL = 1e-4                # slicing's default zero_tol (1/t0)


@pytest.fixture(scope="module")
def packing():
    return jammed.from_arrays(crystal(), np.full(N_X * N_Y, DIAMETER), L)


def test_crystal_is_the_intended_one(packing):
    """The premises of the comparison (they check the set-up, not the code under test)."""
    assert L > 2 * DIAMETER, "the box must exceed two diameters (one image per pair)"
    next_shell = min(2 * B, np.hypot(1.5 * A, B))
    assert max(A, DIAGONAL) < DIAMETER < next_shell, "6 neighbours overlap, the next shell does not"
    found = geometry.find_contacts(packing.positions, packing.diameters, packing.box_length)
    assert np.all(found.count_per_particle(packing.n) == 6), "6 contacts per disk"
    assert not packing.rattler.any(), "no rattlers"
    assert mechanics.net_force(packing) < 1e-14, "exact equilibrium (inversion symmetry)"


@pytest.mark.parametrize("rho", [0.0, 0.5, 2.0])
def test_full_spectrum_equals_bloch_frequencies(comm, packing, rho):
    dm = dynmat.assemble(packing, ContactModel(rho), comm)
    result = slicing.solve(dm, window=None, vectors=False, zero_tol=ZERO_TOL)
    dm.destroy()
    bloch = bloch_omegas(rho)
    assert_all(bloch.size == (3 if rho > 0 else 2) * packing.n, "one Bloch branch per DOF")
    zero = np.abs(bloch) < ZERO_TOL
    assert_all(zero.sum() == 2 and np.all(bloch > -ZERO_TOL),
               f"the crystal is stable with two zero modes (the translations): {bloch[:4]}")
    assert_all(result.n_zero_modes == zero.sum() and result.n_negative == 0,
               f"zero modes {result.n_zero_modes}, negative {result.n_negative}")
    omega_max = bloch[-1]
    # 1e-10 of omega_max: the brief's bound; eigenvalues are Rayleigh quotients (error ~ residual^2)
    assert_close(result.omega, bloch[~zero], rtol=0.0, atol=1e-10 * omega_max, what=f"rho = {rho}")


def test_full_spectrum_in_small_windows_equals_bloch_frequencies(comm, packing):
    """Windows of 10 modes on a crystal whose clusters of equal eigenvalues exceed the quarter-window
    slack: cuts must go beside a cluster, never into it (they once did: SLEPc error 77 on one rank)."""
    dm = dynmat.assemble(packing, ContactModel(0.5), comm)
    try:
        result = slicing.solve(dm, window=None, vectors=False, zero_tol=ZERO_TOL, max_window_modes=10)
    finally:
        dm.destroy()
    bloch = bloch_omegas(0.5)
    assert_close(result.omega, bloch[np.abs(bloch) >= ZERO_TOL], rtol=0.0, atol=1e-10 * bloch[-1],
                 what="windows of 10 modes")  # atol: the brief's 1e-10 of omega_max, as above
