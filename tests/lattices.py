"""The perfect 2D crystal of the closed-form tests (tests/model/test_crystal.py, and the spectral
waves' invariant subspaces in tests/waves/test_lanczos.py): equal disks on a uniformly strained
triangular lattice, slightly compressed, and its Bloch matrices.

The lattice: n_x columns and an even number n_y of rows in the square box L, row j shifted by
half a spacing when j is odd; spacings a = L / n_x along a row and b = L / n_y between rows.
It is the Bravais lattice of a_1 = (a, 0), a_2 = (a/2, b) (a triangular lattice strained along y
when b != a sqrt(3)/2), one disk per cell, so every disk is a centre of inversion: the net force
vanishes exactly and the crystal is in equilibrium for any overlap.  Each disk touches 6
neighbours: 2 in its row at distance a, 4 in the next rows at s = sqrt(a^2/4 + b^2).
"""

import numpy as np

N_X, N_Y = 7, 8
DIAMETER = 1.0                 # equal disks, d = d0
DIAGONAL = 0.99                # s: the diagonal neighbours overlap by 0.01 d0
A = DIAGONAL / np.hypot(0.5, N_X / N_Y)  # row spacing a (b = a n_x / n_y): row overlap ~0.018
B = A * N_X / N_Y
L = N_X * A


def crystal():
    """Positions (N, 2) of the n_x x n_y crystal, rows in order."""
    i, j = np.meshgrid(np.arange(N_X), np.arange(N_Y), indexing="xy")
    x = (i + 0.5 * (j % 2)) * A
    y = j * B
    return np.stack((x.ravel(), y.ravel()), axis=1)


def bloch_matrix(k, rho):
    """The mass-scaled Bloch matrix M^-1/2 B(k) M^-1/2 (3 x 3, or 2 x 2 at rho = 0) at wave vector k (2,).

    Closed form from the pair stiffness of PHYSICS.md section 2 (kn = m = 1, kt = rho, R = d/2,
    I = m d^2/8): for a neighbour at r_j = r_i + delta (|delta| = r, xi = d - r, f_n = kn xi),
    n = -delta / r, t = (-n_y, n_x), P = kn n n^T + (kt - f_n / r) t t^T.  Summing the pair
    blocks over the 6 neighbours with phases exp(i k . delta), the neighbours +-delta pair up:
        translations      sum_half 2 P (1 - cos k.delta)
        translation-spin  -2 i kt R sum_half sin(k.delta) t          (its conjugate transpose below)
        spin              sum_half 2 kt R^2 (1 + cos k.delta)
    over half = {a_1, a_2, a_2 - a_1}.  DOF order (u_x, u_y, theta).
    """
    kt, radius = rho, 0.5 * DIAMETER
    half = np.array([[A, 0.0], [0.5 * A, B], [-0.5 * A, B]])
    r = np.hypot(half[:, 0], half[:, 1])
    n = -half / r[:, None]
    t = np.stack((-n[:, 1], n[:, 0]), axis=1)
    kstar = kt - (DIAMETER - r) / r
    P = n[:, :, None] * n[:, None, :] + kstar[:, None, None] * t[:, :, None] * t[:, None, :]
    dof = 3 if rho > 0 else 2
    scale = 1.0 / np.sqrt(np.array([1.0, 1.0, DIAMETER**2 / 8.0])[:dof])
    phase = half @ np.asarray(k, dtype=float)
    bloch = np.zeros((dof, dof), complex)
    bloch[:2, :2] = np.einsum("d,dab->ab", 2 * (1 - np.cos(phase)), P)
    if dof == 3:
        coupling = -2j * kt * radius * np.einsum("d,da->a", np.sin(phase), t)
        bloch[:2, 2] = coupling
        bloch[2, :2] = coupling.conj()
        bloch[2, 2] = 2 * kt * radius**2 * np.sum(1 + np.cos(phase))
    return scale[:, None] * bloch * scale[None, :]


def bloch_omegas(rho):
    """All omega (3N or 2N,) of the crystal, ascending (negative: -sqrt|omega^2|).

    Allowed k = 2 pi (p, q) / L, p < n_x, q < n_y: exactly one per cell of the reciprocal
    lattice (b_1 = 2 pi / L (n_x, -n_y/2), b_2 = 2 pi / L (0, n_y)).
    """
    lam = np.sort(np.concatenate([np.linalg.eigvalsh(bloch_matrix(2 * np.pi * np.array([p, q]) / L, rho))
                                  for p in range(N_X) for q in range(N_Y)]))
    return np.sign(lam) * np.sqrt(np.abs(lam))
