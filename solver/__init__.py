"""rotsound: sound in disordered frictional disk packings (Saitoh, Shrivastava, Luding).

Importing this package initialises neither MPI nor PETSc.  It caps OpenBLAS/OpenMP at one
thread per process unless the caller set those variables: rotsound runs one MPI rank per
core, and threaded BLAS on short vectors only spins (measured: +50 % system time in FIRE).
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

__version__ = "0.1.0"
