"""Exact vDOS by counting: how many eigenvalues fall in each bin, no eigenvalues, no eigenvectors.

The number of eigenvalues of A = M^-1/2 D M^-1/2 below a shift sigma is the number of negative
pivots of a Cholesky (LDL^T) factorisation of A - sigma I (Sylvester's law of inertia), so the
count of modes with omega in [w_a, w_b) is the difference of the inertias at w_b^2 and w_a^2:
one sparse factorisation per bin edge, exact integers, no Krylov iterations (PHYSICS.md section 3).

Cost [decision]: the pattern of A - sigma I never changes, so each factorising group keeps one
factorisation object (``slicing.ShiftedInertia``) whose symbolic analysis (ordering, elimination
tree) is done once and refactorises numerically only at every further shift.  Bin edges are
independent: they are dealt (``parallel.Groups``' snake) to groups of ``factor_ranks``
consecutive ranks, each group holding its own copy of A spread over its ranks
(``MatCreateRedundantMatrix``) and factorising it in parallel with MUMPS on its sub-communicator.
``factor_ranks`` = 1 gives every rank a sequential factor of its own: no
communication inside a factorisation, the fastest while one whole factor fits in a rank's memory
(memory per rank = one factor).  ``factor_ranks`` = the ranks of the communicator shares one factor
among them all: memory per rank ~ factor / ranks, the way for matrices whose factor does not fit
(3D fills in ~28x).  The inertia is a property of A - sigma I, not of how it is factorised, so the
counts are the same integers on any layout; they are gathered from their owners.
``factor_ranks`` = "auto" (the scene's default) counts the first edge with one factor shared by
all the communicator's ranks (the layout that always fits) and reads MUMPS's estimate of that
factorisation's memory (INFOG(17), summed over its ranks: about one whole factor); then the fewest
ranks G (a divisor of the communicator's size) with estimate / G within half the memory a rank may
use (the node's MemAvailable shared by the communicator's ranks on that node) share each factor
for the other edges; G = all ranks when none does.  On one rank: 1.

Edges: bins [0, w), [w, 2w), ... up to past omega_max (the Lanczos estimate of
``model.operators.largest_omega``, +1e-6 relative); if the inertia there misses any mode, more
bins are added up to the Gershgorin bound.  Modes with omega below ``zero_tol`` (the uniform
translations, and the uniform spins without tangential springs: ``dm.rigid_modes()``) are counted
as zero modes and left out of the histogram, as in ``slicing``; those below -zero_tol^2 as
negative modes.  A bin edge exactly on an eigenvalue counts it in the upper
bin (the inertia counts lambda < sigma), as ``numpy.histogram`` does for [a, b).

Block low-rank [decision]: MUMPS's BLR factorisation (``-inertia_mat_mumps_icntl_35 1
-inertia_mat_mumps_cntl_7 eps``) is allowed but never silent.  It factorises A - sigma I + E with
E of order eps ||A|| (MUMPS's dropping parameter on its scaled matrix), so by Weyl's inequality a
count can be wrong only by eigenvalues within ||E|| of the shift: the result then says
``counts_exact`` = False and gives ``count_window`` = eps ||A||_inf, the nominal half-width (in
omega^2, 1/t0^2) around each edge's omega^2 inside which a mode may sit in the neighbouring bin.
It is nominal, not a proof (MUMPS bounds E only up to a modest constant): BENCHMARKS.md measures
the miscounts against exact counts.  Read back from the factorisation (``options.pc_settings``),
whichever option or default set it.
Units: omega in 1/t0.  Collective on the matrix's communicator.
"""

from __future__ import annotations

import numpy as np

from .. import parallel
from ..model.operators import largest_omega, scaled_operator
from .slicing import ShiftedInertia


def available_gib() -> float:
    """MemAvailable of this node (Linux /proc/meminfo), GiB. Not collective."""
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) / 2**20
    raise RuntimeError("/proc/meminfo has no MemAvailable")


def auto_factor_ranks(A, comm, sigma: float) -> tuple[int, int, dict]:
    """(G, the count below ``sigma``, what G was chosen from) by the rule of the module docstring
    for ``factor_ranks: auto``: the count at ``sigma`` is made on all of ``comm``'s ranks (the
    layout that always fits), and MUMPS's estimate comes with it.  Collective on ``comm`` (mpi4py;
    A's communicator, more than one rank)."""
    from mpi4py import MPI

    counter = ShiftedInertia(A)
    try:
        below = counter.count_below(sigma)
        factor = counter.pc.getFactorMatrix()
        estimate = max(factor.getMumpsInfog(17), 1) / 1024.0  # whole MB summed over the ranks (0 below 1) -> GiB
        factor.destroy()  # the wrapper's reference only
    finally:
        counter.destroy()
    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    budget = comm.allreduce(0.5 * available_gib() / node.size, op=MPI.MIN)
    node.Free()
    ranks = next((g for g in range(1, comm.size + 1) if comm.size % g == 0 and estimate / g <= budget), comm.size)
    return ranks, below, {"factor_estimate_gib": estimate, "factor_budget_gib": budget}


def group_copy(A, groups):
    """A on ``groups``' sub-communicator: A itself for one group of all ranks, a sequential copy
    (SEQAIJ, ``createSubMatrices``) for groups of one rank, else ``MatCreateRedundantMatrix``.
    (A redundant copy on one rank is an MPIAIJ, which measured 6 % slower to factorise and 0.09 GiB
    more per rank than the SEQAIJ at N = 131072: BENCHMARKS.md "scaling_after".)  Collective."""
    from petsc4py import PETSc

    if groups.count == 1:
        return A
    if groups.size == 1:
        everything = PETSc.IS().createStride(A.getSize()[0], 0, 1, comm=PETSc.COMM_SELF)
        try:
            return A.createSubMatrices(everything)[0]
        finally:
            everything.destroy()
    return A.getRedundantMatrix(groups.count, PETSc.Comm(groups.local))


def refactor_work(counter, groups) -> dict:
    """The numeric refactorisations of every group's ``counter`` (:class:`ShiftedInertia`):
    ``refactorisations`` (all groups'), ``refactor_flops`` (their MUMPS flops, RINFOG 3, each
    group's once), ``refactor_seconds`` (the longest time one rank spent in them) and
    ``refactor_cpu_seconds`` (the CPU time all ranks' processes spent in them); the flops over the
    seconds are the rate at which the groups factorised together, over the CPU seconds the rate
    per core they were given (BENCHMARKS "counts_rate").  Collective on ``groups.comm``."""
    from mpi4py import MPI

    first = groups.local.rank == 0
    return {"refactorisations": groups.comm.allreduce(max(counter.factorisations - 1, 0) if first else 0),
            "refactor_flops": groups.comm.allreduce(counter.refactor_flops if first else 0.0),
            "refactor_seconds": groups.comm.allreduce(counter.refactor_seconds, op=MPI.MAX),
            "refactor_cpu_seconds": groups.comm.allreduce(counter.refactor_cpu_seconds)}


def counts_below(A, shifts, comm, factor_ranks: int | str = "auto") -> tuple[np.ndarray, dict]:
    """(number of eigenvalues of A below each of ``shifts`` (S,) int64, factorisation settings).

    Collective on ``comm`` (mpi4py; A's communicator).  The shifts are dealt (a snake:
    ``parallel.Groups``) to the G groups of ``factor_ranks`` consecutive ranks (a divisor of ``comm.size``, or "auto":
    :func:`auto_factor_ranks`), on the group's copy of A with a reused :class:`ShiftedInertia`;
    every rank gets every count, and an error on any rank is raised on all.  The settings add
    ``factor_ranks`` and ``factor_groups`` (and with auto, its estimate and budget, GiB), and the
    work of the refactorisations (:func:`refactor_work`; not auto's first count).
    """
    chosen, known = {}, {}
    if factor_ranks == "auto" and comm.size == 1:
        factor_ranks = 1
    elif factor_ranks == "auto":  # shift 0 is counted on the way; it is group 0's in any layout
        factor_ranks, known[0], chosen = auto_factor_ranks(A, comm, float(shifts[0]))
    local, counter, error, mine = None, None, None, {}
    with parallel.Groups(comm, factor_ranks) as groups:
        try:
            try:
                local = group_copy(A, groups)
                counter = ShiftedInertia(local)
            except BaseException as exc:  # noqa: BLE001 - raised on every rank below
                error = exc
            parallel.agree(comm, error)
            try:
                for index in groups.mine(range(len(shifts))):
                    mine[index] = known[index] if index in known else counter.count_below(float(shifts[index]))
            except BaseException as exc:  # noqa: BLE001 - raised on every rank below
                error = exc
            groups.wait()  # a group done early sleeps instead of spinning in the collective below
            parallel.agree(comm, error)
            counts = groups.share(mine, {index: groups.owner(index) for index in range(len(shifts))})
            settings = comm.bcast(counter.settings(), root=0)  # group 0 always counts shift 0
            settings.update(refactor_work(counter, groups))
        finally:
            if counter is not None:
                counter.destroy()
            if local is not None and local is not A:
                local.destroy()
    settings.update(factor_ranks=groups.size, factor_groups=groups.count, **chosen)
    return np.array([counts[index] for index in range(len(shifts))], dtype=np.int64), settings


def blr_dropping(settings: dict) -> float:
    """CNTL(7) of an inertia factorisation whose settings (``options.pc_settings``) say MUMPS
    compressed it (ICNTL 35 = 1, 2 or 3 with CNTL 7 > 0), else 0.0 (the inertias are exact)."""
    blr = settings.get("mumps_blr", {})
    return float(blr.get("cntl_7", 0.0)) if blr.get("icntl_35", 0) in (1, 2, 3) else 0.0


def solve(dm, *, bin_width: float, zero_tol: float, factor_ranks: int | str = "auto") -> tuple[dict, dict, dict]:
    """The exact vDOS of ``dm`` by counting, as (datasets, attrs, solver settings). Collective;
    ``factor_ranks`` ranks share each factorisation (:func:`counts_below`).

    datasets: edges (B+1,) = 0, w, 2w, ... in 1/t0; counts (B,) int64, the modes with omega in each
    bin (zero modes excluded); density (B,) = counts / (sum(counts) w), unit area.
    attrs: omega_max (Lanczos, 1/t0), n_zero_modes, n_negative_modes, inertia_count (non-zero
    modes counted), factorisations, dof (the matrix's size), n_disks (particles in the matrix,
    disks or spheres), counts_exact (False with a block low-rank factorisation), blr_dropping
    (its CNTL 7, else 0) and count_window (blr_dropping x ||A||_inf in 1/t0^2, else 0: see the
    module docstring).
    """
    from petsc4py import PETSc

    comm = dm.D.getComm().tompi4py()
    omega_max = largest_omega(dm)
    A = scaled_operator(dm)
    try:
        n = A.getSize()[0]
        top = omega_max * (1 + 1e-6)
        edges = bin_width * np.arange(int(np.floor(top / bin_width)) + 2)
        lam0 = zero_tol**2
        below, settings = counts_below(A, np.concatenate(([-lam0, lam0], edges[1:] ** 2)), comm, factor_ranks)
        norm = A.norm(PETSc.NormType.INFINITY)
        if below[-1] < n:  # modes above the Lanczos estimate: count on up to the Gershgorin bound
            bound = np.sqrt(norm * (1 + 1e-9))
            more = bin_width * np.arange(edges.size, int(np.floor(bound / bin_width)) + 2)
            below = np.concatenate((below, counts_below(A, more**2, comm, factor_ranks)[0]))
            edges = np.concatenate((edges, more))
    finally:
        A.destroy()
    n_negative, below_zero_tol = int(below[0]), int(below[1])
    if below[-1] != n:
        raise RuntimeError(f"counting: the inertia at the top edge counts {below[-1]} of {n} modes")
    counts = np.diff(below[1:])
    if np.any(counts < 0):
        raise RuntimeError("counting: inertias decrease with the shift (a factorisation is wrong)")
    density = counts / (counts.sum() * bin_width) if counts.sum() else np.zeros(counts.size)
    attrs = {"omega_max": omega_max, "n_zero_modes": below_zero_tol - n_negative,
             "n_negative_modes": n_negative, "inertia_count": int(counts.sum()),
             "factorisations": int(below.size), "dof": dm.size, "n_disks": int(dm.active.sum())}
    dropping = blr_dropping(settings)
    attrs.update(counts_exact=dropping == 0.0, blr_dropping=dropping, count_window=dropping * norm)
    return {"edges": edges, "counts": counts, "density": density}, attrs, {"inertia": settings,
                                                                           "wmax": dm.wmax_settings}
