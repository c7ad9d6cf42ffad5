"""Distributed dynamical matrix D and mass vector M of a packing (PETSc): the paper's eq:motion
M u'' = -D u with the mass matrix eq:mm, D the Hessian of the contact energy eq:eij (in 3D and
with rolling and twisting springs, PHYSICS.md section 8) summed over contacts (blocks from
``contact_law``), plus, on a packing made with friction, the non-symmetric terms of its stored
tangential forces (docs/stressed_contacts.md), and on a wet packing (``model.cohesion``) the
capillary bridges' pull on every contact and on the bridged pairs across a gap
(``Packing.bridges``; docs/capillary_bridges.md).

DOF order: the non-rattler particles in the matrix's order (:func:`matrix_order`: by cells in
space, so that each rank's contiguous rows are a slab of the box and couple to its two
neighbouring slabs only, whatever order a packing file lists its particles in; the packing's own
order for rotsound's packings, which are stored in that order), each with its D translations,
then its rotations (D = 2: (u_x, u_y, theta); D = 3: (u_x, u_y, u_z, theta_x, theta_y, theta_z)).
``DynamicalMatrix.order`` maps matrix particles to packing particles; results laid over particles
(mode shapes, snapshots) are in packing order (:func:`over_particles`).
Decision: rotations are in the matrix whenever any rotational spring of the contact model is on
(rho, rho_roll or rho_twist > 0: ``ContactModel.rotations``). With none (frictionless, rho = 0)
they carry no stiffness, so they are dropped and the matrix is the D N' x D N' translational
block -- the free rotations never appear as spurious zero modes. Rattlers are excluded. Each
rank owns a contiguous range of matrix particles (``dof`` rows each), finds the contacts touching
its rows among its particles and their neighbouring cells only (``geometry.find_contacts_touching``:
no rank searches the whole packing), computes their blocks (vectorised) and inserts only its own rows, with exact preallocation from the
local CSR pattern.
Units: m = d0 = kn = 1; M = diag(m, ..., I_i, ...) with I_i = m d_i^2 / 8 (disk) or
m d_i^2 / 10 (sphere).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .. import parallel
from .. import profiling
from ..packing import geometry
from .. import contact_law
from ..contact_law import ContactModel
from ..packing import bridges, stressed, walls
from ..packing.configuration import Packing
from ..packing.jammed import spatial_order

MASS = 1.0


@dataclass
class DynamicalMatrix:
    """D (PETSc Mat, block size ``dof``), M (PETSc Vec) and the DOF bookkeeping.

    active : (N,) bool, particles in the matrix;  order : (N_active,) int, the packing index of
    each matrix particle (:func:`matrix_order`);  dim : D (2 or 3);  dof : DOF per particle,
    D translations then (with rotations) 1 (2D) or 3 (3D) rotations;  model : the contact model
    it was assembled with;  disk_range : this rank's [start, stop) among matrix particles;
    n_contacts : global count;  symmetric : False for a stressed packing (stored tangential
    forces) or under YADE's history, whose D has no symmetry (docs/stressed_contacts.md
    sections 2 and 4).
    """

    D: object
    M: object
    active: np.ndarray
    order: np.ndarray
    dof: int
    model: ContactModel
    disk_range: tuple[int, int]
    n_contacts: int
    dim: int = 2
    symmetric: bool = True
    omega_max: float | None = None  # cached by operators.largest_omega
    wmax_settings: dict | None = None  # what its wmax_ EPS used (operators.largest_omega)
    scaled: object | None = None     # M^-1/2 D M^-1/2, cached by waves.spectral
    C: object | None = None          # the dashpots' damping matrix (model.damping: model/damping.py)
    damping_max: float | None = None  # largest eigenvalue of M^-1 C (1/t0), cached by operators
    range_planes: object | None = None  # half-planes about the numerical range of (A, C^), cached by pep windows
    wall_axes: tuple[int, ...] = ()   # the normals' axes of the wall contacts (``held_axes``): docs/walls.md

    @property
    def size(self) -> int:
        return int(self.active.sum()) * self.dof

    @property
    def rotations(self) -> bool:
        """Whether the matrix has rotational DOF (some rotational spring is on)."""
        return self.dof > self.dim

    def rigid_modes(self) -> list[tuple[int, str]]:
        """The exact zero modes of every packing's D, as (DOF slot, name): the uniform translation
        along each axis, and -- with rotations but no tangential spring (rho = 0) -- the uniform
        spin about each rotation axis, which rolling and twisting springs do not resist
        (PHYSICS.md section 8).  Between walls (``wall_axes``, docs/walls.md section 6) the walls
        hold the translation along their normals, and with a tangential spring every translation;
        with rolling springs a spin about an axis other than their normals (2D: the spin), with
        twisting springs a spin about their normals.  Slot s means the vector with 1 in DOF s of
        every particle.  Not collective."""
        names = "xyz"
        walled = bool(self.wall_axes)
        modes = [(axis, f"translation {names[axis]}") for axis in range(self.dim)
                 if axis not in self.wall_axes and not (walled and self.model.rho > 0.0)]
        if self.rotations and self.model.rho == 0.0:
            spins = [2] if self.dim == 2 else [0, 1, 2]
            for k, axis in enumerate(spins):
                rolled = self.model.rho_roll > 0.0 and any(w != axis for w in self.wall_axes)
                twisted = self.dim == 3 and self.model.rho_twist > 0.0 and axis in self.wall_axes
                if not (rolled or twisted):
                    modes.append((self.dim + k, f"spin {names[axis]}"))
        return modes

    def destroy(self) -> None:
        """Free the PETSc objects. Collective."""
        self.D.destroy()
        self.M.destroy()
        for extra in (self.scaled, self.C):
            if extra is not None:
                extra.destroy()


def dof_per_particle(dim: int, model: ContactModel) -> int:
    """DOF per particle: D translations, plus 1 (2D) or 3 (3D) rotations when any rotational
    spring of ``model`` is on. Not collective."""
    return dim + (dim * (dim - 1) // 2 if model.rotations else 0)


MASS_RULES = ("equal", "density")


def particle_masses(packing: Packing, rule: str = "equal") -> np.ndarray:
    """Masses (N,) of every particle under ``model.masses`` = ``rule``. Not collective.

    equal: m = 1 for all (the paper's).  density: the masses the packing's file holds, else
    m proportional to d^D (one density for all), in both cases scaled so that the mean over all
    N particles (rattlers included) is 1: the unit of mass stays the mean mass, so t0 = sqrt(m0/kn)
    keeps its meaning and an equal-size packing gives the same matrix under both rules.
    """
    if rule == "equal":
        return np.full(packing.n, MASS)
    raw = packing.masses if packing.masses is not None else packing.diameters ** packing.dim
    return MASS * raw / raw.mean()


def mass_diagonal(diameters: np.ndarray, masses: np.ndarray, dim: int, dof: int) -> np.ndarray:
    """Diagonal of M (len(diameters) * dof,): m_i on translations, I_i = m_i d_i^2 / 8 (disk) or
    m_i d_i^2 / 10 (sphere) on rotations (eq:mm)."""
    diag = np.empty((diameters.size, dof))
    diag[:, :dim] = masses[:, None]
    if dof > dim:
        diag[:, dim:] = (masses * diameters**2 / (8.0 if dim == 2 else 10.0))[:, None]
    return diag.ravel()


@dataclass
class LocalContacts:
    """The contacts that touch a rank's rows: ``found`` (``geometry.find_contacts_touching`` among
    active particles: packing indices); ``a``, ``b`` their ends as matrix particles;
    ``geometry_args`` (normal, distance, overlap, R_i, R_j) of those contacts; ``first`` (C,) bool:
    the rank owns the contact's lower matrix particle (each contact is first on one rank only)."""

    found: object
    a: np.ndarray
    b: np.ndarray
    geometry_args: tuple
    first: np.ndarray


def matrix_order(packing: Packing) -> np.ndarray:
    """The packing indices (N_active,) of the non-rattlers in the matrix's order: sorted by the cells
    of ``jammed.spatial_order`` (2D: strips along y, by x in a strip; 3D: slabs along z, strips
    along y, by x), rattlers dropped.  The identity on the non-rattlers for packings stored in that
    order (every packing rotsound makes).  Not collective; the same on every rank."""
    order = spatial_order(packing.positions, packing.cell)
    return order[~packing.rattler[order]]


def local_contacts(packing: Packing, order: np.ndarray, disk_range: tuple[int, int]) -> LocalContacts:
    """The contacts touching the matrix particles ``disk_range`` owns (of ``order``, :func:`matrix_order`),
    searched among those particles and their neighbours' cells only; their ends as matrix
    particles. Not collective."""
    start, stop = disk_range
    owned = np.zeros(packing.n, dtype=bool)
    owned[order[start:stop]] = True
    found = geometry.find_contacts_touching(packing.positions, packing.diameters, packing.cell, owned,
                                            ~packing.rattler)
    index = np.full(packing.n, -1)
    index[order] = np.arange(order.size)  # packing particle -> matrix particle
    a, b = index[found.i], index[found.j]
    radius = 0.5 * packing.diameters
    return LocalContacts(found, a, b, (found.normal, found.distance, found.overlap, radius[found.i], radius[found.j]),
                         (np.minimum(a, b) >= start) & (np.minimum(a, b) < stop))


def blocks_csr(a: np.ndarray, b: np.ndarray, blocks: tuple, disk_range: tuple[int, int], dof: int,
               n_active: int) -> sp.csr_matrix:
    """The rows owned by ``disk_range`` (local rows x global columns) of the matrix summed from
    per-contact blocks (X_ii, X_ij, X_ji, X_jj), each (C, dof, dof), of contacts (a, b) (positions
    among the ``n_active`` active particles). Not collective."""
    start, stop = disk_range
    x_ii, x_ij, x_ji, x_jj = blocks
    block_rows = np.concatenate((a, a, b, b))
    block_cols = np.concatenate((a, b, b, a))
    stacked = np.concatenate((x_ii, x_ij, x_jj, x_ji))
    own = (block_rows >= start) & (block_rows < stop)
    block_rows, block_cols, stacked = block_rows[own], block_cols[own], stacked[own]
    k = np.arange(dof)
    rows = ((block_rows - start)[:, None, None] * dof + k[:, None]).repeat(dof, axis=2)
    cols = (block_cols[:, None, None] * dof + k[None, :]).repeat(dof, axis=1)
    csr = sp.coo_matrix((stacked.ravel(), (rows.ravel(), cols.ravel())),
                        shape=((stop - start) * dof, n_active * dof)).tocsr()
    csr.sum_duplicates()
    csr.sort_indices()
    return csr


def local_csr(packing: Packing, model: ContactModel, order: np.ndarray, disk_range: tuple[int, int]
              ) -> tuple[sp.csr_matrix, int, int]:
    """Rows of D owned by ``disk_range`` of the matrix particles ``order`` as a CSR (local rows x
    global columns).

    Returns (csr, dof, number of contacts whose lower matrix particle ``disk_range`` holds: summed
    over the ranks, every contact once).  Not collective.
    """
    dof = dof_per_particle(packing.dim, model)
    contacts = local_contacts(packing, order, disk_range)
    found, geometry_args = contacts.found, contacts.geometry_args
    h_ii, h_ij, h_jj = contact_law.pair_blocks(*geometry_args, model, with_rotation=dof > packing.dim)
    h_ji = np.transpose(h_ij, (0, 2, 1))
    if contact_law.slip_differs(model):  # YADE's slip: not the transpose of the force's action
        s_ii, s_ij, s_ji, s_jj = contact_law.slip_blocks(*geometry_args, model, with_rotation=dof > packing.dim)
        h_ii, h_ij, h_ji, h_jj = h_ii + s_ii, h_ij + s_ij, h_ji + s_ji, h_jj + s_jj
    if packing.tangential is not None and model.stored_forces == "keep":  # the non-symmetric part
        stored = packing.tangential.on(found.i, found.j)
        s_ii, s_ij, s_ji, s_jj = contact_law.stressed_blocks(*geometry_args, stored, model,
                                                             with_rotation=dof > packing.dim)
        h_ii, h_ij, h_ji, h_jj = h_ii + s_ii, h_ij + s_ij, h_ji + s_ji, h_jj + s_jj
        if model.mobilised == "slide":  # contacts at the Coulomb limit take their sliding branch
            limit = stressed.at_limit(stored, np.stack((found.i, found.j), 1), found.overlap,
                                      packing.diameters, model.law, packing.tangential.friction)
            slide = contact_law.sliding_blocks(*(a[limit] for a in geometry_args), stored[limit], model,
                                               with_rotation=dof > packing.dim)
            for block, extra in zip((h_ii, h_ij, h_ji, h_jj), slide):
                block[limit] += extra
    a, b = contacts.a, contacts.b
    if packing.walls is not None:  # each wall contact adds its particle's self block (docs/walls.md)
        owner, w_ii = _wall_blocks(packing, model, order, disk_range, dof > packing.dim)
        zero = np.zeros_like(w_ii)
        a, b = np.concatenate((a, owner)), np.concatenate((b, owner))
        h_ii, h_ij, h_ji, h_jj = (np.concatenate(pair) for pair in ((h_ii, w_ii), (h_ij, zero), (h_ji, zero), (h_jj, zero)))
    if model.cohesion is not None and packing.bridges is not None:  # bridged pairs across a gap
        bridged, (g_ii, g_ij, g_jj) = _gap_bridges(packing, model, order, disk_range, dof > packing.dim)
        a, b = np.concatenate((a, bridged[:, 0])), np.concatenate((b, bridged[:, 1]))
        h_ii, h_ij, h_ji, h_jj = (np.concatenate(pair) for pair in
                                  ((h_ii, g_ii), (h_ij, g_ij), (h_ji, np.transpose(g_ij, (0, 2, 1))), (h_jj, g_jj)))
    csr = blocks_csr(a, b, (h_ii, h_ij, h_ji, h_jj), disk_range, dof, int((~packing.rattler).sum()))
    return csr, dof, int(contacts.first.sum())


def owned_wall_contacts(packing: Packing, order: np.ndarray, disk_range: tuple[int, int]):
    """(the wall contacts (``walls.Touching``) of the matrix particles ``disk_range`` owns, their
    matrix particles (K,)). Not collective."""
    start, stop = disk_range
    owned = np.zeros(packing.n, dtype=bool)
    owned[order[start:stop]] = True
    touch = walls.touching(packing.positions, packing.diameters, packing.walls, owned & ~packing.rattler)
    index = np.full(packing.n, -1)
    index[order] = np.arange(order.size)
    return touch, index[touch.particle]


def _wall_blocks(packing: Packing, model: ContactModel, order: np.ndarray, disk_range: tuple[int, int],
                 with_rotation: bool) -> tuple[np.ndarray, np.ndarray]:
    """The wall contacts' self blocks (K, k, k) (``contact_law.wall_blocks``, plus the stored
    tangential forces' ``wall_stressed_blocks`` when the model keeps them) of the matrix particles
    ``disk_range`` owns, and those particles (K,).  Not collective."""
    touch, owner = owned_wall_contacts(packing, order, disk_range)
    radius = 0.5 * packing.diameters[touch.particle]
    blocks = contact_law.wall_blocks(touch.normal, touch.overlap, radius, model, with_rotation)
    if packing.wall_contacts is not None and model.stored_forces == "keep":
        stored = packing.wall_contacts.on(touch.particle, touch.wall)
        blocks = blocks + contact_law.wall_stressed_blocks(touch.normal, touch.overlap, radius, stored, model,
                                                           with_rotation)
    return owner, blocks


def held_axes(packing: Packing) -> tuple[int, ...]:
    """The axes of the walls some non-rattler touches (the normals of its wall contacts). Not collective."""
    touch = walls.touching(packing.positions, packing.diameters, packing.walls, ~packing.rattler)
    return tuple(int(a) for a in np.unique(packing.walls.axis[touch.wall])) if len(touch) else ()


def _gap_bridges(packing: Packing, model: ContactModel, order: np.ndarray, disk_range: tuple[int, int],
                 with_rotation: bool) -> tuple[np.ndarray, tuple]:
    """The bridged pairs across a gap (``Packing.bridges``) with an end among the matrix particles
    ``disk_range`` owns, as matrix particles (B, 2), and their blocks (H_ii, H_ij, H_jj) under
    ``model`` (its cohesion's pull alone: no spring acts across a gap; docs/capillary_bridges.md).
    Not collective."""
    start, stop = disk_range
    owned = np.zeros(packing.n, dtype=bool)
    owned[order[start:stop]] = True
    pairs = packing.bridges[bridges.rank_share(packing.bridges, owned, ~packing.rattler)]
    normal, distance, overlap = geometry.pair_geometry(packing.positions, packing.diameters, packing.cell, pairs)
    radius = 0.5 * packing.diameters
    blocks = contact_law.pair_blocks(normal, distance, overlap, radius[pairs[:, 0]], radius[pairs[:, 1]], model,
                                     with_rotation=with_rotation)
    index = np.full(packing.n, -1)
    index[order] = np.arange(order.size)
    return index[pairs], blocks


@profiling.logged("rsAssemble")
def assemble(packing: Packing, model: ContactModel, comm, mass_rule: str = "equal") -> DynamicalMatrix:
    """Assemble D and M of ``packing`` (2D or 3D) with the springs and normal law of ``model``
    (``contact_law``), masses by ``mass_rule`` (:func:`particle_masses`), on ``comm`` (PETSc
    communicator). Collective.

    D is flagged symmetric (needed by Cholesky-based inertia in the spectrum stage) unless the
    packing is stressed (``Packing.stressed``: stored tangential forces, docs/stressed_contacts.md)
    and ``model.stored_forces`` keeps them, which needs the tangential spring that holds them
    (ValueError at rho = 0), or YADE's history takes its own slip (``contact_law.slip_differs``).
    """
    from petsc4py import PETSc

    stressed = packing.stressed and model.stored_forces == "keep"
    symmetric = not (stressed or contact_law.slip_differs(model))
    if stressed and model.rho == 0.0:
        raise ValueError("a stressed packing's tangential forces need the tangential spring: rho must be > 0")
    active = ~packing.rattler
    order = matrix_order(packing)
    disk_range = parallel.block_range(order.size, comm.tompi4py())
    csr, dof, mine = local_csr(packing, model, order, disk_range)
    n_contacts = comm.tompi4py().allreduce(mine)
    n_global = int(active.sum()) * dof
    n_local = csr.shape[0]
    D = PETSc.Mat().createAIJ(size=((n_local, n_global), (n_local, n_global)), bsize=dof,
                              csr=(csr.indptr.astype(PETSc.IntType), csr.indices.astype(PETSc.IntType),
                                   csr.data), comm=comm)
    D.assemble()
    D.setOption(PETSc.Mat.Option.SYMMETRIC, symmetric)
    D.setOption(PETSc.Mat.Option.SYMMETRY_ETERNAL, True)
    M = D.createVecLeft()
    start, stop = disk_range
    mine = order[start:stop]
    M.setArray(mass_diagonal(packing.diameters[mine], particle_masses(packing, mass_rule)[mine], packing.dim, dof))
    return DynamicalMatrix(D, M, active, order, dof, model, disk_range, n_contacts, packing.dim, symmetric=symmetric,
                           wall_axes=held_axes(packing) if packing.walls is not None else ())


def gather_csr(mat) -> sp.csr_matrix:
    """The whole distributed ``mat`` as a scipy CSR on every rank. Collective (tests, small N)."""
    comm = mat.getComm().tompi4py()
    indptr, indices, data = mat.getValuesCSR()
    parts = comm.allgather((indptr, indices, data))
    n_rows, n_cols = mat.getSize()
    return sp.vstack([sp.csr_matrix((d, i, p), shape=(p.size - 1, n_cols)) for p, i, d in parts]).tocsr()


def over_particles(dm: DynamicalMatrix, rows: np.ndarray) -> np.ndarray:
    """(..., N, dof): the rank-local rows ``rows`` (..., nloc) of vectors on ``dm``'s layout, gathered
    and laid out over every particle of the packing in its order, zero on rattlers (not in the
    matrix).  Collective."""
    whole = np.concatenate(dm.D.getComm().tompi4py().allgather(np.asarray(rows)), axis=-1)
    full = np.zeros(whole.shape[:-1] + (dm.active.size, dm.dof))
    full[..., dm.order, :] = whole.reshape(whole.shape[:-1] + (-1, dm.dof))
    return full


def in_packing_order(dm: DynamicalMatrix, whole):
    """``whole``, a gathered vector (n,) or matrix (n, n) on ``dm``'s rows (:func:`gather_vec`,
    :func:`gather_csr`), with its rows (and columns) in the packing order of the non-rattlers
    instead of the matrix's (:func:`matrix_order`): for checks against references built particle
    by particle. Not collective."""
    rows = (np.argsort(dm.order)[:, None] * dm.dof + np.arange(dm.dof)).ravel()
    return whole[rows] if whole.ndim == 1 else whole[rows][:, rows]


def gather_vec(vec) -> np.ndarray:
    """The whole distributed ``vec`` as a numpy array on every rank. Collective."""
    comm = vec.getComm().tompi4py()
    return np.concatenate(comm.allgather(vec.getArray().copy()))
