"""FIRE's Verlet list made compiled (numba), on every thread numba has, the same list on any number
of them: a cell list of an orthogonal periodic box, searched particle by particle.

:func:`verlet_list` lists every pair closer than its contact distance plus a reach under periodic
images, in the order of :class:`mechanics.FrictionlessForces`' list (sorted by (i, j), i < j), and
at the same time its neighbour table (``pair_forces.neighbour_table``'s layout: particle a's
entries, first the pairs where it is i, then those where it is j, each in list order).  Each
particle's row is found from its own 3^D cells and sorted by partner, so a row does not depend on
which thread makes it; the rows, kept meanwhile in scratch rows bounded by their blocks' particles,
are placed by a prefix sum of their lengths.  The search compares positions folded into the box,
so a pair within round-off of the reach's edge may be listed here and not by the cKDTree search of
``mechanics`` or the reverse: such a pair is apart by the skin and carries no force.  The image
shift of a pair is -L rint(delta / L) per axis, delta = x_i - x_j: a whole number of sides, the same bits
whenever the pair is listed and exactly negated from j's side, so that the forces
(``pair_forces.net_forces``) do not depend on when the list was made nor on its reach (a listed
pair apart adds +-0 to a sum, which changes no bit).  The first call compiles and caches the
machine code (numba ``cache=True``).  Not collective.
"""

from __future__ import annotations

import numba
import numpy as np

CELLS = 256
"""Cells per chunk of the parallel loops over cells (each chunk's small arrays made once)."""
CHUNK = 2048
"""Particles per chunk of the parallel loop over particles."""


@numba.njit(cache=True, boundscheck=False)
def _cells(x: np.ndarray, diameters: np.ndarray, sides: np.ndarray, cutoff: float, folded: np.ndarray,
           radius: np.ndarray) -> tuple:
    """(cells per axis (D,), first (cells + 1,), members (N,)): the particles of each cell of side
    >= ``cutoff``, in index order (a counting sort); writes their positions folded into the box
    and their radii, in that order, into ``folded`` (N, D) and ``radius`` (N,)."""
    n, dim = x.shape
    per_axis = np.empty(dim, dtype=np.int64)
    for d in range(dim):
        per_axis[d] = max(1, int(np.floor(sides[d] / cutoff)))
    own = np.empty(n, dtype=np.int64)
    inside = np.empty((n, dim))
    for a in range(n):
        flat = 0
        for d in range(dim):
            inside[a, d] = x[a, d] - sides[d] * np.floor(x[a, d] / sides[d])
            k = min(max(int(inside[a, d] * per_axis[d] / sides[d]), 0), per_axis[d] - 1)
            flat = flat * per_axis[d] + k
        own[a] = flat
    total = 1
    for d in range(dim):
        total *= per_axis[d]
    first = np.zeros(total + 1, dtype=np.int64)
    for a in range(n):
        first[own[a] + 1] += 1
    for c in range(total):
        first[c + 1] += first[c]
    cursor = first[:-1].copy()
    members = np.empty(n, dtype=np.int64)
    for a in range(n):
        e = cursor[own[a]]
        cursor[own[a]] = e + 1
        members[e], radius[e] = a, 0.5 * diameters[a]
        for d in range(dim):
            folded[e, d] = inside[a, d]
    return per_axis, first, members


@numba.njit(cache=True, boundscheck=False)
def _neighbour_cells(cell: int, per_axis: np.ndarray, out: np.ndarray, wraps: np.ndarray, coords: np.ndarray) -> int:
    """Write the distinct cells of the 3^D block around ``cell`` (periodic) into ``out`` and into
    ``wraps`` (3^D, D) how many sides each lies across the box (-1, 0 or 1 per axis); return how
    many cells (fewer than 3^D when an axis has fewer than 3 cells: the wraps are then not used).
    ``coords`` (D,): scratch."""
    dim = per_axis.size
    small = False
    rest = cell
    for d in range(dim - 1, -1, -1):
        coords[d] = rest % per_axis[d]
        rest //= per_axis[d]
        small = small or per_axis[d] < 3
    count = 0
    for code in range(3 ** dim):
        flat, digits = 0, code
        for d in range(dim):
            k = coords[d] + digits % 3 - 1
            digits //= 3
            inside = k % per_axis[d]
            wraps[count, d] = (k - inside) // per_axis[d]
            flat = flat * per_axis[d] + inside
        seen = False
        for m in range(count if small else 0):  # only an axis of fewer than 3 cells repeats a cell
            seen = seen or out[m] == flat
        if not seen:
            out[count] = flat
            count += 1
    return count


@numba.njit(cache=True, boundscheck=False)
def _partners(at, cells, block, wraps, folded, radius, sides, reach, small, first, members, image, found) -> tuple:
    """Write the particles listed with the one at ``at`` in cell order into ``found``, sorted;
    return (how many, how many of them have a larger index).  ``cells``, ``block``, ``wraps``: its
    cell's block (:func:`_neighbour_cells`); ``small``: an axis has fewer than 3 cells (minimum
    images instead of the wraps)."""
    dim = folded.shape[1]
    a = members[at]
    count = above = 0
    for m in range(cells):
        for d in range(dim):
            image[d] = folded[at, d] - wraps[m, d] * sides[d]  # its image beside the cell's members
        for e in range(first[block[m]], first[block[m] + 1]):
            squared = 0.0
            for d in range(dim):
                separation = image[d] - folded[e, d]
                if small:
                    separation -= sides[d] * np.rint(separation / sides[d])
                squared += separation * separation
            limit = radius[at] + radius[e] + reach
            if squared < limit * limit and e != at:
                b = members[e]
                k = count  # insertion sort: a row is a few tens of partners
                while k > 0 and found[k - 1] > b:
                    found[k] = found[k - 1]
                    k -= 1
                found[k] = b
                count += 1
                above += b > a
    return count, above


@numba.njit(cache=True, parallel=True, boundscheck=False)
def _room(per_axis, first, room):
    """Write into ``room`` (cells,) an upper bound of the partners of a cell's particles in all:
    its particles times those of its block."""
    dim = per_axis.size
    total = first.size - 1
    for chunk in numba.prange((total + CELLS - 1) // CELLS):
        block = np.empty(3 ** dim, dtype=np.int64)
        wraps = np.empty((3 ** dim, dim), dtype=np.int64)
        coords = np.empty(dim, dtype=np.int64)
        for c in range(chunk * CELLS, min(total, (chunk + 1) * CELLS)):
            near = 0
            for m in range(_neighbour_cells(c, per_axis, block, wraps, coords)):
                near += first[block[m] + 1] - first[block[m]]
            room[c] = (first[c + 1] - first[c]) * near


@numba.njit(cache=True, parallel=True, boundscheck=False)
def _search(folded, radius, sides, reach, per_axis, first, members, offset, scratch, where, above, below):
    """Each particle's listed partners (:func:`_partners`; chunks of cells spread over threads),
    sorted, into ``scratch`` from ``where`` (its cell's ``offset`` and its place in the cell), and
    their numbers above and below it.  ``folded``, ``radius``: positions in the box and radii in
    cell order."""
    dim = folded.shape[1]
    small = False
    for d in range(dim):
        small = small or per_axis[d] < 3
    total = first.size - 1
    for chunk in numba.prange((total + CELLS - 1) // CELLS):
        block = np.empty(3 ** dim, dtype=np.int64)
        wraps = np.empty((3 ** dim, dim), dtype=np.int64)
        coords = np.empty(dim, dtype=np.int64)
        image = np.empty(dim)
        for c in range(chunk * CELLS, min(total, (chunk + 1) * CELLS)):
            cells = _neighbour_cells(c, per_axis, block, wraps, coords)
            near = 0
            for m in range(cells):
                near += first[block[m] + 1] - first[block[m]]
            for at in range(first[c], first[c + 1]):
                a = members[at]
                start = offset[c] + (at - first[c]) * near
                count, up = _partners(at, cells, block, wraps, folded, radius, sides, reach, small, first, members,
                                      image, scratch[start:start + near])
                where[a], above[a], below[a] = start, up, count - up


@numba.njit(cache=True, parallel=True, boundscheck=False)
def _fill(x, diameters, sides, scratch, where, above, below, pair_start, row_start, i, j, shift, contact, reduced,
          partner, table_shift, table_contact, table_reduced):
    """Write each particle's pairs and table entries (:func:`_write`) from its partners in
    ``scratch`` (:func:`_search`), chunks of particles spread over threads."""
    n = x.shape[0]
    for chunk in numba.prange((n + CHUNK - 1) // CHUNK):
        for a in range(chunk * CHUNK, min(n, (chunk + 1) * CHUNK)):
            count = above[a] + below[a]
            _write(a, scratch[where[a]:where[a] + count], count, below[a], x, diameters, sides, pair_start[a],
                   row_start[a], i, j, shift, contact, reduced, partner, table_shift, table_contact, table_reduced)


@numba.njit(cache=True, boundscheck=False)
def _write(a, found, count, up, x, diameters, sides, p, e, i, j, shift, contact, reduced, partner, table_shift,
           table_contact, table_reduced) -> None:
    """Write particle a's sorted partners ``found[:count]`` (``up`` of them below it): its pairs as i
    from row ``p`` of the list, its table entries (partners above it, then below) from row ``e``."""
    dim = x.shape[1]
    for k in range(up, count + up):
        b = found[k] if k < count else found[k - count]
        close = 0.5 * (diameters[a] + diameters[b])
        grown = diameters[a] * diameters[b] / (2.0 * (diameters[a] + diameters[b]))  # contact_law.reduced_radius
        partner[e], table_contact[e], table_reduced[e] = b, close, grown
        for d in range(dim):
            table_shift[e, d] = -(sides[d] * np.rint((x[a, d] - x[b, d]) / sides[d]))
        if b > a:
            i[p], j[p], contact[p], reduced[p] = a, b, close, grown
            for d in range(dim):
                shift[p, d] = table_shift[e, d]
            p += 1
        e += 1

def verlet_list(x: np.ndarray, diameters: np.ndarray, sides: np.ndarray, reach: float, room: tuple = ()) -> tuple:
    """The pairs of ``x`` (N, D) closer than their contact distance (d_i + d_j)/2 plus ``reach``
    in the periodic box of ``sides`` (D,) (each side more than twice the largest diameter plus
    ``reach``: one image of a pair within reach), and their neighbour table:
    ((i, j (P,), shift (P, D), contact (P,), a' (P,)), (start (N + 1,), partner, shift, contact,
    a' (2P rows)), room), pairs sorted by (i, j), i < j, a' = R_i R_j / (R_i + R_j).  The arrays
    are views of ``room`` (the last call's, reused when large enough: fresh arrays cost more in
    page faults than the filling) or of new ones a quarter larger than needed; ``room[0]`` holds
    each particle's partners found by the search (at most its block's particles), which the
    second pass places once the rows' lengths are known, without searching again."""
    n, dim = x.shape
    folded, radius = np.empty_like(x), np.empty(n)
    per_axis, first, members = _cells(x, diameters, sides, float(diameters.max()) + reach, folded, radius)
    offset = np.zeros(first.size, dtype=np.int64)
    _room(per_axis, first, offset[1:])
    np.cumsum(offset, out=offset)
    room = _grown(room, 0, int(offset[-1]), (), np.int64)
    where, above, below = (np.empty(n, dtype=np.int64) for _ in range(3))
    _search(folded, radius, sides, reach, per_axis, first, members, offset, room[0], where, above, below)
    pair_start = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(above, out=pair_start[1:])
    row_start = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(above + below, out=row_start[1:])
    pairs, rows = int(pair_start[-1]), int(row_start[-1])
    kinds = (((), np.int64), ((), np.int64), ((dim,), float), ((), float), ((), float))  # i, j, shift, contact, a'
    for size, first_slot, wanted in ((pairs, 1, kinds), (rows, 6, kinds[1:])):
        for slot, (shape, kind) in enumerate(wanted):
            room = _grown(room, first_slot + slot, size, shape, kind)
    listed = tuple(a[:pairs] for a in room[1:6])
    table = (row_start, *(a[:rows] for a in room[6:10]))
    _fill(x, diameters, sides, room[0], where, above, below, pair_start, row_start, *listed, *table[1:])
    return listed, table, room


def _grown(room: tuple, slot: int, size: int, shape: tuple, kind) -> tuple:
    """``room`` with an array of at least ``size`` rows of ``shape`` at ``slot`` (a quarter more
    than asked when made anew)."""
    room = room + (None,) * (slot + 1 - len(room))
    if room[slot] is None or room[slot].shape[0] < size:
        room = room[:slot] + (np.empty((size + size // 4, *shape), dtype=kind),) + room[slot + 1:]
    return room
