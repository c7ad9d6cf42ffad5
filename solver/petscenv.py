"""Find Debian's petsc4py/slepc4py and initialise them; no user ever exports PETSC_DIR.

Debian installs petsc4py under ``/usr/lib/petscdir/petsc<ver>/<arch>/lib/python3/dist-packages``
and its ``.pth`` file only looks at ``/usr/lib/petsc`` (a link created by the heavy
``-dev`` packages) unless ``PETSC_DIR`` is set.  :func:`ensure_importable` adds the
newest installed real, 32-bit-index build to ``sys.path`` when petsc4py is not already
importable.  Decision: the 32-bit-index build (``PetscInt`` = int32) is used; every
stage keeps ``n * nconv`` below 2**31 (spectrum windows), see the manual, docs/decisions_solvers.md.
"""

from __future__ import annotations

import glob
import importlib.util
import os
import sys

_ROOTS = {"petsc4py": ("PETSC_DIR", "/usr/lib/petscdir/petsc*/*-real"),
          "slepc4py": ("SLEPC_DIR", "/usr/lib/slepcdir/slepc*/*-real")}


def _version_key(path: str) -> tuple[int, ...]:
    digits = "".join(c if c.isdigit() else " " for c in path.split("/")[4])
    return tuple(int(d) for d in digits.split())


def ensure_importable() -> None:
    """Make ``petsc4py`` and ``slepc4py`` importable (Debian layout). Not collective."""
    for module, (env, pattern) in _ROOTS.items():
        if importlib.util.find_spec(module) is not None:
            continue
        roots = [os.environ[env]] if os.environ.get(env) else sorted(glob.glob(pattern), key=_version_key)
        for root in reversed(roots):
            site = os.path.join(root, "lib", "python3", "dist-packages")
            if os.path.isdir(os.path.join(site, module)):
                sys.path.append(site)
                break
        else:
            raise ImportError(f"{module} not found: run 'make test' or tools/setup.sh "
                              f"(installs Debian's python3-{module})")


def init(argv: list[str] | None = None):
    """Initialise PETSc and SLEPc with ``argv`` (PETSc options); return the ``PETSc`` module.

    Collective on ``MPI.COMM_WORLD`` the first time.  Later calls return at once; options in
    ``argv`` of a later call are inserted into the options database.
    """
    ensure_importable()
    import petsc4py
    import slepc4py

    args = [sys.argv[0] if sys.argv else "rotsound"] + list(argv or [])
    petsc4py.init(args)
    slepc4py.init(args)
    from petsc4py import PETSc

    if argv:
        PETSc.Options().insertString(" ".join(argv))
    return PETSc
