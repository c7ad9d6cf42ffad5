"""PETSc log stages and events, so that ``-log_view`` splits a run's time by stage and hot function.

Stages (pushed by the pipeline around each stage of a scene): ``packings``, ``assembly``,
``spectrum`` (slicing), ``kpm``, ``modes``, ``transport`` (the diffusivity), ``waves``,
``analysis``, ``output``.  Events (on the hot functions, counted inside whichever stage calls
them): ``rsPackingFIRE`` (one FIRE minimisation), ``rsAssemble`` (D and M), ``rsInertia`` (one
Sylvester-inertia factorisation), ``rsWindowSolve`` (one slicing window), ``rsOmegaMax`` (the
Lanczos largest-eigenvalue solve, or its cached value), ``rsKPMMoments`` (one set of Chebyshev
moments), ``rsAFModes`` and ``rsAFSum`` (the exact diffusivity's slicing windows and pair sums),
``rsAFKPMProbes`` (one block of probes of the KPM diffusivity), ``rsVerletStep`` (one
block-Verlet step), ``rsLanczosWave`` (one batch of spectral standing waves side by side),
``rsAnalyse`` (the scene analysis), ``rsWriteResults`` (the results file).
PETSc registers a stage or event once per name; both are made on first use, and only once PETSc
is loaded, so the numpy-only modules (packings) stay importable and usable without it.
Not collective: PETSc's logging is per process (``-log_view`` gathers at the end).
"""

from __future__ import annotations

import contextlib
import functools
import sys

STAGES = ("packings", "assembly", "spectrum", "kpm", "modes", "transport", "waves", "analysis", "output")


def _petsc():
    """The PETSc module if petsc4py is loaded and initialised, else None."""
    return sys.modules.get("petsc4py.PETSc")


@functools.cache
def _registered(kind: str, name: str):
    return getattr(_petsc().Log, kind)(name)


def stage(name: str):
    """Context manager: the PETSc log stage ``name`` (one of STAGES) is current inside it."""
    return _registered("Stage", name) if _petsc() is not None else contextlib.nullcontext()


def event(name: str):
    """Context manager: the PETSc log event ``name`` is counted and timed inside it."""
    return _registered("Event", name) if _petsc() is not None else contextlib.nullcontext()


def logged(name: str):
    """Decorator: every call of the function is one PETSc log event ``name``."""
    def decorate(func):
        @functools.wraps(func)
        def wrapper(*args, **kwargs):
            with event(name):
                return func(*args, **kwargs)
        return wrapper
    return decorate
