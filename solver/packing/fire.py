"""FIRE energy minimiser (Bitzek et al., PRL 97, 170201 (2006); with the FIRE 2.0 half-step
correction of Guenole et al., Comput. Mater. Sci. 175, 109584 (2020)).

Generic: knows nothing about disks.  Defaults are those of the original paper.
Not collective.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np


VERSION = 2
"""The algorithm's version, part of a generated packing's content key (``unit_keys.packing_key``):
raised whenever FIRE's steps change a bit (its parameters, the order of its sums), so that a packing
made before is never taken from a units folder or a cache for one made now.  1: one thread (no
version in the key); 2: the force pass and the sums threaded, in a fixed order (issue 60)."""


@dataclass(frozen=True)
class FireParameters:
    """FIRE knobs (dimensionless, times in t0)."""

    dt_start: float = 0.05
    dt_max: float = 0.4  # measured: half the steps of 0.2 at N = 8192; 2/omega_max ~ 0.8
    n_min: int = 5
    f_inc: float = 1.1
    f_dec: float = 0.5
    alpha_start: float = 0.1
    f_alpha: float = 0.99
    initial_delay: bool = False  # FIRE 2.0's: no dt cut or alpha reset in the first n_min steps (measured mixed)


@dataclass(frozen=True)
class FireResult:
    """Outcome of :func:`minimize`: positions (N, d), steps taken, final max |F|, energy."""

    x: np.ndarray
    steps: int
    max_force: float
    energy: float
    converged: bool


def minimize(x0: np.ndarray, forces: Callable[[np.ndarray], tuple[np.ndarray, float]],
             force_tol: float, max_steps: int, params: FireParameters = FireParameters()
             ) -> FireResult:
    """Minimise with unit masses until max_i |F_i| < ``force_tol``.

    ``forces(x)`` returns (F (N, d), energy).  Semi-implicit Euler steps; on uphill motion
    (P = F.v <= 0) the step is halved, velocities zeroed and x moved back by dt v / 2.  Stops,
    not converged, at the first force that is not finite (NaN or inf), ``max_force`` saying so.
    """
    from .fire_steps import threads_for  # numba: imported when used

    with threads_for(len(x0)):
        return _minimize(x0, forces, force_tol, max_steps, params)


def _minimize(x0: np.ndarray, forces: Callable[[np.ndarray], tuple[np.ndarray, float]], force_tol: float,
              max_steps: int, params: FireParameters) -> FireResult:
    """:func:`minimize`'s loop."""
    from .fire_steps import force_measures, kick, mix_and_move, move

    x = np.array(x0, dtype=float)
    v = np.zeros_like(x)
    dt, alpha, positive = params.dt_start, params.alpha_start, 0
    f, energy = forces(x)
    for step in range(max_steps + 1):
        largest, power, f_squared = force_measures(f, v)
        max_force = float(np.sqrt(largest))
        if max_force < force_tol:
            return FireResult(x, step, max_force, energy, True)
        if step == max_steps or not np.isfinite(max_force):  # a NaN or infinite force: no step can mend it
            return FireResult(x, step, max_force, energy, False)
        if power > 0.0:
            positive += 1
            if positive > params.n_min:
                dt = min(dt * params.f_inc, params.dt_max)
                alpha *= params.f_alpha
        else:
            positive = 0
            if not (params.initial_delay and step < params.n_min):
                dt *= params.f_dec
                alpha = params.alpha_start
            x -= 0.5 * dt * v
            v[:] = 0.0
        v_squared = kick(v, f, dt)
        if f_squared > 0.0:
            mix_and_move(x, v, f, 1.0 - alpha, alpha * np.sqrt(v_squared / f_squared), dt)
        else:
            move(x, v, dt)
        f, energy = forces(x)
