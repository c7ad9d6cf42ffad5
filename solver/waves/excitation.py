"""The standing waves of the paper: which velocity component is excited with k along which axis
(tab:modes, and its 3D form in PHYSICS.md section 8), the start velocity (eq:initial), the channel
whose Fourier component is sampled, and the wave numbers a periodic box allows.

A mode's runs (``runs``): every (excited DOF component, axis of k) it has in D dimensions.
DOF slots per particle: 0..D-1 the velocity components, D.. the angular velocity (2D: slot 2 is
theta-dot; 3D: slots 3, 4, 5 are the angular velocity about x, y, z).
    2D, both directions of tab:modes (unchanged):
    L : v_x with k || x,  v_y with k || y      (longitudinal channel: the excited component)
    TR: v_x with k || y,  v_y with k || x      (transverse channel: the excited component)
    RT: theta-dot with k || x, with k || y     (rotational channel)
    3D, k along x, y, z in turn (axis-major), each polarisation:
    L : v_a with k || a                        3 runs
    TR: v_c with k || a, c != a                6 runs (both polarisations)
    RT: omega_c with k || a, c != a            6 runs (both polarisations)
    R : omega_a with k || a                    3 runs (the twist mode; 3D only)
In a tilted (triclinic) cell ``geometry.Cell``, "k || a" means k along the reciprocal vector b_a
of axis a (``Cell.reciprocal()`` row a: b_a . (edge a) = 2 pi, b_a . (the other edges) = 0), so
k . r = 2 pi n s_a with s_a the fractional coordinate and the wave is periodic in the cell; the
polarisation of a run (c, a) then turns with k (``polarisation``): L (c = a, and R) along k, the
others e_c made perpendicular to k (Gram-Schmidt, the smaller c first), so that the two
transverse polarisations stay orthonormal to k.  In an orthogonal cell b_a = 2 pi e_a / L_a and
every polarisation is e_c: everything below is the same, bit for bit, as with k along the axis.
Start (eq:initial): v(0) = A sin(k . r_i(0)) p in the polarisation p (the excited component c in
an orthogonal cell), zero displacement.
Every exact zero mode of the matrix in that component (``DynamicalMatrix.rigid_modes``: the
uniform translation; the uniform spin when rotations carry only rolling/twisting springs, rho = 0)
is projected out, M-orthogonally (PHYSICS.md section 4): in a disordered packing
sum_i sin(k . r_i) != 0, and that momentum (or spin angular momentum) would drift (spin) forever.
Channel: z(t) = sum_i p . v_i(t) exp(-i k . r_i) (the paper's Fourier transform of the velocities)
= b^H v with b_i = exp(i k . r_i(0)) p for the r_i(0) phase (``channel``).
Wave numbers: |k| = 2 pi n / L_a along each axis a used (``waves.axes``; ``waves.n``, or
``waves.kd0`` moved to the nearest n on each side), the same k on every axis pooled; L_a is the
period along k: the side in an orthogonal cell, the height across axis a (``Cell.heights``,
2 pi / |b_a|) in a tilted one (``periods``).
A wave's k, as the functions below take it: a float, k along the run's axis (an orthogonal cell),
or the (D,) wave vector (``wave_vector``).
numpy and one mpi4py reduction; no PETSc solves.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model import dynmat
from ..packing.geometry import Cell

_AXES = range(3)
RUNS = {
    2: {"L": [(0, 0), (1, 1)], "TR": [(0, 1), (1, 0)], "RT": [(2, 0), (2, 1)]},
    3: {"L": [(a, a) for a in _AXES], "TR": [(c, a) for a in _AXES for c in _AXES if c != a],
        "RT": [(3 + c, a) for a in _AXES for c in _AXES if c != a], "R": [(3 + a, a) for a in _AXES]},
}
"""dimension -> mode -> [(excited DOF component, axis of k)] of its runs (module docstring)."""

COMPONENT_NAMES = {2: ("v_x", "v_y", "w_z"), 3: ("v_x", "v_y", "v_z", "w_x", "w_y", "w_z")}
"""dimension -> names of the DOF slots' velocities (w: angular velocity), for labels."""


def runs(mode: str, dim: int) -> list[tuple[int, int]]:
    """[(excited DOF component, axis of k)] of every run of ``mode`` in ``dim`` dimensions, in the
    order of the first axis of a unit's ``z`` (``RUNS``).  Raises KeyError for R in 2D (the scene
    refuses it first: ``rules.check_dimension``).  Not collective."""
    return RUNS[dim][mode]


def run_label(component: int, axis: int, dim: int) -> str:
    """e.g. ``v_y, k || x`` for one run (the results file's ``run_labels``; in a tilted cell k is
    along the reciprocal vector b_x and the polarisation turns with it: ``polarisation``). Not
    collective."""
    return f"{COMPONENT_NAMES[dim][component]}, k || {'xyz'[axis]}"


def _nearest_n(kd: float, side: float) -> int:
    """The n >= 1 whose k = 2 pi n / ``side`` is nearest to ``kd`` (ties to the even n)."""
    return max(1, int(round(kd * side / (2 * np.pi))))


def _refuse_above_two_pi(n: int, side: float) -> None:
    if 2 * np.pi * n / side > 2 * np.pi:
        raise InputError(f"waves.n = {n}: k d0 = {2 * np.pi * n / side:.3f} exceeds 2 pi for box length "
                         f"L = {side:.3f} (allowed n <= {int(side)})")


def wave_numbers(spec, box_length: float) -> tuple[np.ndarray, np.ndarray]:
    """(n (K,), k (K,)) allowed along one side ``box_length`` L: k = 2 pi n / L, from waves.n or
    nearest to waves.kd0 (n >= 1, duplicates merged, ascending).  Raises InputError above
    k d0 = 2 pi. Not collective."""
    ns = np.array(sorted(set(spec.n) if spec.n is not None else {_nearest_n(kd, box_length) for kd in spec.kd0}))
    for n in ns[-1:]:
        _refuse_above_two_pi(int(n), box_length)
    return ns, 2 * np.pi * ns / box_length


SPREAD = 0.01
"""Largest relative spread of one wave number's k over the axes whose runs are pooled [choice]:
the runs' C(k, t) are averaged as one k, so their k must agree; 1 % is below the scatter of a
fitted dispersion."""


def wave_axes(spec, dim: int) -> list[int]:
    """Axes (0, 1[, 2]) along which k runs: ``waves.axes``, or every axis. Not collective."""
    return list(range(dim)) if spec.axes is None else sorted("xyz".index(a) for a in spec.axes)


def periods(box) -> np.ndarray:
    """(D,) the period L_a of a standing wave along each axis a (|k| = 2 pi n / L_a): the sides of
    an orthogonal cell, the heights 2 pi / |b_a| of a tilted one (``box``: a Cell, or the (D,) sides
    of an orthogonal one). Not collective."""
    if isinstance(box, Cell) and box.tilted:
        return box.heights
    return np.asarray(box.sides if isinstance(box, Cell) else box, dtype=float)


def wave_vectors(spec, box, axes: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """(n (K, A), k (K, A)): for each asked wave number, the allowed n and |k| = 2 pi n / L_a along
    each of the A ``axes`` of the cell ``box`` (a Cell, or the (D,) sides of an orthogonal one; L_a:
    ``periods``).  A square or cubic box gives the same column
    A times (``wave_numbers``); in a box whose sides differ, waves.kd0 is moved to the nearest
    allowed k along each axis, and the axes' k of one wave number must agree to ``SPREAD``
    (waves.n, the same n on sides that differ, cannot).  Rows sorted by k, duplicates merged.
    Raises InputError naming waves.axes otherwise, or above k d0 = 2 pi. Not collective."""
    sides = periods(box)[axes]
    if np.all(sides == sides[0]):
        ns, ks = wave_numbers(spec, float(sides[0]))
        return np.repeat(ns[:, None], len(axes), axis=1), np.repeat(ks[:, None], len(axes), axis=1)
    asked = spec.n if spec.n is not None else spec.kd0
    rows = {tuple(int(v) for v in [value] * len(axes)) if spec.n is not None else
            tuple(_nearest_n(value, side) for side in sides) for value in asked}
    ns = np.array(sorted(rows, key=lambda row: np.mean(2 * np.pi * np.array(row) / sides)))
    for column, side in enumerate(sides):
        _refuse_above_two_pi(int(ns[:, column].max()), float(side))
    ks = 2 * np.pi * ns / sides
    spread = np.ptp(ks, axis=1) / ks.mean(axis=1)
    if spread.max() > SPREAD:
        row = int(spread.argmax())
        names = ", ".join(f"k_{'xyz'[a]} = {k:.4f} (n = {n}, L = {side:.4g})"
                          for a, k, n, side in zip(axes, ks[row], ns[row], sides))
        differ = "the tilted cell's periods along waves.axes differ" if isinstance(box, Cell) and box.tilted \
            else "the box's sides differ"
        raise InputError(f"waves: {differ}, and the wave number asked has {names}: "
                         f"{100 * spread[row]:.1f} % apart, more than the {100 * SPREAD:g} % over which runs are "
                         f"pooled; set waves.axes to the axes whose allowed k agree (e.g. [{'xyz'[axes[0]]}])"
                         + ("" if spec.n is None else ", or give waves.kd0 instead of waves.n"))
    return ns, ks


def log_lines(spec, ns: np.ndarray, ks: np.ndarray, axes: list[int], box) -> list[str]:
    """The log's lines on the wave numbers ``ns``, ``ks`` (K, A) of ``wave_vectors`` along ``axes``
    of the cell ``box``: with waves.kd0 in an orthogonal cell, the k and n it was moved to (one line
    per axis where the sides differ); in a tilted cell always, one line per axis: |k|, n, the period
    and the direction b_a / |b_a| along which k runs. Not collective."""
    lengths = periods(box)
    tilted = isinstance(box, Cell) and box.tilted
    if spec.kd0 is None and not tilted:
        return []
    several = tilted or len(set(lengths[axes])) > 1
    lines = []
    for column, axis in enumerate(axes if several else axes[:1]):
        numbers = (f"{', '.join(f'{k:.4f}' for k in ks[:, column])} "
                   f"(n = {', '.join(map(str, ns[:, column]))}")
        if tilted:
            row = box.reciprocal()[axis]
            direction = ", ".join(f"{c:.4f}" for c in row / np.linalg.norm(row))
            lines.append(f"waves: |k| d0 = {numbers}, period {lengths[axis]:.3f} along b_{'xyz'[axis]} = ({direction}))")
        else:
            along = f", along {'xyz'[axis]}" if several else ""
            lines.append(f"waves: k d0 = {numbers}, L = {lengths[axis]:.3f}{along})")
    return lines


def wave_modes(spec, rotations: bool) -> list[str]:
    """Modes that exist for a matrix with or without rotations (no RT or R without rotational
    springs). Not collective."""
    return [m for m in spec.modes if rotations or m not in ("RT", "R")]


def wave_vector(k: float, axis: int, box) -> float | np.ndarray:
    """A run's k as the functions below take it: ``k`` (|k|, ``wave_vectors``) itself along ``axis``
    of an orthogonal cell (``box``: a Cell or (D,) sides), else the (D,) vector |k| b_a / |b_a| along
    the reciprocal vector of ``axis`` in a tilted cell. Not collective."""
    if not (isinstance(box, Cell) and box.tilted):
        return k
    row = box.reciprocal()[axis]
    return k * row / np.linalg.norm(row)


def k_vector(k, axis: int, dim: int) -> np.ndarray:
    """(D,) the wave vector of ``k``: a float along ``axis``, or the (D,) vector as it is."""
    if np.ndim(k) == 0:
        vector = np.zeros(dim)
        vector[axis] = k
        return vector
    return np.asarray(k, dtype=float)


def polarisation(component: int, axis: int, k, dim: int, dof: int) -> np.ndarray:
    """(dof,) the unit polarisation p of run (``component``, ``axis``) with wave vector ``k`` (float
    along ``axis``, or (D,)) over a particle's DOF slots: within the slots of ``component``
    (velocities, or the angular velocities in 3D) k^ for L and R (the slot's index there = axis),
    else e_c minus its parts along k^ and, for the second transverse slot, along the first's
    polarisation (Gram-Schmidt in the order of the slots); 2D's w_z is always e_2 (perpendicular
    to k in the plane).  With k along ``axis`` every p is e_component exactly. Not collective."""
    p = np.zeros(dof)
    rotation = component >= dim
    if rotation and dim == 2:
        p[component] = 1.0
        return p
    first = dim if rotation else 0
    slot = component - first
    direction = k_vector(k, axis, dim)
    basis = [direction / np.linalg.norm(direction)]
    if slot != axis:
        for other in [c for c in range(dim) if c != axis and c <= slot]:
            vector = np.eye(dim)[other]
            for done in basis:
                vector = vector - (vector @ done) * done
            basis.append(vector / np.linalg.norm(vector))
    p[first:first + dim] = basis[-1]
    return p


def phases(positions: np.ndarray, axis: int, k) -> np.ndarray:
    """k . r (N,) of ``positions`` (N, D): k r_a for a float ``k`` along ``axis``, else r @ k."""
    if np.ndim(k) == 0:
        return k * positions[:, axis]
    return positions @ np.asarray(k, dtype=float)


def start_velocity(dm, positions, mode_component, axis, k, amplitude, comm) -> np.ndarray:
    """Local part (nloc,) of v(0) (eq:initial) for one run (``mode_component``, ``axis``; ``k`` a
    float along the axis or the (D,) wave vector, ``wave_vector``), with the exact zero modes of
    ``dm`` in the polarisation's slots projected out.  ``comm``: mpi4py communicator of ``dm``.
    Collective.

    The zero mode of slot c is the uniform vector e_c (``dm.rigid_modes()``); its M-orthogonal
    projection removes sum_i M_i,c v_i,c / sum_i M_i,c: the mean velocity (equal masses) or the
    spin angular momentum over the total moment of inertia (I_i = m d_i^2 / 8 or / 10 differ).
    Then e_c^T M v(0) = 0 and no part of v(0) translates or spins forever.
    """
    start, stop = dm.disk_range
    r0 = positions[dm.order[start:stop]]
    p = polarisation(mode_component, axis, k, dm.dim, dm.dof)
    slots = np.flatnonzero(p)
    v0 = np.zeros((stop - start, dm.dof))
    v0[:, slots] = amplitude * np.sin(phases(r0, axis, k))[:, None] * p[slots]
    free = [slot for slot, _ in dm.rigid_modes() if p[slot] != 0.0]
    if free:
        weight = dm.M.getArray(readonly=True).reshape(-1, dm.dof)
        sums = comm.allreduce(np.array([[np.sum(weight[:, c] * v0[:, c]), np.sum(weight[:, c])] for c in free]))
        for c, (moment, inertia) in zip(free, sums):
            v0[:, c] -= moment / inertia
    return v0.ravel()


def whole_start(dm, positions, mode_component, axis, k, amplitude, comm) -> np.ndarray:
    """v(0) of :func:`start_velocity` whole on every rank, (N', dof) over the non-rattlers in the
    packing's order (not the matrix's): the start handed to a DEM code or a dense reference.
    Collective."""
    local = start_velocity(dm, positions, mode_component, axis, k, amplitude, comm)
    return dynmat.in_packing_order(dm, np.concatenate(comm.allgather(local))).reshape(-1, dm.dof)


def channel(dm, positions, mode_component, axis, k) -> np.ndarray:
    """Local part (nloc,) complex of b: b_i = exp(i k . r_i(0)) p in the polarisation's slots
    (``polarisation``: e_c in an orthogonal cell), 0 in the others, so that z_fixed = b^H v =
    sum_i p . v_i exp(-i k . r_i(0)). Not collective."""
    start, stop = dm.disk_range
    r0 = positions[dm.order[start:stop]]
    p = polarisation(mode_component, axis, k, dm.dim, dm.dof)
    slots = np.flatnonzero(p)
    b = np.zeros((stop - start, dm.dof), complex)
    b[:, slots] = np.exp(1j * phases(r0, axis, k))[:, None] * p[slots]
    return b.ravel()
