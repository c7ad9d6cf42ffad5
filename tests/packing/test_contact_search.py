"""A rank's share of the contact search (geometry.find_contacts_touching, cells_around) against
brute force over every pair: the same contacts, in find_contacts' order, from a subset of the box."""

import numpy as np
import pytest
from conftest import all_pairs, assert_close, jammed_packing

from solver.packing import geometry

pytestmark = pytest.mark.serial_only  # one rank's share, computed and checked in one process


def brute_force(p, owned, active):
    """(i, j) of every overlapping pair i < j of active particles with an end in ``owned``, sorted
    by i then j, and their overlaps: by all_pairs (no neighbour search)."""
    overlap, _, _ = all_pairs(p)
    i, j = np.nonzero(np.triu(overlap > 0.0, k=1))
    keep = active[i] & active[j] & (owned[i] | owned[j])
    return i[keep], j[keep], overlap[i[keep], j[keep]]


def masks(p):
    """Owned masks: a slab of the matrix's kind (the lowest quarter along the last axis), scattered
    particles, none, all."""
    last = p.positions[:, -1]
    slab = last < np.quantile(last, 0.25)
    scattered = np.random.default_rng(3).random(p.n) < 0.05
    return {"slab": slab, "scattered": scattered, "none": np.zeros(p.n, bool), "all": np.ones(p.n, bool)}


@pytest.mark.parametrize("dim, n, phi", [(2, 512, 0.9), (3, 512, 0.7)])
@pytest.mark.parametrize("which", ["slab", "scattered", "none", "all"])
def test_contacts_touching_owned_particles_are_brute_forces(dim, n, phi, which):
    p = jammed_packing(n, phi, 4, dim=dim)
    owned = masks(p)[which]
    active = ~p.rattler
    found = geometry.find_contacts_touching(p.positions, p.diameters, p.box, owned, active)
    i, j, overlap = brute_force(p, owned, active)
    assert np.array_equal(found.i, i) and np.array_equal(found.j, j), which
    assert_close(found.overlap, overlap, rtol=1e-12, atol=1e-15, what="overlaps")  # round-off of r_ij
    whole = geometry.find_contacts(p.positions, p.diameters, p.box, active)
    keep = owned[whole.i] | owned[whole.j]
    assert np.array_equal(found.normal, whole.normal[keep]), "not find_contacts' own geometry"


@pytest.mark.parametrize("dim, n, phi", [(2, 512, 0.9), (3, 512, 0.7)])
def test_cells_around_a_slab_hold_its_neighbours_and_not_the_whole_box(dim, n, phi):
    p = jammed_packing(n, phi, 4, dim=dim)
    owned = masks(p)["slab"]
    cutoff = float(p.diameters.max())
    near = geometry.cells_around(p.positions, p.box, cutoff, owned)
    _, _, distance = all_pairs(p)
    within = (distance[owned] < cutoff).any(axis=0) | owned
    assert np.all(near[within]), "a particle within the cutoff of an owned one was left out"
    assert near.sum() < 0.8 * p.n, f"{near.sum()} of {p.n}: the search is not restricted"


def test_cells_around_a_box_less_than_three_cells_wide_is_everything():
    rng = np.random.default_rng(0)
    box = np.array([4.0, 20.0])  # 2 cells of side >= 1.5 along x
    positions = rng.uniform(0.0, 1.0, (200, 2)) * box
    owned = np.zeros(200, bool)
    owned[0] = True
    assert geometry.cells_around(positions, box, 1.5, owned).all()
