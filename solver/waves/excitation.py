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
Wave numbers: k = 2 pi n / L along each axis (``waves.n``, or ``waves.kd0`` moved to the nearest n).
numpy and one mpi4py reduction; no PETSc solves.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

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
    refuses it first: ``schema.check_dimension``).  Not collective."""
    return RUNS[dim][mode]


def run_label(component: int, axis: int, dim: int) -> str:
    """e.g. ``v_y, k || x`` for one run (the results file's ``run_labels``). Not collective."""
    return f"{COMPONENT_NAMES[dim][component]}, k || {'xyz'[axis]}"


def wave_numbers(spec, box) -> tuple[np.ndarray, np.ndarray]:
    """(n (K,), k (K,)) allowed by the square or cubic box ``box`` ((D,) sides, or one) along any of its axes:
    k = 2 pi n / L, from waves.n or nearest to waves.kd0 (n >= 1, duplicates merged, ascending).
    Raises InputError above k d0 = 2 pi, and for a box whose sides differ: the runs along the
    axes are pooled, so they need one set of allowed k. Not collective."""
    box = np.atleast_1d(np.asarray(box, dtype=float))
    if np.any(box != box[0]):
        raise InputError(f"waves: the packing's box has sides {', '.join(f'{side:.4g}' for side in box)}; standing "
                         f"waves are pooled over the axes and need a square or cubic box (one k for "
                         f"every axis)")
    box_length = float(box[0])
    if spec.n is not None:
        ns = np.array(sorted(set(spec.n)))
    else:
        ns = np.array(sorted({max(1, int(round(kd * box_length / (2 * np.pi)))) for kd in spec.kd0}))
    ks = 2 * np.pi * ns / box_length
    if ks.max() > 2 * np.pi:
        raise InputError(f"waves.n = {int(ns.max())}: k d0 = {ks.max():.3f} exceeds 2 pi for box length "
                         f"L = {box_length:.3f} (allowed n <= {int(box_length)})")
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
    r0 = positions[dm.active][start:stop]
    v0 = np.zeros((stop - start, dm.dof))
    v0[:, mode_component] = amplitude * np.sin(k * r0[:, axis])
    if any(slot == mode_component for slot, _ in dm.rigid_modes()):
        weight = dm.M.getArray(readonly=True).reshape(-1, dm.dof)[:, mode_component]
        moment, inertia = comm.allreduce(np.array([np.sum(weight * v0[:, mode_component]), np.sum(weight)]))
        v0[:, mode_component] -= moment / inertia
    return v0.ravel()


def channel(dm, positions, mode_component, axis, k) -> np.ndarray:
    """Local part (nloc,) complex of b: b_i,c = exp(i k r_i,a(0)) in the channel component c, 0 in
    the others, so that z_fixed = b^H v = sum_i v_i,c exp(-i k r_i,a(0)). Not collective."""
    start, stop = dm.disk_range
    r0 = positions[dm.active][start:stop]
    b = np.zeros((stop - start, dm.dof), complex)
    b[:, mode_component] = np.exp(1j * k * r0[:, axis])
    return b.ravel()
