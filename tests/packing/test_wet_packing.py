"""Wet packings made by rotsound's FIRE with capillary bridges (solver/packing/wet.py, jammed.generate
with cohesion): FIRE's forces against its energy, the packing at rest with the pull and not
without it, its bridges within rupture distance, a stable matrix (no negative eigenvalue at the
minimum FIRE found), and a packing below dry jamming that only the bridges hold."""

import dataclasses

import numpy as np
import pytest
from conftest import assert_close, central_gradient

from solver.capillary import Cohesion, rupture_distance
from solver.contact_law import ContactModel
from solver.errors import InputError
from solver.model import dynmat
from solver.packing import jammed, mechanics, wet

pytestmark = pytest.mark.serial_only  # FIRE is serial; the matrix is checked on 2 ranks in test_wet_dynmat

COHESION = Cohesion("willett", surface_tension=0.002, volume=1e-3)


@pytest.fixture(scope="module")
def wet_2d():
    return jammed.generate(128, 0.86, np.random.SeedSequence(5), cohesion=COHESION)


def test_fire_forces_are_minus_the_gradient_of_its_energy():
    rng = np.random.default_rng(1)
    n, box = 48, np.full(2, 7.0)
    diameters = rng.choice([jammed.D_SMALL, jammed.D_LARGE], n)
    x = rng.uniform(0, 7.0, (n, 2))
    forces = wet.WetForces(diameters, box, Cohesion("soulie", surface_tension=0.05, liquid_content=0.05))
    forces(x)  # the bridges of the touching pairs
    forces(x)
    bridged = len(forces.keys)
    force, _ = forces(x)
    for h in (1e-6, 5e-7):
        gradient = central_gradient(lambda y: np.array([forces(y.reshape(n, 2))[1]]), x.reshape(1, -1), h)
        assert len(forces.keys) == bridged, "a bridge formed or broke under the steps"
        # energy ~ 1: central differences at h ~ 1e-6 leave ~1e-16/h ~ 1e-10 of round-off
        assert_close(-gradient.reshape(n, 2), force, rtol=0, atol=1e-8, what=f"F = -dE/dx, h = {h}")


def test_bridges_given_at_the_start_are_kept_until_they_rupture():
    """WetForces(bridged=) carries a packing's bridges on (the quasistatic shear's steps): a pair
    apart within its rupture distance pulls only when it was bridged at the start, and a given
    bridge beyond its rupture distance breaks."""
    diameters, box = np.ones(3), np.full(2, 10.0)
    s_c = float(rupture_distance(0.5, 0.5, COHESION))
    x = np.array([[1.0, 1.0], [2.0 + 0.5 * s_c, 1.0], [5.0, 5.0]])  # 0 and 1 apart by s_c / 2, 2 alone
    for bridged, pulled in ((None, False), (np.array([[1, 0]]), True)):
        forces = wet.WetForces(diameters, box, COHESION, bridged=bridged)
        force, _ = forces(x)
        assert (force[0, 0] > 0 and force[1, 0] < 0) == pulled and np.all(force[2] == 0)
        assert forces.bridged(3).tolist() == ([[0, 1]] if pulled else [])
    x[1, 0] = 2.0 + 1.5 * s_c
    forces = wet.WetForces(diameters, box, COHESION, bridged=np.array([[0, 1]]))
    force, _ = forces(x)
    assert np.all(force == 0) and forces.bridged(3).size == 0 and forces.broken == 1


def test_a_wet_packing_is_at_rest_with_the_pull_and_not_without(wet_2d):
    p = wet_2d
    assert p.model.cohesion == COHESION and p.info["n_bridges"] > p.info["n_contacts"]
    assert mechanics.net_force(p) < 1e-5, "not at rest with the pull"
    dry = dataclasses.replace(p, model=ContactModel(), bridges=None)
    assert mechanics.net_force(dry) > 100 * mechanics.net_force(p), "the pull changes nothing"
    mechanics.require_equilibrium(p, "wet")
    radius = 0.5 * p.diameters
    i, j = p.bridges.T
    delta = p.positions[i] - p.positions[j]
    gap = np.linalg.norm(delta - p.box * np.rint(delta / p.box), axis=1) - radius[i] - radius[j]
    assert len(gap) > 0 and np.all((gap > 0) & (gap < rupture_distance(radius[i], radius[j], COHESION)))


def test_a_wet_packing_is_a_stable_minimum(comm, wet_2d):
    """FIRE stopped at a minimum of the wet energy: the matrix has no negative eigenvalue beyond
    round-off (a wrong sign of the pull or of its stiffness gives some)."""
    for model in (ContactModel(cohesion=COHESION), ContactModel(rho=0.5, cohesion=COHESION)):
        dm = dynmat.assemble(wet_2d, model, comm)
        try:
            values = np.linalg.eigvalsh(dynmat.gather_csr(dm.D).toarray())
        finally:
            dm.destroy()
        # the residual forces (<= 1e-6) and round-off allow -1e-9 of the largest
        assert values.min() > -1e-9 * values.max(), f"rho = {model.rho}: lowest eigenvalue {values.min():.3e}"


@pytest.mark.parametrize("dim, phi, gamma", [(2, 0.8, 0.01), (3, 0.6, 0.01)])
def test_bridges_hold_a_packing_below_dry_jamming(comm, dim, phi, gamma):
    """The dry packing of the same start does not jam (every particle a rattler); the wet one
    stands, at rest, and is rigid: its matrix has the D translations as its only zero modes and
    no negative eigenvalue (measured: the next eigenvalue 4e-4 to 5e-3 of the largest)."""
    seed = np.random.SeedSequence(5)
    dry = jammed.generate(128, phi, seed, dim=dim)
    assert mechanics.jamming_failure(dry) is not None, "the dry packing jammed: phi is not below jamming"
    cohesion = Cohesion("willett", surface_tension=gamma, volume=1e-3)
    p = jammed.generate(128, phi, seed, dim=dim, cohesion=cohesion)
    assert mechanics.jamming_failure(p) is None, mechanics.jamming_failure(p)
    mechanics.require_equilibrium(p, "wet")
    dm = dynmat.assemble(p, ContactModel(cohesion=cohesion), comm)
    try:
        values = np.linalg.eigvalsh(dynmat.gather_csr(dm.D).toarray())
    finally:
        dm.destroy()
    zero = np.abs(values) < 1e-9 * values.max()
    assert zero.sum() == dim and values.min() > -1e-9 * values.max(), f"lowest eigenvalues {values[:dim + 2]}"


def test_a_box_too_small_for_the_bridges_is_refused_before_fire():
    """16 disks at phi 0.86 (L = 3.88) with bridges of volume 1 (s_c = 1 d0 at theta = 0) would
    reach through two periodic images (2 (d_L + s_c) = 4.33): InputError naming the box side, the
    contact distance, s_c and the keys to change, before FIRE (it used to run FIRE regardless)."""
    cohesion = Cohesion("willett", surface_tension=0.002, volume=1.0)
    side = jammed.box_length_for(jammed.bidisperse_diameters(16), 0.86, 2)
    s_c = float(rupture_distance(np.array([0.5 * jammed.D_LARGE]), np.array([0.5 * jammed.D_LARGE]), cohesion)[0])
    with pytest.raises(InputError) as caught:
        jammed.generate(16, 0.86, np.random.SeedSequence(5), cohesion=cohesion)
    message = str(caught.value)
    for fragment in (f"box side L = {side:.4g} d0", f"2 (d + s_c) = {2 * (jammed.D_LARGE + s_c):.4g} d0",
                     f"d = {jammed.D_LARGE:.4g} d0", f"s_c = {s_c:.4g} d0", "packing.n", "packing.phi",
                     "model.cohesion.volume"):
        assert fragment in message, f"{fragment!r} not in {message!r}"


def test_the_box_condition_holds_at_its_edge():
    """A box side just above 2 (d + s_c) of the largest pair is accepted, just below refused; the
    largest pair is the one of the largest reach d + s_c (here the two large disks)."""
    cohesion = Cohesion("soulie", surface_tension=0.05, liquid_content=0.05)
    diameters = np.array([jammed.D_SMALL, jammed.D_LARGE, jammed.D_SMALL])
    radius = 0.5 * jammed.D_LARGE
    edge = 2.0 * (jammed.D_LARGE + float(rupture_distance(np.array([radius]), np.array([radius]), cohesion)[0]))
    wet.WetForces(diameters, np.full(2, edge * (1 + 1e-9)), cohesion)
    with pytest.raises(InputError, match="must exceed 2"):
        wet.WetForces(diameters, np.array([edge * (1 + 1e-9), edge * (1 - 1e-9)]), cohesion)
