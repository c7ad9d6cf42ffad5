"""The standing waves of the paper: which velocity component is excited with k along which axis
(tab:modes), the start velocity (eq:initial), the channel whose Fourier component is sampled,
and the wave numbers a periodic box allows.

Each mode runs in both directions of tab:modes:
    L : v_x with k || x,  v_y with k || y      (longitudinal channel: the excited component)
    TR: v_x with k || y,  v_y with k || x      (transverse channel: the excited component)
    RT: theta-dot with k || x, with k || y     (rotational channel)
Start (eq:initial): v_c(0) = A sin(k r_i,a(0)) in the excited component c, zero displacement.
The uniform translation is projected out of a translational start (PHYSICS.md section 4): in a
disordered packing sum_i sin(k . r_i) != 0 and that momentum would drift forever.
Channel: z(t) = sum_i v_i,c(t) exp(-i k r_i,a) (the paper's Fourier transform of the velocities)
= b^H v with b_i,c = exp(i k r_i,a(0)) for the r_i(0) phase (``channel``).
Wave numbers: k = 2 pi n / L along x or y (``waves.n``, or ``waves.kd0`` moved to the nearest n).
numpy and one mpi4py reduction; no PETSc solves.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

EXCITATIONS = {"L": [(0, 0), (1, 1)], "TR": [(0, 1), (1, 0)], "RT": [(2, 0), (2, 1)]}
"""mode -> [(excited DOF component, axis of k)] for its two directions (tab:modes)."""


def wave_numbers(spec, box_length: float) -> tuple[np.ndarray, np.ndarray]:
    """(n (K,), k (K,)) allowed by the box: k = 2 pi n / L, from waves.n or nearest to waves.kd0
    (n >= 1, duplicates merged, ascending).  Raises InputError above k d0 = 2 pi. Not collective."""
    if spec.n is not None:
        ns = np.array(sorted(set(spec.n)))
    else:
        ns = np.array(sorted({max(1, int(round(kd * box_length / (2 * np.pi)))) for kd in spec.kd0}))
    ks = 2 * np.pi * ns / box_length
    if ks.max() > 2 * np.pi:
        raise InputError(f"waves.n = {int(ns.max())}: k d0 = {ks.max():.3f} exceeds 2 pi for box length "
                         f"L = {box_length:.3f} (allowed n <= {int(box_length)})")
    return ns, ks


def wave_modes(spec, dof: int) -> list[str]:
    """Modes that exist for this matrix (no RT without rotations, i.e. at rho = 0). Not collective."""
    return [m for m in spec.modes if not (m == "RT" and dof == 2)]


def start_velocity(dm, positions, mode_component, axis, k, amplitude, comm) -> np.ndarray:
    """Local part (nloc,) of v(0) (eq:initial) for one run; uniform translation projected out.
    ``comm``: mpi4py communicator of ``dm``. Collective."""
    start, stop = dm.disk_range
    r0 = positions[dm.active][start:stop]
    v0 = np.zeros((stop - start, dm.dof))
    v0[:, mode_component] = amplitude * np.sin(k * r0[:, axis])
    if mode_component < 2:
        total = comm.allreduce(v0[:, mode_component].sum())
        v0[:, mode_component] -= total / int(dm.active.sum())
    return v0.ravel()


def channel(dm, positions, mode_component, axis, k) -> np.ndarray:
    """Local part (nloc,) complex of b: b_i,c = exp(i k r_i,a(0)) in the channel component c, 0 in
    the others, so that z_fixed = b^H v = sum_i v_i,c exp(-i k r_i,a(0)). Not collective."""
    start, stop = dm.disk_range
    r0 = positions[dm.active][start:stop]
    b = np.zeros((stop - start, dm.dof), complex)
    b[:, mode_component] = np.exp(1j * k * r0[:, axis])
    return b.ravel()
