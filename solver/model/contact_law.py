"""The contact law eq:eij in one place: normal forces and the exact pair Hessian blocks.

e_ij = kn xi^2 / 2 + kt |u_perp|^2 / 2 with kn = 1 (units m = d0 = kn = 1).  To second order
in the displacements (PHYSICS.md section 2), with n = (r_i - r_j)/r_ij, t = (-n_y, n_x),
f_n = kn xi, k* = kt - f_n / r_ij, P = kn n n^T + k* t t^T, DOF order (u_x, u_y, theta):

    H_ii = [[ P, -kt R_i t], [-kt R_i t^T, kt R_i^2]]   H_jj = [[ P, kt R_j t], [kt R_j t^T, kt R_j^2]]
    H_ij = [[-P, -kt R_j t], [ kt R_i t^T, kt R_i R_j]]  H_ji = H_ij^T

The -f_n/r_ij t t^T term is the geometric (prestress) term of the normal force; it is kept,
so the matrix is the exact Hessian of the energy.  Not collective.
"""

from __future__ import annotations

import numpy as np

KN = 1.0  # normal stiffness, the unit of stiffness


def normal_force(overlap: np.ndarray) -> np.ndarray:
    """Magnitude f_n = kn xi (C,) of the repulsive normal force of each contact."""
    return KN * overlap


def pair_blocks(normal: np.ndarray, distance: np.ndarray, overlap: np.ndarray,
                radius_i: np.ndarray, radius_j: np.ndarray, rho: float,
                with_rotation: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the Hessian blocks (H_ii, H_ij, H_jj) of every contact, each (C, k, k).

    ``k`` is 3 with rotations (x, y, theta) and 2 without (translations only, used for
    rho = 0 where rotations carry no stiffness).  H_ji is H_ij transposed.
    """
    kt = rho * KN
    n = normal
    t = np.stack((-n[:, 1], n[:, 0]), axis=1)
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
