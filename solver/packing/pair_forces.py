"""FIRE's inner loop compiled: net frictionless normal forces over a pair list (numba), on every
thread numba has, the same bits on any number of them.

eq:eij at rho = 0 (kn = 1): a pair (i, j) at separation s = x_i - x_j + shift with contact
distance c = (d_i + d_j)/2 and overlap xi = max(c - |s|, 0) pushes i by f_n s / |s| and j by
minus that, f_n = xi and energy xi^2 / 2 (harmonic), or f_n = sqrt(a' xi) xi and energy
(2/5) sqrt(a' xi) xi^2 (hertz, a' = R_i R_j / (R_i + R_j)); ``contact_law.normal_pair``,
vectorised, is the same formula.

A gather, not a scatter: the pair list (sorted by (i, j)) is turned once per list change into a
neighbour table (:func:`neighbour_table`, CSR: each particle's entries, both directions of every
pair, first the pairs where it is i, then those where it is j, each in list order), and
:func:`net_forces` sums each particle's force over its own entries in that order, particles
spread over threads (``numba.prange``) in chunks of ``CHUNK``.  No two threads write one force,
and each force is the same sum in the same order on 1 or 8 threads; the energy is summed per
chunk and the chunks' sums in chunk order, also independent of the thread count.  A pair's
geometry is computed twice (once from each side: the same numbers negated, exactly), which costs
less than storing the pair forces and gathering them.  The first call compiles (~3 s) and caches
the machine code next to this file (numba ``cache=True``); later processes load it.  Not collective.
"""

from __future__ import annotations

import numba
import numpy as np

CHUNK = 2048
"""Particles per chunk of this module's parallel loops and reductions: fixed, so that sums do not
depend on the number of threads (their partial sums are added in chunk order)."""


@numba.njit(cache=True, boundscheck=False)
def neighbour_table(n: int, i: np.ndarray, j: np.ndarray, shift: np.ndarray, contact: np.ndarray,
                    reduced: np.ndarray, start: np.ndarray, partner: np.ndarray, table_shift: np.ndarray,
                    table_contact: np.ndarray, table_reduced: np.ndarray) -> None:
    """Fill the neighbour table of the pair list (i, j (P,), shift (P, D), contact (P,), a' (P,))
    of ``n`` particles: start (n + 1,), and each particle's entries partner, shift, contact, a'
    (at least 2P rows each, reused from one list to the next: fresh arrays cost more in page
    faults than the filling, measured 15 against 5.5 ms at N = 65536), particle a's at
    start[a]:start[a + 1], first its pairs as i (shift as listed), then as j (shift negated), each
    in list order.  Serial, O(P)."""
    start[:] = 0
    for p in range(i.size):
        start[i[p] + 1] += 1
        start[j[p] + 1] += 1
    for a in range(n):
        start[a + 1] += start[a]
    cursor = start[:-1].copy()
    for p in range(i.size):  # as i
        e = cursor[i[p]]
        cursor[i[p]] = e + 1
        partner[e], table_contact[e], table_reduced[e] = j[p], contact[p], reduced[p]
        for d in range(shift.shape[1]):
            table_shift[e, d] = shift[p, d]
    for p in range(i.size):  # as j
        e = cursor[j[p]]
        cursor[j[p]] = e + 1
        partner[e], table_contact[e], table_reduced[e] = i[p], contact[p], reduced[p]
        for d in range(shift.shape[1]):
            table_shift[e, d] = -shift[p, d]


@numba.njit(cache=True, parallel=True, boundscheck=False)
def net_forces(x: np.ndarray, start: np.ndarray, partner: np.ndarray, shift: np.ndarray, contact: np.ndarray,
               reduced: np.ndarray, hertz: bool, out: np.ndarray) -> float:
    """Write the net force on each particle into ``out`` (N, D) and return the energy.

    x : (N, D) positions, D = 2 or 3;  start, partner, shift, contact, reduced : the neighbour
    table of :func:`neighbour_table`;  hertz : the Hertz law instead of the harmonic one.  Every
    pair's energy is counted from both sides, halved.
    """
    n = x.shape[0]
    three = x.shape[1] == 3
    chunks = (n + CHUNK - 1) // CHUNK
    energies = np.empty(chunks)
    for c in numba.prange(chunks):
        energy = 0.0
        for a in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            f0 = f1 = f2 = s2 = 0.0
            for e in range(start[a], start[a + 1]):
                b = partner[e]
                s0 = (x[a, 0] - x[b, 0]) + shift[e, 0]
                s1 = (x[a, 1] - x[b, 1]) + shift[e, 1]
                squared = s0 * s0 + s1 * s1
                if three:  # the same for every pair: the compiler hoists it
                    s2 = (x[a, 2] - x[b, 2]) + shift[e, 2]
                    squared += s2 * s2
                distance = np.sqrt(squared)
                overlap = max(contact[e] - distance, 0.0)  # no branch: a zero force is added instead
                if hertz:  # the same for every pair, like ``three``
                    growth = np.sqrt(reduced[e] * overlap)
                    scale = growth * overlap / distance
                    energy += 0.4 * growth * overlap * overlap
                else:
                    scale = overlap / distance
                    energy += 0.5 * overlap * overlap
                f0 += scale * s0
                f1 += scale * s1
                f2 += scale * s2
            out[a, 0] = f0
            out[a, 1] = f1
            if three:
                out[a, 2] = f2
        energies[c] = energy
    total = 0.0
    for c in range(chunks):
        total += energies[c]
    return 0.5 * total


@numba.njit(cache=True, parallel=True, boundscheck=False)
def largest_squared_move(x: np.ndarray, reference: np.ndarray) -> float:
    """max_n |x_n - reference_n|^2 over (N, D) arrays, the Verlet list's check of every FIRE step
    (components summed in order), in one pass without temporaries, in chunks of ``CHUNK`` on
    every thread; NaN if a move is NaN, as numpy's max (the compiled ``max`` drops a NaN, issue 58:
    the squares' sum says, as in ``fire_steps.force_measures``)."""
    n = x.shape[0]
    chunks = (n + CHUNK - 1) // CHUNK
    largest, total = np.empty(chunks), np.empty(chunks)
    for c in numba.prange(chunks):
        most, added = 0.0, 0.0
        for a in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            d0 = x[a, 0] - reference[a, 0]
            squared = d0 * d0
            for d in range(1, x.shape[1]):
                dd = x[a, d] - reference[a, d]
                squared += dd * dd
            most = max(most, squared)
            added += squared
        largest[c], total[c] = most, added
    return largest.max() if total.sum() == total.sum() else np.nan
