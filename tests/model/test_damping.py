"""The damping matrix C of the contact dashpots (solver/model/damping.py, contact_law.damping_blocks):
against LAMMPS's gran/*/history dashpot forces and torques, written out here from LAMMPS's
formulas (docs/damping.md), differentiated in the velocities, per contact (2D and 3D, both laws,
both levers) and summed over a packing (1 and 2 ranks); symmetric, positive semi-definite, blind to
rigid translations."""

import dataclasses

import numpy as np
import pytest
from conftest import assert_all, assert_close, jammed_packing

from solver import contact_law
from solver.contact_law import ContactModel
from solver.model import damping, dynmat
from solver.packing import geometry

GAMMA_N, GAMMA_T = 0.7, 0.3


def lammps_dashpot(normal, overlap, radius_i, radius_j, m_eff, law, lever, v_i, w_i, v_j, w_j):
    """LAMMPS's dashpot part of one contact's force on i and torques on i and j (pair
    gran/hooke/history, gran/hertz/history: damp = meff gamma_n (v_r . n); vtr = v_t - (R_i w_i +
    R_j w_j) x n; fs = -polyhertz meff gamma_t vtr; torque_i = -R_i n x fs, torque_j = -R_j n x fs),
    with the arms at the middle of the overlap under ``lever`` contact.  w: (C,) in 2D."""
    dim = normal.shape[1]
    poly = np.ones_like(overlap) if law == "harmonic" else np.sqrt(overlap * radius_i * radius_j / (radius_i + radius_j))
    arm_i, arm_j = (radius_i, radius_j) if lever == "radius" else (radius_i - overlap / 2, radius_j - overlap / 2)
    vr = v_i - v_j
    vn = np.sum(vr * normal, axis=1)[:, None] * normal
    if dim == 2:
        spin = arm_i * w_i + arm_j * w_j
        wr_x_n = spin[:, None] * np.stack((-normal[:, 1], normal[:, 0]), axis=1)
    else:
        wr_x_n = np.cross(arm_i[:, None] * w_i + arm_j[:, None] * w_j, normal)
    vtr = vr - vn - wr_x_n
    fs = -(poly * m_eff * GAMMA_T)[:, None] * vtr
    force = -(poly * m_eff * GAMMA_N)[:, None] * vn + fs
    n_x_fs = normal[:, 0] * fs[:, 1] - normal[:, 1] * fs[:, 0] if dim == 2 else np.cross(normal, fs)
    scale = (lambda a: a) if dim == 2 else (lambda a: a[:, None])
    return force, -scale(arm_i) * n_x_fs, -scale(arm_j) * n_x_fs


def _contacts(dim, count, seed):
    rng = np.random.default_rng(seed)
    normal = rng.normal(size=(count, dim))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    radius_i, radius_j = rng.uniform(0.4, 0.7, count), rng.uniform(0.4, 0.7, count)
    return normal, rng.uniform(1e-3, 5e-2, count), radius_i, radius_j, rng.uniform(0.3, 1.5, count)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("law", ["harmonic", "hertz"])
@pytest.mark.parametrize("lever", ["radius", "contact"])
def test_damping_blocks_are_lammps_dashpots(dim, law, lever):
    """-d(force, torques)/d(v_i, w_i, v_j, w_j) of LAMMPS's dashpots by central differences (the
    force is linear: exact to round-off) equals [[C_ii, C_ij], [C_ij^T, C_jj]] to 1e-12 of its largest
    entry, for 20 random contacts."""
    normal, overlap, radius_i, radius_j, m_eff = _contacts(dim, 20, 5)
    model = ContactModel(0.5, law=law, lever=lever, gamma_n=GAMMA_N, gamma_t=GAMMA_T)
    c_ii, c_ij, c_jj = contact_law.damping_blocks(normal, overlap, radius_i, radius_j, m_eff, model)
    r = 1 if dim == 2 else 3
    m = dim + r
    full = np.block([[c_ii, c_ij], [np.transpose(c_ij, (0, 2, 1)), c_jj]])

    def response(x):  # x (C, 2m) -> (C, 2m): force and torque on i, force and torque on j
        v_i, w_i, v_j, w_j = x[:, :dim], x[:, dim:m], x[:, m:m + dim], x[:, m + dim:]
        if dim == 2:
            w_i, w_j = w_i[:, 0], w_j[:, 0]
        force, tau_i, tau_j = lammps_dashpot(normal, overlap, radius_i, radius_j, m_eff, law, lever,
                                             v_i, w_i, v_j, w_j)
        tau_i, tau_j = (tau_i[:, None], tau_j[:, None]) if dim == 2 else (tau_i, tau_j)
        return np.concatenate((force, tau_i, -force, tau_j), axis=1)

    h = 1e-3
    numeric = np.empty_like(full)
    for column in range(2 * m):
        step = np.zeros((20, 2 * m))
        step[:, column] = h
        numeric[:, :, column] = -(response(step) - response(-step)) / (2 * h)
    assert_close(full, numeric, rtol=0.0, atol=1e-12 * np.abs(full).max(), what=f"{dim}D {law} {lever}")


def _damped_packing(dim):
    p = jammed_packing(48 if dim == 2 else 40, 0.86 if dim == 2 else 0.68, 9, dim)
    return p, ContactModel(0.4, rho_roll=0.1 if dim == 3 else 0.0, gamma_n=GAMMA_N, gamma_t=GAMMA_T)


@pytest.mark.parametrize("dim", [2, 3])
def test_assembled_damping_matrix_is_the_sum_of_contact_dashpots(comm, dim):
    """-C V equals LAMMPS's dashpot forces and torques summed over every contact for random
    velocities V, with masses by density (m_eff differs between contacts), to 1e-12 of their
    largest; C has D's layout.  On 1 and 2 ranks."""
    p, model = _damped_packing(dim)
    dm = dynmat.assemble(p, model, comm, "density")
    C = damping.assemble(p, dm, "density")
    assert_all(C.getSizes() == dm.D.getSizes() and C.getBlockSize() == dm.dof == {2: 3, 3: 6}[dim],
               f"sizes {C.getSizes()}, dof {dm.dof}")
    dense = dynmat.gather_csr(C).toarray()
    dm.destroy()
    C.destroy()
    active = ~p.rattler
    index = np.cumsum(active) - 1
    found = geometry.find_contacts(p.positions, p.diameters, p.box, active)
    masses = dynmat.particle_masses(p, "density")
    m_eff = masses[found.i] * masses[found.j] / (masses[found.i] + masses[found.j])
    rng = np.random.default_rng(2)
    dof = dm.dof
    V = rng.normal(size=(int(active.sum()), dof))
    a, b = index[found.i], index[found.j]
    w_i, w_j = (V[a, dim], V[b, dim]) if dim == 2 else (V[a, dim:], V[b, dim:])
    force, tau_i, tau_j = lammps_dashpot(found.normal, found.overlap, p.diameters[found.i] / 2,
                                         p.diameters[found.j] / 2, m_eff, model.law, model.lever,
                                         V[a, :dim], w_i, V[b, :dim], w_j)
    total = np.zeros_like(V)
    np.add.at(total[:, :dim], a, force)
    np.add.at(total[:, :dim], b, -force)
    np.add.at(total[:, dim:], a, tau_i[:, None] if dim == 2 else tau_i)
    np.add.at(total[:, dim:], b, tau_j[:, None] if dim == 2 else tau_j)
    assert_close(-dense @ V.ravel(), total.ravel(), rtol=0.0, atol=1e-12 * np.abs(total).max(), what=f"{dim}D")


@pytest.mark.parametrize("dim", [2, 3])
def test_damping_matrix_is_symmetric_semidefinite_and_spares_translations(comm, dim):
    """C = C^T to round-off of the summation, its eigenvalues >= -1e-13 of the largest, C e = 0 for a rigid translation e
    (to 1e-14 of |C|); a rigid spin is damped (v_t = -(R_i + R_j) w x n at every contact)."""
    p, model = _damped_packing(dim)
    dm = dynmat.assemble(p, model, comm)
    C = damping.assemble(p, dm)
    dense = dynmat.gather_csr(C).toarray()
    dof = dm.dof
    dm.destroy()
    C.destroy()
    lam = np.linalg.eigvalsh(dense)
    assert_close(dense, dense.T, rtol=0.0, atol=1e-15 * np.abs(dense).max(), what="C - C^T (summation order)")
    assert_all(lam.min() > -1e-13 * lam.max(), f"min eigenvalue {lam.min()}")
    for component in range(dof):
        e = np.zeros((dense.shape[0] // dof, dof))
        e[:, component] = 1.0
        response = np.abs(dense @ e.ravel()).max() / np.abs(dense).max()
        if component < dim:
            assert_close(response, 0.0, rtol=0.0, atol=1e-14, what=f"translation {component}")
        else:
            assert_all(response > 1e-3, f"spin {component}: |C e| = {response}")


def test_tangential_dashpot_alone_keeps_the_rotations():
    """rho = 0 with gamma_t > 0: the rotations stay in the matrix, since the dashpot acts on them."""
    model = dataclasses.replace(ContactModel(0.0), gamma_t=0.2)
    assert_all(dynmat.dof_per_particle(2, model) == 3 and dynmat.dof_per_particle(2, ContactModel(0.0)) == 2
               and dynmat.dof_per_particle(3, model) == 6, "dof")


@pytest.mark.parametrize("e", [0.3, 0.7, 0.95])
def test_restitution_gives_the_collision_it_promises(e):
    """Two disks of mass 1 and diameter 1 meet head-on at relative speed 0.02 and are integrated by
    PETSc TS (RK4, dt = 1e-3 t0) under the harmonic spring and rotsound's dashpot blocks with
    gamma_n = contact_law.restitution_damping(e), in contact while xi > 0 (LAMMPS's rule): the
    relative speed after over before is e to 1e-6 (measured 1e-7 to 5e-7; the exit found by a
    Taylor step from the last state in contact, since the force jumps there)."""
    from petsc4py import PETSc

    model = ContactModel(1.0, gamma_n=contact_law.restitution_damping(e))
    normal = np.array([[-1.0, 0.0]])  # from particle 2 (right) to particle 1 (left)

    def acceleration(state):
        x1, x2, v1, v2 = state
        xi = 1.0 - (x2 - x1)
        if xi < 0.0:  # the start (xi = 0, approaching) is in contact: the force is smooth from t = 0
            return 0.0, 0.0
        c_ii, c_ij, c_jj = contact_law.damping_blocks(normal, np.array([xi]), np.array([0.5]), np.array([0.5]),
                                                      np.array([0.5]), model, with_rotation=False)
        spring = -contact_law.KN * xi  # on 1, along x (n = -x)
        return (spring - c_ii[0, 0, 0] * v1 - c_ij[0, 0, 0] * v2, -spring - c_ij[0, 0, 0] * v1 - c_jj[0, 0, 0] * v2)

    def rhs(ts, t, X, F):
        state = X.getArray(readonly=True)
        F.setArray([state[2], state[3], *acceleration(state)])

    ts = PETSc.TS().create(PETSc.COMM_SELF)
    X = PETSc.Vec().createWithArray(np.array([0.0, 1.0, 0.01, -0.01]), comm=PETSc.COMM_SELF)
    ts.setRHSFunction(rhs, X.duplicate())
    ts.setType("rk")
    ts.setRKType("4")
    ts.setTimeStep(1e-3)
    ts.setMaxTime(20.0)
    ts.setExactFinalTime(PETSc.TS.ExactFinalTime.MATCHSTEP)
    history = []
    ts.setMonitor(lambda ts_, step, t, x: history.append(x.getArray().copy()))
    ts.solve(X)
    states = np.array(history)
    xi = 1.0 - (states[:, 1] - states[:, 0])
    last = np.flatnonzero((xi[:-1] > 0) & (xi[1:] <= 0))[0]  # the last state in contact
    # the force jumps to 0 at xi = 0, so no state after it is used: from the last one, a Taylor
    # step of second order in the overlap to xi = 0 (the neglected term, dt^3 times the jerk, ~1e-10)
    x1, x2, v1, v2 = states[last]
    a1, a2 = acceleration(states[last])
    rate, curvature = v1 - v2, a1 - a2  # xi' and xi''
    tau = (-rate - np.sqrt(rate**2 - 2 * curvature * xi[last])) / curvature
    after = -(rate + curvature * tau)
    assert_all(0.0 <= tau <= 1e-3, f"tau {tau}")
    assert_close(after / 0.02, e, rtol=0.0, atol=1e-6, what=f"e = {e}")
