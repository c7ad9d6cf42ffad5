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
Start (eq:initial): v_c(0) = A sin(k r_i,a(0)) in the excited component c, zero displacement.
Every exact zero mode of the matrix in that component (``DynamicalMatrix.rigid_modes``: the
uniform translation; the uniform spin when rotations carry only rolling/twisting springs, rho = 0)
is projected out, M-orthogonally (PHYSICS.md section 4): in a disordered packing
sum_i sin(k . r_i) != 0, and that momentum (or spin angular momentum) would drift (spin) forever.
Channel: z(t) = sum_i v_i,c(t) exp(-i k r_i,a) (the paper's Fourier transform of the velocities)
= b^H v with b_i,c = exp(i k r_i,a(0)) for the r_i(0) phase (``channel``).
Wave numbers: k = 2 pi n / L_a along each axis a used (``waves.axes``; ``waves.n``, or
``waves.kd0`` moved to the nearest n on each side), the same k on every axis pooled.
numpy and one mpi4py reduction; no PETSc solves.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model import dynmat

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
    """e.g. ``v_y, k || x`` for one run (the results file's ``run_labels``). Not collective."""
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


def wave_vectors(spec, box: np.ndarray, axes: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """(n (K, A), k (K, A)): for each asked wave number, the allowed n and k = 2 pi n / L_a along
    each of the A ``axes`` of the box ``box`` (D,).  A square or cubic box gives the same column
    A times (``wave_numbers``); in a box whose sides differ, waves.kd0 is moved to the nearest
    allowed k along each axis, and the axes' k of one wave number must agree to ``SPREAD``
    (waves.n, the same n on sides that differ, cannot).  Rows sorted by k, duplicates merged.
    Raises InputError naming waves.axes otherwise, or above k d0 = 2 pi. Not collective."""
    sides = np.asarray(box, dtype=float)[axes]
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
        raise InputError(f"waves: the box's sides differ, and the wave number asked has {names}: "
                         f"{100 * spread[row]:.1f} % apart, more than the {100 * SPREAD:g} % over which runs are "
                         f"pooled; set waves.axes to the axes whose allowed k agree (e.g. [{'xyz'[axes[0]]}])"
                         + ("" if spec.n is None else ", or give waves.kd0 instead of waves.n"))
    return ns, ks


def wave_modes(spec, rotations: bool) -> list[str]:
    """Modes that exist for a matrix with or without rotations (no RT or R without rotational
    springs). Not collective."""
    return [m for m in spec.modes if rotations or m not in ("RT", "R")]


def start_velocity(dm, positions, mode_component, axis, k, amplitude, comm) -> np.ndarray:
    """Local part (nloc,) of v(0) (eq:initial) for one run, with the exact zero modes of ``dm`` in
    the excited component projected out.  ``comm``: mpi4py communicator of ``dm``. Collective.

    The zero mode of slot c is the uniform vector e_c (``dm.rigid_modes()``); its M-orthogonal
    projection removes sum_i M_i,c v_i,c / sum_i M_i,c: the mean velocity (equal masses) or the
    spin angular momentum over the total moment of inertia (I_i = m d_i^2 / 8 or / 10 differ).
    Then e_c^T M v(0) = 0 and no part of v(0) translates or spins forever.
    """
    start, stop = dm.disk_range
    r0 = positions[dm.order[start:stop]]
    v0 = np.zeros((stop - start, dm.dof))
    v0[:, mode_component] = amplitude * np.sin(k * r0[:, axis])
    if any(slot == mode_component for slot, _ in dm.rigid_modes()):
        weight = dm.M.getArray(readonly=True).reshape(-1, dm.dof)[:, mode_component]
        moment, inertia = comm.allreduce(np.array([np.sum(weight * v0[:, mode_component]), np.sum(weight)]))
        v0[:, mode_component] -= moment / inertia
    return v0.ravel()


def whole_start(dm, positions, mode_component, axis, k, amplitude, comm) -> np.ndarray:
    """v(0) of :func:`start_velocity` whole on every rank, (N', dof) over the non-rattlers in the
    packing's order (not the matrix's): the start handed to a DEM code or a dense reference.
    Collective."""
    local = start_velocity(dm, positions, mode_component, axis, k, amplitude, comm)
    return dynmat.in_packing_order(dm, np.concatenate(comm.allgather(local))).reshape(-1, dm.dof)


def channel(dm, positions, mode_component, axis, k) -> np.ndarray:
    """Local part (nloc,) complex of b: b_i,c = exp(i k r_i,a(0)) in the channel component c, 0 in
    the others, so that z_fixed = b^H v = sum_i v_i,c exp(-i k r_i,a(0)). Not collective."""
    start, stop = dm.disk_range
    r0 = positions[dm.order[start:stop]]
    b = np.zeros((stop - start, dm.dof), complex)
    b[:, mode_component] = np.exp(1j * k * r0[:, axis])
    return b.ravel()
