"""The damping matrix C of a packing's contact dashpots (PETSc), on the layout of its dynamical
matrix: M u'' = -D u - C u' (docs/damping.md).  Per contact the blocks of
``contact_law.damping_blocks`` (LAMMPS's gran/*/history dashpots, gamma_n and gamma_t of the
contact model, m_eff = m_i m_j / (m_i + m_j) from the particle masses), summed like D's
(``dynmat.blocks_csr``), and each wall contact's on its particle (``contact_law.wall_damping_blocks``,
docs/walls.md): symmetric and positive semi-definite, with the rigid translations along periodic
axes in its null space.  Collective where it says so.  Units: m = d0 = kn = 1, gamma in 1/t0.
"""

from __future__ import annotations

import numpy as np

from .. import contact_law, profiling
from ..packing.configuration import Packing
from . import dynmat


def local_csr(packing: Packing, dm: dynmat.DynamicalMatrix, mass_rule: str = "equal"):
    """Rows of C owned by ``dm.disk_range`` (local rows x global columns, scipy CSR) for the
    dashpots of ``dm.model``, masses by ``mass_rule`` (``dynmat.particle_masses``).  Not collective."""
    contacts = dynmat.local_contacts(packing, dm.order, dm.disk_range)
    masses = dynmat.particle_masses(packing, mass_rule)
    m_i, m_j = masses[contacts.found.i], masses[contacts.found.j]
    normal, _, overlap, radius_i, radius_j = contacts.geometry_args
    c_ii, c_ij, c_jj = contact_law.damping_blocks(normal, overlap, radius_i, radius_j, m_i * m_j / (m_i + m_j),
                                                  dm.model, with_rotation=dm.dof > dm.dim)
    a, b, c_ji = contacts.a, contacts.b, np.transpose(c_ij, (0, 2, 1))
    if packing.walls is not None:  # each wall contact's dashpots on its particle alone, m_eff = m_i (docs/walls.md)
        touch, owner = dynmat.owned_wall_contacts(packing, dm.order, dm.disk_range)
        w_ii = contact_law.wall_damping_blocks(touch.normal, touch.overlap, 0.5 * packing.diameters[touch.particle],
                                               masses[touch.particle], dm.model, with_rotation=dm.dof > dm.dim)
        zero = np.zeros_like(w_ii)
        a, b = np.concatenate((a, owner)), np.concatenate((b, owner))
        c_ii, c_ij, c_ji, c_jj = (np.concatenate(pair) for pair in ((c_ii, w_ii), (c_ij, zero), (c_ji, zero), (c_jj, zero)))
    return dynmat.blocks_csr(a, b, (c_ii, c_ij, c_ji, c_jj), dm.disk_range, dm.dof, int(dm.active.sum()))


@profiling.logged("rsAssembleDamping")
def assemble(packing: Packing, dm: dynmat.DynamicalMatrix, mass_rule: str = "equal"):
    """C (PETSc Mat, block size ``dm.dof``, flagged symmetric) of ``packing`` with the rows, columns
    and communicator of ``dm`` (assembled from the same packing and ``mass_rule``). Collective."""
    from petsc4py import PETSc

    csr = local_csr(packing, dm, mass_rule)
    sizes = dm.D.getSizes()
    C = PETSc.Mat().createAIJ(size=sizes, bsize=dm.dof, csr=(csr.indptr.astype(PETSc.IntType),
                                                             csr.indices.astype(PETSc.IntType), csr.data),
                              comm=dm.D.getComm())
    C.assemble()
    C.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    C.setOption(PETSc.Mat.Option.SYMMETRY_ETERNAL, True)
    return C
