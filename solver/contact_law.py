"""The contact law, the paper's eq:eij and its 3D form with rolling and twisting springs, in one
place: pair energy, forces and torques, and the exact pair Hessian blocks of the dynamical matrix
(PHYSICS.md sections 1, 2 and 8).

Units m = d0 = kn = 1; kt = rho kn, kr = rho_roll kn, ko = rho_twist kn (3D only).  Per contact
(i, j), with the reference (jammed) geometry n = (r_i - r_j)/r_ij (minimum image), P = I - n n^T,
R = d/2, a' = R_i R_j / (R_i + R_j), displacements u (D components) and rotations theta (a
scalar about z in 2D, a 3-vector in 3D), Delta u = u_i - u_j:

    e_ij = kn xi^2 / 2 + kt |s_t|^2 / 2 + kr |s_r|^2 / 2 + ko s_o^2 / 2         (eq:eij at kr = ko = 0)
    xi = (d_i + d_j)/2 - |r_i - r_j + Delta u|     exact geometry; the kn term is 0 once xi <= 0
    s_t = P Delta u - (R_i theta_i + R_j theta_j) x n      tangential displacement of the contact point
    s_r = a' (theta_i - theta_j) x n,   s_o = a' n . (theta_i - theta_j)     rolling, twisting

In 2D theta x n is theta t with t = (-n_y, n_x), so s_t = delta_t t with the paper's
delta_t = t . Delta u - R_i theta_i - R_j theta_j (its u_perp = u_ij - u_par - theta_ij x n).  The
springs are measured from the unstressed state: they are switched on after FIRE, so the packing
stays in equilibrium for every rho.  The normal part alone is the energy FIRE minimises
(``normal_pair``).  To second order the springs are linear maps B of (u_i, theta_i, u_j, theta_j)
and add k B^T B; the normal spring adds K = kn n n^T - (f_n / r_ij) P on the translations (the
geometric, prestress term, kept).  In 2D, DOF order (u_x, u_y, theta), with k* = kt - f_n / r_ij
and kr = 0 this is

    H_ii = [[ P', -kt R_i t], [-kt R_i t^T, kt R_i^2]]   H_jj = [[ P', kt R_j t], [kt R_j t^T, kt R_j^2]]
    H_ij = [[-P', -kt R_j t], [ kt R_i t^T, kt R_i R_j]]  H_ji = H_ij^T,   P' = kn n n^T + k* t t^T.

The blocks are the exact Hessian of e_ij at the reference (tests/model/test_contact_law.py checks them,
and the forces, against central differences of ``pair_energy`` in 2D and 3D with every spring on).
A packing made with friction stands on stored tangential forces f_t (per contact, the force on i
from j): :func:`stressed_blocks` adds what they contribute in LAMMPS's history convention, a
non-symmetric term (docs/stressed_contacts.md; tests/model/test_stressed.py checks it against
finite differences of LAMMPS's update).
Capillary bridges (``ContactModel.cohesion``, :mod:`solver.capillary`) add their pull F(s) at the
gap s = -xi to the normal force, touching or across a gap (docs/capillary_bridges.md).
Every function is vectorised over the C contacts.  The springs of a model travel together as
one :class:`ContactModel`.  Not collective.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from solver.capillary import Cohesion, bridge_energy, bridge_force, bridge_stiffness

KN = 1.0  # normal stiffness, the unit of stiffness
LAWS = ("harmonic", "hertz")


@dataclass(frozen=True)
class ContactModel:
    """What every contact of a matrix is made of (eq:eij; PHYSICS.md sections 1, 2 and 8).

    rho = kt / kn (tangential), rho_roll = kr / kn (rolling), rho_twist = ko / kn (twisting, 3D
    only): stiffness ratios >= 0;  law : the normal law, ``harmonic`` (kn xi) or ``hertz``
    (kn sqrt(a' xi) xi, every spring scaled by :func:`spring_scale`);  mobilised : how a stressed
    contact at the Coulomb limit responds, ``stick`` or ``slide`` (:func:`sliding_blocks`);
    lever : where the tangential force acts, ``radius`` (R from each centre: LAMMPS) or
    ``contact`` (R - xi/2, the middle of the overlap: LIGGGHTS and YADE) (:func:`lever_arms`);
    stored_forces : ``keep`` a stressed packing's stored tangential forces in the matrix, or
    ``drop`` them (unstressed springs on the same packing, for comparison);  history : the DEM
    code's update of the tangential spring, ``lammps`` (projected onto the turning tangent plane,
    slip taken at the lever: LAMMPS, LIGGGHTS) or ``yade`` (YADE's ScGeom: also turned about the
    normal with the pair's mean spin, :func:`stressed_blocks`, and its own slip,
    :func:`slip_blocks`) or ``granular`` (LAMMPS's pair granular: projected as ``lammps``, to first
    order, but the slip taken at the radii R while the torques act at the lever,
    :func:`slip_blocks`).  The scene gives one per
    rho (``ModelSpec.contact``).  ``gamma_n``, ``gamma_t``: the contact dashpots (1/t0), in
    LAMMPS's gran/*/history convention (:func:`damping_blocks`; 0: none).  ``cohesion``: the
    capillary bridges (:class:`solver.capillary.Cohesion`; None: dry), whose pull acts along the
    line of centres of every bridged pair, touching or across a gap (docs/capillary_bridges.md).
    A stressed packing's stored tangential forces belong to the packing (``Packing.tangential``),
    not to the model.
    """

    rho: float = 0.0
    rho_roll: float = 0.0
    rho_twist: float = 0.0
    law: str = "harmonic"
    mobilised: str = "stick"
    lever: str = "radius"
    stored_forces: str = "keep"
    history: str = "lammps"
    gamma_n: float = 0.0
    gamma_t: float = 0.0
    cohesion: Cohesion | None = None

    @property
    def damped(self) -> bool:
        """Whether a contact dashpot is on (``damping_blocks``; docs/damping.md)."""
        return self.gamma_n > 0.0 or self.gamma_t > 0.0

    def at_rest(self) -> ContactModel:
        """The part of this model that a packing at rest is checked under and its forces are
        computed with (``Packing.model``): the normal ``law``, the ``lever`` of the stored
        tangential forces' torques and the bridges' pull.  The springs, the Coulomb response, the
        history and the dashpots act on motion only: they are at their defaults."""
        return ContactModel(law=self.law, lever=self.lever, cohesion=self.cohesion)

    @property
    def rotations(self) -> bool:
        """Whether some rotational spring, or the tangential dashpot, is on (then the matrix keeps
        rotational DOF: the dashpot acts on the rotations through the contact point's velocity)."""
        return self.rho > 0.0 or self.rho_roll > 0.0 or self.rho_twist > 0.0 or self.gamma_t > 0.0


LEVERS = ("radius", "contact")      # ContactModel.lever
MOBILISED = ("stick", "slide")      # ContactModel.mobilised
STORED_FORCES = ("keep", "drop")    # ContactModel.stored_forces
HISTORIES = ("lammps", "yade", "granular")  # ContactModel.history


def lever_arms(radius_i: np.ndarray, radius_j: np.ndarray, overlap: np.ndarray, lever: str
               ) -> tuple[np.ndarray, np.ndarray]:
    """Distances (C,) from each centre to where the tangential force acts: R (``radius``,
    LAMMPS's gran/*/history) or R - xi/2 (``contact``, the middle of the overlap, as LIGGGHTS and
    YADE take it); they enter the contact point's slip and the torques
    (docs/stressed_contacts.md section 2)."""
    if lever == "radius":
        return radius_i, radius_j
    return radius_i - 0.5 * overlap, radius_j - 0.5 * overlap


def slip_differs(model: ContactModel) -> bool:
    """Whether the tangential spring's slip is not the transpose of its force's action (YADE's
    history, or LAMMPS's pair granular under the lever R - xi/2, with a tangential spring): it
    then adds :func:`slip_blocks`, which are not symmetric.  Not collective."""
    granular = model.history == "granular" and model.lever != "radius"
    return (model.history == "yade" or granular) and model.rho > 0.0


def reduced_radius(d_i: np.ndarray, d_j: np.ndarray) -> np.ndarray:
    """a' = R_i R_j / (R_i + R_j) (C,) of contacts between diameters d_i and d_j."""
    return d_i * d_j / (2.0 * (d_i + d_j))


def normal_force(overlap: np.ndarray, law: str = "harmonic", reduced: np.ndarray | None = None) -> np.ndarray:
    """Magnitude f_n (C,) of the repulsive normal force of each contact (xi > 0): kn xi (harmonic)
    or kn sqrt(a' xi) xi (hertz: LAMMPS's gran/hertz/history, a' = ``reduced`` = R_i R_j/(R_i + R_j))."""
    return KN * overlap if law == "harmonic" else KN * np.sqrt(reduced * overlap) * overlap


def normal_energy(overlap: np.ndarray, law: str = "harmonic", reduced: np.ndarray | None = None) -> np.ndarray:
    """Normal part of eq:eij (C,) for overlaps xi > 0: kn xi^2 / 2 (harmonic) or
    (2/5) kn sqrt(a') xi^(5/2) (hertz), whose derivative is :func:`normal_force`."""
    if law == "harmonic":
        return 0.5 * KN * overlap**2
    return 0.4 * KN * np.sqrt(reduced * overlap) * overlap**2


def spring_scale(overlap: np.ndarray, law: str = "harmonic", reduced: np.ndarray | None = None) -> np.ndarray:
    """Factor (C,) on every spring of a contact at its reference overlap: 1 (harmonic), or
    sqrt(a' xi) (hertz), the contact radius' growth that makes the Hertz normal force kn sqrt(a' xi) xi
    and, as in LAMMPS's gran/hertz/history (Mindlin), the tangential stiffness kt sqrt(a' xi);
    the rolling and twisting springs scale the same way [choice], so that rho, rho_roll and
    rho_twist stay ratios to kn for both laws.  The normal tangent stiffness is
    df_n/dxi = (3/2) kn sqrt(a' xi) (:func:`normal_stiffness`).  0 for a pair that does not touch
    (xi < 0: a capillary bridge across a gap carries no spring)."""
    touching = overlap >= 0
    if law == "harmonic":
        return touching.astype(float)
    return np.sqrt(reduced * np.where(touching, overlap, 0.0))


def tangential_growth(overlap: np.ndarray, law: str) -> np.ndarray:
    """c = (dk_t/dxi) / k_t (C,) at the reference overlap: 0 (harmonic) or 1/(2 xi) (hertz, whose
    tangential stiffness follows the current overlap as in LAMMPS; docs/stressed_contacts.md)."""
    return np.zeros_like(overlap) if law == "harmonic" else 0.5 / overlap


def normal_stiffness(overlap: np.ndarray, law: str = "harmonic", reduced: np.ndarray | None = None) -> np.ndarray:
    """df_n / dxi (C,): kn (harmonic) or (3/2) kn sqrt(a' xi) (hertz); 0 where xi < 0."""
    return (1.5 if law == "hertz" else 1.0) * KN * spring_scale(overlap, law, reduced)


def normal_pair(separation: np.ndarray, contact: np.ndarray, law: str = "harmonic",
                reduced: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Exact-geometry normal force and energy of pairs at ``separation`` r_i - r_j (C, D), D = 2 or 3.

    ``contact`` (C,) is (d_i + d_j)/2, ``reduced`` (C,) a' (hertz only).  Returns (force on i
    (C, D), energy (C,)); the force on j is minus that on i.  Pairs with xi <= 0 give zero.  This
    is eq:eij at rho = 0, the frictionless energy FIRE minimises.
    """
    squared = separation[:, 0] * separation[:, 0]
    for axis in range(1, separation.shape[1]):  # column sums: faster than einsum in FIRE's loop
        squared += separation[:, axis] * separation[:, axis]
    distance = np.sqrt(squared)
    overlap = np.maximum(contact - distance, 0.0)
    force = (normal_force(overlap, law, reduced) / distance)[:, None] * separation
    return force, normal_energy(overlap, law, reduced)


def tangent(normal: np.ndarray) -> np.ndarray:
    """t = (-n_y, n_x) (C, 2): n rotated by +90 degrees, so that z x n = t (2D only)."""
    return np.stack((-normal[:, 1], normal[:, 0]), axis=1)


def _rotation_map(normal: np.ndarray) -> np.ndarray:
    """C_n (C, D, r) with C_n theta = theta x n: 2D (r = 1) the column t; 3D (r = 3) -[n]_x."""
    if normal.shape[1] == 2:
        return tangent(normal)[:, :, None]
    nx, ny, nz = normal.T
    zero = np.zeros_like(nx)
    return -np.stack((np.stack((zero, -nz, ny), 1), np.stack((nz, zero, -nx), 1),
                      np.stack((-ny, nx, zero), 1)), 1)


def _tangential_map(normal: np.ndarray, c_n: np.ndarray, arm_i: np.ndarray, arm_j: np.ndarray) -> np.ndarray:
    """B_t (C, D, 2m): the tangential stretch s_t as a linear map of (u_i, theta_i, u_j, theta_j),
    m = D + r, with lever arms ``arm_i``, ``arm_j`` (:func:`lever_arms`) and C_n = ``c_n``."""
    count, dim = normal.shape
    m = dim + c_n.shape[2]
    proj = np.eye(dim)[None] - normal[:, :, None] * normal[:, None, :]
    b_t = np.zeros((count, dim, 2 * m))
    b_t[:, :, :dim], b_t[:, :, m:m + dim] = proj, -proj
    b_t[:, :, dim:m], b_t[:, :, m + dim:] = -arm_i[:, None, None] * c_n, -arm_j[:, None, None] * c_n
    return b_t


def _rotations(theta: np.ndarray) -> np.ndarray:
    """theta as (C, r): 2D rotations come as (C,) scalars, 3D as (C, 3)."""
    return theta[:, None] if theta.ndim == 1 else theta


def _refuse_twist_in_2d(normal: np.ndarray, model: ContactModel) -> None:
    """Refuse a twisting spring in 2D (PHYSICS.md section 8: 3D only)."""
    if normal.shape[1] == 2 and model.rho_twist != 0:
        raise ValueError(f"rho_twist = {model.rho_twist}: twisting resistance exists in 3D only")


def stretches(normal: np.ndarray, radius_i: np.ndarray, radius_j: np.ndarray, du: np.ndarray,
              theta_i: np.ndarray, theta_j: np.ndarray, arms: tuple | None = None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(s_t (C, D), s_r (C, D), s_o (C,)) of PHYSICS.md section 8, from the reference ``normal``.

    s_t = P (u_i - u_j) - (R_i theta_i + R_j theta_j) x n (tangential; in 2D delta_t t),
    s_r = a' (theta_i - theta_j) x n (rolling), s_o = a' n . (theta_i - theta_j) (twisting; 0 in 2D),
    with a' = R_i R_j / (R_i + R_j).  du (C, D); theta (C,) in 2D, (C, 3) in 3D; ``arms`` the
    lever arms (:func:`lever_arms`) in place of R_i, R_j in s_t (None: the radii).
    """
    c_n = _rotation_map(normal)
    ti, tj = _rotations(theta_i), _rotations(theta_j)
    reduced = radius_i * radius_j / (radius_i + radius_j)
    arm_i, arm_j = arms if arms is not None else (radius_i, radius_j)
    spin = arm_i[:, None] * ti + arm_j[:, None] * tj
    s_t = du - np.einsum("cd,cd->c", normal, du)[:, None] * normal - np.einsum("cdr,cr->cd", c_n, spin)
    s_r = reduced[:, None] * np.einsum("cdr,cr->cd", c_n, ti - tj)
    s_o = (reduced * np.einsum("cd,cd->c", normal, ti - tj) if normal.shape[1] == 3
           else np.zeros(normal.shape[0]))
    return s_t, s_r, s_o


def pair_energy(separation: np.ndarray, contact: np.ndarray, normal: np.ndarray,
                radius_i: np.ndarray, radius_j: np.ndarray, model: ContactModel, du: np.ndarray,
                theta_i: np.ndarray, theta_j: np.ndarray) -> np.ndarray:
    """Energy e_ij (C,) after displacements from the reference contacts (eq:eij; in 3D and with
    rolling and twisting springs PHYSICS.md section 8).

    separation : (C, D) reference r_i - r_j (minimum image);  contact : (C,) (d_i + d_j)/2;
    normal : (C, D) reference n;  radius_i, radius_j : (C,);  model : the springs and the normal
    law (under hertz the springs carry :func:`spring_scale` of the reference overlap);
    du : (C, D) u_i - u_j;  theta_i, theta_j : (C,) in 2D, (C, 3) in 3D.
    """
    _refuse_twist_in_2d(normal, model)
    reduced = radius_i * radius_j / (radius_i + radius_j)
    _, normal_part = normal_pair(separation + du, contact, model.law, reduced)
    overlap = _reference_overlap(separation, contact)
    scale = spring_scale(overlap, model.law, reduced)
    s_t, s_r, s_o = stretches(normal, radius_i, radius_j, du, theta_i, theta_j,
                              lever_arms(radius_i, radius_j, overlap, model.lever))
    energy = normal_part + 0.5 * KN * scale * (model.rho * np.einsum("cd,cd->c", s_t, s_t)
                                               + model.rho_roll * np.einsum("cd,cd->c", s_r, s_r)
                                               + model.rho_twist * s_o**2)
    if model.cohesion is not None:
        gap = np.linalg.norm(separation + du, axis=1) - contact
        energy = energy + bridge_energy(gap, radius_i, radius_j, model.cohesion)
    return energy


def _reference_overlap(separation: np.ndarray, contact: np.ndarray) -> np.ndarray:
    """xi (C,) at the reference separation (C, D)."""
    return contact - np.sqrt(np.einsum("cd,cd->c", separation, separation))


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b per contact: (C,) (the z component) in 2D, (C, 3) in 3D."""
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] if a.shape[1] == 2 else np.cross(a, b)


def pair_forces(separation: np.ndarray, contact: np.ndarray, normal: np.ndarray,
                radius_i: np.ndarray, radius_j: np.ndarray, model: ContactModel, du: np.ndarray,
                theta_i: np.ndarray, theta_j: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Minus the gradient of ``pair_energy`` (same arguments): (F_i (C, D), tau_i, tau_j), the
    torques (C,) in 2D and (C, 3) in 3D.

    F_i = (f_n - F_b) n' - kt s_t (n' the current normal, F_b the bridge's pull at the current
    gap under ``model.cohesion``), F_j = -F_i;
    tau_i = -kt R_i s_t x n - kr a' n x s_r - ko a' s_o n,
    tau_j = -kt R_j s_t x n + kr a' n x s_r + ko a' s_o n (torques about each centre).
    In 2D (s_t = delta_t t): tau_i = kt delta_t R_i - kr a'^2 (theta_i - theta_j).  Under hertz,
    kt, kr and ko carry :func:`spring_scale` of the reference overlap.
    """
    _refuse_twist_in_2d(normal, model)
    reduced = radius_i * radius_j / (radius_i + radius_j)
    force, _ = normal_pair(separation + du, contact, model.law, reduced)
    if model.cohesion is not None:
        current = separation + du
        distance = np.linalg.norm(current, axis=1)
        pull = bridge_force(distance - contact, radius_i, radius_j, model.cohesion)
        force = force - (pull / distance)[:, None] * current
    overlap = _reference_overlap(separation, contact)
    k = KN * spring_scale(overlap, model.law, reduced)
    arm_i, arm_j = lever_arms(radius_i, radius_j, overlap, model.lever)
    s_t, s_r, s_o = stretches(normal, radius_i, radius_j, du, theta_i, theta_j, (arm_i, arm_j))
    slide = cross(s_t, normal)
    roll = cross(normal, s_r)
    tau_common = -model.rho_roll * _expand(k * reduced, roll)
    twist = -model.rho_twist * _expand(k * reduced * s_o, normal) if normal.shape[1] == 3 else 0.0
    tau_i = -model.rho * _expand(k * arm_i, slide) + tau_common + twist
    tau_j = -model.rho * _expand(k * arm_j, slide) - tau_common - twist
    return force - model.rho * k[:, None] * s_t, tau_i, tau_j


def _expand(scale: np.ndarray, value: np.ndarray) -> np.ndarray:
    """scale (C,) times value (C,) or (C, 3)."""
    return scale * value if value.ndim == 1 else scale[:, None] * value


def pair_blocks(normal: np.ndarray, distance: np.ndarray, overlap: np.ndarray,
                radius_i: np.ndarray, radius_j: np.ndarray, model: ContactModel,
                with_rotation: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the Hessian blocks (H_ii, H_ij, H_jj) of every contact, each (C, k, k).

    ``k`` is D + r with rotations ((x, y, theta) in 2D, (x, y, z, theta_x, theta_y, theta_z) in
    3D) and D without (translations only, for a model with no rotational stiffness, where the
    rotations would be free).  H_ji is H_ij transposed.  Each spring adds k B^T B, B the linear
    map of its stretch on (u_i, theta_i, u_j, theta_j) (PHYSICS.md section 8); the normal spring
    adds [[K, -K], [-K, K]] on the translations, K = k_n n n^T - (f_n / r_ij) P (geometric term
    kept), k_n = df_n/dxi; under hertz every spring carries :func:`spring_scale` (``model.law``).
    Under ``model.cohesion`` the bridge's pull F_b(s) at the gap s = -xi joins both terms,
    K = (k_n + dF_b/ds) n n^T - ((f_n - F_b) / r_ij) P (docs/capillary_bridges.md); a pair across a
    gap (xi < 0, bridged) has that alone, no spring.
    """
    _refuse_twist_in_2d(normal, model)
    law = model.law
    count, dim = normal.shape
    c_n = _rotation_map(normal)
    rot = c_n.shape[2]
    m = dim + rot
    reduced = radius_i * radius_j / (radius_i + radius_j)
    proj = np.eye(dim)[None] - normal[:, :, None] * normal[:, None, :]
    along = normal_stiffness(overlap, law, reduced)
    net_force = normal_force(np.maximum(overlap, 0.0), law, reduced)
    if model.cohesion is not None:
        along = along + bridge_stiffness(-overlap, radius_i, radius_j, model.cohesion)
        net_force = net_force - bridge_force(-overlap, radius_i, radius_j, model.cohesion)
    stiff = (along[:, None, None] * normal[:, :, None] * normal[:, None, :]
             - (net_force / distance)[:, None, None] * proj)
    scale = spring_scale(overlap, law, reduced)
    full = np.zeros((count, 2 * m, 2 * m))
    for a, sa in ((0, 1), (m, -1)):
        for b, sb in ((0, 1), (m, -1)):
            full[:, a:a + dim, b:b + dim] = sa * sb * stiff
    b_t = _tangential_map(normal, c_n, *lever_arms(radius_i, radius_j, overlap, model.lever))
    b_r = np.zeros((count, dim, 2 * m))
    b_r[:, :, dim:m], b_r[:, :, m + dim:] = reduced[:, None, None] * c_n, -reduced[:, None, None] * c_n
    springs = [(model.rho, b_t), (model.rho_roll, b_r)]
    if dim == 3:
        b_o = np.zeros((count, 1, 2 * m))
        b_o[:, 0, dim:m], b_o[:, 0, m + dim:] = reduced[:, None] * normal, -reduced[:, None] * normal
        springs.append((model.rho_twist, b_o))
    for ratio, b in springs:
        if ratio:
            full += KN * ratio * scale[:, None, None] * np.einsum("cki,ckj->cij", b, b)
    k = m if with_rotation else dim
    return full[:, :k, :k], full[:, :k, m:m + k], full[:, m:m + k, m:m + k]


def _cross_matrix(vector: np.ndarray) -> np.ndarray:
    """[a]_x (C, r, D) with [a]_x b = a x b: 2D (r = 1) the row (-a_y, a_x) (the z component),
    3D the skew matrix."""
    if vector.shape[1] == 2:
        return np.stack((-vector[:, 1], vector[:, 0]), axis=1)[:, None, :]
    return -_rotation_map(vector)


def _slip_map(normal: np.ndarray, c_n: np.ndarray, distance: np.ndarray, overlap: np.ndarray,
              radius_i: np.ndarray, radius_j: np.ndarray, model: ContactModel) -> np.ndarray:
    """The slip that loads the tangential spring as a linear map (C, D, 2m) of (u_i, theta_i, u_j,
    theta_j): B_t with the torques' :func:`lever_arms` under ``history: lammps``; under ``yade``
    (Debian's YADE 2023.02a, measured: docs/stressed_contacts.md section 2) the arms R and the
    relative translation scaled by alpha = (R_i + R_j) / r: alpha P (u_i - u_j) - (R_i theta_i +
    R_j theta_j) x n; under ``granular`` (LAMMPS's pair granular, Debian's 2022 LAMMPS, measured:
    docs/finite_amplitude.md section 7) the radii R, whatever the torques' lever."""
    if model.history == "granular":
        return _tangential_map(normal, c_n, radius_i, radius_j)
    if model.history != "yade":
        return _tangential_map(normal, c_n, *lever_arms(radius_i, radius_j, overlap, model.lever))
    b_t = _tangential_map(normal, c_n, radius_i, radius_j)
    dim, m = normal.shape[1], b_t.shape[2] // 2
    alpha = ((radius_i + radius_j) / distance)[:, None, None]
    b_t[:, :, :dim] *= alpha
    b_t[:, :, m:m + dim] *= alpha
    return b_t


def slip_blocks(normal: np.ndarray, distance: np.ndarray, overlap: np.ndarray, radius_i: np.ndarray,
                radius_j: np.ndarray, model: ContactModel,
                with_rotation: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What the tangential spring adds when its slip (:func:`_slip_map`) is not the transpose of
    its force's action, B_t with the torques' :func:`lever_arms` (:func:`slip_differs`: YADE's
    history; docs/stressed_contacts.md section 2): (S_ii, S_ij, S_ji, S_jj), each (C, k, k) like
    :func:`pair_blocks`'s, which holds kt B_t^T B_t; the spring is kt B_t^T B_slip, so this is
    kt B_t^T (B_slip - B_t), of size kt xi / r (translations) and kt xi / 2 (rotations), not
    symmetric.
    """
    count, dim = normal.shape
    c_n = _rotation_map(normal)
    m = dim + c_n.shape[2]
    reduced = radius_i * radius_j / (radius_i + radius_j)
    torque = _tangential_map(normal, c_n, *lever_arms(radius_i, radius_j, overlap, model.lever))
    slip = _slip_map(normal, c_n, distance, overlap, radius_i, radius_j, model)
    kt = KN * model.rho * spring_scale(overlap, model.law, reduced)
    full = kt[:, None, None] * np.einsum("cki,ckj->cij", torque, slip - torque)
    k = m if with_rotation else dim
    return full[:, :k, :k], full[:, :k, m:m + k], full[:, m:m + k, :k], full[:, m:m + k, m:m + k]


def stressed_blocks(normal: np.ndarray, distance: np.ndarray, overlap: np.ndarray,
                    radius_i: np.ndarray, radius_j: np.ndarray, tangential: np.ndarray, model: ContactModel,
                    with_rotation: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What stored tangential forces add to the contact blocks (docs/stressed_contacts.md
    section 2): (S_ii, S_ij, S_ji, S_jj), each (C, k, k) like :func:`pair_blocks`'s, with
    S_ji != S_ij^T in general (no energy: LAMMPS's history update).

    tangential : (C, D) the stored tangential force f_t on i from j (units kn d0; perpendicular
    to ``normal``).  With G = n f_t^T / r + c f_t n^T and T = [f_t]_x P / r + c (n x f_t) n^T
    (c = :func:`tangential_growth` of ``model.law``),
    the rows of u_i gain (G, -G) on the columns of (u_i, u_j), the rows of u_j (-G, G), those of
    theta_i R_i (-T, T), those of theta_j R_j (-T, T); no column of a rotation gains anything (but
    under history: yade).
    Under ``model.lever`` = contact the arms are l = R - xi/2 (:func:`lever_arms`) and, since they
    shorten as the overlap grows, each torque row gains -1/2 (n x f_t) n^T on the columns of u_i
    (+ on u_j): l T becomes l T - (n x f_t) n^T / 2.  Under ``model.history`` = yade (3D) the
    stored force also turns about n by the pair's mean spin, f_t += 1/2 n.(theta_i + theta_j)
    n x f_t: the rows of u_i gain -W/2 on both rotation columns (u_j: +W/2) with W = (n x f_t) n^T,
    those of theta_i -l_i f_t n^T / 2 (theta_j: -l_j f_t n^T / 2).  Zero forces add exact zeros.
    """
    count, dim = normal.shape
    rot = _rotation_map(normal).shape[2]
    c = tangential_growth(overlap, model.law)[:, None, None]
    proj = np.eye(dim)[None] - normal[:, :, None] * normal[:, None, :]
    g = (normal[:, :, None] * tangential[:, None, :] / distance[:, None, None]
         + c * tangential[:, :, None] * normal[:, None, :])
    turn = cross(normal, tangential).reshape(count, rot)[:, :, None] * normal[:, None, :]  # (n x f_t) n^T
    t = np.einsum("crd,cde->cre", _cross_matrix(tangential), proj) / distance[:, None, None] + c * turn
    m = dim + rot if with_rotation else dim
    blocks = [np.zeros((count, m, m)) for _ in range(4)]  # ii, ij, ji, jj
    for block, sign in zip(blocks, (1.0, -1.0, -1.0, 1.0)):
        block[:, :dim, :dim] = sign * g
    if with_rotation:
        shorten = 0.5 * turn if model.lever == "contact" else 0.0
        arm_i, arm_j = lever_arms(radius_i, radius_j, overlap, model.lever)
        for block, arm, sign in zip(blocks, (arm_i, arm_i, arm_j, arm_j), (-1.0, 1.0, -1.0, 1.0)):
            block[:, dim:, :dim] = sign * (arm[:, None, None] * t - shorten)
        if model.history == "yade" and dim == 3:  # the twist turn; in 2D n.theta = 0
            spin = 0.5 * tangential[:, :, None] * normal[:, None, :]  # f_t n^T / 2
            for block, arm, sign in zip(blocks, (arm_i, arm_i, arm_j, arm_j), (-1.0, -1.0, 1.0, 1.0)):
                block[:, :dim, dim:] = sign * 0.5 * turn
                block[:, dim:, dim:] = -arm[:, None, None] * spin
    return tuple(blocks)


def sliding_blocks(normal: np.ndarray, distance: np.ndarray, overlap: np.ndarray, radius_i: np.ndarray,
                   radius_j: np.ndarray, tangential: np.ndarray, model: ContactModel,
                   with_rotation: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What turns the stick blocks (:func:`pair_blocks` + :func:`stressed_blocks`) of contacts at
    the Coulomb limit, |f_t| = mu f_n, into their sliding branch (``model.mobilised: slide``;
    docs/stressed_contacts.md section 5): (S_ii, S_ij, S_ji, S_jj), each (C, k, k).

    LAMMPS rescales a trial force above the cone back onto it, f_t = mu f_n(xi) s^ with s^ the
    trial's direction; to first order the stick increment keeps its part across s^ and its part
    along s^ becomes mu df_n/dxi dxi (the cone growing with the load).  With w = kt B_t^T s^ +
    mu (c f_n - kn') (n, 0, -n, 0) (c = :func:`tangential_growth`, kn' = df_n/dxi; B_t the
    :func:`_slip_map`), the rows of
    u_i gain -s^ w^T, those of u_j + s^ w^T, those of theta_i R_i (n x s^) w^T, those of theta_j
    R_j (n x s^) w^T.  Valid for increments that load the contact along s^ (it slides); an
    unloading one sticks.  ``tangential`` (C, D) the stored forces, all non-zero.
    """
    count, dim = normal.shape
    c_n = _rotation_map(normal)
    rot = c_n.shape[2]
    m = dim + rot
    reduced = radius_i * radius_j / (radius_i + radius_j)
    size = np.linalg.norm(tangential, axis=1)
    slip = tangential / size[:, None]
    fn = normal_force(overlap, model.law, reduced)
    mu = size / fn  # at the limit: |f_t| = mu f_n
    kt = KN * model.rho * spring_scale(overlap, model.law, reduced)
    arm_i, arm_j = lever_arms(radius_i, radius_j, overlap, model.lever)
    w = kt[:, None] * np.einsum("cdk,cd->ck", _slip_map(normal, c_n, distance, overlap, radius_i, radius_j, model),
                                slip)
    load = mu * (tangential_growth(overlap, model.law) * fn - normal_stiffness(overlap, model.law, reduced))
    w[:, :dim] += load[:, None] * normal
    w[:, m:m + dim] -= load[:, None] * normal
    turn = cross(normal, slip).reshape(count, rot)  # n x s^
    k = m if with_rotation else dim
    keep = np.r_[0:k, m:m + k]
    w = w[:, keep]
    blocks = []
    for sign_u, radius in ((-1.0, arm_i), (1.0, arm_j)):
        rows = np.zeros((count, k, 2 * k))
        rows[:, :dim] = sign_u * slip[:, :, None] * w[:, None, :]
        if with_rotation:
            rows[:, dim:] = radius[:, None, None] * turn[:, :, None] * w[:, None, :]
        blocks += [rows[:, :, :k], rows[:, :, k:]]
    return tuple(blocks)  # ii, ij, ji, jj


def damping_blocks(normal: np.ndarray, overlap: np.ndarray, radius_i: np.ndarray, radius_j: np.ndarray,
                   m_eff: np.ndarray, model: ContactModel,
                   with_rotation: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Blocks (C_ii, C_ij, C_jj), each (C, k, k) like :func:`pair_blocks`' (C_ji = C_ij^T), of the
    contact dashpots in LAMMPS's gran/hooke/history and gran/hertz/history convention
    (docs/damping.md): the force on i is -s m_eff (gamma_n v_n + gamma_t v_t), with
    m_eff = m_i m_j / (m_i + m_j) (``m_eff`` (C,)), v_n = n n^T (v_i - v_j), v_t = B_t (v_i, w_i,
    v_j, w_j) the tangential spring's map (the contact point's relative tangential velocity, arms
    :func:`lever_arms`), the torques from the tangential part through the same arms, and
    s = :func:`spring_scale` (1, or LAMMPS's Hertz factor sqrt(a' xi)).  So
    C = s m_eff (gamma_n B_n^T B_n + gamma_t B_t^T B_t), B_n = [n^T, 0, -n^T, 0]: symmetric,
    positive semi-definite, with no geometric term (a dashpot carries no force at rest).
    """
    count, dim = normal.shape
    c_n = _rotation_map(normal)
    m = dim + c_n.shape[2]
    b_n = np.zeros((count, 1, 2 * m))
    b_n[:, 0, :dim], b_n[:, 0, m:m + dim] = normal, -normal
    b_t = _tangential_map(normal, c_n, *lever_arms(radius_i, radius_j, overlap, model.lever))
    scale = m_eff * spring_scale(overlap, model.law, radius_i * radius_j / (radius_i + radius_j))
    full = scale[:, None, None] * (model.gamma_n * np.einsum("cki,ckj->cij", b_n, b_n)
                                   + model.gamma_t * np.einsum("cki,ckj->cij", b_t, b_t))
    k = m if with_rotation else dim
    return full[:, :k, :k], full[:, :k, m:m + k], full[:, m:m + k, m:m + k]


RESTITUTION_M_EFF = 0.5
"""Reduced mass of the collision ``model.restitution`` refers to: two particles of the mean mass 1."""

RESTITUTION_RULE = (f"gamma_n = 2 omega_0 (-ln e) / sqrt(pi^2 + ln^2 e), omega_0 = sqrt(kn / m_eff), m_eff = "
                    f"{RESTITUTION_M_EFF:g}: a head-on collision of two particles of the mean mass under the harmonic "
                    f"law, in contact until the overlap is zero again (LAMMPS's convention; docs/damping.md section 5)")
"""How :func:`restitution_damping` derives gamma_n, in words, for the log and the results file."""


def restitution_damping(restitution: float, m_eff: float = RESTITUTION_M_EFF) -> float:
    """gamma_n (1/t0) of the harmonic normal dashpot that gives a binary collision of reduced mass
    ``m_eff`` (default: two particles of the mean mass 1) the normal coefficient of restitution
    e = ``restitution`` in (0, 1], in LAMMPS's convention (docs/damping.md section 5): the overlap
    obeys xi'' + gamma_n xi' + omega_0^2 xi = 0, omega_0^2 = kn / m_eff, the contact lasts half a
    damped period pi / omega_d (LAMMPS lets the force turn attractive until xi = 0), so
    e = exp(-gamma_n pi / (2 omega_d)) and gamma_n = 2 omega_0 (-ln e) / sqrt(pi^2 + ln^2 e)."""
    log = np.log(restitution)
    return float(2.0 * np.sqrt(KN / m_eff) * -log / np.sqrt(np.pi**2 + log**2))


# --- a particle against a flat immovable wall (docs/walls.md) -------------------------------------
# The pair law with the other body immovable and of infinite radius: a' = R, no geometric term (a
# flat wall's normal does not turn), the rotations the particle's own; the tangential force acts at
# the lever of ``model.lever`` (``wall_arm``: R, LAMMPS's fix wall/gran; R - xi/2, LIGGGHTS's).

def wall_arm(radius: np.ndarray, overlap: np.ndarray, lever: str) -> np.ndarray:
    """(K,) distance from the particle's centre to where a wall's tangential force acts: R
    (``radius``: LAMMPS's fix wall/gran) or R - xi/2 (``contact``: LIGGGHTS's fix wall/gran
    primitive walls, its surface model's contact radius; docs/walls.md section 7)."""
    return lever_arms(radius, radius, overlap, lever)[0]


def _wall_maps(normal: np.ndarray, radius: np.ndarray, arm: np.ndarray) -> list[tuple[str, np.ndarray]]:
    """The wall contact's stretches as linear maps of the particle's (u, theta): [(spring, B (K, k, m))]
    for the tangential s_t = P u - l theta x n (l = ``arm``, :func:`wall_arm`), rolling
    s_r = R theta x n and (3D) twisting s_o = R n . theta, m = D + r."""
    count, dim = normal.shape
    c_n = _rotation_map(normal)
    m = dim + c_n.shape[2]
    b_t = np.zeros((count, dim, m))
    b_t[:, :, :dim] = np.eye(dim)[None] - normal[:, :, None] * normal[:, None, :]
    b_t[:, :, dim:] = -arm[:, None, None] * c_n
    b_r = np.zeros((count, dim, m))
    b_r[:, :, dim:] = radius[:, None, None] * c_n
    maps = [("rho", b_t), ("rho_roll", b_r)]
    if dim == 3:
        b_o = np.zeros((count, 1, m))
        b_o[:, 0, dim:] = radius[:, None] * normal
        maps.append(("rho_twist", b_o))
    return maps


def wall_energy(normal: np.ndarray, overlap: np.ndarray, radius: np.ndarray, model: ContactModel,
                u: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Energy (K,) of wall contacts (reference ``normal`` (K, D) from the wall into the particle,
    ``overlap`` (K,) xi, ``radius`` (K,) R) after the particle moves by u (K, D) and turns by theta
    ((K,) in 2D, (K, 3) in 3D): the normal energy at xi - n.u (exact: the wall is flat) with
    a' = R, plus kt |s_t|^2/2 + kr |s_r|^2/2 + ko s_o^2/2 scaled by :func:`spring_scale`."""
    _refuse_twist_in_2d(normal, model)
    energy = normal_energy(np.maximum(overlap - np.einsum("kd,kd->k", normal, u), 0.0), model.law, radius)
    x = np.concatenate((u, _rotations(theta)), axis=1)
    scale = spring_scale(overlap, model.law, radius)
    for name, b in _wall_maps(normal, radius, wall_arm(radius, overlap, model.lever)):
        stretch = np.einsum("kij,kj->ki", b, x)
        energy = energy + 0.5 * KN * getattr(model, name) * scale * np.einsum("ki,ki->k", stretch, stretch)
    return energy


def wall_blocks(normal: np.ndarray, overlap: np.ndarray, radius: np.ndarray, model: ContactModel,
                with_rotation: bool = True) -> np.ndarray:
    """The self blocks (K, k, k) the wall contacts add to their particles' rows of D (k as in
    :func:`pair_blocks`): k_n n n^T on the translations (k_n = df_n/dxi at a' = R, no geometric
    term) plus kx B^T B for each spring's map B (:func:`_wall_maps`), the Hessian of
    :func:`wall_energy` (docs/walls.md section 3)."""
    _refuse_twist_in_2d(normal, model)
    count, dim = normal.shape
    maps = _wall_maps(normal, radius, wall_arm(radius, overlap, model.lever))
    m = maps[0][1].shape[2]
    full = np.zeros((count, m, m))
    full[:, :dim, :dim] = (normal_stiffness(overlap, model.law, radius)[:, None, None]
                           * normal[:, :, None] * normal[:, None, :])
    scale = spring_scale(overlap, model.law, radius)
    for name, b in maps:
        ratio = getattr(model, name)
        if ratio:
            full += KN * ratio * scale[:, None, None] * np.einsum("cki,ckj->cij", b, b)
    k = m if with_rotation else dim
    return full[:, :k, :k]


def wall_stressed_blocks(normal: np.ndarray, overlap: np.ndarray, radius: np.ndarray, tangential: np.ndarray,
                         model: ContactModel, with_rotation: bool = True) -> np.ndarray:
    """What stored tangential forces ``tangential`` (K, D) on the particles from their walls add to
    the self blocks (K, k, k), in LAMMPS's history convention (docs/walls.md sections 4 and 7): the
    wall's normal does not turn, so only the Hertz stiffness' growth with the overlap remains, with
    c = :func:`tangential_growth`: the rows of u gain c f_t n^T, those of theta -l c (n x f_t) n^T
    on the columns of u (l = :func:`wall_arm`); under ``model.lever`` = contact the lever
    l = R - xi/2 also grows as the particle leaves the wall, adding (n x f_t) n^T / 2 to those rows.
    Zero under the harmonic law with the lever R."""
    count, dim = normal.shape
    rot = _rotation_map(normal).shape[2]
    c = tangential_growth(overlap, model.law)[:, None, None]
    m = dim + rot if with_rotation else dim
    block = np.zeros((count, m, m))
    block[:, :dim, :dim] = c * tangential[:, :, None] * normal[:, None, :]
    if with_rotation:
        turn = cross(normal, tangential).reshape(count, rot)[:, :, None] * normal[:, None, :]  # (n x f_t) n^T
        lengthen = 0.5 if model.lever == "contact" else 0.0
        block[:, dim:, :dim] = (lengthen - wall_arm(radius, overlap, model.lever)[:, None, None] * c) * turn
    return block


def wall_damping_blocks(normal: np.ndarray, overlap: np.ndarray, radius: np.ndarray, mass: np.ndarray,
                        model: ContactModel, with_rotation: bool = True) -> np.ndarray:
    """The dashpots' self blocks (K, k, k) of wall contacts (LAMMPS's fix wall/gran: m_eff = m_i,
    ``mass`` (K,)): s m (gamma_n n n^T + gamma_t B_t^T B_t), B_t the tangential map of
    :func:`_wall_maps`, s = :func:`spring_scale` at a' = R (docs/walls.md section 5)."""
    count, dim = normal.shape
    b_t = _wall_maps(normal, radius, wall_arm(radius, overlap, model.lever))[0][1]
    m = b_t.shape[2]
    b_n = np.zeros((count, 1, m))
    b_n[:, 0, :dim] = normal
    scale = mass * spring_scale(overlap, model.law, radius)
    full = scale[:, None, None] * (model.gamma_n * np.einsum("cki,ckj->cij", b_n, b_n)
                                   + model.gamma_t * np.einsum("cki,ckj->cij", b_t, b_t))
    k = m if with_rotation else dim
    return full[:, :k, :k]
