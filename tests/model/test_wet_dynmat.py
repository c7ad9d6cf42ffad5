"""The dynamical matrix of a wet packing (capillary bridges on every contact and on the bridged
pairs across a gap, ``Packing.bridges``) against central differences of the total energy, on 1
and 2 ranks, and the bridges' list checked against its packing (solver/packing/bridges.py)."""

import dataclasses

import numpy as np
import pytest
from conftest import assert_close, central_hessian, split_generalised

from solver import contact_law
from solver.capillary import Cohesion
from solver.contact_law import ContactModel
from solver.errors import InputError
from solver.model import dynmat
from solver.packing import bridges, geometry, jammed

COHESION = Cohesion("willett", surface_tension=0.01, contact_angle=0.2, volume=1e-3)  # s_c = 0.11


def wet(packing, cohesion=COHESION, widest=0.1):
    """``packing`` with every pair apart by 1e-4 to ``widest`` bridged, under ``cohesion``."""
    candidates = geometry.candidate_pairs(packing.positions, packing.box, float(packing.diameters.max()) + widest)
    _, _, overlap = geometry.pair_geometry(packing.positions, packing.diameters, packing.box, candidates)
    apart = candidates[(-overlap > 1e-4) & (-overlap < widest)]
    listed = bridges.build(apart, packing.positions, packing.diameters, packing.box, cohesion, "test")
    return dataclasses.replace(packing, bridges=listed,
                               model=dataclasses.replace(packing.model, cohesion=cohesion)), listed


def spheres(seed=3):
    """32 spheres of an FCC crystal with spacing about one diameter, moved by up to 0.03: about as
    many neighbours touching as apart."""
    rng = np.random.default_rng(seed)
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    grid = np.stack(np.meshgrid(*[np.arange(2)] * 3, indexing="ij"), -1).reshape(-1, 1, 3)
    lattice = 1.0 * np.sqrt(2.0)
    positions = ((grid + basis) * lattice).reshape(-1, 3) + rng.uniform(-0.03, 0.03, (32, 3))
    return jammed.from_arrays(positions, rng.uniform(0.97, 1.03, 32), 2 * lattice, rattler=np.zeros(32, dtype=bool))


def dense_matrix(packing, model, comm) -> np.ndarray:
    """D of ``packing`` under ``model``, dense, rows and columns in the packing's order; the PETSc
    matrix destroyed before returning.  Collective on ``comm``."""
    dm = dynmat.assemble(packing, model, comm)
    try:
        return dynmat.in_packing_order(dm, dynmat.gather_csr(dm.D).toarray())
    finally:
        dm.destroy()


def total_energy_hessian(packing, model, pairs, h=1e-5):
    """Dense Hessian (N dof x N dof) from central differences of every pair's energy
    (``contact_law.pair_energy`` under ``model``), pairs (P, 2), assembled by hand."""
    dim = packing.dim
    normal, distance, overlap = geometry.pair_geometry(packing.positions, packing.diameters, packing.box, pairs)
    assert np.abs(overlap).min() > 5 * h, "the steps must not move a pair across xi = 0"
    i, j = pairs[:, 0], pairs[:, 1]
    radius = 0.5 * packing.diameters
    m = dim + (1 if dim == 2 else 3)

    def energy(w):
        du, theta_i, theta_j = split_generalised(w, dim)
        return contact_law.pair_energy(normal * distance[:, None], radius[i] + radius[j], normal, radius[i], radius[j],
                                       model, du=du, theta_i=theta_i, theta_j=theta_j)

    local = central_hessian(energy, len(pairs), 2 * m, h)
    dof = dynmat.dof_per_particle(dim, model)
    dense = np.zeros((packing.n * dof, packing.n * dof))
    keep = np.arange(dof)
    for c in range(len(pairs)):
        rows = np.concatenate((i[c] * dof + keep, j[c] * dof + keep))
        dense[np.ix_(rows, rows)] += local[c][np.ix_(np.r_[keep, m + keep], np.r_[keep, m + keep])]
    return dense


@pytest.mark.parametrize("dim, springs", [(2, {}), (2, {"rho": 0.5, "rho_roll": 0.2}),
                                          (3, {"rho": 1.0, "rho_roll": 0.3, "rho_twist": 0.2})])
def test_wet_matrix_is_the_hessian_of_contacts_and_bridges(comm, small_packing, dim, springs):
    packing, listed = wet(small_packing if dim == 2 else spheres())
    assert len(listed) >= 8, "too few bridges across a gap for the check to mean much"
    model = ContactModel(**springs, cohesion=COHESION)
    found = geometry.find_contacts(packing.positions, packing.diameters, packing.box)
    pairs = np.concatenate((np.stack((found.i, found.j), 1), listed))
    expected = total_energy_hessian(packing, model, pairs)
    dense = dense_matrix(packing, model, comm)
    scale = np.abs(expected).max()
    # central differences of a smooth energy at h = 1e-5: truncation ~1e-10, round-off ~1e-16/h^2 ~ 1e-6
    assert_close(dense, expected, rtol=0, atol=1e-6 * scale, what=f"{dim}D wet D against central differences")
    dry = dense_matrix(packing, ContactModel(**springs), comm)
    assert np.abs(dry - expected).max() > 1e-3 * scale, "the bridges change nothing"


def test_bridges_are_checked_against_their_packing(small_packing):
    packing, listed = wet(small_packing)
    found = geometry.find_contacts(packing.positions, packing.diameters, packing.box)
    touching = np.stack((found.j[:3], found.i[:3]), 1)  # reversed order: put right
    again = bridges.build(np.concatenate((listed[::-1, ::-1], touching)), packing.positions, packing.diameters,
                          packing.box, COHESION, "test")
    assert np.array_equal(again, listed), "canonical order, contacts dropped"
    far = geometry.candidate_pairs(packing.positions, packing.box, 2.0)
    _, _, overlap = geometry.pair_geometry(packing.positions, packing.diameters, packing.box, far)
    beyond = far[np.argmax(-overlap > 0.2)][None]
    for pairs, message in ((beyond, r"beyond the rupture distance \(first: particles .*, gap 0.\d+ d0 >= s_c = 0.11 "),
                           (np.array([[0, 64]]), "names particle index"),
                           (np.array([[3, 3]]), "pairs particle 3 with itself"),
                           (np.concatenate((listed[:1], listed[:1])), "listed more than once")):
        with pytest.raises(InputError, match=message):
            bridges.build(pairs, packing.positions, packing.diameters, packing.box, COHESION, "test")


LIGGGHTS_WET = Cohesion("soulie", surface_tension=0.005, contact_angle=0.0, liquid_content=0.05)


@pytest.mark.parametrize("dim, bridges_apart", [(2, 6), (3, 24)])
def test_liggghts_wet_packing_is_at_rest_with_the_pull_and_its_response_is_minus_d_x(comm, dim, bridges_apart):
    """LIGGGHTS's own wet packings (tests/data/dem/liggghts_{2d,3d}_wet.*, cohesion
    easo/capillary/viscous, no tangential spring), read with their contact files, whose pairs apart
    are their bridges: at rest under rotsound's Soulie pull (not without it), and LIGGGHTS's forces
    one step after moving every particle are -D x of rotsound's wet matrix to the moves' second
    order (measured 1.4e-8 of the largest force in 2D, 2.3e-8 in 3D); the dry matrix misses by 1.2e-2
    and 4.9e-2."""
    import re

    from conftest import REPO

    from solver.io import hdf5
    from solver.packing import mechanics

    data = REPO / "tests" / "data" / "dem"
    stem = f"liggghts_{dim}d_wet"
    files = {"contacts": str(data / f"{stem}.contacts"), "contacts_format": "liggghts-local"}
    p = hdf5.read_packings(str(data / f"{stem}.data"), model=ContactModel(lever="contact", cohesion=LIGGGHTS_WET),
                           **files)[0]
    assert p.dim == dim and len(p.bridges) == bridges_apart and p.info["n_bridges"] > p.info["n_contacts"], p.info
    assert mechanics.net_force(p) < 1e-10, mechanics.net_force(p)
    dry = dataclasses.replace(p, model=ContactModel(lever="contact"), bridges=None)
    assert mechanics.net_force(dry) > 1e-2, "the pull changes nothing"
    with pytest.raises(InputError, match="read it with model.cohesion"):
        hdf5.read_packings(str(data / f"{stem}.data"), model=ContactModel(lever="contact"), **files)
    text = (data / f"{stem}.response").read_text()
    frames = [np.loadtxt(chunk.strip().splitlines()[:p.n]) for chunk in re.split(r"ITEM: ATOMS[^\n]*\n", text)[1:]]
    assert len(frames) == 3 and np.array_equal(frames[0][:, 0], np.arange(1, p.n + 1))
    d0, dt, active = p.info["length_unit"], 1e-4, ~p.rattler  # the script's step; kn = 1
    moves = frames[0][active, 1:1 + dim] * dt / d0
    forces = 0.5 * (frames[1][active, 4:4 + dim] - frames[2][active, 4:4 + dim]) / d0
    errors = {}
    for name, model in (("wet", ContactModel(lever="contact", cohesion=LIGGGHTS_WET)),
                        ("dry", ContactModel(lever="contact"))):
        dense = dense_matrix(p, model, comm)
        errors[name] = np.abs(forces + (dense @ moves.ravel()).reshape(moves.shape)).max() / np.abs(forces).max()
    assert errors["wet"] < 1e-6 and errors["dry"] > 5e-3, errors
