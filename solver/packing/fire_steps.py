"""FIRE's per-step vector work compiled (numba) and spread over every thread numba has, the same
bits on any number of them: the elementwise updates are the same operations on each element
whichever thread does it, and each reduction is summed in chunks of ``CHUNK`` particles fixed in
advance, its partial sums added in chunk order (never per thread).  Each pass is one sweep over
the arrays, fused where FIRE allows: the force's measures (largest |F_i|^2, P = F.v, |F|^2) in one,
the kick and |v|^2 in another.  Arrays: (N, D) float64, C order.  The first call compiles and
caches the machine code (numba ``cache=True``).  Not collective.
"""

from __future__ import annotations

import contextlib

import numba
import numpy as np

CHUNK = 2048
"""Particles per chunk of this module's reductions: fixed, so that sums do not depend on the
number of threads."""


@contextlib.contextmanager
def threads_for(n: int):
    """Within it, numba runs on one thread when ``n`` particles make a single chunk (no thread to
    start and wait for on every pass, which small packings would mostly spend), else on all it
    has.  The same bits either way."""
    before = numba.get_num_threads()
    numba.set_num_threads(1 if n <= CHUNK else before)
    try:
        yield
    finally:
        numba.set_num_threads(before)


@numba.njit(cache=True, parallel=True, boundscheck=False)
def force_measures(f: np.ndarray, v: np.ndarray) -> tuple[float, float, float]:
    """(max_i |f_i|^2, f.v, f.f) in one pass, components summed left to right, each sum in fixed
    chunks.  max_i |f_i|^2 is NaN if any component of f is (the compiled ``max`` drops a NaN: FIRE
    read NaN forces as converged, issue 58), as f.f then is."""
    n = f.shape[0]
    chunks = (n + CHUNK - 1) // CHUNK
    parts = np.empty((chunks, 3))
    for c in numba.prange(chunks):
        largest, power, total = 0.0, 0.0, 0.0
        for a in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            squared = f[a, 0] * f[a, 0]
            along = f[a, 0] * v[a, 0]
            for d in range(1, f.shape[1]):
                squared += f[a, d] * f[a, d]
                along += f[a, d] * v[a, d]
            largest = max(largest, squared)
            total += squared
            power += along
        parts[c, 0], parts[c, 1], parts[c, 2] = largest, power, total
    largest, power, total = 0.0, 0.0, 0.0
    for c in range(chunks):
        largest = max(largest, parts[c, 0])
        power += parts[c, 1]
        total += parts[c, 2]
    return (largest if total == total else np.nan), power, total


@numba.njit(cache=True, parallel=True, boundscheck=False)
def kick(v: np.ndarray, f: np.ndarray, dt: float) -> float:
    """v += dt f in place; return v.v after it (in fixed chunks)."""
    n = v.shape[0]
    chunks = (n + CHUNK - 1) // CHUNK
    parts = np.empty(chunks)
    for c in numba.prange(chunks):
        total = 0.0
        for a in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            for d in range(v.shape[1]):
                v[a, d] += dt * f[a, d]
                total += v[a, d] * v[a, d]
        parts[c] = total
    total = 0.0
    for c in range(chunks):
        total += parts[c]
    return total


@numba.njit(cache=True, parallel=True, boundscheck=False)
def mix_and_move(x: np.ndarray, v: np.ndarray, f: np.ndarray, keep: float, push: float, dt: float) -> None:
    """v = keep v + push f, then x += dt v, in place."""
    for a in numba.prange(v.shape[0]):
        for d in range(v.shape[1]):
            v[a, d] = keep * v[a, d] + push * f[a, d]
            x[a, d] += dt * v[a, d]


@numba.njit(cache=True, parallel=True, boundscheck=False)
def move(x: np.ndarray, v: np.ndarray, dt: float) -> None:
    """x += dt v, in place."""
    for a in numba.prange(x.shape[0]):
        for d in range(x.shape[1]):
            x[a, d] += dt * v[a, d]
