"""Stored tangential forces (docs/stressed_contacts.md): contact_law.stressed_blocks against
central differences of LAMMPS's own history update (and of YADE's, model.history: yade), written
out here independently of the derivation, in 2D and 3D under both laws; a dimer whose entries are
known by hand."""

import numpy as np
import pytest
from conftest import assert_close, jammed_packing, with_random_stored_forces

from solver import contact_law
from solver.contact_law import ContactModel


STEPS = np.array([2e-3, 1e-3, 5e-4, 2.5e-4])


def _cross(a, b):
    """a x b: the z component (C,) in 2D, (C, 3) in 3D."""
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] if a.shape[1] == 2 else np.cross(a, b)


def _spin_cross_normal(spin, normal):
    """spin x n (C, D): spin (C,) about z in 2D, (C, 3) in 3D."""
    if normal.shape[1] == 2:
        return spin[:, None] * np.stack((-normal[:, 1], normal[:, 0]), axis=1)
    return np.cross(spin, normal)


def lammps_step(separation, tangential, radius_i, radius_j, law, rho, x, friction=None, lever="radius"):
    """Generalised forces (C, 2m) = (F_i, tau_i, F_j, tau_j) after one step of LAMMPS's
    gran/hooke/history (or gran/hertz/history) that moves the contact by x (C, 2m) =
    (u_i, theta_i, u_j, theta_j) from a reference at rest with separation (C, D) and stored
    tangential force ``tangential`` (C, D) on i: PairGranHookeHistory::compute with v dt = x,
    the history incremented by the relative tangential displacement of the contact point
    (with the new normal), projected onto the new tangent plane, the force -k_t(xi) s, rescaled
    onto the Coulomb cone mu f_n when ``friction`` = mu is given and the trial exceeds it.  With
    ``lever`` = contact the slip and the torques use the arms R - xi/2 of the current overlap
    (LIGGGHTS's and YADE's contact point) instead of R."""
    dim = separation.shape[1]
    m = x.shape[1] // 2
    u_i, th_i, u_j, th_j = x[:, :dim], x[:, dim:m], x[:, m:m + dim], x[:, m + dim:]
    if dim == 2:
        th_i, th_j = th_i[:, 0], th_j[:, 0]
    reduced = radius_i * radius_j / (radius_i + radius_j)

    def stiffness(overlap):  # (f_n, k_t) of the law at this overlap
        scale = np.ones_like(overlap) if law == "harmonic" else np.sqrt(reduced * overlap)
        return scale * overlap, rho * scale

    overlap0 = radius_i + radius_j - np.linalg.norm(separation, axis=1)
    s = -tangential / stiffness(overlap0)[1][:, None]  # the stored history
    moved = separation + u_i - u_j
    distance = np.linalg.norm(moved, axis=1)
    normal = moved / distance[:, None]
    f_n, k_t = stiffness(radius_i + radius_j - distance)
    du = u_i - u_j
    if lever == "contact":  # LIGGGHTS's and YADE's arms: the middle of the current overlap
        overlap = radius_i + radius_j - np.linalg.norm(separation + u_i - u_j, axis=1)
        radius_i, radius_j = radius_i - 0.5 * overlap, radius_j - 0.5 * overlap
    spin = radius_i * th_i + radius_j * th_j if dim == 2 else radius_i[:, None] * th_i + radius_j[:, None] * th_j
    increment = du - np.einsum("cd,cd->c", du, normal)[:, None] * normal - _spin_cross_normal(spin, normal)
    s = s + increment
    s = s - np.einsum("cd,cd->c", s, normal)[:, None] * normal
    f_t = -k_t[:, None] * s
    if friction is not None:  # the Coulomb cap: a trial force above mu f_n is rescaled onto the cone
        size = np.linalg.norm(f_t, axis=1)
        over = size > friction * f_n
        f_t[over] *= (friction * f_n[over] / size[over])[:, None]
    force = f_n[:, None] * normal + f_t
    turn = _cross(normal, f_t)
    tau_i = -(radius_i * turn if dim == 2 else radius_i[:, None] * turn)
    tau_j = -(radius_j * turn if dim == 2 else radius_j[:, None] * turn)
    if dim == 2:
        tau_i, tau_j = tau_i[:, None], tau_j[:, None]
    return np.concatenate((force, tau_i, -force, tau_j), axis=1)


def yade_step(separation, tangential, radius_i, radius_j, rho, x, friction=None):
    """(F_i, tau_i, F_j, tau_j) (C, 2m) after one step of YADE's Law2_ScGeom_FrictPhys_CundallStrack
    (3D, kn = 1, ks = rho) that moves the contact by x from a reference at rest, written in YADE's
    own terms: body 1 = i, body 2 = j, normal n from 1 to 2, shearForce f_s = the force on 2 from
    1 (= -f_t); ScGeom::precompute's orthonormal_axis = n_prev x n and twist_axis = dt/2 n.(w_1 +
    w_2) n (w dt = theta), ScGeom::rotate's f_s -= f_s x orthonormal_axis, f_s -= f_s x
    twist_axis (no projection), then f_s -= ks * shearIncrement: the relative velocity of the
    contact with avoidGranularRatcheting (branches R_1 n and -R_2 n: ScGeom's radius1, radius2 are
    the spheres' radii; the relative translation scaled by alpha = (R_1 + R_2) / r, which Debian's
    YADE 2023.02a does: a dimer at r = 0.99 moved by d across n shears by d / 0.99), its normal
    part removed, times dt; the force on 1 is -(kn depth n + f_s), the torque on each body
    (R_k - depth/2) n x (-f_s) (Law2's lever).  With
    ``friction`` = tan(phi) a shear force above tan(phi) kn depth is rescaled onto it."""
    u_1, w_1, u_2, w_2 = x[:, :3], x[:, 3:6], x[:, 6:9], x[:, 9:]
    prev = -separation / np.linalg.norm(separation, axis=1)[:, None]
    branch = -(separation + u_1 - u_2)
    distance = np.linalg.norm(branch, axis=1)
    normal = branch / distance[:, None]
    depth = radius_i + radius_j - distance
    arm_1, arm_2 = radius_i - 0.5 * depth, radius_j - 0.5 * depth
    shear = -tangential
    shear = shear - np.cross(shear, np.cross(prev, normal))
    shear = shear - np.cross(shear, 0.5 * np.einsum("cd,cd->c", normal, w_1 + w_2)[:, None] * normal)
    alpha = ((radius_i + radius_j) / distance)[:, None]
    velocity = alpha * (u_2 - u_1) + np.cross(w_2, -radius_j[:, None] * normal) - np.cross(w_1, radius_i[:, None] * normal)
    velocity = velocity - np.einsum("cd,cd->c", velocity, normal)[:, None] * normal
    shear = shear - rho * velocity
    if friction is not None:
        size = np.linalg.norm(shear, axis=1)
        over = size > friction * depth
        shear[over] *= (friction * depth[over] / size[over])[:, None]
    on_2 = depth[:, None] * normal + shear
    torque_1 = arm_1[:, None] * np.cross(normal, -on_2)
    torque_2 = arm_2[:, None] * np.cross(normal, -on_2)
    return np.concatenate((-on_2, torque_1, on_2, torque_2), axis=1)


def stressed_contacts(dim, count=20, seed=0, ratio=0.6):
    """Random contacts (overlaps 0.01-0.05) with stored tangential forces of |f_t| = ratio f_n
    (harmonic f_n) in random tangent directions."""
    rng = np.random.default_rng(seed)
    radii = rng.uniform(0.4, 0.6, size=(2, count))
    normal = rng.normal(size=(count, dim))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    overlap = rng.uniform(0.01, 0.05, count)
    direction = rng.normal(size=(count, dim))
    direction -= np.einsum("cd,cd->c", direction, normal)[:, None] * normal
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    tangential = ratio * overlap[:, None] * direction
    separation = normal * (radii[0] + radii[1] - overlap)[:, None]
    return separation, normal, overlap, radii[0], radii[1], tangential


def full_matrix(blocks):
    """[[ii, ij], [ji, jj]] (C, 2m, 2m) from four (C, m, m) blocks."""
    ii, ij, ji, jj = blocks
    return np.concatenate((np.concatenate((ii, ij), 2), np.concatenate((ji, jj), 2)), 1)


def linear_matrix(separation, normal, overlap, r_i, r_j, tangential, model, stressed=True):
    """The contact's K (C, 2m, 2m): pair_blocks, slip_blocks (YADE's slip, as dynmat adds them)
    and (if ``stressed``) stressed_blocks."""
    distance = np.linalg.norm(separation, axis=1)
    ii, ij, jj = contact_law.pair_blocks(normal, distance, overlap, r_i, r_j, model)
    k = full_matrix((ii, ij, np.transpose(ij, (0, 2, 1)), jj))
    if contact_law.slip_differs(model):
        k = k + full_matrix(contact_law.slip_blocks(normal, distance, overlap, r_i, r_j, model))
    if stressed:
        k = k + full_matrix(contact_law.stressed_blocks(normal, distance, overlap, r_i, r_j, tangential, model))
    return k


def jacobian(separation, tangential, r_i, r_j, law, rho, size, h, lever="radius"):
    """d(generalised force)/dx (C, size, size) of ``lammps_step`` by central differences."""
    out = np.empty((separation.shape[0], size, size))
    for b in range(size):
        x = np.zeros((separation.shape[0], size))
        x[:, b] = h
        out[:, :, b] = (lammps_step(separation, tangential, r_i, r_j, law, rho, x, lever=lever)
                        - lammps_step(separation, tangential, r_i, r_j, law, rho, -x, lever=lever)) / (2 * h)
    return out


@pytest.mark.serial_only  # pure numpy
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("law", ["harmonic", "hertz"])
@pytest.mark.parametrize("lever", ["radius", "contact"])
def test_stressed_blocks_are_the_linearised_lammps_update(dim, law, lever):
    separation, normal, overlap, r_i, r_j, tangential = stressed_contacts(dim, seed=dim)
    if law == "hertz":  # stored forces of the Hertz scale: |f_t| = 0.6 f_n
        tangential = tangential * np.sqrt(r_i * r_j / (r_i + r_j) * overlap)[:, None]
    rho = 0.7
    model = ContactModel(rho, law=law, lever=lever)
    exact = linear_matrix(separation, normal, overlap, r_i, r_j, tangential, model)
    size = exact.shape[1]
    # Hertz's sqrt(xi) at overlaps down to 0.01 has large third derivatives: smaller steps
    steps = STEPS if law == "harmonic" else STEPS / 8
    errors = [np.abs(jacobian(separation, tangential, r_i, r_j, law, rho, size, h, lever) + exact).max()
              / np.abs(exact).max() for h in steps]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    # a missing or wrong term leaves an error of the stored forces' size (|f_t|/r ~ 0.01), flat in h
    assert np.all(np.abs(orders - 2) < 0.15), f"errors {errors}, orders {orders}"
    assert errors[-1] < 1e-6, f"error {errors[-1]} at h = {steps[-1]}"
    unstressed = linear_matrix(separation, normal, overlap, r_i, r_j, tangential, model, stressed=False)
    miss = np.abs(jacobian(separation, tangential, r_i, r_j, law, rho, size, steps[-1], lever) + unstressed).max()
    assert miss / np.abs(exact).max() > 1e-3, f"the unstressed blocks also match ({miss:.2e}): the test is blind"
    assert np.abs(exact - np.transpose(exact, (0, 2, 1))).max() > 1e-3, "stressed blocks came out symmetric"


@pytest.mark.serial_only  # pure numpy
def test_yade_history_is_the_linearised_yade_update():
    """model.history: yade, lever contact against central differences of YADE's step (3D): the
    twist of the stored force with the pair's mean spin and YADE's slip (arms R where the torques
    take R - xi/2, translations scaled by (R_i + R_j) / r) are there; LAMMPS's blocks miss them."""
    separation, normal, overlap, r_i, r_j, tangential = stressed_contacts(3, seed=9)
    rho = 0.7
    model = ContactModel(rho, lever="contact", history="yade")
    exact = linear_matrix(separation, normal, overlap, r_i, r_j, tangential, model)
    size = exact.shape[1]

    def slope(h):
        out = np.empty_like(exact)
        for b in range(size):
            x = np.zeros((separation.shape[0], size))
            x[:, b] = h
            out[:, :, b] = (yade_step(separation, tangential, r_i, r_j, rho, x)
                            - yade_step(separation, tangential, r_i, r_j, rho, -x)) / (2 * h)
        return out

    errors = [np.abs(slope(h) + exact).max() / np.abs(exact).max() for h in STEPS]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - 2) < 0.15), f"errors {errors}, orders {orders}"
    assert errors[-1] < 1e-6, f"error {errors[-1]} at h = {STEPS[-1]}"
    lammps = linear_matrix(separation, normal, overlap, r_i, r_j, tangential,
                           ContactModel(rho, lever="contact"))
    miss = np.abs(slope(STEPS[-1]) + lammps).max() / np.abs(exact).max()
    assert miss > 1e-3, f"LAMMPS's history also matches YADE's step ({miss:.2e}): the test is blind"
    two_d = stressed_contacts(2, seed=9)
    blocks = [contact_law.stressed_blocks(two_d[1], np.linalg.norm(two_d[0], axis=1), *two_d[2:],
                                          ContactModel(rho, lever="contact", history=h)) for h in ("lammps", "yade")]
    assert all(np.array_equal(a, b) for a, b in zip(*blocks)), "history: yade changed a 2D matrix"


@pytest.mark.serial_only  # pure numpy
def test_yade_history_slides_like_yades_capped_update():
    """At the Coulomb limit YADE rescales the shear force as LAMMPS does; its twist turns f_t
    across the slip, so sliding_blocks is the same: one-sided differences of YADE's capped step
    against stick + slide blocks under history: yade (as in the LAMMPS test below)."""
    separation, normal, overlap, r_i, r_j, tangential = stressed_contacts(3, seed=8, ratio=1.0)
    mu, rho = 0.6, 0.7
    tangential = mu * overlap[:, None] * tangential / np.linalg.norm(tangential, axis=1)[:, None]
    model = ContactModel(rho, lever="contact", history="yade")
    stick = linear_matrix(separation, normal, overlap, r_i, r_j, tangential, model)
    distance = np.linalg.norm(separation, axis=1)
    slide = stick + full_matrix(contact_law.sliding_blocks(normal, distance, overlap, r_i, r_j, tangential, model))
    x = 0.1 * np.random.default_rng(3).normal(size=(stick.shape[0], stick.shape[1]))
    x[:, :3] -= tangential / np.linalg.norm(tangential, axis=1)[:, None]  # u_i against f_t: loads
    x[:, 3:6] += normal  # and a spin about the normal, which turns f_t
    h = 1e-6

    def force(step):
        return yade_step(separation, tangential, r_i, r_j, rho, step * x, friction=mu)

    base = force(0.0)
    slope = 2 * (force(h) - base) / h - (force(2 * h) - base) / (2 * h)
    expected = -np.einsum("cij,cj->ci", slide, x)
    scale = np.abs(expected).max()
    assert_close(slope, expected, rtol=0.0, atol=1e-7 * scale, what="one-sided slope vs sliding blocks")


@pytest.mark.serial_only
@pytest.mark.parametrize("dim", [2, 3])
def test_zero_stored_forces_add_exact_zeros(dim):
    separation, normal, overlap, r_i, r_j, _ = stressed_contacts(dim, seed=5)
    for law in ("harmonic", "hertz"):
        added = contact_law.stressed_blocks(normal, np.linalg.norm(separation, axis=1), overlap, r_i, r_j,
                                            np.zeros_like(normal), ContactModel(1.0, law=law, lever="contact"))
        assert len(added) > 0 and all(np.all(block == 0.0) for block in added), law


@pytest.mark.serial_only
@pytest.mark.parametrize("law", ["harmonic", "hertz"])
def test_a_stressed_dimer_by_hand(law):
    """Two disks on the x axis (n = x, t = y), disk i at +x, stored force f along +y on i: the new
    entries are D[u_ix, u_iy] = f/r and, under hertz, D[u_iy, u_ix] = f/(2 xi) and
    D[theta_i, u_ix] = -R_i f/(2 xi) (docs/stressed_contacts.md section 2, 2D)."""
    r_i, r_j, overlap, f = np.array([0.5]), np.array([0.7]), np.array([0.02]), 0.004
    distance = r_i + r_j - overlap
    normal = np.array([[1.0, 0.0]])
    tangential = np.array([[0.0, f]])
    ii, ij, ji, jj = contact_law.stressed_blocks(normal, distance, overlap, r_i, r_j, tangential,
                                                 ContactModel(1.0, law=law))
    c = 0.0 if law == "harmonic" else 1.0 / (2 * overlap[0])
    g = np.array([[0.0, f / distance[0]], [c * f, 0.0]])
    expected_ii = np.zeros((3, 3))
    expected_ii[:2, :2] = g
    expected_ii[2, :2] = [-r_i[0] * c * f, 0.0]
    assert_close(ii[0], expected_ii, rtol=1e-15, what="S_ii")
    expected_ij = -expected_ii
    expected_ij[2, :2] = [r_i[0] * c * f, 0.0]
    assert_close(ij[0], expected_ij, rtol=1e-15, what="S_ij")
    assert_close(ji[0][:2], -expected_ii[:2], rtol=1e-15, what="S_ji translations")
    assert_close(ji[0][2, :2], [-r_j[0] * c * f, 0.0], rtol=1e-15, what="S_ji torque row")
    assert_close(jj[0][2, :2], [r_j[0] * c * f, 0.0], rtol=1e-15, what="S_jj torque row")
    assert np.all(ii[0][:, 2] == 0) and np.all(jj[0][:, 2] == 0), "a rotation column gained a term"


def summed_lammps_forces(p, stored, law, rho, x, friction=None, contacts=None):
    """Generalised force (N', dof) on every non-rattler after LAMMPS's one-step update moves all
    particles by x (N', dof) in the matrix's DOF order, summed over contacts (lammps_step): over
    ``contacts`` (a, b, r_a - r_b) among the non-rattlers (their indices among them), or, when None,
    those geometry finds in p's box."""
    from solver.packing import geometry

    active = ~p.rattler
    if contacts is None:
        index = np.cumsum(active) - 1
        found = geometry.find_contacts(p.positions, p.diameters, p.box, active)
        a, b = index[found.i], index[found.j]
        separation = found.normal * found.distance[:, None]
    else:
        a, b, separation = contacts
    i, j = np.flatnonzero(active)[a], np.flatnonzero(active)[b]
    radius = 0.5 * p.diameters
    pair = lammps_step(separation, stored.on(i, j), radius[i], radius[j], law, rho,
                       np.concatenate((x[a], x[b]), axis=1), friction)
    dof = x.shape[1]
    out = np.zeros_like(x)
    np.add.at(out, a, pair[:, :dof])
    np.add.at(out, b, pair[:, dof:])
    return out


@pytest.mark.parametrize("dim", [2, 3])
def test_assembled_stressed_matrix_is_the_summed_lammps_update(comm, dim):
    """D of a packing with stored forces against central differences of LAMMPS's update summed
    over every contact: the blocks land on the right rows and columns with the right signs."""
    from solver.model import dynmat

    p = with_random_stored_forces(jammed_packing(32 if dim == 2 else 48, 0.9 if dim == 2 else 0.7, 3, dim), 11)
    model = ContactModel(0.8)
    dm = dynmat.assemble(p, model, comm)
    dense = dynmat.in_packing_order(dm, dynmat.gather_csr(dm.D).toarray())
    assert not dm.symmetric and np.abs(dense - dense.T).max() > 1e-4, "a stressed D came out symmetric"
    x = np.random.default_rng(2).normal(size=(int((~p.rattler).sum()), dm.dof))
    h = 1e-6
    slope = (summed_lammps_forces(p, p.tangential, "harmonic", 0.8, h * x)
             - summed_lammps_forces(p, p.tangential, "harmonic", 0.8, -h * x)) / (2 * h)
    # central differences, h = 1e-6 on forces of order 1: truncation ~1e-12, round-off ~1e-10
    assert_close(slope.ravel(), -dense @ x.ravel(), rtol=0.0, atol=1e-8 * np.abs(dense).max(), what="-D x")
    dm.destroy()


@pytest.mark.parametrize("dim", [2, 3])
def test_zero_stored_forces_give_todays_matrix_bit_for_bit(comm, dim):
    from solver.model import dynmat

    p = jammed_packing(32 if dim == 2 else 48, 0.9 if dim == 2 else 0.7, 3, dim)
    zero = with_random_stored_forces(p, 11, zero=True)
    assert zero.tangential is not None and not zero.stressed
    model = ContactModel(0.8, rho_roll=0.3, law="harmonic")
    plain, stored = dynmat.assemble(p, model, comm), dynmat.assemble(zero, model, comm)
    assert stored.symmetric and stored.D.isSymmetric(0.0)
    a, b = dynmat.gather_csr(plain.D), dynmat.gather_csr(stored.D)
    assert np.array_equal(a.indptr, b.indptr) and np.array_equal(a.indices, b.indices)
    assert np.array_equal(a.data, b.data), "zero stored forces changed D"
    plain.destroy()
    stored.destroy()


@pytest.mark.serial_only
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("law", ["harmonic", "hertz"])
@pytest.mark.parametrize("lever", ["radius", "contact"])
def test_sliding_blocks_are_lammps_update_at_the_coulomb_limit(dim, law, lever):
    """Contacts at |f_t| = mu f_n moved in a direction that loads them (the relative tangential
    displacement against f_t, plus a 10 % random part): LAMMPS's capped update has one-sided
    derivative K_stick + S_slide (Richardson-extrapolated forward differences, O(h^2): at h = 1e-6
    about 1e-9 of the largest force, round-off beyond); the stick blocks alone miss by the
    tangential stiffness along the slip."""
    separation, normal, overlap, r_i, r_j, tangential = stressed_contacts(dim, seed=7, ratio=1.0)
    mu = 0.6
    reduced = r_i * r_j / (r_i + r_j)
    fn = contact_law.normal_force(overlap, law, reduced)
    tangential = mu * fn[:, None] * tangential / np.linalg.norm(tangential, axis=1)[:, None]  # on the cone
    rho = 0.7
    model = ContactModel(rho, law=law, lever=lever)
    stick = linear_matrix(separation, normal, overlap, r_i, r_j, tangential, model)
    distance = np.linalg.norm(separation, axis=1)
    slide = stick + full_matrix(contact_law.sliding_blocks(normal, distance, overlap, r_i, r_j, tangential, model))
    count, size = stick.shape[0], stick.shape[1]
    m = size // 2
    rng = np.random.default_rng(3)
    x = 0.1 * rng.normal(size=(count, size))
    x[:, :dim] -= tangential / np.linalg.norm(tangential, axis=1)[:, None]  # u_i against f_t: loads
    h = 1e-6

    def force(step):
        return lammps_step(separation, tangential, r_i, r_j, law, rho, step * x, friction=mu, lever=lever)

    base = force(0.0)
    slope = 2 * (force(h) - base) / h - (force(2 * h) - base) / (2 * h)  # forward differences: O(h) cancels
    expected = -np.einsum("cij,cj->ci", slide, x)
    scale = np.abs(expected).max()
    assert_close(slope, expected, rtol=0.0, atol=1e-7 * scale, what="one-sided slope vs sliding blocks")
    miss = np.abs(slope + np.einsum("cij,cj->ci", stick, x)).max()
    assert miss > 1e-2 * scale, f"the stick blocks also match ({miss:.2e}): the test is blind"
    assert m == dim + (1 if dim == 2 else 3)


@pytest.mark.parametrize("dim", [2, 3])
def test_assembled_matrix_slides_the_contacts_at_the_coulomb_limit(comm, dim):
    """model.mobilised: slide on a packing whose stored forces are at half the cone except one at
    mu f_n: D is LAMMPS's capped update summed over the packing, differentiated one-sidedly in a
    direction that loads that contact (the others stick either way); stick misses it."""
    import dataclasses

    from solver.model import dynmat
    from solver.packing import geometry
    from solver.packing.stressed import TangentialForces

    mu = 0.8
    p = with_random_stored_forces(jammed_packing(32 if dim == 2 else 48, 0.9 if dim == 2 else 0.7, 3, dim), 11,
                                  ratio=0.5 * mu)
    found = geometry.find_contacts(p.positions, p.diameters, p.box, ~p.rattler)
    force = p.tangential.force.copy()
    force[0] *= 2.0  # contact 0 (pairs sorted alike) now at mu f_n
    p = dataclasses.replace(p, tangential=TangentialForces(p.tangential.pairs, force, mu))
    assert (found.i[0], found.j[0]) == tuple(p.tangential.pairs[0])
    index = np.cumsum(~p.rattler) - 1
    x = 0.1 * np.random.default_rng(4).normal(size=(int((~p.rattler).sum()), dim + (1 if dim == 2 else 3)))
    x[index[found.i[0]], :dim] -= force[0] / np.linalg.norm(force[0])  # loads contact 0 along its slip
    h = 1e-6
    base = summed_lammps_forces(p, p.tangential, "harmonic", 0.8, 0.0 * x, mu)
    slope = (2 * (summed_lammps_forces(p, p.tangential, "harmonic", 0.8, h * x, mu) - base) / h
             - (summed_lammps_forces(p, p.tangential, "harmonic", 0.8, 2 * h * x, mu) - base) / (2 * h))
    for mode, should_match in (("slide", True), ("stick", False)):
        dm = dynmat.assemble(p, ContactModel(0.8, mobilised=mode), comm)
        dense = dynmat.in_packing_order(dm, dynmat.gather_csr(dm.D).toarray())
        dm.destroy()
        error = np.abs(slope.ravel() + dense @ x.ravel()).max() / np.abs(dense).max()
        # one-sided Richardson differences at h = 1e-6: ~1e-9; stick misses by the slip's stiffness
        assert (error < 1e-7) == should_match, f"{mode}: error {error:.2e}"


def test_dropped_stored_forces_give_the_unstressed_matrix(comm):
    """model.stored_forces: drop on a stressed packing is the matrix of the same packing without
    them, bit for bit, and symmetric."""
    import dataclasses

    from solver.model import dynmat

    p = with_random_stored_forces(jammed_packing(32, 0.9, 3, 2), 11)
    dropped = dynmat.assemble(p, ContactModel(0.8, stored_forces="drop"), comm)
    plain = dynmat.assemble(dataclasses.replace(p, tangential=None), ContactModel(0.8), comm)
    a, b = dynmat.gather_csr(dropped.D), dynmat.gather_csr(plain.D)
    assert dropped.symmetric and np.array_equal(a.indptr, b.indptr) and np.array_equal(a.data, b.data)
    dropped.destroy()
    plain.destroy()


def test_assembled_yade_matrix_is_yades_own_one_step_response(comm):
    """YADE's forces and torques one step after moving every body of its packing (with velocity
    move / dt; tests/data/dem/yade_3d_friction_uniform.response, made by YADE 2023.02a itself) are
    -D x for D under model.history: yade, read from YADE's files, to the moves' second order (1e-7
    moves: ~1e-8 of the largest force); under LAMMPS's history, or without the stored forces, D
    misses by far more."""
    from conftest import REPO

    from solver.io import hdf5
    from solver.model import dynmat

    data = REPO / "tests" / "data" / "dem"
    p = hdf5.read_packings(str(data / "yade_3d_friction_uniform.spheres"),
                           contacts=str(data / "yade_3d_friction_uniform.contacts"), contacts_format="yade",
                           model=ContactModel(lever="contact"), friction=0.5)[0]
    table = np.loadtxt(data / "yade_3d_friction_uniform.response")
    d0, kn = p.info["length_unit"], 5e4  # kn = young R = 1e5 * 0.5 (yade_3d_friction.py uniform)
    active = ~p.rattler
    moves, forces = table[:, 2:8].reshape(2, p.n, 6)[:, active], table[:, 8:].reshape(2, p.n, 6)[:, active]
    moves[..., :3] /= d0
    forces[..., :3] /= kn * d0
    forces[..., 3:] /= kn * d0 ** 2
    rho = 2.0 / 7.0  # FrictMat poisson: ks / kn
    errors = {}
    for name, model in (("yade", ContactModel(rho, lever="contact", history="yade")),
                        ("lammps", ContactModel(rho, lever="contact")),
                        ("unstressed", ContactModel(rho, lever="contact", history="yade", stored_forces="drop"))):
        dm = dynmat.assemble(p, model, comm)
        dense = dynmat.in_packing_order(dm, dynmat.gather_csr(dm.D).toarray())
        dm.destroy()
        predicted = np.array([-(dense @ x.ravel()).reshape(x.shape) for x in moves])
        errors[name] = np.abs(forces - predicted).max() / np.abs(forces).max()
    assert errors["yade"] < 1e-6, errors
    assert errors["lammps"] > 1e-3 and errors["unstressed"] > 1e-4, errors


def test_assembled_liggghts_matrix_is_liggghts_own_one_step_response(comm):
    """LIGGGHTS's forces and torques one step after moving every particle of its packing
    (tests/data/dem/liggghts_3d_friction.response, made by LIGGGHTS 3.8.0 itself; translations
    only: its RT wave, tests/waves/test_liggghts_waves.py, referees the rotations) are -D x for D
    under LAMMPS's history with the lever R - xi/2, read from its files, to the moves' second
    order (measured 3.5e-8 of the largest force, 1.4e-7 of the largest torque); with the lever R
    the torques miss by 5e-2, without the stored forces D misses by 5e-3."""
    import re

    from conftest import REPO

    from solver.io import hdf5
    from solver.model import dynmat

    data = REPO / "tests" / "data" / "dem"
    p = hdf5.read_packings(str(data / "liggghts_3d_friction.data"), contacts=str(data / "liggghts_3d_friction.contacts"),
                           contacts_format="liggghts-local", model=ContactModel(lever="contact"), friction=0.5)[0]
    text = (data / "liggghts_3d_friction.response").read_text()
    frames = [np.loadtxt(chunk.strip().splitlines()[:p.n]) for chunk in re.split(r"ITEM: ATOMS[^\n]*\n", text)[1:]]
    assert len(frames) == 3 and np.array_equal(frames[0][:, 0], np.arange(1, p.n + 1))
    d0, dt = p.info["length_unit"], 1e-4  # kn = 1; the script's time step
    active = ~p.rattler
    moves = np.zeros((int(active.sum()), 6))
    moves[:, :3] = frames[0][active, 1:4] * dt / d0
    forces = 0.5 * (frames[1][active, 4:] - frames[2][active, 4:])
    forces[:, :3] /= d0
    forces[:, 3:] /= d0 ** 2
    errors = {}
    for name, model in (("contact", ContactModel(2 / 7, lever="contact")), ("radius", ContactModel(2 / 7)),
                        ("unstressed", ContactModel(2 / 7, lever="contact", stored_forces="drop"))):
        dm = dynmat.assemble(p, model, comm)
        dense = dynmat.in_packing_order(dm, dynmat.gather_csr(dm.D).toarray())
        dm.destroy()
        errors[name] = np.abs(forces + (dense @ moves.ravel()).reshape(moves.shape)).max(axis=0) / np.abs(forces).max(
            axis=0).clip(1e-300)
    assert errors["contact"].max() < 1e-6, errors
    assert errors["radius"].max() > 1e-2 and errors["unstressed"].max() > 1e-3, errors
