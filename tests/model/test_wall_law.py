"""A particle against a flat immovable wall (docs/walls.md): contact_law.wall_blocks against central
differences of the wall contact's energy (2D and 3D, both laws, every spring on, both levers), and
wall_stressed_blocks against central differences of LAMMPS's fix wall/gran history update (lever R)
and LIGGGHTS's (lever R - xi/2 at the current overlap) written out here independently of the
derivation."""

import numpy as np
import pytest
from conftest import central_hessian

from solver import contact_law
from solver.contact_law import ContactModel

pytestmark = pytest.mark.serial_only  # pure numpy

STEPS = np.array([2e-3, 1e-3, 5e-4, 2.5e-4])


def wall_contacts(dim, count=16, seed=0, ratio=0.6):
    """Random wall contacts: normals along random axes and sides, radii 0.4-0.7, overlaps
    0.01-0.05, stored tangential forces of |f_t| = ratio f_n (harmonic f_n) in random tangent
    directions."""
    rng = np.random.default_rng(seed)
    normal = np.zeros((count, dim))
    normal[np.arange(count), rng.integers(0, dim, count)] = rng.choice([-1.0, 1.0], count)
    radius = rng.uniform(0.4, 0.7, count)
    overlap = rng.uniform(0.01, 0.05, count)
    direction = rng.normal(size=(count, dim))
    direction -= np.einsum("kd,kd->k", direction, normal)[:, None] * normal
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    return normal, overlap, radius, ratio * overlap[:, None] * direction


def split(w, dim):
    """(u (K, D), theta (K,) in 2D or (K, 3) in 3D) of generalised displacements w (K, D + r)."""
    return w[:, :dim], (w[:, dim] if dim == 2 else w[:, dim:])


def models(dim, law, lever="radius"):
    springs = [ContactModel(0.0, law=law, lever=lever), ContactModel(0.7, law=law, lever=lever),
               ContactModel(0.7, 0.3, law=law, lever=lever)]
    if dim == 3:
        springs.append(ContactModel(0.7, 0.3, 0.2, law=law, lever=lever))
    return springs


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("law", ["harmonic", "hertz"])
@pytest.mark.parametrize("lever", ["radius", "contact"])
def test_wall_blocks_are_the_hessian_of_the_wall_energy(dim, law, lever):
    normal, overlap, radius, _ = wall_contacts(dim, seed=dim)
    size = dim + (1 if dim == 2 else 3)
    for model in models(dim, law, lever):
        exact = contact_law.wall_blocks(normal, overlap, radius, model)
        assert exact.shape == (normal.shape[0], size, size)

        def energy(w):
            return contact_law.wall_energy(normal, overlap, radius, model, *split(w, dim))

        errors = [np.abs(central_hessian(energy, normal.shape[0], size, h) - exact).max() / np.abs(exact).max()
                  for h in STEPS]
        # harmonic: the energy is quadratic (round-off only); hertz: xi^(5/2) leaves O(h^2) ~ (h/xi)^2
        assert errors[-1] < (1e-7 if law == "harmonic" else 1e-4), f"{model}: errors {errors}"
        if law == "hertz":
            orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
            assert np.all(np.abs(orders - 2) < 0.15), f"{model}: errors {errors}, orders {orders}"


@pytest.mark.parametrize("dim", [2, 3])
def test_the_wall_is_not_a_particle_of_finite_radius(dim):
    """Negative control: the pair blocks of a particle against a huge but finite immovable one
    tend to the wall's; one of radius 1 (a pair's lever and geometric term) is far from them."""
    normal, overlap, radius, _ = wall_contacts(dim, seed=5)
    model = ContactModel(0.7, 0.3, 0.2 if dim == 3 else 0.0)
    wall = contact_law.wall_blocks(normal, overlap, radius, model)
    for other, close in ((1e7, True), (0.5, False)):
        big = np.full_like(radius, other)
        ii, _, _ = contact_law.pair_blocks(normal, radius + big - overlap, overlap, radius, big, model)
        gap = np.abs(ii - wall).max() / np.abs(wall).max()
        assert (gap < 1e-6) == close, f"R_j = {other}: pair block differs from the wall's by {gap:.2e}"


def dem_wall_step(normal, overlap, radius, tangential, law, rho, x, lever="radius"):
    """Generalised force (K, D + r) = (F, tau) on the particle after one step of LAMMPS's fix
    wall/gran hooke/history or hertz/history (``lever`` radius) or LIGGGHTS's fix wall/gran primitive
    with tangential history (``lever`` contact) that moves it by x = (u, theta) from a reference at
    rest with stored tangential force ``tangential`` (K, D): the wall's normal does not turn, the
    history s = -f_t / k_t(xi0) is incremented by the contact point's tangential displacement
    P u - l theta x n and projected onto the tangent plane, f_t = -k_t(xi) s, the force f_n(xi) n +
    f_t with xi = xi0 - n.u, the torque -l n x f_t; l = R (LAMMPS) or R - xi/2 at the new overlap
    (LIGGGHTS's surface model: cr = radi - deltan/2)."""
    dim = normal.shape[1]
    u, theta = split(x, dim)
    xi = overlap - np.einsum("kd,kd->k", normal, u)
    arm = radius if lever == "radius" else radius - 0.5 * xi

    def stiffness(xi):  # (f_n, k_t) with a' = R (LAMMPS: polyhertz = sqrt((radius - r) radius))
        scale = np.ones_like(xi) if law == "harmonic" else np.sqrt(radius * xi)
        return scale * xi, rho * scale

    s = -tangential / stiffness(overlap)[1][:, None]
    spin = (arm * theta)[:, None] * np.stack((-normal[:, 1], normal[:, 0]), 1) if dim == 2 else \
        np.cross(arm[:, None] * theta, normal)
    s = s + u - np.einsum("kd,kd->k", u, normal)[:, None] * normal - spin
    s = s - np.einsum("kd,kd->k", s, normal)[:, None] * normal
    f_n, k_t = stiffness(xi)
    f_t = -k_t[:, None] * s
    force = f_n[:, None] * normal + f_t
    if dim == 2:
        torque = -(arm * (normal[:, 0] * f_t[:, 1] - normal[:, 1] * f_t[:, 0]))[:, None]
    else:
        torque = -arm[:, None] * np.cross(normal, f_t)
    return np.concatenate((force, torque), axis=1)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("law", ["harmonic", "hertz"])
@pytest.mark.parametrize("lever", ["radius", "contact"])
def test_wall_stressed_blocks_are_the_linearised_dem_wall_update(dim, law, lever):
    normal, overlap, radius, tangential = wall_contacts(dim, seed=10 + dim)
    if law == "hertz":
        tangential = tangential * np.sqrt(radius * overlap)[:, None]
    rho = 0.7
    model = ContactModel(rho, law=law, lever=lever)
    exact = contact_law.wall_blocks(normal, overlap, radius, model) \
        + contact_law.wall_stressed_blocks(normal, overlap, radius, tangential, model)
    size = exact.shape[1]

    def jacobian(h):
        out = np.empty((normal.shape[0], size, size))
        for b in range(size):
            x = np.zeros((normal.shape[0], size))
            x[:, b] = h
            out[:, :, b] = (dem_wall_step(normal, overlap, radius, tangential, law, rho, x, lever)
                            - dem_wall_step(normal, overlap, radius, tangential, law, rho, -x, lever)) / (2 * h)
        return out

    steps = STEPS if law == "harmonic" else STEPS / 8
    errors = [np.abs(jacobian(h) + exact).max() / np.abs(exact).max() for h in steps]
    assert errors[-1] < 1e-6, f"errors {errors}"
    if law == "hertz" or lever == "contact":  # the stored forces' term is there, and the blocks without it miss
        plain = contact_law.wall_blocks(normal, overlap, radius, model)
        miss = np.abs(jacobian(steps[-1]) + plain).max() / np.abs(exact).max()
        assert miss > 1e-3, f"the blocks without the stored forces also match ({miss:.2e}): the test is blind"
        assert np.abs(exact - np.transpose(exact, (0, 2, 1))).max() > 1e-3, "stressed wall blocks came out symmetric"
    else:  # a flat wall's normal does not turn: under the harmonic law the stored forces add nothing
        assert not np.any(contact_law.wall_stressed_blocks(normal, overlap, radius, tangential, model))
    if lever == "contact":  # the other lever's blocks miss LIGGGHTS's update
        other = ContactModel(rho, law=law)
        wrong = contact_law.wall_blocks(normal, overlap, radius, other) \
            + contact_law.wall_stressed_blocks(normal, overlap, radius, tangential, other)
        miss = np.abs(jacobian(steps[-1]) + wrong).max() / np.abs(exact).max()
        assert miss > 1e-3, f"the blocks with the lever R also match LIGGGHTS's update ({miss:.2e})"


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("lever", ["radius", "contact"])
def test_wall_dashpots_are_the_damping_of_the_contact_point_velocity(dim, lever):
    """C v . v / (s m) = gamma_n (n.v)^2 + gamma_t |v_t|^2 for random velocities (v, w), v_t the
    velocity of the point at the lever l (R, or R - xi/2: LIGGGHTS's vtr at cr)."""
    normal, overlap, radius, _ = wall_contacts(dim, seed=20)
    model = ContactModel(0.7, gamma_n=0.3, gamma_t=0.2, lever=lever)
    mass = np.linspace(0.5, 2.0, normal.shape[0])
    blocks = contact_law.wall_damping_blocks(normal, overlap, radius, mass, model)
    rng = np.random.default_rng(21)
    x = rng.normal(size=(normal.shape[0], blocks.shape[1]))
    v, w = split(x, dim)
    arm = radius if lever == "radius" else radius - 0.5 * overlap
    spin = (arm * w)[:, None] * np.stack((-normal[:, 1], normal[:, 0]), 1) if dim == 2 else \
        np.cross(arm[:, None] * w, normal)
    along = np.einsum("kd,kd->k", v, normal)
    slip = v - along[:, None] * normal - spin
    expected = mass * (0.3 * along**2 + 0.2 * np.einsum("kd,kd->k", slip, slip))
    got = np.einsum("ki,kij,kj->k", x, blocks, x)
    assert np.allclose(got, expected, rtol=1e-12, atol=0.0)
