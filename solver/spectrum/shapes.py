"""Mode shapes: whole eigenvectors of A = M^-1/2 D M^-1/2 nearest chosen frequencies (the scene's
``modes`` section), kept for pictures, exports and the localisation of single modes.

For each target omega_t: SLEPc Krylov-Schur with shift-and-invert about omega_t^2 (MUMPS
Cholesky), the ``count`` modes whose omega^2 is nearest omega_t^2 (what shift-and-invert finds;
for count = 1 also the nearest omega), zero modes (omega < zero_tol: the rigid translations and
spins, ``dm.rigid_modes``) left out.  No spectrum slicing and no inertia: one factorisation per
target, whatever the size of the spectrum.  Two close targets can return the same mode twice.

Fields of a mode, from the orthonormal e (|e| = 1) by u = M^-1/2 e (PHYSICS.md section 3):
``displacement`` (N, D) in d0 and ``rotation`` (N, R) in rad (R = 1 in 2D, the angle about z;
3 in 3D; absent without rotational springs), and ``share`` (N, 2), each particle's part of
|e|^2 (its share of the mode's kinetic energy) and the rotational part of that, over every particle of the packing in its order,
zero on rattlers (not in the matrix).  The sign of an eigenvector is arbitrary: it is fixed so
that the largest |e| component is positive, which makes the fields independent of the number of
ranks.  K, Q and the participation ratio as ``modes.energies``.  omega is the Rayleigh quotient
of the converged vector; ``residual`` the largest relative residual ||A e - omega^2 e|| / omega^2.

Options: the EPS has the prefix ``modes_`` (``-modes_eps_tol``, ``-modes_eps_ncv``,
``-modes_st_pc_factor_mat_solver_type``, ``-modes_st_mat_mumps_icntl_*``); defaults set in code
first, what it used read back.  Symmetric D only (the caller refuses stressed packings).
Collective on the matrix's communicator.  Units: omega in 1/t0.
"""

from __future__ import annotations

import numpy as np

from . import modes
from .. import profiling
from ..model import dynmat
from ..model.operators import scaled_operator
from ..options import eps_settings

PREFIX = "modes_"


def _configure(eps, A, target: float, nev: int, tol: float) -> None:
    """Shift-and-invert EPS about ``target`` (omega^2) for ``nev`` pairs, prefix ``modes_``:
    defaults in code, then setFromOptions (options win). Collective."""
    from petsc4py import PETSc
    from slepc4py import SLEPc

    eps.setOperators(A)
    eps.setProblemType(SLEPc.EPS.ProblemType.HEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setDimensions(nev=nev)
    eps.setTarget(target)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
    eps.setTolerances(tol=tol)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    ksp = st.getKSP()
    ksp.setType(PETSc.KSP.Type.PREONLY)
    ksp.getPC().setType(PETSc.PC.Type.CHOLESKY)
    ksp.getPC().setFactorSolverType("mumps")
    eps.setOptionsPrefix(PREFIX)
    eps.setFromOptions()


@profiling.logged("rsModeShapes")
def solve(dm, targets: list[float], count: int, tol: float = 1e-10, zero_tol: float = 1e-4) -> tuple[dict, dict]:
    """The ``count`` modes nearest each of ``targets`` (omega, 1/t0) of ``dm``. Collective; the
    same arrays on every rank.

    Returns (datasets, settings): datasets ``target`` and ``omega`` (M,), M = len(targets) x count,
    sorted by omega within each target; ``displacement`` (M, N, D); ``rotation`` (M, N, R) when
    the matrix has rotations; ``share`` (M, N, 2): each particle's part of |e|^2 = 1 (its kinetic
    energy share in the mode), and the part of that in its rotations; the ``modes.energies``
    arrays (M,) each; ``residual`` (M,).
    ``settings``: what the EPS used (of the last target).  Raises RuntimeError on every rank if
    fewer than ``count`` non-zero modes converge.
    """
    from slepc4py import SLEPc

    comm = dm.D.getComm()
    mpi = comm.tompi4py()
    A = scaled_operator(dm)
    n_zero = len(dm.rigid_modes())
    chosen: dict[str, list] = {"target": [], "lam": [], "local": [], "sums": [], "residual": []}
    settings: dict = {}
    vec, image = A.createVecRight(), A.createVecLeft()
    try:
        for target in targets:
            eps = SLEPc.EPS().create(comm)
            try:
                _configure(eps, A, max(target, zero_tol) ** 2, min(count + n_zero, A.getSize()[0]), tol)
                eps.solve()
                found = []
                for i in range(eps.getConverged()):
                    eps.getEigenpair(i, vec)
                    A.mult(vec, image)
                    lam = image.dot(vec) / vec.dot(vec)
                    if lam < zero_tol**2:
                        continue
                    vec.normalize()
                    local = vec.getArray(readonly=True).copy()
                    sums = mpi.allreduce(modes.local_sums(local[None, :], dm.dof, dm.dim))[0]
                    found.append((abs(lam - target**2), lam, local, sums,
                                  eps.computeError(i, SLEPc.EPS.ErrorType.RELATIVE)))
                settings = eps_settings(eps)
            finally:
                eps.destroy()
            if len(found) < count:
                raise RuntimeError(f"modes: {len(found)} of {count} non-zero modes converged near omega = "
                                   f"{target:g}; raise -modes_eps_max_it or -modes_eps_ncv")
            for _, lam, local, sums, residual in sorted(sorted(found, key=lambda f: f[0])[:count],
                                                        key=lambda f: f[1]):
                for key, value in zip(("target", "lam", "local", "sums", "residual"),
                                      (target, lam, local, sums, residual)):
                    chosen[key].append(value)
    finally:
        vec.destroy()
        image.destroy()
        A.destroy()
    e = dynmat.over_particles(dm, np.array(chosen["local"]))  # (M, N, dof), only the modes kept
    flat = e.reshape(len(e), -1)
    e *= np.sign(flat[np.arange(len(e)), np.argmax(np.abs(flat), axis=1)])[:, None, None]
    masses = dynmat.over_particles(dm, dm.M.getArray(readonly=True))  # 0 on rattlers
    u = np.divide(e, np.sqrt(masses), out=np.zeros_like(e), where=masses > 0)  # u = M^-1/2 e
    squares = e**2
    datasets = {"target": np.array(chosen["target"]), "omega": np.sqrt(np.array(chosen["lam"])),
                "displacement": u[..., :dm.dim], "residual": np.array(chosen["residual"]),
                "share": np.stack((squares.sum(axis=2), squares[..., dm.dim:].sum(axis=2)), axis=2)}
    if dm.rotations:
        datasets["rotation"] = u[..., dm.dim:]
    datasets.update(modes.energies(np.array(chosen["sums"]), int(dm.active.sum()), dm.dim))
    return datasets, mpi.bcast(settings, root=0)
