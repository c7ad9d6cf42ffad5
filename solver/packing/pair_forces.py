"""FIRE's inner loop compiled: net frictionless normal forces over a pair list (numba).

eq:eij at rho = 0 (kn = 1): a pair (i, j) at separation s = x_i - x_j + shift with contact
distance c = (d_i + d_j)/2 and overlap xi = max(c - |s|, 0) pushes i by f_n s / |s| and j by
minus that, f_n = xi and energy xi^2 / 2 (harmonic), or f_n = sqrt(a' xi) xi and energy
(2/5) sqrt(a' xi) xi^2 (hertz, a' = R_i R_j / (R_i + R_j)); ``contact_law.normal_pair``,
vectorised, is the same formula.

Compiled, because a step of FIRE is one pass over ~6 pairs per sphere (~200,000 at N = 32768 in
3D) and numpy's version of that pass is a chain of temporaries and gathers: measured at
N = 32768 (mid-FIRE list), 3.2 ms against 10 ms for sparse products in 3D and 1.3 ms against
4.6 ms in 2D (scripts/benchmarks/bench_packing.py and bench_packing3d.py give the whole-FIRE numbers).  The
loop has no branch on the overlap (a zero force is added instead: branch mispredictions cost a
third) and the same floating-point operations, in the same order, as the sparse products it
replaces (the separation x_i - x_j + shift, |s|^2 summed x then y then z, and each particle's
forces summed in list order, first those where it is i, then minus those where it is j), so
packings are bit for bit what they were.  The first call compiles (~2 s) and caches the machine
code next to this file (numba ``cache=True``); later processes load it.  Not collective.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, boundscheck=False)
def net_forces(x: np.ndarray, i: np.ndarray, j: np.ndarray, shift: np.ndarray, contact: np.ndarray,
               reduced: np.ndarray, hertz: bool, out: np.ndarray, on_j: np.ndarray) -> float:
    """Write the net force on each particle into ``out`` (N, D) and return the energy.

    x : (N, D) positions, D = 2 or 3;  i, j : (P,) int listed pairs;  shift : (P, D) periodic
    image shifts;  contact : (P,) contact distances;  reduced : (P,) a' (used by hertz only);
    hertz : the Hertz law instead of the harmonic one;  on_j : (N, D) scratch.
    """
    three = x.shape[1] == 3
    out[:] = 0.0
    on_j[:] = 0.0
    energy = 0.0
    s2 = 0.0
    for p in range(i.size):
        a, b = i[p], j[p]
        s0 = (x[a, 0] - x[b, 0]) + shift[p, 0]
        s1 = (x[a, 1] - x[b, 1]) + shift[p, 1]
        squared = s0 * s0 + s1 * s1
        if three:  # the same for every pair: the compiler hoists it
            s2 = (x[a, 2] - x[b, 2]) + shift[p, 2]
            squared += s2 * s2
        distance = np.sqrt(squared)
        overlap = max(contact[p] - distance, 0.0)
        if hertz:  # the same for every pair, like ``three``
            growth = np.sqrt(reduced[p] * overlap)
            scale = growth * overlap / distance
            energy += 0.4 * growth * overlap * overlap
        else:
            scale = overlap / distance
            energy += 0.5 * overlap * overlap
        out[a, 0] += scale * s0
        out[a, 1] += scale * s1
        on_j[b, 0] += scale * s0
        on_j[b, 1] += scale * s1
        if three:
            out[a, 2] += scale * s2
            on_j[b, 2] += scale * s2
    out -= on_j
    return energy


@numba.njit(cache=True, boundscheck=False)
def largest_squared_move(x: np.ndarray, reference: np.ndarray) -> float:
    """max_n |x_n - reference_n|^2 over (N, D) arrays, the Verlet list's check of every FIRE step:
    ``np.einsum("nd,nd->n", step, step).max()`` with step = x - reference (components summed in
    order), in one pass without the (N, D) and (N,) temporaries; NaN if a move is NaN, as numpy's
    (the compiled ``max`` drops a NaN, issue 58: the squares' sum says, as in
    ``fire_steps.largest_squared_force``; the same time as without it, measured at N = 10^6)."""
    largest, total = 0.0, 0.0
    for n in range(x.shape[0]):
        d0 = x[n, 0] - reference[n, 0]
        squared = d0 * d0
        for d in range(1, x.shape[1]):
            dd = x[n, d] - reference[n, d]
            squared += dd * dd
        largest = max(largest, squared)
        total += squared
    return largest if total == total else np.nan
