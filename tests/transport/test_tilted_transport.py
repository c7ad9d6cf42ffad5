"""Transport in a tilted (sheared) periodic cell: the Allen-Feldman position operators and the
packet's start region and saturation use the cell's images, checked against brute force over them.
Every test runs on 1 and 2 ranks against rank-free references."""

import itertools

import numpy as np
from conftest import assert_all, assert_close, brute_contacts

from solver.contact_law import ContactModel
from solver.model import dynmat
from solver.model.operators import scaled_operator
from solver.packing import jammed
from solver.transport import allen_feldman as af
from solver.transport import packet


def sheared_disks():
    """64 disks at phi = 0.9 at rest in a cell tilted by xy = 0.3 L (seed 7)."""
    return jammed.generate(64, 0.9, np.random.SeedSequence([7, 0]), shear=0.3)


def test_position_operators_of_a_tilted_packing_take_the_cells_images(comm):
    """Every particle block of X^a is A's times the a-th component of the pair's separation through
    the cell's nearest image (brute force), zero where no contact couples the pair."""
    p = sheared_disks()
    dm = dynmat.assemble(p, ContactModel(0.5), comm)
    try:
        X = af.position_operators(dm, p.positions, p.cell, comm)
        A = scaled_operator(dm)
        try:
            a = dynmat.in_packing_order(dm, dynmat.gather_csr(A).toarray())
            x = [dynmat.in_packing_order(dm, dynmat.gather_csr(Xa).toarray()) for Xa in X]
        finally:
            for mat in [A, *X]:
                mat.destroy()
    finally:
        dm.destroy()
    active = ~p.rattler
    i, j, delta = brute_contacts(p.positions[active], p.diameters[active], p.cell)
    dof, n = dm.dof, int(active.sum())
    for axis in range(p.dim):
        separation = np.zeros((n, n))
        separation[i, j], separation[j, i] = delta[:, axis], -delta[:, axis]
        expected = a * np.kron(separation, np.ones((dof, dof)))
        assert_close(x[axis], expected, rtol=0, atol=1e-12 * np.abs(expected).max(),
                     what=f"X^{axis} of the tilted cell")


def test_the_packets_start_region_and_saturation_in_a_tilted_cell(comm):
    """The start holds the non-rattlers within the radius of the centre through the cell's images
    (brute force), and the saturation is the uniform spread <|r - <r>|^2> over the tilted cell
    (sum of its edges' |a|^2 / 12; a fine grid of the cell's fractional midpoints gives it to
    (1 - 1/m^2) per axis)."""
    p = sheared_disks()
    dm = dynmat.assemble(p, ContactModel(0.0), comm)
    h = p.cell.matrix
    centre = h @ np.array([0.95, 0.5])  # near the tilted face: the region reaches across it
    try:
        _, at = packet.spreading(dm, p.positions, p.cell, band=(1.0, 2.5), centre=centre, radius=2.5,
                                 times=np.linspace(0.0, 2.0, 5), seed=11, comm=comm, tol=1e-10)
    finally:
        dm.destroy()
    images = np.array(list(itertools.product([-1, 0, 1], repeat=2)), dtype=float) @ h.T
    distance = np.linalg.norm((p.positions - centre)[:, None, :] + images[None], axis=2).min(axis=1)
    inside = (distance <= 2.5) & ~p.rattler
    assert_all(at["start_particles"] == inside.sum(),
               f"{at['start_particles']} start particles, {inside.sum()} by brute force")
    m = 1000
    s = (np.stack(np.meshgrid(*[np.arange(m)] * 2, indexing="ij"), -1).reshape(-1, 2) + 0.5) / m
    r = s @ h.T
    spread = np.mean(np.sum((r - r.mean(axis=0)) ** 2, axis=1))
    assert_close(at["saturation"] * (1 - 1 / m**2), spread, rtol=1e-10, atol=0, what="uniform spread of the cell")
