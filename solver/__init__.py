"""rotsound: sound in disordered frictional disk packings (Saitoh, Shrivastava, Luding).

Importing this package initialises neither MPI nor PETSc.  It caps OpenBLAS/OpenMP at one
thread per process unless the caller set those variables: rotsound runs one MPI rank per
core, and threaded BLAS on short vectors only spins (measured: +50 % system time in FIRE).
It also switches off numba's coloured error messages unless the caller chose: where colorama is
installed, numba's colouring makes colorama write a reset code (ESC[0m) to stdout at exit under
mpirun, one per rank, into output that users and tests parse.  (Numba reads the variable when
first imported: importing numba before rotsound keeps the caller's setting.)
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
os.environ.setdefault("NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING", "1")

__version__ = "0.1.0"
