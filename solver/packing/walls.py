"""Flat immovable walls, the particles touching them, their stored tangential forces, and gravity
(docs/walls.md).

A wall is a plane perpendicular to an axis of the cell (``Walls``: its axis and its position along
it, rotsound's coordinates), as LAMMPS's ``fix wall/gran ... xplane/yplane/zplane`` and LIGGGHTS's
``primitive type planex/y/z`` define them, on an axis that is not periodic
(``Packing.periodic``).  It faces the side its particles are on (``Walls.facing``, +1 or -1
along the axis): a particle touches it when its centre is closer than its radius, with overlap
xi = R_i - h (h the centre's distance from the plane) and normal n = facing e_axis, from the wall
into the particle.  The contact law is the particles' (``contact_law.wall_blocks``): the wall is
a particle that does not move, of infinite radius (the reduced radius a' = R_i, the lever R_i).
A wall contact's stored tangential force (``WallContacts``, from a file: ``read_wall_contacts``)
is the force on the particle from the wall that the DEM code's spring history held at rest.
Gravity (``Packing.gravity``) is a body force per unit mass: m_i g on particle i
(``weights``), in the balance of a packing at rest, not in its stiffness.

Units d0 = m = kn = 1 (force kn d0).  Not collective.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import contact_law
from ..errors import InputError
from . import stressed

AXES = "xyz"


@dataclass(frozen=True)
class Walls:
    """axis (W,) int64 the axis each wall is perpendicular to (0 = x, 1 = y, 2 = z); position (W,)
    float64 where it crosses that axis (d0, the cell's coordinates); facing (W,) float64, +1 or -1:
    the direction along the axis from the wall into the packing."""

    axis: np.ndarray
    position: np.ndarray
    facing: np.ndarray

    def __len__(self) -> int:
        return int(self.axis.size)

    def normals(self, dim: int) -> np.ndarray:
        """(W, D) each wall's unit normal, from the wall into the packing."""
        normal = np.zeros((len(self), dim))
        normal[np.arange(len(self)), self.axis] = self.facing
        return normal


@dataclass(frozen=True)
class WallContacts:
    """particle (C,) int64 the particle index; wall (C,) int64 the wall's index in ``Walls``;
    force (C, D) float64 the stored tangential force on the particle from the wall (kn d0); each
    (particle, wall) once, sorted by (particle, wall)."""

    particle: np.ndarray
    wall: np.ndarray
    force: np.ndarray

    def __len__(self) -> int:
        return int(self.particle.size)

    def on(self, particle: np.ndarray, wall: np.ndarray) -> np.ndarray:
        """Stored force (len(particle), D) on each wall contact (particle, wall): zero for a contact
        the file does not list."""
        count = int(max(self.wall.max(initial=-1), wall.max(initial=-1))) + 1
        return stressed.stored_at(self.particle * count + self.wall, self.force, particle.astype(np.int64) * count + wall)

    def nonzero(self) -> bool:
        """Whether any stored force is not zero."""
        return bool(np.any(self.force != 0.0))


@dataclass(frozen=True)
class Touching:
    """The wall contacts of a packing found from its positions: particle (K,), wall (K,), normal
    (K, D) from the wall into the particle, overlap (K,) xi = R - h > 0, sorted by (particle, wall)."""

    particle: np.ndarray
    wall: np.ndarray
    normal: np.ndarray
    overlap: np.ndarray

    def __len__(self) -> int:
        return int(self.particle.size)


def facing_of(axis: int, position: float, positions: np.ndarray, where: str) -> float:
    """+1 or -1: the side of the plane (``axis``, ``position``) every centre of ``positions`` (N, D)
    is on.  InputError naming ``where`` when centres lie on both sides or on the plane (a wall
    through the packing: some particle's centre is beyond it)."""
    side = positions[:, axis] - position
    if np.all(side > 0.0):
        return 1.0
    if np.all(side < 0.0):
        return -1.0
    above, below = np.flatnonzero(side > 0.0), np.flatnonzero(side <= 0.0)
    first = below[0] if above.size > below.size else above[0]
    raise InputError(f"{where}: the wall {AXES[axis]} = {position:g} goes through the packing: particle {first} "
                     f"(0-based) has its centre at {AXES[axis]} = {positions[first, axis]:g}, "
                     f"{above.size} centre(s) above the wall and {below.size} on it or below; every particle's centre must be on one side of a "
                     f"wall, the packing's")


def build(axis, position, positions: np.ndarray, diameters: np.ndarray, periodic: np.ndarray,
          where: str) -> Walls:
    """The walls (``axis`` (W,) ints, ``position`` (W,) d0) of a packing (``positions`` (N, D),
    ``diameters`` (N,), ``periodic`` (D,) bool), each facing its particles (:func:`facing_of`).
    InputError naming ``where`` for: an axis not among the packing's, a wall on a periodic axis, a
    wall through the packing, a particle overlapping a wall by its radius or more."""
    axis = np.asarray(axis, dtype=np.int64).reshape(-1)
    position = np.asarray(position, dtype=float).reshape(-1)
    dim = positions.shape[1]
    for w, (a, p) in enumerate(zip(axis, position)):
        if not 0 <= a < dim:
            raise InputError(f"{where}: wall {w} is perpendicular to axis {a}; a {dim}D packing has axes "
                             f"{', '.join(AXES[:dim])}")
        if periodic[a]:
            raise InputError(f"{where}: wall {w} ({AXES[a]} = {p:g}) stands on the periodic axis {AXES[a]}; walls "
                             f"stand on axes that are not periodic (a LAMMPS boundary f, fm or fs)")
        if not np.isfinite(p):
            raise InputError(f"{where}: wall {w} has position {p}; it must be finite")
    facing = np.array([facing_of(a, p, positions, where) for a, p in zip(axis, position)])
    return Walls(axis, position, facing)


def touching(positions: np.ndarray, diameters: np.ndarray, walls: Walls | None,
             active: np.ndarray | None = None) -> Touching:
    """The wall contacts (:class:`Touching`) of the ``active`` particles (all when None), from
    their centres: overlap xi = R - h > 0, h = facing (x_axis - position)."""
    dim = positions.shape[1]
    if walls is None or not len(walls):
        return Touching(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, dim)), np.zeros(0))
    height = walls.facing[None, :] * (positions[:, walls.axis] - walls.position[None, :])  # (N, W)
    overlap = 0.5 * diameters[:, None] - height
    touch = overlap > 0.0
    if active is not None:
        touch &= active[:, None]
    particle, wall = np.nonzero(touch)  # row-major: sorted by (particle, wall)
    return Touching(particle.astype(np.int64), wall.astype(np.int64), walls.normals(dim)[wall], overlap[particle, wall])


def build_contacts(particle, wall, force, positions: np.ndarray, diameters: np.ndarray, walls: Walls | None,
                   where: str) -> WallContacts:
    """The stored forces of wall contacts in canonical form: ``particle`` (C,) indices, ``wall`` (C,)
    wall indices, ``force`` (C, D) the force on the particle from the wall (its part along the wall's
    normal, the normal force, is dropped: the law gives it from the overlap; its tangential part is
    kept).  InputError naming ``where`` for: a particle index out of range, a wall index not
    among the walls, a contact listed twice, a non-finite force, a force on a particle that does
    not touch its wall."""
    particle = np.asarray(particle, dtype=np.int64).reshape(-1)
    wall = np.asarray(wall, dtype=np.int64).reshape(-1)
    n, dim = positions.shape
    force = np.asarray(force, dtype=float).reshape(particle.size, -1)
    count = 0 if walls is None else len(walls)
    if force.shape[1] != dim:
        raise InputError(f"{where}: the wall forces have {force.shape[1]} components, the packing is {dim}D")
    if not np.all(np.isfinite(force)):
        raise InputError(f"{where}: a wall force is NaN or infinite")
    bad = np.flatnonzero((particle < 0) | (particle >= n))
    if bad.size:
        raise InputError(f"{where}: wall contact {bad[0]} names particle index {particle[bad[0]]}, not among the "
                         f"packing's {n} particles")
    bad = np.flatnonzero((wall < 0) | (wall >= count))
    if bad.size:
        raise InputError(f"{where}: wall contact {bad[0]} names wall {wall[bad[0]]}, but the packing has "
                         f"{count} wall(s) (indices from 0, in the order of packing.walls, or for walls at a LAMMPS "
                         f"box's bounds: per walled axis x, y, z, lower then upper)")
    order = np.lexsort((wall, particle))
    particle, wall, force = particle[order], wall[order], force[order]
    twice = np.flatnonzero((particle[1:] == particle[:-1]) & (wall[1:] == wall[:-1]))
    if twice.size:
        raise InputError(f"{where}: the wall contact of particle {particle[twice[0]]} with wall {wall[twice[0]]} is "
                         f"listed more than once")
    normal = walls.normals(dim)[wall] if count else np.zeros((0, dim))
    height = (walls.facing[wall] * (positions[particle, walls.axis[wall]] - walls.position[wall])
              if count else np.zeros(0))
    overlap = 0.5 * diameters[particle] - height
    keep = (overlap > 0.0) | np.any(force != 0.0, axis=1)
    particle, wall, force, normal, overlap = particle[keep], wall[keep], force[keep], normal[keep], overlap[keep]
    apart = np.flatnonzero(overlap <= 0.0)
    if apart.size:
        k = apart[0]
        raise InputError(f"{where}: {apart.size} listed wall contact(s) carry a force but do not touch their wall "
                         f"(first: particle {particle[k]} and wall {wall[k]}, at overlap {overlap[k]:.3e} d0 <= 0); the "
                         f"wall contact file and the packing file must be written at the same step")
    along = np.einsum("cd,cd->c", force, normal)
    return WallContacts(particle, wall, force - along[:, None] * normal)


def weights(masses: np.ndarray | None, n: int, gravity: np.ndarray) -> np.ndarray:
    """(N, D) the body force m_i g on each of ``n`` particles (kn d0) under ``gravity`` (D,):
    ``masses`` the packing's own (its file's, ``Packing.masses``), 1 each when None (rotsound's unit
    mass)."""
    mass = np.ones(n) if masses is None else masses
    return mass[:, None] * np.asarray(gravity, dtype=float)[None, :]


def gravity_problem(gravity: np.ndarray | None, walls: Walls | None, periodic: np.ndarray) -> str | None:
    """Why ``gravity`` (D,) cannot hold at rest in this cell, or None: a component along a periodic
    axis (nothing balances it: the packing falls for ever through its images), or along a walled
    axis with no wall on the side it pushes toward."""
    if gravity is None:
        return None
    for axis, g in enumerate(gravity):
        if g == 0.0:
            continue
        if periodic[axis]:
            return (f"packing.gravity has the component {g:g} along the periodic axis {AXES[axis]}: nothing holds a "
                    f"packing against it (no wall across a periodic axis); gravity must point along a walled axis")
        below = walls is not None and np.any((walls.axis == axis) & (walls.facing * np.sign(g) < 0.0))
        if not below:
            return (f"packing.gravity pulls along {AXES[axis]} ({g:g}) but no wall on that side holds the packing; "
                    f"give a wall facing against it (packing.walls)")
    return None



def loads(positions: np.ndarray, diameters: np.ndarray, walls: Walls | None, stored: WallContacts | None, law: str,
          active: np.ndarray | None = None) -> tuple[Touching, np.ndarray, np.ndarray]:
    """(the wall contacts of the ``active`` particles, the force (K, D) on each particle from its
    wall, the torque (K, r) it exerts, r = 1 in 2D, 3 in 3D): the normal force of ``law`` with
    a' = R along n plus the ``stored`` tangential force, whose torque is -R n x f_t (the lever is the
    full radius, LAMMPS's fix wall/gran).  Units kn d0, kn d0^2."""
    touch = touching(positions, diameters, walls, active)
    radius = 0.5 * diameters[touch.particle]
    force = contact_law.normal_force(touch.overlap, law, radius)[:, None] * touch.normal
    rot = 1 if positions.shape[1] == 2 else 3
    torque = np.zeros((len(touch), rot))
    if stored is not None:
        tangential = stored.on(touch.particle, touch.wall)
        force = force + tangential
        torque = -radius[:, None] * contact_law.cross(touch.normal, tangential).reshape(len(touch), rot)
    return touch, force, torque


def volume_between(sides: np.ndarray, walls: Walls | None) -> float:
    """The cell's volume (area in 2D) between its walls: along an axis with walls on both sides the
    distance between the innermost two, else the cell's side."""
    extent = np.asarray(sides, dtype=float).copy()
    for axis in range(extent.size):
        if walls is None:
            break
        on = walls.axis == axis
        lower, upper = walls.position[on & (walls.facing > 0)], walls.position[on & (walls.facing < 0)]
        if lower.size and upper.size:
            extent[axis] = upper.min() - lower.max()
    return float(np.prod(extent))
