"""rotsound: sound in disordered frictional disk packings (Saitoh, Shrivastava, Luding).

Importing this package initialises neither MPI nor PETSc.  It caps OpenBLAS/OpenMP at one
thread per process unless the caller set those variables: rotsound runs one MPI rank per
core, and threaded BLAS on short vectors only spins (measured: +50 % system time in FIRE).
FIRE's compiled loops (``packing.pair_forces``, ``packing.fire_steps``) are threaded by numba,
the same bits on any number of threads: NUMBA_NUM_THREADS, unless the caller set it, is the
process's cores (``os.sched_getaffinity``) shared among the ranks mpirun started on this node
(Open MPI's OMPI_COMM_WORLD_LOCAL_SIZE, MPICH's MPI_LOCALNRANKS), at least 1: one process alone
uses every core; ranks bound to a core each, or sharing the node's, do not oversubscribe it.
It also switches off numba's coloured error messages unless the caller chose: where colorama is
installed, numba's colouring makes colorama write a reset code (ESC[0m) to stdout at exit under
mpirun, one per rank, into output that users and tests parse.  (Numba reads the variable when
first imported: importing numba before rotsound keeps the caller's setting.)
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
_ranks_here = os.environ.get("OMPI_COMM_WORLD_LOCAL_SIZE") or os.environ.get("MPI_LOCALNRANKS") or "1"
os.environ.setdefault("NUMBA_NUM_THREADS", str(max(1, len(os.sched_getaffinity(0)) // int(_ranks_here))))
os.environ.setdefault("NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING", "1")

__version__ = "0.1.0"
