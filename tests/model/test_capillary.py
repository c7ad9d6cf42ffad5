"""Capillary bridges (solver/capillary.py) and their place in the contact law: the pull against
its closed forms, its energy and stiffness against central differences, and the pair Hessian
blocks and forces of bridged pairs, touching and across a gap, against central differences of
the pair energy (docs/capillary_bridges.md)."""

import numpy as np
import pytest
from conftest import assert_close, central_gradient, central_hessian, split_generalised as split

from solver import capillary, contact_law
from solver.capillary import Cohesion
from solver.contact_law import ContactModel
from solver.packing import jammed

pytestmark = pytest.mark.serial_only  # pure numpy: nothing to gain from a second rank

STEPS = np.array([2e-3, 1e-3, 5e-4, 2.5e-4])  # as in test_contact_law: moves < 0.01, never across s = 0
LAWS = [Cohesion("willett", surface_tension=0.02, contact_angle=0.3, volume=1e-3),
        Cohesion("soulie", surface_tension=0.02, contact_angle=0.3, volume=1e-3),
        Cohesion("soulie", surface_tension=0.05, liquid_content=0.05),
        Cohesion("willett", surface_tension=0.05, contact_angle=0.1, liquid_content=0.08)]


def radii(count, seed=0):
    return 0.5 * np.random.default_rng(seed).choice([jammed.D_SMALL, jammed.D_LARGE], size=(2, count))


@pytest.mark.parametrize("cohesion", LAWS, ids=lambda c: f"{c.law}-{'V' if c.volume else 'c'}")
def test_pull_is_constant_touching_continuous_at_contact_and_zero_from_rupture(cohesion):
    r_i, r_j = radii(8)
    s_c = capillary.rupture_distance(r_i, r_j, cohesion)
    touching = capillary.bridge_force(np.full(8, -0.02), r_i, r_j, cohesion)
    assert_close(capillary.bridge_force(np.full(8, -0.001), r_i, r_j, cohesion), touching, rtol=1e-15,
                 what="pull while touching")
    assert_close(capillary.bridge_force(np.full(8, 1e-12), r_i, r_j, cohesion), touching, rtol=1e-9,
                 what="pull just across the gap")
    inside = capillary.bridge_force(0.999 * s_c, r_i, r_j, cohesion)
    assert np.all((inside > 0) & (inside < touching)), "the pull falls across the gap and stays > 0"
    assert np.all(capillary.bridge_force(s_c, r_i, r_j, cohesion) == 0), "a bridge at rupture pulls"
    assert np.all(capillary.bridge_force(2 * s_c, r_i, r_j, cohesion) == 0), "a broken bridge pulls"


def test_willett_closed_form():
    """F0 = 2 pi a' gamma cos(theta) touching; F0 / (1 + 1.05 + 2.5) at S = s sqrt(a'/V) = 1;
    s_c = (1 + theta/2) V^(1/3)."""
    cohesion = Cohesion("willett", surface_tension=0.03, contact_angle=0.4, volume=2e-3)
    r_i, r_j = np.array([0.5, 0.7]), np.array([0.7, 0.7])
    reduced = r_i * r_j / (r_i + r_j)
    f0 = 2 * np.pi * reduced * 0.03 * np.cos(0.4)
    assert_close(capillary.bridge_force(np.zeros(2), r_i, r_j, cohesion), f0, rtol=1e-14, what="F0")
    assert_close(capillary.bridge_force(np.sqrt(2e-3 / reduced), r_i, r_j, cohesion), f0 / 4.55, rtol=1e-14,
                 what="F at S = 1")
    assert_close(capillary.rupture_distance(r_i, r_j, cohesion), np.full(2, 1.2 * np.cbrt(2e-3)), rtol=1e-14,
                 what="s_c")


def test_liquid_content_gives_each_particle_its_share():
    """Equal spheres: each gives c (4/3) pi R^3 (1 - sqrt(3)/2) / 2, so V = c (4/3) pi R^3 (1 - sqrt(3)/2)."""
    cohesion = Cohesion("soulie", surface_tension=0.05, liquid_content=0.01)
    radius = np.array([0.5, 0.7])
    expected = 0.01 * 4 / 3 * np.pi * radius**3 * (1 - np.sqrt(3) / 2)
    assert_close(capillary.bridge_volume(radius, radius, cohesion), expected, rtol=1e-14, what="V")


@pytest.mark.parametrize("cohesion", LAWS, ids=lambda c: f"{c.law}-{'V' if c.volume else 'c'}")
def test_energy_and_stiffness_are_the_pull_integrated_and_differentiated(cohesion):
    r_i, r_j = radii(12, seed=1)
    s_c = capillary.rupture_distance(r_i, r_j, cohesion)
    gap = np.random.default_rng(2).uniform(0.02, 0.9, 12) * s_c
    for name, value, of in (("energy", capillary.bridge_energy, capillary.bridge_force),
                            ("pull", capillary.bridge_force, capillary.bridge_stiffness)):
        errors = [np.abs((value(gap + h, r_i, r_j, cohesion) - value(gap - h, r_i, r_j, cohesion)) / (2 * h)
                         - of(gap, r_i, r_j, cohesion)).max() for h in 1e-3 * s_c.min() * np.array([1, 0.5, 0.25])]
        orders = np.log2(np.array(errors[:-1]) / errors[1:])
        assert np.all(np.abs(orders - 2) < 0.1), f"d{name}/ds: errors {errors}, orders {orders}"
        assert errors[-1] < 1e-6 * np.abs(of(gap, r_i, r_j, cohesion)).max(), f"d{name}/ds: error {errors[-1]}"
    touching = np.full(12, -0.01)
    assert_close(capillary.bridge_energy(touching, r_i, r_j, cohesion),
                 -0.01 * capillary.bridge_force(touching, r_i, r_j, cohesion), rtol=1e-14, what="W touching")
    assert np.all(capillary.bridge_stiffness(touching, r_i, r_j, cohesion) == 0), "stiffness while touching"


def bridged_pairs(dim, law, seed=0, count=16):
    """Reference pairs in ``dim`` D: half touching (overlaps 0.01-0.05), half across a gap
    (0.01-0.05, inside the rupture distance of the LAWS' bridges, >= 0.06)."""
    rng = np.random.default_rng(seed)
    r_i, r_j = radii(count, seed)
    normal = rng.normal(size=(count, dim))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    overlap = rng.uniform(0.01, 0.05, count) * np.where(np.arange(count) % 2, 1.0, -1.0)
    contact = r_i + r_j
    geometry = {"separation": normal * (contact - overlap)[:, None], "contact": contact,
                "normal": normal, "radius_i": r_i, "radius_j": r_j}
    return geometry, overlap


CASES = [(2, "harmonic", LAWS[0], {"rho": 0.5, "rho_roll": 0.3}), (2, "hertz", LAWS[1], {"rho": 0.5}),
         (3, "harmonic", LAWS[2], {"rho": 0.5, "rho_roll": 0.3, "rho_twist": 0.2}),
         (3, "hertz", LAWS[3], {"rho": 1.0, "rho_roll": 0.2})]


@pytest.mark.parametrize("dim, law, cohesion, springs", CASES, ids=lambda x: str(x) if not isinstance(x, Cohesion) else x.law)
def test_bridged_pair_blocks_and_forces_match_central_differences(dim, law, cohesion, springs):
    geometry, overlap = bridged_pairs(dim, law)
    assert np.all(-overlap < capillary.rupture_distance(geometry["radius_i"], geometry["radius_j"], cohesion))
    model = ContactModel(**springs, law=law, cohesion=cohesion)
    count, size = overlap.size, 2 * (dim + (1 if dim == 2 else 3))

    def energy(w):
        du, theta_i, theta_j = split(w, dim)
        return contact_law.pair_energy(**geometry, model=model, du=du, theta_i=theta_i, theta_j=theta_j)

    h_ii, h_ij, h_jj = contact_law.pair_blocks(geometry["normal"], geometry["contact"] - overlap, overlap,
                                               geometry["radius_i"], geometry["radius_j"], model)
    exact = np.concatenate((np.concatenate((h_ii, h_ij), 2),
                            np.concatenate((np.transpose(h_ij, (0, 2, 1)), h_jj), 2)), 1)
    errors = [np.abs(central_hessian(energy, count, size, h) - exact).max() / np.abs(exact).max() for h in STEPS]
    orders = np.log2(np.array(errors[:-1]) / errors[1:])
    assert np.all(np.abs(orders - 2) < 0.15), f"blocks: errors {errors}, orders {orders}"
    assert errors[-1] < 1e-4, f"blocks: error {errors[-1]}"
    gap = overlap < 0
    assert np.all(np.abs(exact[gap]).max(axis=(1, 2)) > 0), "a bridged pair across a gap has no stiffness"
    dry = contact_law.pair_blocks(geometry["normal"], geometry["contact"] - overlap, overlap, geometry["radius_i"],
                                  geometry["radius_j"], ContactModel(**springs, law=law))
    assert np.all(dry[0][gap] == 0), "a dry pair across a gap has a stiffness"
    assert np.abs(h_ii - dry[0]).max() > 1e-3 * np.abs(dry[0]).max(), "the bridges change nothing"

    w = 1e-3 * np.random.default_rng(3).normal(size=(count, size))
    du, theta_i, theta_j = split(w, dim)
    force, tau_i, tau_j = contact_law.pair_forces(**geometry, model=model, du=du, theta_i=theta_i, theta_j=theta_j)
    col = (lambda t: t[:, None]) if dim == 2 else (lambda t: t)  # noqa: E731
    generalised = np.concatenate((force, col(tau_i), -force, col(tau_j)), axis=1)
    errors = [np.abs(generalised + central_gradient(energy, w, h)).max() / np.abs(generalised).max() for h in STEPS]
    orders = np.log2(np.array(errors[:-1]) / errors[1:])
    assert np.all(np.abs(orders - 2) < 0.15), f"forces: errors {errors}, orders {orders}"


def test_the_pull_is_kept_at_rest():
    cohesion = LAWS[0]
    assert ContactModel(rho=1.0, cohesion=cohesion).at_rest() == ContactModel(cohesion=cohesion)


@pytest.mark.parametrize("fields, message", [
    ({"law": "rabinovich", "surface_tension": 0.1, "volume": 1e-3}, "cohesion law 'rabinovich': allowed are willett, soulie"),
    ({"surface_tension": -0.1, "volume": 1e-3}, "surface_tension = -0.1: must be finite and >= 0"),
    ({"surface_tension": 0.0, "volume": 1e-3}, "surface_tension = 0.0: must be > 0"),
    ({"surface_tension": 0.1, "volume": float("nan")}, "volume = nan: must be finite"),
    ({"surface_tension": 0.1, "volume": 1e-3, "contact_angle": np.pi / 2}, r"contact_angle = 1.57\d*: must be in \[0, pi/2\)"),
    ({"surface_tension": 0.1}, "give exactly one of volume"),
    ({"surface_tension": 0.1, "volume": 1e-3, "liquid_content": 0.01}, "give exactly one of volume"),
])
def test_bad_cohesion_is_refused_naming_the_field(fields, message):
    with pytest.raises(ValueError, match=message):
        Cohesion(**fields)


def test_soulie_pull_is_liggghts_own_on_pairs_opening_through_rupture():
    """LIGGGHTS 3.8.0's forces (cohesion easo/capillary/viscous, no viscosity) on two isolated pairs
    of spheres, from touching through rupture and back across the gap without touching
    (tests/data/dem/liggghts_bridge_pairs.dump): kn xi minus rotsound's pull, for a pair bridged
    under the rule that a bridge forms at contact and breaks at s_c, to LIGGGHTS's constants
    (it takes 4/3 as 1.333333333, 2.5e-10 in V: 1e-9).  Measured: 2.2e-10 relative."""
    import pathlib

    text = (pathlib.Path(__file__).parents[1] / "data" / "dem" / "liggghts_bridge_pairs.dump").read_text()
    frames = [np.array([line.split() for line in block.strip().splitlines()[1:5]], float)
              for block in text.split("ITEM: ATOMS")[1:]]
    assert len(frames) == 13
    pairs = [(0, 1, 0.5, 0.7, 20.0), (2, 3, 0.6, 0.6, 45.0)]  # rows, radii, contact angle (degrees)
    bridged = [False, False]
    measured, expected, states = [], [], []
    for frame in frames:
        for p, (a, b, r_i, r_j, angle) in enumerate(pairs):
            cohesion = Cohesion("soulie", surface_tension=0.02, contact_angle=np.deg2rad(angle), liquid_content=0.05)
            gap = frame[b, 1] - frame[a, 1] - (r_i + r_j)
            s_c = capillary.rupture_distance(np.array([r_i]), np.array([r_j]), cohesion)[0]
            bridged[p] = gap <= 0 or (bridged[p] and gap < s_c)
            pull = capillary.bridge_force(np.array([gap]), np.array([r_i]), np.array([r_j]), cohesion)[0]
            expected.append(-(max(-gap, 0.0) - (pull if bridged[p] else 0.0)))  # on the left sphere, along x
            measured.append(frame[a, 4])
            states.append(bridged[p])
    measured, expected = np.array(measured), np.array(expected)
    assert_close(measured, expected, rtol=1e-9, what="LIGGGHTS's force against kn xi - F")
    assert all(np.all(frame[:, 5:] == 0) for frame in frames), "LIGGGHTS's forces leave the line of centres"
    states = np.array(states)
    assert states.sum() == 19 and not states[-4:].any(), "the frames do not cover forming, pulling and breaking"
    assert np.abs(measured[-4:]).max() == 0, "LIGGGHTS re-formed a bridge across a gap"
