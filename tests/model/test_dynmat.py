"""Dynamical matrix: exact Hessian (finite differences), symmetry, zero modes, rank invariance."""

import numpy as np
import pytest
from conftest import TOL, assert_all, assert_close, central_hessian

from solver.contact_law import ContactModel
from solver.packing import geometry
from solver import contact_law
from solver.model import dynmat
from solver.packing import configuration, jammed


def pair_energies(ref_delta, contact, normal, radius_i, radius_j, springs, law, w):
    """Energy of every contact (C,) for relative coordinates w (C, 2m) = (u_i, th_i, u_j, th_j),
    m = D + r (r = 1 rotation in 2D, 3 in 3D); ``springs`` = (rho, rho_roll, rho_twist).

    contact_law's energy (its own blocks are checked against it in test_contact_law.py); here
    the assembled D is checked against the same energy.
    """
    dim = normal.shape[1]
    m = w.shape[1] // 2
    theta_i, theta_j = w[:, dim:m], w[:, m + dim:]
    if dim == 2:
        theta_i, theta_j = theta_i[:, 0], theta_j[:, 0]
    return contact_law.pair_energy(ref_delta, contact, normal, radius_i, radius_j, ContactModel(*springs, law=law),
                                   du=w[:, :dim] - w[:, m:m + dim], theta_i=theta_i, theta_j=theta_j)


def finite_difference_matrix(p, springs, h=1e-5, law="harmonic", contacts=None):  # 2 h below the smallest overlap
    """Dense Hessian from central differences of each contact's energy, assembled by hand; over
    ``contacts`` (i, j, r_i - r_j) among the non-rattlers (their indices among them), or, when
    None, the contacts geometry finds in p's cubic box."""
    active = ~p.rattler
    pos, diam = p.positions[active], p.diameters[active]
    if contacts is None:
        found = geometry.find_contacts(pos, diam, p.box_length)
        contacts = found.i, found.j, geometry.minimum_image(pos[found.i] - pos[found.j], p.box_length)
    i, j, ref = contacts
    normal = ref / np.sqrt(np.einsum("pd,pd->p", ref, ref))[:, None]
    args = (ref, 0.5 * (diam[i] + diam[j]), normal, 0.5 * diam[i], 0.5 * diam[j], springs, law)
    count, dim = normal.shape
    m = dim + (1 if dim == 2 else 3)
    local = central_hessian(lambda w: pair_energies(*args, w), count, 2 * m, h)
    dof = dynmat.dof_per_particle(dim, ContactModel(*springs))
    n = active.sum() * dof
    dense = np.zeros((n, n))
    keep = np.arange(dof)
    for c in range(count):
        idx = np.concatenate((i[c] * dof + keep, j[c] * dof + keep))
        sel = np.concatenate((keep, m + keep))
        dense[np.ix_(idx, idx)] += local[c][np.ix_(sel, sel)]
    return dense


def spheres(seed=5, cells=2, spacing=0.985):
    """A small 3D test configuration (not a jammed packing; contacts are all D needs): an FCC
    crystal of ``cells``^3 cubic cells, diameters 1 +- 3 %, centres moved by up to 0.02, so that
    normals, radii and overlaps all differ. 32 spheres, about 190 contacts."""
    rng = np.random.default_rng(seed)
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    grid = np.stack(np.meshgrid(*[np.arange(cells)] * 3, indexing="ij"), -1).reshape(-1, 1, 3)
    lattice = spacing * np.sqrt(2.0)
    positions = ((grid + basis) * lattice).reshape(-1, 3) + rng.uniform(-0.02, 0.02, (4 * cells**3, 3))
    diameters = rng.uniform(0.97, 1.03, 4 * cells**3)
    return jammed.from_arrays(positions, diameters, cells * lattice,
                               rattler=np.zeros(4 * cells**3, dtype=bool))


SPRINGS = [(0.0, 0.0, 0.0), (0.2, 0.0, 0.0), (1.0, 0.0, 0.0), (0.7, 0.3, 0.0)]
SPRINGS_3D = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.7, 0.3, 0.4), (0.0, 0.5, 0.2)]


@pytest.mark.parametrize("dim, springs, law", [(2, s, "harmonic") for s in SPRINGS]
                         + [(3, s, "harmonic") for s in SPRINGS_3D]
                         + [(2, (0.7, 0.3, 0.0), "hertz"), (3, (0.7, 0.3, 0.4), "hertz")])
def test_hessian_matches_finite_differences(comm, small_packing, dim, springs, law):
    """The assembled D against central differences of every contact's energy (contact_law), with
    every spring, harmonic and Hertz (whose normal stiffness (3/2) sqrt(a' xi), force
    sqrt(a' xi) xi and spring scale sqrt(a' xi) all enter)."""
    p = small_packing if dim == 2 else spheres()
    found = geometry.find_contacts(p.positions, p.diameters, p.box_length, ~p.rattler)
    assert found.overlap.min() > 5e-5, "h = 1e-5 steps must not open a contact"
    dm = dynmat.assemble(p, ContactModel(springs[0], rho_roll=springs[1], rho_twist=springs[2], law=law), comm)
    dense = dynmat.in_packing_order(dm, dynmat.gather_csr(dm.D).toarray())
    assert dm.dim == dim and dm.dof == dynmat.dof_per_particle(dim, ContactModel(*springs))
    dm.destroy()
    fd = finite_difference_matrix(p, springs, law=law)
    if law == "hertz":
        # xi^(5/2) has a fourth derivative ~ xi^(-3/2): at the smallest overlaps (~1e-4) h = 1e-5
        # leaves ~6e-6 of O(h^2) truncation, and a smaller h meets the round-off of |r| ~ 1
        # (f_n eps / h^2); Richardson's (4 FD(h/2) - FD(h)) / 3 cancels the h^2 term
        fd = (4 * finite_difference_matrix(p, springs, h=5e-6, law=law) - fd) / 3
    error = np.abs(dense - fd).max()
    assert_all(error < TOL["fd_hessian"] * np.abs(dense).max(), f"D differs from FD Hessian: {error}")
    # the check resolves the geometric term f_n/r (~0.02): dropping it would fail the test
    assert_all(error < 1e-3 * np.max(found.overlap / found.distance), "FD check cannot see f_n/r")


def test_sphere_mass_matrix(comm):
    p = spheres()
    dm = dynmat.assemble(p, ContactModel(1.0, rho_roll=0.1), comm)
    mass = dynmat.in_packing_order(dm, dynmat.gather_vec(dm.M)).reshape(-1, 6)
    assert dm.D.getBlockSize() == 6
    # I = m d^2 / 10 of a uniform sphere of unit mass, on each of the three rotations
    assert_close(mass[:, 3:], np.repeat(p.diameters[:, None] ** 2 / 10.0, 3, axis=1),
                 rtol=2 * np.finfo(float).eps, what="sphere inertia")
    assert_close(mass[:, :3], np.ones((p.n, 3)), rtol=0, what="unit masses")
    dm.destroy()


@pytest.mark.parametrize("dim", [2, 3])
def test_density_masses_follow_the_diameters_or_the_file(comm, small_packing, dim):
    """model.masses: density gives m_i = d_i^D / mean(d^D) over all N and I_i = m_i d_i^2 / 8 (disk)
    or / 10 (sphere) on the matrix's (non-rattler) rows; a file's own masses are used instead
    (here c d^(D+1), so not the diameters' rule) and scaled the same way; D itself does not
    change.  A mass rule applied to the rattler-free subset, or an inertia from the unit mass,
    breaks it."""
    p = small_packing if dim == 2 else spheres()
    active = ~p.rattler
    for raw in (None, 7.0 * p.diameters ** (dim + 1)):
        q = configuration.Packing(p.positions, p.diameters, p.box, p.rattler, p.info, raw)
        dm = dynmat.assemble(q, ContactModel(1.0), comm, mass_rule="density")
        dm_equal = dynmat.assemble(q, ContactModel(1.0), comm)
        m = (p.diameters ** dim if raw is None else raw)
        m = (m / m.mean())[active]
        mass = dynmat.in_packing_order(dm, dynmat.gather_vec(dm.M)).reshape(-1, dm.dof)
        inertia = m * p.diameters[active] ** 2 / (8.0 if dim == 2 else 10.0)
        assert_close(mass[:, :dim], np.repeat(m[:, None], dim, axis=1), rtol=4 * np.finfo(float).eps,
                     what="masses")
        assert_close(mass[:, dim:], np.repeat(inertia[:, None], dm.dof - dim, axis=1),
                     rtol=8 * np.finfo(float).eps, what="inertia")
        assert_all((dynmat.gather_csr(dm.D) != dynmat.gather_csr(dm_equal.D)).nnz == 0, "D changed with the masses")
        assert_all(np.ptp(m) > 0.05, "masses too alike for the check to mean much")  # >> the rtol
        dm.destroy()
        dm_equal.destroy()


@pytest.mark.parametrize("rho", [0.0, 0.5, 2.0])
def test_symmetric_with_translation_zero_modes(comm, small_packing, rho):
    dm = dynmat.assemble(small_packing, ContactModel(rho), comm)
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
    p = jammed.generate(256, 0.86, np.random.SeedSequence([3, 1]))
    dm = dynmat.assemble(p, ContactModel(1.0), comm)
    assert dm.D.getBlockSize() == 3
    n_active = int((~p.rattler).sum())
    assert dm.D.getSize() == (3 * n_active, 3 * n_active)
    mass = dynmat.gather_vec(dm.M)
    # I = m d^2 / 8 of a uniform disk of unit mass: one multiplication, round-off only
    assert_close(mass[2::3], p.diameters[~p.rattler] ** 2 / 8.0, rtol=2 * np.finfo(float).eps, what="inertia")
    assert_close(mass[0::3], np.ones(n_active), rtol=0, what="unit masses")
    dm.destroy()


@pytest.mark.mpi
@pytest.mark.parametrize("dim, springs", [(2, (0.0, 0.0, 0.0)), (2, (1.0, 0.2, 0.0)), (3, (1.0, 0.3, 0.4))])
def test_parallel_matrix_equals_serial(comm, small_packing, dim, springs):
    from petsc4py import PETSc

    p = small_packing if dim == 2 else spheres()
    dm = dynmat.assemble(p, ContactModel(springs[0], rho_roll=springs[1], rho_twist=springs[2]), comm)
    ref = dynmat.assemble(p, ContactModel(springs[0], rho_roll=springs[1], rho_twist=springs[2]), PETSc.COMM_SELF)
    D, R = dynmat.gather_csr(dm.D), dynmat.gather_csr(ref.D)
    assert_all(abs(D - R).max() <= TOL["rank_invariance"] * abs(R).max(), "D differs from serial")
    assert_all(np.array_equal(dynmat.gather_vec(dm.M), dynmat.gather_vec(ref.M)), "M differs")
    assert_all(dm.D.getOwnershipRange()[0] % dm.dof == 0, "row ownership not block aligned")
    dm.destroy()
    ref.destroy()
