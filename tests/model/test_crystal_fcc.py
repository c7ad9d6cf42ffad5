"""The FCC crystal of equal spheres (issue 18's hard check): its spectrum is known in closed form.

Equal spheres d = 1, m = 1 (kn = 1) on an FCC lattice in a periodic cubic box of n_c^3 cubic
cells (4 spheres each, lattice constant a_c), nearest neighbours at r = a_c / sqrt(2) = d - xi
(overlap xi), 12 of them; the next shell (a_c ~ 1.41 d) does not touch.  Every sphere is a centre
of inversion, so the net force vanishes exactly and the crystal is in equilibrium at any overlap.

1. The project's full spectrum (packing -> model.dynmat -> spectrum.slicing) equals the Bloch
   frequencies of the same crystal to 1e-10 of omega_max, for every wave vector the box allows,
   with and without rolling and twisting springs.  The Bloch matrix is written here from
   PHYSICS.md section 8's springs, not from ``contact_law``.
2. As xi -> 0 the transverse/rotational pair along [100] of the project's matrix becomes the
   paper's lattice model a sqrt(f -+ sqrt(g)) (PHYSICS.md section 6, coefficient 399), with
   l = a_c / 4 and a = sqrt(kn / m) (= 1 / t0 here), for both branches; the error is linear in xi.

Derivation of a (rho_roll = rho_twist = 0, R = d/2, I = m d^2 / 10, kt = rho kn).  Take
k = (k, 0, 0) and the polarisation (u_y, theta_z); write c = cos(2kl), s = sin(2kl) with
2kl = k a_c / 2 = k . delta for the 8 neighbours with delta_x = +-a_c/2 (the 4 with delta_x = 0
have phase 0).  Summing the blocks of ``bloch_matrix`` over the 12 neighbours (n = -delta/r) at
xi = 0, in the three groups delta = (+-1, +-1, 0), (+-1, 0, +-1), (0, +-1, +-1) times a_c/2:
    D_TT = sum (1 - E)(kn n_y^2 + kt (1 - n_y^2))   n_y^2 = 1/2, 0, (E = 1); sum (1 - E) = 4 (1 - c)
         = 2 (kn + kt)(1 - c) + 4 kt (1 - c) = (2 kn + 6 kt)(1 - c);
    D_RR = kt R^2 sum (1 + E)(1 - n_z^2)            1 - n_z^2 = 1, 1/2, 1/2
         = kt R^2 [4 (1 + c) + 2 (1 + c) + 4] = kt d^2 (3c + 5) / 2;
    D_TR = -kt R sum (1 + E) n_x                     n_x = -+1/sqrt(2), -+1/sqrt(2), 0
         = 4 sqrt(2) i kt R s = 2 sqrt(2) i kt d s.
Mass-scaled (divide by m, m I, sqrt(m I)): A_TT = (2 + 6 rho)(1 - c) kn/m,
A_RR = 5 rho (3c + 5) kn/m, |A_TR| = 4 sqrt(5) rho s kn/m (d drops out).  The eigenvalues are
(A_TT + A_RR)/2 -+ sqrt(((A_TT - A_RR)/2)^2 + |A_TR|^2), and with c = 1 - 2 sin^2(kl):
    (A_TT + A_RR)/2 = 2 sin^2(kl) + 9 rho cos^2(kl) + 11 rho = f            (times kn/m),
    ((A_TT - A_RR)/2)^2 + |A_TR|^2 = g (with 399)                             (times (kn/m)^2),
so omega^2 = (kn/m)(f -+ sqrt(g)): a_t = a_r = a = sqrt(kn/m) = 1/t0 for m = d = kn = 1.  Check:
omega_r(0)^2 = A_RR(0) = 40 kt/m, PHYSICS.md section 8's uniform spin of an FCC crystal.  (The
paper fits a_r ~ 0.73/t0 and l ~ 0.446 d0 to a disordered packing; here l = a_c/4 = d/(2 sqrt 2)
~ 0.354 d at contact.)  ``test_lattice_model_is_the_fcc_pair_at_contact`` checks this identity.
At xi > 0 the only change is the geometric (prestress) term -(kn xi / r) P of each contact on the
translations: A_TT -> A_TT - 6 (kn xi / (r m)) (1 - c), A_RR and A_TR unchanged (the lever arm is R
= d/2, the phases use the actual a_c), so by Weyl's inequality each omega^2 of the pair is within
6 (kn xi / (r m)) (1 - c) of (kn/m)(f -+ sqrt(g)) at l = a_c / 4: the error is linear in xi.
"""

import numpy as np
import pytest
from conftest import assert_all, assert_close

from solver.contact_law import ContactModel
from solver.analysis import lattice
from solver.model import dynmat
from solver.packing import geometry
from solver.packing import jammed
from solver.packing import mechanics
from solver.spectrum import slicing

DIAMETER = 1.0
INERTIA = DIAMETER**2 / 10.0   # sphere, m = 1
BASIS = np.array([[0.0, 0.0, 0.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.5], [0.5, 0.5, 0.0]])
ZERO_TOL = 1e-4                # slicing's default zero_tol (1/t0)


def lattice_constant(overlap):
    """a_c with nearest neighbours at d - overlap."""
    return np.sqrt(2.0) * (DIAMETER - overlap)


def fcc(n_cells, overlap):
    """The crystal as a Packing: 4 n_c^3 equal spheres in the cube of side n_c a_c."""
    a_c = lattice_constant(overlap)
    cells = np.stack(np.meshgrid(*[np.arange(n_cells)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    positions = ((cells[:, None, :] + BASIS[None]) * a_c).reshape(-1, 3)
    return jammed.from_arrays(positions, np.full(len(positions), DIAMETER), n_cells * a_c)


def neighbours(overlap):
    """The 12 nearest-neighbour vectors delta (12, 3): a_c/2 times the permutations of (+-1, +-1, 0)."""
    a_c = lattice_constant(overlap)
    out = []
    for a in (1.0, -1.0):
        for b in (1.0, -1.0):
            out += [(a, b, 0.0), (a, 0.0, b), (0.0, a, b)]
    return 0.5 * a_c * np.array(out)


def cross_map(n):
    """C (3, 3) with C theta = theta x n."""
    return np.array([[0.0, n[2], -n[1]], [-n[2], 0.0, n[0]], [n[1], -n[0], 0.0]])


def bloch_matrix(k, overlap, rho, rho_roll=0.0, rho_twist=0.0):
    """Mass-scaled Bloch matrix M^-1/2 B(k) M^-1/2 (6 x 6, or 3 x 3 with no rotational spring).

    One sphere per primitive cell.  For each neighbour delta (r = |delta|, n = -delta/r, the
    contact's normal seen from the centre sphere i, P = I - n n^T, C theta = theta x n, so
    C^T C = P and P C = C), phase E = exp(i k . delta), f_n = kn xi, R = d/2, a' = R/2, the pair
    blocks of PHYSICS.md section 8 (H_ii + H_ij E, DOF (u, theta)) are
        uu           [kn n n^T - (f_n / r) P + kt P] (1 - E)          normal (exact geometry), tangential
        u theta      -kt R C (1 + E)                                    tangential
        theta u      -kt R C^T (1 - E)
        theta theta  kt R^2 P (1 + E) + kr a'^2 P (1 - E) + ko a'^2 n n^T (1 - E)
    from s_t = P (u_i - u_j) - R (theta_i + theta_j) x n, s_r = a' (theta_i - theta_j) x n,
    s_o = a' n . (theta_i - theta_j).  M = diag(m, m, m, I, I, I), I = m d^2 / 10.
    """
    kt, kr, ko = rho, rho_roll, rho_twist
    radius, reduced = 0.5 * DIAMETER, 0.25 * DIAMETER
    rotations = rho > 0 or rho_roll > 0 or rho_twist > 0
    bloch = np.zeros((6, 6), complex)
    for delta in neighbours(overlap):
        r = np.linalg.norm(delta)
        n = -delta / r
        nn = np.outer(n, n)
        P = np.eye(3) - nn
        C = cross_map(n)
        E = np.exp(1j * (k @ delta))
        bloch[:3, :3] += (nn - (overlap / r) * P + kt * P) * (1 - E)
        bloch[:3, 3:] += -kt * radius * C * (1 + E)
        bloch[3:, :3] += -kt * radius * C.T * (1 - E)
        bloch[3:, 3:] += (kt * radius**2 * P * (1 + E) + kr * reduced**2 * P * (1 - E)
                          + ko * reduced**2 * nn * (1 - E))
    scale = 1.0 / np.sqrt(np.array([1.0, 1.0, 1.0, INERTIA, INERTIA, INERTIA]))
    bloch = scale[:, None] * bloch * scale[None, :]
    return bloch if rotations else bloch[:3, :3]


def allowed_k(n_cells, overlap):
    """The 4 n_c^3 wave vectors of the box, one per class modulo the reciprocal lattice.

    k = 2 pi m / L, m integer; the FCC reciprocal lattice in these units is spanned by
    (2n_c, 0, 0), (0, 2n_c, 0), n_c (1, 1, 1) (triangular basis), so m in
    [0, 2n_c) x [0, 2n_c) x [0, n_c) is one representative each.
    """
    box = n_cells * lattice_constant(overlap)
    m = np.stack(np.meshgrid(np.arange(2 * n_cells), np.arange(2 * n_cells), np.arange(n_cells),
                             indexing="ij"), axis=-1).reshape(-1, 3)
    return 2 * np.pi * m / box


def bloch_omegas(n_cells, overlap, rho, rho_roll=0.0, rho_twist=0.0):
    """Every omega of the crystal (6N or 3N,), ascending (negative: -sqrt|omega^2|)."""
    lam = np.sort(np.concatenate([np.linalg.eigvalsh(bloch_matrix(k, overlap, rho, rho_roll, rho_twist))
                                  for k in allowed_k(n_cells, overlap)]))
    return np.sign(lam) * np.sqrt(np.abs(lam))


N_CELLS, OVERLAP = 2, 0.01  # N = 32: the allowed k include Gamma, X, L and W


@pytest.fixture(scope="module")
def crystal():
    return fcc(N_CELLS, OVERLAP)


def test_fcc_crystal_is_the_intended_one(crystal):
    """The premises of the comparison (they check the set-up, not the code under test)."""
    a_c = lattice_constant(OVERLAP)
    assert crystal.dim == 3 and crystal.n == 4 * N_CELLS**3
    assert crystal.box_length > 2 * DIAMETER, "the box must exceed two diameters (one image per pair)"
    assert a_c / np.sqrt(2) < DIAMETER < a_c, "12 neighbours overlap, the next shell does not"
    found = geometry.find_contacts(crystal.positions, crystal.diameters, crystal.box_length)
    assert np.all(found.count_per_particle(crystal.n) == 12), "12 contacts per sphere"
    assert_close(found.overlap, np.full(len(found), OVERLAP), rtol=1e-13, what="overlaps")
    assert not crystal.rattler.any(), "no rattlers"
    assert mechanics.net_force(crystal) < 1e-14, "exact equilibrium (inversion symmetry)"
    # the k list: distinct modulo the reciprocal lattice (plane waves orthogonal on the sites)
    k = allowed_k(N_CELLS, OVERLAP)
    waves = np.exp(1j * crystal.positions @ k.T)
    gram = waves.conj().T @ waves / crystal.n
    assert k.shape[0] == crystal.n and np.abs(gram - np.eye(crystal.n)).max() < 1e-12


@pytest.mark.parametrize("rho, rho_roll, rho_twist", [(0.0, 0.0, 0.0), (1 / 7, 0.0, 0.0), (0.5, 0.0, 0.0),
                                                      (2.0, 0.0, 0.0), (0.5, 0.3, 0.2), (0.0, 0.3, 0.2)])
def test_fcc_full_spectrum_equals_bloch_frequencies(comm, crystal, rho, rho_roll, rho_twist):
    dm = dynmat.assemble(crystal, ContactModel(rho, rho_roll=rho_roll, rho_twist=rho_twist), comm)
    try:
        result = slicing.solve(dm, window=None, vectors=False, zero_tol=ZERO_TOL)
        rigid = len(dm.rigid_modes())
    finally:
        dm.destroy()
    bloch = bloch_omegas(N_CELLS, OVERLAP, rho, rho_roll, rho_twist)
    rotations = rho > 0 or rho_roll > 0 or rho_twist > 0
    assert_all(bloch.size == (6 if rotations else 3) * crystal.n, "one Bloch branch per DOF")
    zero = np.abs(bloch) < ZERO_TOL
    assert_all(zero.sum() == rigid and np.all(bloch > -ZERO_TOL),
               f"the crystal is stable with {rigid} zero modes (translations, spins at rho = 0): {bloch[:8]}")
    assert_all(result.n_zero_modes == zero.sum() and result.n_negative == 0,
               f"zero modes {result.n_zero_modes}, negative {result.n_negative}")
    # 1e-10 of omega_max: the bound; eigenvalues are Rayleigh quotients (error ~ residual^2)
    assert_close(result.omega, bloch[~zero], rtol=0.0, atol=1e-10 * bloch[-1],
                 what=f"rho = {rho}, rho_roll = {rho_roll}, rho_twist = {rho_twist}")


def pair_along_100(a, positions, box, p):
    """(lambda_t, lambda_r) of the (u_y, theta_z) plane waves at k = (2 pi p / L, 0, 0) of the
    sparse mass-scaled matrix ``a`` (6N DOF), and how far that 2-space is from invariant."""
    n = positions.shape[0]
    phase = np.exp(2j * np.pi * p * positions[:, 0] / box) / np.sqrt(n)
    basis = np.zeros((6 * n, 2), complex)
    basis[1::6, 0] = phase   # u_y
    basis[5::6, 1] = phase   # theta_z
    image = a @ basis
    reduced = basis.conj().T @ image
    leak = np.linalg.norm(image - basis @ reduced) / np.linalg.norm(image) if p else 0.0
    return np.linalg.eigvalsh(reduced), leak


@pytest.mark.serial_only  # a 6x6 Bloch matrix in numpy, no communicator
@pytest.mark.parametrize("rho", [0.1, 1 / 7, 0.5, 2.0])
def test_lattice_model_is_the_fcc_pair_at_contact(rho):
    """The derivation in the module docstring: at xi = 0 the (u_y, theta_z) block of the Bloch
    matrix along [100] has eigenvalues (kn/m)(f -+ sqrt(g)) with the coefficient 399, l = a_c/4
    and a = 1, over the whole zone (round-off: ~1e-15 of omega^2 ~ 40 rho)."""
    l = lattice_constant(0.0) / 4
    ks = np.linspace(0.0, np.pi / l, 41)
    got = np.array([np.linalg.eigvalsh(bloch_matrix(np.array([k, 0, 0]), 0.0, rho)[np.ix_([1, 5], [1, 5])])
                    for k in ks])
    omega_t, omega_r = lattice.lattice_omega(ks, rho, l, 1.0, 1.0)
    assert_close(got, np.stack((omega_t**2, omega_r**2), axis=1), rtol=0, atol=1e-12 * (40 * rho + 4),
                 what=f"(f -+ sqrt g) at rho = {rho}")


def test_project_pair_along_100_becomes_the_lattice_model(comm):
    """The project's matrix (model.dynmat on the crystal, n_c = 4: kl = pi p / 8) reduced to the
    (u_y, theta_z) plane waves along [100]: as xi goes 1e-2 -> 1e-3 -> 1e-4, its pair tends to
    a^2 (f -+ sqrt(g)) with a = 1 and l = a_c / 4, within the docstring's Weyl bound
    6 (xi / r)(1 - cos 2kl) at every k and xi.  The largest error is linear in xi: it is the bound
    itself, 12 xi / r, at the zone edge kl = pi/2, where s = 0 decouples the pair and the TR mode
    is a pure translation carrying the whole geometric shift."""
    n_cells, rhos, overlaps = 4, (0.1, 1 / 7, 0.5, 2.0), np.array([1e-2, 1e-3, 1e-4])
    worst = []
    for overlap in overlaps:
        packing = fcc(n_cells, overlap)
        l, r = lattice_constant(overlap) / 4, DIAMETER - overlap
        errors = []
        for rho in rhos:
            dm = dynmat.assemble(packing, ContactModel(rho), comm)
            try:
                scale = 1.0 / np.sqrt(dynmat.in_packing_order(dm, dynmat.gather_vec(dm.M)))
                a = dynmat.in_packing_order(dm, dynmat.gather_csr(dm.D)).multiply(scale[:, None]).multiply(scale[None, :]).tocsr()
            finally:
                dm.destroy()
            for p in range(2 * n_cells):
                k = 2 * np.pi * p / packing.box_length
                lam, leak = pair_along_100(a, packing.positions, packing.box_length, p)
                assert_all(leak < 1e-13, f"the (u_y, theta_z) plane waves at p = {p} are not invariant: {leak}")
                omega_t, omega_r = lattice.lattice_omega(k, rho, l, 1.0, 1.0)
                error = np.abs(lam - np.array([omega_t**2, omega_r**2]))
                weyl = 6 * overlap / r * (1 - np.cos(2 * k * l))
                # atol beside the bound: round-off of lambda ~ 1e-15 x 40 rho
                assert_all(np.all(error <= weyl + 1e-13 * (40 * rho + 4)),
                           f"xi = {overlap}, rho = {rho}, kl = {k * l:.3f}: error {error} > Weyl bound {weyl}")
                errors.append(error.max())
        worst.append(max(errors))
    # round-off of lambda ~ 1e-15 x 40 rho against errors >= 1e-3: 1e-8 relative is ample
    assert_close(np.array(worst), 12 * overlaps / (DIAMETER - overlaps), rtol=1e-8,
                 what="largest error = 12 xi / r (linear in xi)")
