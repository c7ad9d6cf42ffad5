"""The contact law eq:eij (solver/contact_law.py): its Hessian blocks and forces against
central differences of its own energy, with Taylor-convergence checks, and the FIRE force."""

import numpy as np
import pytest
from conftest import assert_close, central_gradient, central_hessian, split_generalised as split

from solver import contact_law
from solver.contact_law import ContactModel
from solver.packing import jammed
from solver.packing import mechanics

pytestmark = pytest.mark.serial_only  # pure numpy: nothing to gain from a second rank

STEPS = np.array([2e-3, 1e-3, 5e-4, 2.5e-4])  # central-difference steps of the Taylor checks
# (the mixed differences move a contact by up to 2 h + |w| < 0.01: never across xi = 0)


def random_contacts(count=24, seed=0):
    """Reference contacts of bidisperse disks at random angles, overlaps 0.01-0.05 d0.

    Returns the keyword arguments of ``pair_energy`` except the displacements, and the overlaps.
    """
    rng = np.random.default_rng(seed)
    radii = 0.5 * rng.choice([jammed.D_SMALL, jammed.D_LARGE], size=(2, count))
    angle = rng.uniform(0, 2 * np.pi, count)
    normal = np.stack((np.cos(angle), np.sin(angle)), axis=1)
    contact = radii[0] + radii[1]
    overlap = rng.uniform(0.01, 0.05, count)
    geometry = {"separation": normal * (contact - overlap)[:, None], "contact": contact,
                "normal": normal, "radius_i": radii[0], "radius_j": radii[1]}
    return geometry, overlap


def energy_of(geometry, rho, w):
    """pair_energy for generalised displacements w (C, 6) = (u_i, theta_i, u_j, theta_j)."""
    return contact_law.pair_energy(**geometry, model=ContactModel(rho), du=w[:, 0:2] - w[:, 3:5],
                                   theta_i=w[:, 2], theta_j=w[:, 5])


def blocks_as_6x6(geometry, overlap, rho):
    """[[H_ii, H_ij], [H_ji, H_jj]] (C, 6, 6) from contact_law.pair_blocks."""
    distance = geometry["contact"] - overlap
    h_ii, h_ij, h_jj = contact_law.pair_blocks(geometry["normal"], distance, overlap,
                                               geometry["radius_i"], geometry["radius_j"], ContactModel(rho))
    top = np.concatenate((h_ii, h_ij), axis=2)
    bottom = np.concatenate((np.transpose(h_ij, (0, 2, 1)), h_jj), axis=2)
    return np.concatenate((top, bottom), axis=1)


def observed_order(errors):
    """Slopes log2(e(h) / e(h/2)) of successive halvings of the step."""
    errors = np.asarray(errors)
    return np.log2(errors[:-1] / errors[1:])


@pytest.mark.parametrize("rho", [0.0, 0.2, 1.0])
def test_hessian_blocks_match_central_differences_at_second_order(rho):
    geometry, overlap = random_contacts()
    exact = blocks_as_6x6(geometry, overlap, rho)
    scale = np.abs(exact).max()
    count = geometry["contact"].size
    errors = [np.abs(central_hessian(lambda w: energy_of(geometry, rho, w), count, 6, h) - exact).max() / scale
              for h in STEPS]
    orders = observed_order(errors)
    # Wrong blocks leave an error that does not fall with h (the geometric term alone is
    # f_n / r ~ 0.01-0.05 here): the slope then drops to ~0 and the check fails.
    assert np.all(np.abs(orders - 2) < 0.1), f"rho = {rho}: errors {errors}, orders {orders}"
    assert errors[-1] < 1e-6, f"rho = {rho}: error {errors[-1]} at h = {STEPS[-1]}"


def test_translation_blocks_at_rho_zero_are_the_full_blocks_without_rotation():
    geometry, overlap = random_contacts(seed=1)
    distance = geometry["contact"] - overlap
    full = contact_law.pair_blocks(geometry["normal"], distance, overlap, geometry["radius_i"],
                                   geometry["radius_j"], ContactModel(0.0))
    small = contact_law.pair_blocks(geometry["normal"], distance, overlap, geometry["radius_i"],
                                    geometry["radius_j"], ContactModel(0.0), with_rotation=False)
    for f, s in zip(full, small):
        assert_close(s, f[:, :2, :2], rtol=0.0, what="2 x 2 translation block")
        assert np.all(f[:, 2, :] == 0) and np.all(f[:, :, 2] == 0), "rotations carry stiffness at rho = 0"


@pytest.mark.parametrize("rho", [0.0, 0.5])
def test_forces_and_torques_are_minus_the_energy_gradient(rho):
    geometry, _ = random_contacts(seed=2)
    count = geometry["contact"].size
    rng = np.random.default_rng(3)
    w = 1e-3 * rng.normal(size=(count, 6))  # a displaced state: forces beyond the linear ones
    force, tau_i, tau_j = contact_law.pair_forces(**geometry, model=ContactModel(rho), du=w[:, 0:2] - w[:, 3:5],
                                                  theta_i=w[:, 2], theta_j=w[:, 5])
    generalised = np.concatenate((force, tau_i[:, None], -force, tau_j[:, None]), axis=1)
    errors = [np.abs(generalised + central_gradient(lambda x: energy_of(geometry, rho, x), w, h)).max()
              / np.abs(generalised).max() for h in STEPS]
    orders = observed_order(errors)
    assert np.all(np.abs(orders - 2) < 0.1), f"errors {errors}, orders {orders}"
    # Taylor remainder along a random direction: e(w + h v) - e(w) + h F.v = O(h^2)
    v = rng.normal(size=(count, 6))
    remainder = [np.abs(energy_of(geometry, rho, w + h * v) - energy_of(geometry, rho, w)
                        + h * np.sum(generalised * v, axis=1)).max() for h in STEPS]
    orders = observed_order(remainder)
    assert np.all(np.abs(orders - 2) < 0.1), f"Taylor remainders {remainder}, orders {orders}"


def test_unstressed_tangential_springs_and_rolling_without_slip():
    geometry, overlap = random_contacts(seed=4)
    count = overlap.size
    zero, zero2 = np.zeros(count), np.zeros((count, 2))
    # at the reference only the normal force acts: the packing stays in equilibrium for any rho
    force, tau_i, tau_j = contact_law.pair_forces(**geometry, model=ContactModel(1.0), du=zero2, theta_i=zero,
                                                  theta_j=zero)
    assert_close(force, contact_law.normal_force(overlap)[:, None] * geometry["normal"], rtol=1e-13,
                 what="reference force")  # rtol: n recomputed from the separation, a few ulp
    assert np.all(tau_i == 0) and np.all(tau_j == 0), "torques at the reference"
    # two disks rolling on each other like gears (R_i theta_i = -R_j theta_j) do not slip
    phi = 1e-3
    rolling = contact_law.pair_energy(**geometry, model=ContactModel(1.0), du=zero2, theta_i=phi / geometry["radius_i"],
                                      theta_j=-phi / geometry["radius_j"])
    assert_close(rolling, contact_law.normal_energy(overlap), rtol=1e-12, what="rolling without slip")
    # equal spins make the contact points slide by (R_i + R_j) phi
    sliding = contact_law.pair_energy(**geometry, model=ContactModel(1.0), du=zero2, theta_i=np.full(count, phi),
                                      theta_j=np.full(count, phi))
    slip = (geometry["radius_i"] + geometry["radius_j"]) * phi
    assert_close(sliding - contact_law.normal_energy(overlap), 0.5 * slip**2, rtol=1e-9, what="sliding")


def test_fire_forces_are_minus_the_gradient_of_fire_energy():
    """The FIRE force of packing/jammed.py (eq:eij at rho = 0 via contact_law.normal_pair)."""
    rng = np.random.default_rng(6)
    n, box = 24, 4.2  # dense enough for ~2-3 overlaps per disk, box > 2 max(d)
    diameters = rng.permutation(jammed.bidisperse_diameters(n))
    x = rng.uniform(0, box, size=(n, 2))
    forces = mechanics.FrictionlessForces(diameters, box)
    f, energy = forces(x)
    assert energy > 0.1, "no overlaps: the check would be empty"
    h = 1e-6
    grad = np.empty_like(x)
    for i in range(n):
        for axis in range(2):
            step = np.zeros_like(x)
            step[i, axis] = h
            grad[i, axis] = (forces(x + step)[1] - forces(x - step)[1]) / (2 * h)
    # central differences, h = 1e-6, of an energy ~1: truncation ~1e-12, round-off ~1e-10
    assert_close(f, -grad, rtol=0.0, atol=1e-7 * np.abs(f).max(), what="FIRE force vs -grad E")


@pytest.mark.parametrize("law", ["harmonic", "hertz"])
@pytest.mark.parametrize("dim", [2, 3])
def test_compiled_fire_forces_equal_a_brute_force_sum_over_all_pairs(dim, law):
    """packing/pair_forces.py (numba, on FIRE's Verlet list) against every pair of the periodic box
    by minimum image, through contact_law.normal_pair and np.add.at: a pair missing from the list,
    a wrong image shift or a wrong sign or axis in the compiled loop breaks it."""
    rng = np.random.default_rng(11 + dim)
    n = 40
    diameters = rng.permutation(jammed.bidisperse_diameters(n))
    box = jammed.box_length_for(diameters, 0.9 if dim == 2 else 0.75, dim)
    x = rng.uniform(-box, 2 * box, size=(n, dim))  # unwrapped, as during FIRE
    f, energy = mechanics.FrictionlessForces(diameters, box, law=law)(x)
    i, j = np.triu_indices(n, 1)
    delta = x[i] - x[j]
    separation = delta - box * np.rint(delta / box)
    reduced = diameters[i] * diameters[j] / (2 * (diameters[i] + diameters[j]))  # R_i R_j / (R_i + R_j)
    pair_force, pair_energy = contact_law.normal_pair(separation, 0.5 * (diameters[i] + diameters[j]), law, reduced)
    expected = np.zeros_like(x)
    np.add.at(expected, i, pair_force)
    np.add.at(expected, j, -pair_force)
    assert np.count_nonzero(pair_energy) > n, "too few overlaps for the check to mean much"
    # the same formula summed in another order: round-off only (~1e-16 relative per term)
    assert_close(f, expected, rtol=0.0, atol=1e-13 * np.abs(expected).max(), what=f"{dim}D forces")
    assert_close(energy, pair_energy.sum(), rtol=1e-13, what=f"{dim}D energy")


# --- 3D spheres and rolling / twisting springs (PHYSICS.md section 8) ---------------------------

def random_contacts_nd(dim, count=16, seed=0):
    """Like ``random_contacts`` in ``dim`` = 2 or 3 (normals uniform on the circle / sphere)."""
    rng = np.random.default_rng(seed)
    radii = 0.5 * rng.choice([jammed.D_SMALL, jammed.D_LARGE], size=(2, count))
    normal = rng.normal(size=(count, dim))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    contact = radii[0] + radii[1]
    overlap = rng.uniform(0.01, 0.05, count)
    geometry = {"separation": normal * (contact - overlap)[:, None], "contact": contact,
                "normal": normal, "radius_i": radii[0], "radius_j": radii[1]}
    return geometry, overlap


def energy_nd(geometry, springs, w):
    du, theta_i, theta_j = split(w, geometry["normal"].shape[1])
    return contact_law.pair_energy(**geometry, model=ContactModel(**springs), du=du, theta_i=theta_i, theta_j=theta_j)


SPRINGS = [(2, {"rho": 0.5, "rho_roll": 0.3}), (2, {"rho": 0.0, "rho_roll": 0.7}),
           (3, {"rho": 0.5, "rho_roll": 0.3, "rho_twist": 0.2}), (3, {"rho": 1.0}),
           (3, {"rho": 0.0, "rho_roll": 0.0, "rho_twist": 0.4}),
           # Hertz: normal force kn sqrt(a' xi) xi, every spring scaled by sqrt(a' xi) at the reference
           (2, {"rho": 0.5, "rho_roll": 0.3, "law": "hertz"}),
           (3, {"rho": 0.5, "rho_roll": 0.3, "rho_twist": 0.2, "law": "hertz"})]


@pytest.mark.parametrize("dim, springs", SPRINGS)
def test_nd_hessian_blocks_match_central_differences_at_second_order(dim, springs):
    geometry, overlap = random_contacts_nd(dim)
    count, size = overlap.size, 2 * (dim + (1 if dim == 2 else 3))
    h_ii, h_ij, h_jj = contact_law.pair_blocks(geometry["normal"], geometry["contact"] - overlap, overlap,
                                               geometry["radius_i"], geometry["radius_j"], ContactModel(**springs))
    exact = np.concatenate((np.concatenate((h_ii, h_ij), 2),
                            np.concatenate((np.transpose(h_ij, (0, 2, 1)), h_jj), 2)), 1)
    assert exact.shape == (count, size, size)
    errors = [np.abs(central_hessian(lambda w: energy_nd(geometry, springs, w), count, size, h) - exact).max()
              / np.abs(exact).max() for h in STEPS]
    orders = observed_order(errors)
    # the springs are quadratic, so only the exact-geometry normal term leaves an O(h^2) error;
    # a wrong block leaves an error that does not fall with h (slope ~0)
    assert np.all(np.abs(orders - 2) < 0.1), f"{dim}D {springs}: errors {errors}, orders {orders}"
    # Hertz's xi^(5/2) leaves a truncation error ~ (h / xi)^2 / 10 (xi >= 0.01, h = 2.5e-4: ~1e-4;
    # measured 1.1e-5); the harmonic energy's is far smaller.  The slope above is the real check.
    assert errors[-1] < (1e-4 if springs.get("law") == "hertz" else 1e-6), f"{dim}D {springs}: error {errors[-1]}"


@pytest.mark.parametrize("dim, springs", SPRINGS)
def test_nd_forces_and_torques_are_minus_the_energy_gradient(dim, springs):
    geometry, _ = random_contacts_nd(dim, seed=2)
    count, size = geometry["contact"].size, 2 * (dim + (1 if dim == 2 else 3))
    w = 1e-3 * np.random.default_rng(3).normal(size=(count, size))
    du, theta_i, theta_j = split(w, dim)
    force, tau_i, tau_j = contact_law.pair_forces(**geometry, model=ContactModel(**springs), du=du, theta_i=theta_i,
                                                  theta_j=theta_j)
    col = (lambda t: t[:, None]) if dim == 2 else (lambda t: t)  # noqa: E731
    generalised = np.concatenate((force, col(tau_i), -force, col(tau_j)), axis=1)
    errors = [np.abs(generalised + central_gradient(lambda x: energy_nd(geometry, springs, x), w, h)).max()
              / np.abs(generalised).max() for h in STEPS]
    orders = observed_order(errors)
    assert np.all(np.abs(orders - 2) < 0.1), f"{dim}D {springs}: errors {errors}, orders {orders}"


def test_3d_springs_act_on_the_motions_they_resist():
    """Uniform spin: only the tangential spring, slip (R_i + R_j) phi; a relative spin about n:
    only twisting, a' |dphi|; a relative spin about an axis normal to n: only rolling."""
    geometry, overlap = random_contacts_nd(3, seed=5)
    n, count = geometry["normal"], overlap.size
    base = contact_law.normal_energy(overlap)
    zero3 = np.zeros((count, 3))
    axis = np.cross(n, np.random.default_rng(6).normal(size=(count, 3)))
    axis /= np.linalg.norm(axis, axis=1)[:, None]  # unit, normal to n
    reduced = geometry["radius_i"] * geometry["radius_j"] / (geometry["radius_i"] + geometry["radius_j"])
    phi = 1e-3

    def extra(springs, theta_i, theta_j):
        return contact_law.pair_energy(**geometry, model=ContactModel(**springs), du=zero3, theta_i=theta_i,
                                       theta_j=theta_j) - base

    spin = phi * axis
    zero = 1e-12 * base  # round-off of e - e_normal; a spring that acts adds ~(a' phi)^2 ~ 1e-8 >> this
    slip = (geometry["radius_i"] + geometry["radius_j"]) * phi
    assert_close(extra({"rho": 1.0}, spin, spin), 0.5 * slip**2, rtol=1e-9, what="uniform spin, tangential")
    assert np.all(np.abs(extra({"rho": 0.0, "rho_roll": 1.0, "rho_twist": 1.0}, spin, spin)) < zero), \
        "rolling / twisting springs resist a uniform spin"
    twist = phi * n
    assert_close(extra({"rho": 0.0, "rho_twist": 1.0}, twist, -twist), 0.5 * (2 * phi * reduced) ** 2,
                 rtol=1e-9, what="relative twist")
    assert np.all(np.abs(extra({"rho": 0.0, "rho_roll": 1.0}, twist, -twist)) < zero), "rolling resists a twist"
    assert_close(extra({"rho": 0.0, "rho_roll": 1.0}, spin, -spin), 0.5 * (2 * phi * reduced) ** 2,
                 rtol=1e-9, what="relative roll")
    assert np.all(np.abs(extra({"rho": 0.0, "rho_twist": 1.0}, spin, -spin)) < zero), "twisting resists a roll"


def test_twisting_spring_is_refused_in_2d():
    geometry, overlap = random_contacts_nd(2)
    with pytest.raises(ValueError, match="rho_twist = 0.1: twisting resistance exists in 3D only"):
        contact_law.pair_blocks(geometry["normal"], geometry["contact"] - overlap, overlap,
                                geometry["radius_i"], geometry["radius_j"], ContactModel(0.5, rho_twist=0.1))
