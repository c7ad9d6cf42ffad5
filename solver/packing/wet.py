"""FIRE's forces on a wet packing: the normal forces of :class:`mechanics.FrictionlessForces` plus
the pull of every capillary bridge, with the bridges' history kept step by step
(docs/capillary_bridges.md section 4): a pair that touches is bridged from then on, until its gap
reaches the rupture distance s_c.  So the bridged set depends on the path FIRE takes, as it does
in a DEM code's protocol.  Units d0 = kn = m = 1.  Not collective.
"""

from __future__ import annotations

import numpy as np

from .. import capillary
from . import geometry
from .mechanics import FrictionlessForces


class WetForces:
    """Forces (N, D) and energy of a wet packing for ``fire.minimize``, and its bridged pairs.

    diameters (N,), box (D,) sides, ``cohesion`` the bridges' law, ``law`` the normal law.  The
    bridged pairs are kept as sorted keys i N + j (i < j); each call adds the pairs its contact
    list finds touching and drops those apart by s_c or more, then adds their pull (the whole pass
    vectorised over the bridges).  The box must exceed twice the largest contact distance plus
    s_c, so that a bridge spans one periodic image (minimum image on unwrapped positions).
    """

    def __init__(self, diameters: np.ndarray, box, cohesion: capillary.Cohesion, law: str = "harmonic"):
        self.dry = FrictionlessForces(diameters, box, law=law)
        self.box, self.cohesion, self.radius = box, cohesion, 0.5 * diameters
        self.keys = np.zeros(0, dtype=np.int64)
        self.broken = 0

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, float]:
        force, energy = self.dry(x)
        n = x.shape[0]
        dry = self.dry
        separation = x[dry.i] - x[dry.j] + dry.shift
        touching = np.einsum("pd,pd->p", separation, separation) <= dry.contact**2
        keys = np.union1d(self.keys, dry.i[touching] * n + dry.j[touching])
        i, j = np.divmod(keys, n)
        delta = geometry.minimum_image(x[i] - x[j], self.box)
        distance = np.sqrt(np.einsum("pd,pd->p", delta, delta))
        gap = distance - self.radius[i] - self.radius[j]
        r_i, r_j = self.radius[i], self.radius[j]
        alive = gap < capillary.rupture_distance(r_i, r_j, self.cohesion)
        self.broken += int(np.count_nonzero(~alive))
        self.keys = keys[alive]
        i, j, delta, distance, gap = i[alive], j[alive], delta[alive], distance[alive], gap[alive]
        r_i, r_j = r_i[alive], r_j[alive]
        pull = (capillary.bridge_force(gap, r_i, r_j, self.cohesion) / distance)[:, None] * delta  # on j from i
        for axis in range(x.shape[1]):
            force[:, axis] += (np.bincount(j, pull[:, axis], minlength=n) - np.bincount(i, pull[:, axis], minlength=n))
        return force, energy + float(capillary.bridge_energy(gap, r_i, r_j, self.cohesion).sum())

    def bridged(self, n: int) -> np.ndarray:
        """The bridged pairs now (B, 2), contacts included, sorted by (i, j)."""
        return np.stack(np.divmod(self.keys, n), axis=1)
