"""FIRE's forces on a wet packing: the normal forces of :class:`mechanics.FrictionlessForces` plus
the pull of every capillary bridge, with the bridges' history kept step by step
(docs/capillary_bridges.md section 4): a pair that touches is bridged from then on, until its gap
reaches the rupture distance s_c.  So the bridged set depends on the path FIRE takes, as it does
in a DEM code's protocol.  Units d0 = kn = m = 1.  Not collective.
"""

from __future__ import annotations

import numpy as np

from .. import capillary
from ..errors import InputError
from . import geometry
from .mechanics import FrictionlessForces


def check_box(diameters: np.ndarray, box, cohesion: capillary.Cohesion) -> None:
    """InputError unless every side of ``box`` (D,) (every height of a tilted ``geometry.Cell``)
    exceeds 2 (d + s_c) for every pair of the ``diameters``' sizes, d = R_i + R_j the pair's
    contact distance and s_c its bridge's rupture distance under ``cohesion`` (d0): a bridge must
    reach its partner through one periodic image only (minimum image on unwrapped positions).  Not collective."""
    radius = np.unique(0.5 * np.asarray(diameters, dtype=float))
    r_i, r_j = np.meshgrid(radius, radius)
    rupture = capillary.rupture_distance(r_i, r_j, cohesion)
    k = int(np.argmax(r_i + r_j + rupture))
    contact, s_c, side = float((r_i + r_j).flat[k]), float(rupture.flat[k]), geometry.narrowest(box)
    if not side > 2.0 * (contact + s_c):
        raise InputError(f"a wet packing's box side L = {side:.4g} d0 must exceed 2 (d + s_c) = "
                         f"{2.0 * (contact + s_c):.4g} d0, with d = {contact:.4g} d0 the largest contact distance and "
                         f"s_c = {s_c:.4g} d0 its bridge's rupture distance under model.cohesion (law "
                         f"{cohesion.law}): a bridge would reach its partner through two periodic images; choose a "
                         f"larger packing.n, a smaller packing.phi or less liquid (model.cohesion.volume or "
                         f"liquid_content)")


class WetForces:
    """Forces (N, D) and energy of a wet packing for ``fire.minimize``, and its bridged pairs.

    diameters (N,), box (D,) sides or a ``geometry.Cell``, ``cohesion`` the bridges' law, ``law`` the normal law,
    ``bridged`` the pairs (B, 2) bridged at the start (a wet packing's bridges carried on; None: none).  The
    bridged pairs are kept as sorted keys i N + j (i < j); each call adds the pairs its contact
    list finds touching and drops those apart by s_c or more, then adds their pull (the whole pass
    vectorised over the bridges).  The box must exceed twice the largest contact distance plus
    s_c, so that a bridge spans one periodic image (minimum image on unwrapped positions):
    InputError otherwise (:func:`check_box`), before any force is computed.
    """

    def __init__(self, diameters: np.ndarray, box, cohesion: capillary.Cohesion, law: str = "harmonic",
                 bridged: np.ndarray | None = None):
        check_box(diameters, box, cohesion)
        self.dry = FrictionlessForces(diameters, box, law=law)
        self.box, self.cohesion, self.radius = box, cohesion, 0.5 * diameters
        pairs = np.sort(np.zeros((0, 2)) if bridged is None else bridged, axis=1).astype(np.int64)
        self.keys = np.unique(pairs[:, 0] * diameters.size + pairs[:, 1])
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
