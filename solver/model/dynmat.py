"""Distributed dynamical matrix D and mass vector M of a packing (PETSc): the paper's eq:motion
M u'' = -D u with the mass matrix eq:mm, D the Hessian of the contact energy eq:eij summed over
contacts (blocks from ``contact_law``).

DOF order per non-rattler disk, in packing order: (u_x, u_y, theta) for rho > 0.
Decision for rho = 0 (frictionless): rotations carry no stiffness, so they are dropped and the
matrix is the 2N' x 2N' translational block (block size 2) -- the N' free rotations never
appear as spurious zero modes.  Rattlers are excluded.  Each rank owns a contiguous range of
disks (3 or 2 rows each), computes the contact blocks touching its rows (vectorised) and
inserts only its own rows, with exact preallocation from the local CSR pattern.
Units: m = d0 = kn = 1; M = diag(m, m, I_i) with I_i = m d_i^2 / 8.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .. import parallel
from .. import profiling
from ..packing import geometry as contacts
from . import contact_law
from ..packing.jammed import Packing

MASS = 1.0


@dataclass
class DynamicalMatrix:
    """D (PETSc Mat, block size ``dof``), M (PETSc Vec) and the DOF bookkeeping.

    active : (N,) bool, disks in the matrix;  dof : 3 (x, y, theta) or 2 (rho = 0);
    disk_range : this rank's [start, stop) among active disks;  n_contacts : global count.
    """

    D: object
    M: object
    active: np.ndarray
    dof: int
    rho: float
    disk_range: tuple[int, int]
    n_contacts: int
    omega_max: float | None = None  # cached by operators.largest_omega
    wmax_settings: dict | None = None  # what its wmax_ EPS used (operators.largest_omega)
    scaled: object | None = None     # M^-1/2 D M^-1/2, cached by waves.spectral

    @property
    def size(self) -> int:
        return int(self.active.sum()) * self.dof

    def destroy(self) -> None:
        """Free the PETSc objects. Collective."""
        self.D.destroy()
        self.M.destroy()
        if self.scaled is not None:
            self.scaled.destroy()


def mass_diagonal(diameters: np.ndarray, dof: int) -> np.ndarray:
    """Diagonal of M for the given disks, (len(diameters) * dof,)."""
    diag = np.empty((diameters.size, dof))
    diag[:, :2] = MASS
    if dof == 3:
        diag[:, 2] = MASS * diameters**2 / 8.0
    return diag.ravel()


def local_csr(packing: Packing, rho: float, disk_range: tuple[int, int]
              ) -> tuple[sp.csr_matrix, int, int]:
    """Rows of D owned by ``disk_range`` as a CSR (local rows x global columns).

    Returns (csr, dof, global number of contacts).  Not collective.
    """
    active = ~packing.rattler
    dof = 3 if rho > 0.0 else 2
    index = np.cumsum(active) - 1  # disk -> position among active disks
    found = contacts.find_contacts(packing.positions, packing.diameters, packing.box_length, active)
    a, b = index[found.i], index[found.j]
    start, stop = disk_range
    touch = ((a >= start) & (a < stop)) | ((b >= start) & (b < stop))
    a, b = a[touch], b[touch]
    radius = 0.5 * packing.diameters
    h_ii, h_ij, h_jj = contact_law.pair_blocks(
        found.normal[touch], found.distance[touch], found.overlap[touch],
        radius[found.i[touch]], radius[found.j[touch]], rho, with_rotation=dof == 3)
    block_rows = np.concatenate((a, a, b, b))
    block_cols = np.concatenate((a, b, b, a))
    blocks = np.concatenate((h_ii, h_ij, h_jj, np.transpose(h_ij, (0, 2, 1))))
    own = (block_rows >= start) & (block_rows < stop)
    block_rows, block_cols, blocks = block_rows[own], block_cols[own], blocks[own]
    k = np.arange(dof)
    rows = ((block_rows - start)[:, None, None] * dof + k[:, None]).repeat(dof, axis=2)
    cols = (block_cols[:, None, None] * dof + k[None, :]).repeat(dof, axis=1)
    n_rows, n_cols = (stop - start) * dof, int(active.sum()) * dof
    csr = sp.coo_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())),
                        shape=(n_rows, n_cols)).tocsr()
    csr.sum_duplicates()
    csr.sort_indices()
    return csr, dof, len(found)


@profiling.logged("rsAssemble")
def assemble(packing: Packing, rho: float, comm) -> DynamicalMatrix:
    """Assemble D and M on ``comm`` (PETSc communicator). Collective.

    D is flagged symmetric (needed by Cholesky-based inertia in the spectrum stage).
    """
    from petsc4py import PETSc

    active = ~packing.rattler
    disk_range = parallel.block_range(int(active.sum()), comm.tompi4py())
    csr, dof, n_contacts = local_csr(packing, rho, disk_range)
    n_global = int(active.sum()) * dof
    n_local = csr.shape[0]
    D = PETSc.Mat().createAIJ(size=((n_local, n_global), (n_local, n_global)), bsize=dof,
                              csr=(csr.indptr.astype(PETSc.IntType), csr.indices.astype(PETSc.IntType),
                                   csr.data), comm=comm)
    D.assemble()
    D.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    D.setOption(PETSc.Mat.Option.SYMMETRY_ETERNAL, True)
    M = D.createVecLeft()
    start, stop = disk_range
    M.setArray(mass_diagonal(packing.diameters[active][start:stop], dof))
    return DynamicalMatrix(D, M, active, dof, rho, disk_range, n_contacts)


def gather_csr(mat) -> sp.csr_matrix:
    """The whole distributed ``mat`` as a scipy CSR on every rank. Collective (tests, small N)."""
    comm = mat.getComm().tompi4py()
    indptr, indices, data = mat.getValuesCSR()
    parts = comm.allgather((indptr, indices, data))
    n_rows, n_cols = mat.getSize()
    return sp.vstack([sp.csr_matrix((d, i, p), shape=(p.size - 1, n_cols)) for p, i, d in parts]).tocsr()


def gather_vec(vec) -> np.ndarray:
    """The whole distributed ``vec`` as a numpy array on every rank. Collective."""
    comm = vec.getComm().tompi4py()
    return np.concatenate(comm.allgather(vec.getArray().copy()))
