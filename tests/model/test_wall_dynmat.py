"""The dynamical matrix of a packing between walls under gravity (docs/walls.md): the exact zero
modes are the rigid modes the walls leave (``DynamicalMatrix.rigid_modes``), counted from the
dense spectrum; gravity adds no stiffness; the walls' blocks are on the diagonal; the matrix on 2
ranks equals the serial one."""

import dataclasses

import numpy as np
import pytest
from conftest import TOL, assert_all
from walled import settled

from solver import contact_law, references
from solver.contact_law import ContactModel
from solver.model import damping, dynmat
from solver.packing import walls

MODELS = [  # (springs, expected rigid modes in 2D, in 3D)
    (ContactModel(0.0), ["translation x"], ["translation x", "translation y"]),
    (ContactModel(0.5), [], []),
    (ContactModel(0.0, rho_roll=0.3), ["translation x"], ["translation x", "translation y", "spin z"]),
    (ContactModel(0.0, rho_roll=0.3, rho_twist=0.2), None, ["translation x", "translation y"]),
]


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("index", range(len(MODELS)))
def test_zero_modes_are_the_rigid_modes_the_walls_leave(comm, dim, index):
    model, *expected = MODELS[index]
    if expected[dim - 2] is None:
        pytest.skip("twisting is 3D only")
    dm = dynmat.assemble(settled(dim), model, comm)
    try:
        names = [name for _, name in dm.rigid_modes()]
        assert_all(names == expected[dim - 2], f"{model}: rigid modes {names}")
        lam = references.dense_eigenvalues(dm)
        zero = np.abs(lam) < 1e-10 * lam.max()
        assert_all(zero.sum() == len(names), f"{model}: {zero.sum()} zero modes, rigid modes {names}")
        assert_all(lam.min() > -1e-10 * lam.max(), f"{model}: negative eigenvalue {lam.min()}")
        whole = dynmat.gather_csr(dm.D)
        for slot, name in dm.rigid_modes():
            v = np.zeros(whole.shape[0])
            v[slot::dm.dof] = 1.0
            assert_all(np.abs(whole @ v).max() < 1e-12, f"{name}: |D v| = {np.abs(whole @ v).max()}")
    finally:
        dm.destroy()


@pytest.mark.parametrize("dim", [2, 3])
def test_without_walls_every_translation_would_be_free(comm, dim):
    """Negative control: the walls' blocks are what holds the walled axis (and, with a tangential
    spring, the others): the same contacts without them leave the translations free."""
    p = settled(dim)
    with_walls = dynmat.assemble(p, ContactModel(0.5), comm)
    without = dynmat.assemble(dataclasses.replace(p, walls=None), ContactModel(0.5), comm)
    try:
        D, bare = dynmat.gather_csr(with_walls.D), dynmat.gather_csr(without.D)
        v = np.zeros(D.shape[0])
        v[dim - 1::with_walls.dof] = 1.0  # the translation along the walls' normal
        assert_all(np.abs(bare @ v).max() < 1e-12 and np.abs(D @ v).max() > 0.1, "walls hold nothing")
        diff = (D - bare).tocoo()
        assert_all(np.all(diff.row // with_walls.dof == diff.col // with_walls.dof), "wall blocks off the diagonal")
    finally:
        with_walls.destroy()
        without.destroy()


@pytest.mark.parametrize("dim", [2, 3])
def test_gravity_adds_no_stiffness(comm, dim):
    p = settled(dim)
    model = ContactModel(0.5, 0.2)
    heavy, light = dynmat.assemble(p, model, comm), dynmat.assemble(dataclasses.replace(p, gravity=None), model, comm)
    try:
        assert_all((dynmat.gather_csr(heavy.D) != dynmat.gather_csr(light.D)).nnz == 0, "gravity changed D")
    finally:
        heavy.destroy()
        light.destroy()


@pytest.mark.parametrize("dim", [2, 3])
def test_stored_wall_forces_make_the_hertz_matrix_non_symmetric(comm, dim):
    """Stored wall forces under hertz add wall_stressed_blocks on the diagonal (their FD check is in
    test_wall_law.py): the assembled difference is exactly those blocks, and D is flagged non-symmetric;
    under the harmonic law they add nothing and D stays symmetric."""
    p = settled(dim)
    touch = walls.touching(p.positions, p.diameters, p.walls)
    tangent = np.roll(touch.normal, 1, axis=1)  # along another axis: tangential
    stored = walls.WallContacts(touch.particle, touch.wall, 1e-3 * tangent)
    for law in ("harmonic", "hertz"):  # the packing's law (Packing.model) is the matrix's
        p = dataclasses.replace(p, model=ContactModel(law=law))
        if law == "harmonic":  # a flat wall's normal does not turn: nothing added, still symmetric
            loaded = dynmat.assemble(dataclasses.replace(p, wall_contacts=stored), ContactModel(0.5), comm)
            plain = dynmat.assemble(p, ContactModel(0.5), comm)
            try:
                same = (dynmat.gather_csr(loaded.D) != dynmat.gather_csr(plain.D)).nnz == 0
                assert_all(same and loaded.symmetric, "harmonic stored wall forces changed D")
            finally:
                loaded.destroy()
                plain.destroy()
    model = ContactModel(0.5, law="hertz")
    loaded = dynmat.assemble(dataclasses.replace(p, wall_contacts=stored), model, comm)
    plain = dynmat.assemble(p, model, comm)
    try:
        assert_all(not loaded.symmetric and plain.symmetric, "symmetry flags")
        diff = (dynmat.gather_csr(loaded.D) - dynmat.gather_csr(plain.D)).toarray()
        expected = np.zeros_like(diff)
        blocks = contact_law.wall_stressed_blocks(touch.normal, touch.overlap, 0.5 * p.diameters[touch.particle],
                                                  stored.force, model)
        rows = np.argsort(loaded.order)[touch.particle]  # matrix particle of each contact
        for row, block in zip(rows, blocks):
            expected[row * loaded.dof:(row + 1) * loaded.dof, row * loaded.dof:(row + 1) * loaded.dof] += block
        assert_all(np.abs(diff - expected).max() <= 1e-15 * np.abs(expected).max(), "stressed wall blocks")
        assert_all(np.abs(expected).max() > 1e-5, "the stored forces added nothing: the test is blind")
    finally:
        loaded.destroy()
        plain.destroy()


@pytest.mark.parametrize("dim", [2, 3])
def test_wall_dashpots_on_the_diagonal(comm, dim):
    p = settled(dim)
    model = ContactModel(0.5, gamma_n=0.3, gamma_t=0.2)
    dm = dynmat.assemble(p, model, comm)
    C = damping.assemble(p, dm)
    bare = damping.assemble(dataclasses.replace(p, walls=None), dm)
    try:
        diff = (dynmat.gather_csr(C) - dynmat.gather_csr(bare)).tocoo()
        assert_all(diff.nnz > 0 and np.all(diff.row // dm.dof == diff.col // dm.dof), "wall dashpots")
        whole = dynmat.gather_csr(C).toarray()
        assert_all(np.abs(whole - whole.T).max() <= 1e-15 * np.abs(whole).max(), "C not symmetric")
    finally:
        for m in (C, bare):
            m.destroy()
        dm.destroy()


@pytest.mark.mpi
@pytest.mark.parametrize("dim", [2, 3])
def test_parallel_walled_matrix_equals_serial(comm, dim):
    from petsc4py import PETSc

    p = settled(dim)
    touch = walls.touching(p.positions, p.diameters, p.walls)
    p = dataclasses.replace(p, model=ContactModel(law="hertz"),
                            wall_contacts=walls.WallContacts(touch.particle, touch.wall,
                                                             1e-3 * np.roll(touch.normal, 1, axis=1)))
    model = ContactModel(0.5, 0.2, 0.1 if dim == 3 else 0.0, law="hertz")
    dm, ref = dynmat.assemble(p, model, comm), dynmat.assemble(p, model, PETSc.COMM_SELF)
    try:
        D, R = dynmat.gather_csr(dm.D), dynmat.gather_csr(ref.D)
        assert_all(abs(D - R).max() <= TOL["rank_invariance"] * abs(R).max(), "D differs from serial")
        assert_all(dm.rigid_modes() == ref.rigid_modes(), "rigid modes differ")
    finally:
        dm.destroy()
        ref.destroy()
