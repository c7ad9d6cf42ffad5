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


MUMPS_PTSCOTCH = [f"/usr/lib/x86_64-linux-gnu/lib{name}_ptscotch-5.5.so" for name in ("mumps_common", "pord", "dmumps")]
"""Debian's PT-Scotch build of MUMPS (package libmumps-ptscotch-5.5, installed by scripts/tools/setup.sh):
the MUMPS 5.5.1 that Debian's PETSc links, built with SCOTCH's nested dissection (ICNTL 7 = 3),
which Debian's default build lacks (its orderings: PORD, AMD, AMF, QAMD)."""
_MUMPS_BUILD: list[str] = []  # the build this process loaded, once decided


def mumps_build() -> str:
    """Which MUMPS this process factorises with: "ptscotch" (:data:`MUMPS_PTSCOTCH`, loaded by
    :func:`ensure_importable` before PETSc) or "debian" (the build Debian's PETSc links). Not
    collective."""
    return _MUMPS_BUILD[0] if _MUMPS_BUILD else "debian"


def _load_mumps() -> None:
    """Load :data:`MUMPS_PTSCOTCH` with RTLD_GLOBAL before PETSc's library is loaded, when it is
    installed and the environment does not say ``ROTSOUND_MUMPS=debian``: PETSc's calls of
    ``dmumps_c`` then resolve to it, the same MUMPS version, structure and interface with SCOTCH
    added.  Decision (issue 48, BENCHMARKS "orderings"): SCOTCH orders the 3D matrices with 42 %
    fewer flops than PORD (a 32768-sphere factorisation 197 s -> 135 s, the same counts), the 2D
    ones alike.  Too late once PETSc is loaded (by an import before this): the process then keeps
    Debian's build, and says so through :func:`mumps_build`.  Not collective."""
    import ctypes

    if _MUMPS_BUILD:
        return
    wanted = os.environ.get("ROTSOUND_MUMPS", "ptscotch")
    if wanted not in ("ptscotch", "debian"):
        from .errors import InputError

        raise InputError(f"environment: ROTSOUND_MUMPS = {wanted!r}: allowed are 'ptscotch' (the default, used "
                         f"when Debian's libmumps-ptscotch-5.5 is installed) and 'debian'")
    if wanted == "debian" or "petsc4py.PETSc" in sys.modules or not all(map(os.path.exists, MUMPS_PTSCOTCH)):
        _MUMPS_BUILD.append("debian")
        return
    for path in MUMPS_PTSCOTCH:
        ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL)
    _MUMPS_BUILD.append("ptscotch")


def ensure_importable() -> None:
    """Make ``petsc4py`` and ``slepc4py`` importable (Debian layout), with the MUMPS build of
    :func:`_load_mumps`. Not collective."""
    _load_mumps()
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
            raise ImportError(f"{module} not found: run 'make test' or scripts/tools/setup.sh "
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
