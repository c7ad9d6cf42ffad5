"""Dynamical matrix: exact Hessian (finite differences), symmetry, zero modes, rank invariance."""

import numpy as np
import pytest
from conftest import COMM, TOL, assert_all, assert_close, central_hessian

from solver.packing import geometry as contacts
from solver.model import contact_law, dynmat
from solver.packing import jammed as packing


def pair_energies(ref_delta, contact, normal, radius_i, radius_j, rho, w):
    """Energy of every contact (C,) for relative coordinates w (C, 6) = (u_i, th_i, u_j, th_j).

    contact_law's eq:eij energy (its own blocks are checked against it, with a Taylor test, in
    test_contact_law.py); here the assembled D is checked against the same energy.
    """
    return contact_law.pair_energy(ref_delta, contact, normal, radius_i, radius_j, rho,
                                   du=w[:, 0:2] - w[:, 3:5], theta_i=w[:, 2], theta_j=w[:, 5])


def finite_difference_matrix(p, rho, h=1e-5):  # 2 h below the smallest overlap (9e-5)
    """Dense Hessian from central differences of each contact's energy, assembled by hand."""
    active = ~p.rattler
    pos, diam = p.positions[active], p.diameters[active]
    found = contacts.find_contacts(pos, diam, p.box_length)
    ref = contacts.minimum_image(pos[found.i] - pos[found.j], p.box_length)
    args = (ref, 0.5 * (diam[found.i] + diam[found.j]), found.normal,
            0.5 * diam[found.i], 0.5 * diam[found.j], rho)
    count = len(found)
    local = central_hessian(lambda w: pair_energies(*args, w), count, 6, h)
    dof = 3 if rho > 0 else 2
    n = active.sum() * dof
    dense = np.zeros((n, n))
    keep = [0, 1, 2][:dof]
    for c in range(count):
        idx = np.concatenate((found.i[c] * dof + np.arange(dof), found.j[c] * dof + np.arange(dof)))
        sel = np.concatenate((keep, [3 + k for k in keep]))
        dense[np.ix_(idx, idx)] += local[c][np.ix_(sel, sel)]
    return dense


@pytest.mark.parametrize("rho", [0.0, 0.2, 1.0])
def test_hessian_matches_finite_differences(comm, small_packing, rho):
    dm = dynmat.assemble(small_packing, rho, comm)
    dense = dynmat.gather_csr(dm.D).toarray()
    dm.destroy()
    fd = finite_difference_matrix(small_packing, rho)
    error = np.abs(dense - fd).max()
    assert_all(error < TOL["fd_hessian"] * np.abs(dense).max(), f"D differs from FD Hessian: {error}")
    # the check resolves the geometric term f_n/r (~0.02): dropping it would fail the test
    found = contacts.find_contacts(small_packing.positions, small_packing.diameters, small_packing.box_length)
    assert_all(error < 1e-3 * np.max(found.overlap / found.distance), "FD check cannot see f_n/r")


@pytest.mark.parametrize("rho", [0.0, 0.5, 2.0])
def test_symmetric_with_translation_zero_modes(comm, small_packing, rho):
    dm = dynmat.assemble(small_packing, rho, comm)
    D = dynmat.gather_csr(dm.D)
    n = D.shape[0]
    assert_all(abs(D - D.T).max() <= TOL["roundoff"] * abs(D).max(), "D not symmetric")
    for axis in range(2):
        v = np.zeros(n)
        v[axis::dm.dof] = 1.0
        assert_all(np.abs(D @ v).max() < TOL["roundoff"] * abs(D).max(), f"translation {axis}")
    # a uniform spin is not a zero mode for rho > 0 (PHYSICS.md section 2)
    if dm.dof == 3:
        spin = np.zeros(n)
        spin[2::3] = 1.0
        assert_all(spin @ D @ spin > 1.0, "uniform spin has stiffness")
    dm.destroy()


def test_block_size_mass_and_rattlers_excluded(comm):
    p = packing.generate(256, 0.86, np.random.SeedSequence([3, 1]))
    dm = dynmat.assemble(p, 1.0, comm)
    assert dm.D.getBlockSize() == 3
    n_active = int((~p.rattler).sum())
    assert dm.D.getSize() == (3 * n_active, 3 * n_active)
    mass = dynmat.gather_vec(dm.M)
    # I = m d^2 / 8 of a uniform disk of unit mass: one multiplication, round-off only
    assert_close(mass[2::3], p.diameters[~p.rattler] ** 2 / 8.0, rtol=2 * np.finfo(float).eps, what="inertia")
    assert_close(mass[0::3], np.ones(n_active), rtol=0, what="unit masses")
    dm.destroy()


@pytest.mark.mpi
@pytest.mark.parametrize("rho", [0.0, 1.0])
def test_parallel_matrix_equals_serial(comm, small_packing, rho):
    from petsc4py import PETSc

    dm = dynmat.assemble(small_packing, rho, comm)
    ref = dynmat.assemble(small_packing, rho, PETSc.COMM_SELF)
    D, R = dynmat.gather_csr(dm.D), dynmat.gather_csr(ref.D)
    assert_all(abs(D - R).max() <= TOL["rank_invariance"] * abs(R).max(), "D differs from serial")
    assert_all(np.array_equal(dynmat.gather_vec(dm.M), dynmat.gather_vec(ref.M)), "M differs")
    assert_all(dm.D.getOwnershipRange()[0] % dm.dof == 0, "row ownership not block aligned")
    dm.destroy()
    ref.destroy()
