"""The dynamical matrix of a packing in a tilted (triclinic) periodic cell: its contacts against
brute force over explicit images of the cell, its values against finite differences of the contact
energy over those contacts, and its rows on 2 ranks against 1."""

import numpy as np
import pytest
from conftest import TOL, assert_all, assert_close, brute_contacts, with_random_stored_forces
from test_dynmat import finite_difference_matrix, spheres
from test_stressed import summed_lammps_forces

from solver.contact_law import ContactModel
from solver.model import damping, dynmat
from solver.packing import geometry, jammed

SHEAR = 0.3


def sheared_disks():
    """64 disks at phi = 0.9 that FIRE brought to rest in a cell tilted by xy = 0.3 L (seed 7)."""
    return jammed.generate(64, 0.9, np.random.SeedSequence([7, 0]), shear=SHEAR)


def tilted_spheres():
    """The 108 jittered FCC spheres of ``test_dynmat.spheres`` (3 cubic cells of side a a side) in
    a cell tilted by xy = a, xz = -a, yz = a: whole lattice periods, so the crystal's contacts are
    all there, but every contact across a face of the cell meets another sphere (another jitter)
    than in the cube."""
    cube = spheres(cells=3)
    a = cube.box[0] / 3
    cell = geometry.Cell(cube.box, np.array([a, -a, a]), np.ones(3, dtype=bool))
    # the crystal's own positions (sites in [0, 2.5 a] plus jitter): undo the cube's wrapping, whose
    # shifts by 3 a along y or z are not periods of the tilted cell
    crystal = np.where(cube.positions > 2.75 * a, cube.positions - cube.box, cube.positions)
    return jammed.from_arrays(crystal, cube.diameters, cell, rattler=np.zeros(cube.n, dtype=bool))


@pytest.mark.serial_only  # contacts on arrays, no communicator
def test_the_test_packings_are_tilted_and_meet_other_partners_across_the_faces():
    """The matrix tests below see the tilt: the contacts of the tilted packings are not those of the
    same positions in the orthogonal box, and the sheared disks' FIRE tilt is 0.3 L."""
    disks, balls = sheared_disks(), tilted_spheres()
    assert_close(disks.tilt, [SHEAR * disks.box[0]], rtol=0, atol=0, what="xy = shear L")
    for p in (disks, balls):
        tilted = brute_contacts(p.positions, p.diameters, p.cell)
        square = brute_contacts(np.mod(p.positions, p.box), p.diameters, geometry.Cell.of(p.box, p.dim))
        assert_all(set(zip(*tilted[:2])) != set(zip(*square[:2])), "the tilt changes some contacts")
        overlap = 0.5 * (p.diameters[tilted[0]] + p.diameters[tilted[1]]) - np.linalg.norm(tilted[2], axis=1)
        assert_all(overlap.max() < 0.1, "overlaps of a packing: no two particles on one site")


@pytest.mark.parametrize("dim, springs, law", [(2, (0.0, 0.0, 0.0), "harmonic"), (2, (0.7, 0.3, 0.0), "harmonic"),
                                               (2, (0.7, 0.3, 0.0), "hertz"), (3, (0.0, 0.0, 0.0), "harmonic"),
                                               (3, (0.7, 0.3, 0.4), "harmonic"), (3, (0.7, 0.3, 0.4), "hertz")])
def test_tilted_hessian_matches_finite_differences_over_brute_force_contacts(comm, dim, springs, law):
    """D of a tilted packing against central differences of every contact's energy (contact_law),
    the contacts and their separations found by brute force over the cell's images: the matrix
    has every contact across the tilted faces, with the right partner and the right normal."""
    p = sheared_disks() if dim == 2 else tilted_spheres()
    active = ~p.rattler
    i, j, ref = brute_contacts(p.positions[active], p.diameters[active], p.cell)
    overlap = 0.5 * (p.diameters[active][i] + p.diameters[active][j]) - np.linalg.norm(ref, axis=1)
    assert overlap.min() > 5e-5, "h = 1e-5 steps must not open a contact"
    model = ContactModel(springs[0], rho_roll=springs[1], rho_twist=springs[2], law=law)
    dm = dynmat.assemble(p, model, comm)
    try:
        dense = dynmat.in_packing_order(dm, dynmat.gather_csr(dm.D).toarray())
        assert_all(dm.n_contacts == i.size, f"{dm.n_contacts} contacts in the matrix, {i.size} by brute force")
    finally:
        dm.destroy()
    fd = finite_difference_matrix(p, springs, law=law, contacts=(i, j, ref))
    if law == "hertz":  # Richardson, as test_dynmat's Hertz case
        fd = (4 * finite_difference_matrix(p, springs, h=5e-6, law=law, contacts=(i, j, ref)) - fd) / 3
    error = np.abs(dense - fd).max()
    assert_all(error < TOL["fd_hessian"] * np.abs(dense).max(), f"D differs from FD Hessian: {error}")
    assert_all(error < 1e-3 * np.max(overlap), "FD check cannot see f_n/r")


@pytest.mark.parametrize("dim", [2, 3])
def test_tilted_stressed_matrix_is_the_summed_lammps_update_over_brute_force_contacts(comm, dim):
    """D of a tilted packing with stored tangential forces against central differences of LAMMPS's
    one-step update summed over the brute-force contacts (test_stressed's check, in the tilted cell)."""
    p = with_random_stored_forces(sheared_disks() if dim == 2 else tilted_spheres(), 11)
    active = ~p.rattler
    contacts = brute_contacts(p.positions[active], p.diameters[active], p.cell)
    dm = dynmat.assemble(p, ContactModel(0.8), comm)
    try:
        dense = dynmat.in_packing_order(dm, dynmat.gather_csr(dm.D).toarray())
    finally:
        dm.destroy()
    x = np.random.default_rng(2).normal(size=(int(active.sum()), dm.dof))
    h = 1e-6
    slope = (summed_lammps_forces(p, p.tangential, "harmonic", 0.8, h * x, contacts=contacts)
             - summed_lammps_forces(p, p.tangential, "harmonic", 0.8, -h * x, contacts=contacts)) / (2 * h)
    # as test_stressed: central differences, h = 1e-6 on forces of order 1
    assert_close(slope.ravel(), -dense @ x.ravel(), rtol=0.0, atol=1e-8 * np.abs(dense).max(), what="-D x")


@pytest.mark.parametrize("dim", [2, 3])
def test_tilted_damping_couples_the_brute_force_contacts(comm, dim):
    """The dashpots' C of a tilted packing couples exactly the pairs in contact by brute force."""
    p = sheared_disks() if dim == 2 else tilted_spheres()
    model = ContactModel(0.5, gamma_n=0.3, gamma_t=0.2)
    dm = dynmat.assemble(p, model, comm)
    C = damping.assemble(p, dm)
    try:
        whole = dynmat.in_packing_order(dm, dynmat.gather_csr(C).toarray())
    finally:
        C.destroy()
        dm.destroy()
    active = ~p.rattler
    i, j, _ = brute_contacts(p.positions[active], p.diameters[active], p.cell)
    dof = dm.dof
    blocks = np.abs(whole).reshape(whole.shape[0] // dof, dof, -1, dof).sum(axis=(1, 3))
    expected = np.zeros_like(blocks, dtype=bool)
    expected[i, j] = expected[j, i] = True
    np.fill_diagonal(blocks, 0.0)
    assert_all(np.array_equal(blocks > 0, expected), "C's off-diagonal blocks are the brute-force contacts")


@pytest.mark.mpi
@pytest.mark.parametrize("dim, springs", [(2, (0.0, 0.0, 0.0)), (2, (1.0, 0.2, 0.0)), (3, (1.0, 0.3, 0.4))])
def test_tilted_parallel_matrix_equals_serial(comm, dim, springs):
    """D of a tilted packing assembled on the ranks of ``comm`` equals COMM_SELF's (each rank's
    contact search in its own slab of the tilted cell)."""
    from petsc4py import PETSc

    p = sheared_disks() if dim == 2 else tilted_spheres()
    model = ContactModel(springs[0], rho_roll=springs[1], rho_twist=springs[2])
    dm = dynmat.assemble(p, model, comm)
    ref = dynmat.assemble(p, model, PETSc.COMM_SELF)
    try:
        D, R = dynmat.gather_csr(dm.D), dynmat.gather_csr(ref.D)
        assert_all(abs(D - R).max() <= TOL["rank_invariance"] * abs(R).max(), "D differs from serial")
        assert_all(dm.n_contacts == ref.n_contacts, "contact counts differ")
        assert_all(np.array_equal(dynmat.gather_vec(dm.M), dynmat.gather_vec(ref.M)), "M differs")
    finally:
        dm.destroy()
        ref.destroy()
