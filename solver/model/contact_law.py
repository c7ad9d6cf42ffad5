"""The contact law, the paper's eq:eij, in one place: pair energy, forces and torques, and the
exact pair Hessian blocks of the dynamical matrix (PHYSICS.md sections 1, 2 and 8).

Units m = d0 = kn = 1, kt = rho kn.  Per contact (i, j), with the reference (jammed) geometry
n = (r_i - r_j)/r_ij (minimum image), t = (-n_y, n_x), R = d/2, and displacements u, theta
(Delta u = u_i - u_j):

    e_ij = kn xi^2 / 2 + kt delta_t^2 / 2                                       (eq:eij)
    xi = (d_i + d_j)/2 - |r_i - r_j + Delta u|     exact geometry; the kn term is 0 once xi <= 0
    delta_t = t . Delta u - R_i theta_i - R_j theta_j

delta_t is the tangential displacement of the contact point (the paper's u_perp = u_ij - u_par
- theta_ij x n, written along t; PHYSICS.md section 8's s_t in 2D), measured from the
unstressed state: the tangential springs are switched on after FIRE, so the packing stays in
equilibrium for every rho.  The normal part alone (rho = 0) is the energy FIRE minimises
(``normal_pair``).  To second order in the displacements (PHYSICS.md section 2), with
f_n = kn xi, k* = kt - f_n / r_ij, P = kn n n^T + k* t t^T, DOF order (u_x, u_y, theta):

    H_ii = [[ P, -kt R_i t], [-kt R_i t^T, kt R_i^2]]   H_jj = [[ P, kt R_j t], [kt R_j t^T, kt R_j^2]]
    H_ij = [[-P, -kt R_j t], [ kt R_i t^T, kt R_i R_j]]  H_ji = H_ij^T

The -f_n/r_ij t t^T term is the geometric (prestress) term of the normal force; it is kept,
so the blocks are the exact Hessian of e_ij at the reference (tests/test_contact_law.py checks
them against central differences of ``pair_energy``).  Every function is vectorised over the
C contacts.  Not collective.
"""

from __future__ import annotations

import numpy as np

KN = 1.0  # normal stiffness, the unit of stiffness


def normal_force(overlap: np.ndarray) -> np.ndarray:
    """Magnitude f_n = kn xi (C,) of the repulsive normal force of each contact (xi > 0)."""
    return KN * overlap


def normal_energy(overlap: np.ndarray) -> np.ndarray:
    """Normal part kn xi^2 / 2 (C,) of eq:eij for overlaps xi > 0."""
    return 0.5 * KN * overlap**2


def normal_pair(separation: np.ndarray, contact: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact-geometry normal force and energy of pairs at ``separation`` r_i - r_j (C, 2).

    ``contact`` (C,) is (d_i + d_j)/2.  Returns (force on i (C, 2), energy (C,)); the force on
    j is minus that on i.  Pairs with xi <= 0 give zero.  This is eq:eij at rho = 0, the
    frictionless energy FIRE minimises.
    """
    distance = np.hypot(separation[:, 0], separation[:, 1])
    overlap = np.maximum(contact - distance, 0.0)
    force = (normal_force(overlap) / distance)[:, None] * separation
    return force, normal_energy(overlap)


def tangent(normal: np.ndarray) -> np.ndarray:
    """t = (-n_y, n_x) (C, 2): n rotated by +90 degrees, so that z x n = t."""
    return np.stack((-normal[:, 1], normal[:, 0]), axis=1)


def tangential_stretch(normal: np.ndarray, radius_i: np.ndarray, radius_j: np.ndarray,
                       du: np.ndarray, theta_i: np.ndarray, theta_j: np.ndarray) -> np.ndarray:
    """delta_t = t . (u_i - u_j) - R_i theta_i - R_j theta_j (C,), t from the reference ``normal``."""
    return np.sum(tangent(normal) * du, axis=1) - radius_i * theta_i - radius_j * theta_j


def pair_energy(separation: np.ndarray, contact: np.ndarray, normal: np.ndarray,
                radius_i: np.ndarray, radius_j: np.ndarray, rho: float, du: np.ndarray,
                theta_i: np.ndarray, theta_j: np.ndarray) -> np.ndarray:
    """Energy e_ij (C,) of eq:eij after displacements from the reference contacts.

    separation : (C, 2) reference r_i - r_j (minimum image);  contact : (C,) (d_i + d_j)/2;
    normal : (C, 2) reference n;  radius_i, radius_j : (C,);  rho = kt / kn;
    du : (C, 2) u_i - u_j;  theta_i, theta_j : (C,) rotations.
    """
    _, normal_part = normal_pair(separation + du, contact)
    stretch = tangential_stretch(normal, radius_i, radius_j, du, theta_i, theta_j)
    return normal_part + 0.5 * rho * KN * stretch**2


def pair_forces(separation: np.ndarray, contact: np.ndarray, normal: np.ndarray,
                radius_i: np.ndarray, radius_j: np.ndarray, rho: float, du: np.ndarray,
                theta_i: np.ndarray, theta_j: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Minus the gradient of ``pair_energy`` (same arguments): (F_i (C, 2), tau_i (C,), tau_j (C,)).

    F_i = f_n n' - kt delta_t t (n' the current normal), F_j = -F_i;
    tau_i = kt delta_t R_i and tau_j = kt delta_t R_j (torques about each disk's centre).
    """
    force, _ = normal_pair(separation + du, contact)
    kt_stretch = rho * KN * tangential_stretch(normal, radius_i, radius_j, du, theta_i, theta_j)
    force = force - kt_stretch[:, None] * tangent(normal)
    return force, kt_stretch * radius_i, kt_stretch * radius_j


def pair_blocks(normal: np.ndarray, distance: np.ndarray, overlap: np.ndarray,
                radius_i: np.ndarray, radius_j: np.ndarray, rho: float,
                with_rotation: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the Hessian blocks (H_ii, H_ij, H_jj) of every contact, each (C, k, k).

    ``k`` is 3 with rotations (x, y, theta) and 2 without (translations only, used for
    rho = 0 where rotations carry no stiffness).  H_ji is H_ij transposed.
    """
    kt = rho * KN
    n = normal
    t = tangent(n)
    kstar = kt - normal_force(overlap) / distance
    proj = KN * n[:, :, None] * n[:, None, :] + kstar[:, None, None] * t[:, :, None] * t[:, None, :]
    dof = 3 if with_rotation else 2
    count = normal.shape[0]
    h_ii = np.zeros((count, dof, dof))
    h_ij = np.zeros((count, dof, dof))
    h_jj = np.zeros((count, dof, dof))
    h_ii[:, :2, :2] = proj
    h_jj[:, :2, :2] = proj
    h_ij[:, :2, :2] = -proj
    if with_rotation:
        ri = (kt * radius_i)[:, None] * t
        rj = (kt * radius_j)[:, None] * t
        h_ii[:, :2, 2] = h_ii[:, 2, :2] = -ri
        h_jj[:, :2, 2] = h_jj[:, 2, :2] = rj
        h_ij[:, :2, 2] = -rj
        h_ij[:, 2, :2] = ri
        h_ii[:, 2, 2] = kt * radius_i**2
        h_jj[:, 2, 2] = kt * radius_j**2
        h_ij[:, 2, 2] = kt * radius_i * radius_j
    return h_ii, h_ij, h_jj
