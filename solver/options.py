"""The scene's ``petsc:`` mapping and the PETSc options database.

Flattening follows PETSc's own YAML reader: nested keys join with ``_``; ``null`` is a flag
without value, booleans become true/false, lists are comma-joined.  YAML options are put in
front of the command-line options when PETSc is initialised, so the command line wins and
options read at initialisation (``-log_view``, ``-malloc_debug``) work from YAML too.
Options are without prefix for the main objects (``-eps_*``/``-st_*`` for the spectrum,
``-ts_*`` for the waves).  Which options were never used (misspelt?) is read back from PETSc
itself (``PetscOptionsUsed``, through ctypes: petsc4py 3.18 has no binding).
"""

from __future__ import annotations

import ctypes
from typing import Any

from .errors import InputError


def flatten(mapping: dict, prefix: str = "") -> dict[str, str | None]:
    """``{'eps': {'tol': 1e-9}}`` -> ``{'eps_tol': '1e-09'}``; None values are flags."""
    flat: dict[str, str | None] = {}
    for key, value in mapping.items():
        name = f"{prefix}{str(key).lstrip('-')}"
        if isinstance(value, dict):
            flat.update(flatten(value, name + "_"))
        elif value is None:
            flat[name] = None
        elif isinstance(value, bool):
            flat[name] = "true" if value else "false"
        elif isinstance(value, (list, tuple)):
            flat[name] = ",".join(str(v) for v in value)
        elif isinstance(value, (int, float, str)):
            flat[name] = str(value)
        else:
            raise InputError(f"petsc.{name} = {value!r}: must be a number, string, bool, list or null")
    return flat


def to_argv(flat: dict[str, str | None]) -> list[str]:
    """Options as argv words: ``['-eps_tol', '1e-09', '-log_view']``."""
    argv: list[str] = []
    for name, value in flat.items():
        argv.append(f"-{name}")
        if value is not None:
            argv.append(value)
    return argv


def split_argv(argv: list[str]) -> tuple[list[str], list[str]]:
    """Split a command line into (ours, PETSc's): PETSc options start with one '-' and a letter.

    A PETSc option's value is the next word unless that word is itself an option.
    """
    ours: list[str] = []
    petsc: list[str] = []
    expect_value = False
    for word in argv:
        is_option = word.startswith("-") and not word.startswith("--") and len(word) > 1 and word[1].isalpha()
        if is_option:
            petsc.append(word)
            expect_value = True
        elif expect_value and not word.startswith("--"):
            petsc.append(word)
            expect_value = False
        else:
            ours.append(word)
            expect_value = False
    return ours, petsc


PREFIXES = {
    "spectrum_": "the spectrum-slicing EPS (-spectrum_eps_*, -spectrum_st_*, -spectrum_st_mat_mumps_icntl_*)",
    "inertia_": "the Sylvester-inertia factorisations that place windows and count modes "
                "(-inertia_pc_factor_mat_solver_type, -inertia_mat_mumps_icntl_*)",
    "wmax_": "the Lanczos EPS for the largest eigenfrequency (-wmax_eps_*)",
    "waves_": "the standing-wave TS and its SNES/KSP (-waves_ts_*, -waves_ksp_*)",
}
"""Options prefix of each solver object -> what it configures (README table)."""

STAGE_PREFIXES = {
    ("spectra", "slicing"): ("spectrum_", "inertia_", "wmax_"),
    ("spectra", "kpm"): ("wmax_",),
    ("waves", "ts"): ("waves_", "wmax_"),
    ("waves", "spectral"): ("wmax_",),
}
"""(stage, method) -> prefixes of the options that can change that stage's units."""


def acting_on(argv: list[str], stage: str, method: str) -> dict[str, str | None]:
    """The options in argv words (name without '-' -> value or None) that act on ``stage``
    computed with ``method``: those with one of its prefixes. Not collective."""
    prefixes = STAGE_PREFIXES.get((stage, method), ())
    found: dict[str, str | None] = {}
    for index, word in enumerate(argv):
        if word.startswith("-") and len(word) > 1 and word[1].isalpha():
            value = argv[index + 1] if index + 1 < len(argv) and not (
                argv[index + 1].startswith("-") and len(argv[index + 1]) > 1 and argv[index + 1][1].isalpha()) else None
            if word[1:].startswith(prefixes):
                found[word[1:]] = value  # a later word wins, as in PETSc
    return dict(sorted(found.items()))


def option_names(argv: list[str]) -> list[str]:
    """Names (without '-') of the options in argv words."""
    return [w[1:] for w in argv if w.startswith("-") and len(w) > 1 and w[1].isalpha()]


def _libpetsc():
    with open("/proc/self/maps", encoding="utf-8") as maps:
        for line in maps:
            path = line.split()[-1]
            if "libpetsc" in path and ".so" in path:
                return ctypes.CDLL(path)
    raise RuntimeError("libpetsc is not loaded")


def unused(names: list[str]) -> list[str]:
    """Those of ``names`` that PETSc never queried (misspelt or not applicable). Not collective."""
    func = _libpetsc().PetscOptionsUsed
    func.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.POINTER(ctypes.c_int)]
    result = []
    for name in names:
        used = ctypes.c_int(0)
        if func(None, name.encode(), ctypes.byref(used)) != 0:
            raise RuntimeError(f"PetscOptionsUsed failed for {name}")
        if not used.value:
            result.append(name)
    return result


def snapshot() -> dict[str, Any]:
    """All options now in the database (name -> value), for provenance."""
    from petsc4py import PETSc

    return dict(PETSc.Options().getAll())
