"""Small packings settled under gravity between two walls, made in memory (docs/walls.md): two
layers of equal particles (2D: two rows of 4 disks; 3D: two square layers of 3 x 3 spheres) on a
floor, under a ceiling that touches the top layer, periodic along the other axes, brought to rest
by minimising the energy of the normal contacts, the walls and gravity (harmonic law, m = 1)."""

import numpy as np
import scipy.optimize

from solver import contact_law
from solver.packing import geometry, mechanics, walls
from solver.packing.geometry import Cell
from solver.packing.jammed import from_arrays

SPACING = 0.99  # d0: neighbours in a layer overlap by 0.01
GRAVITY = 0.01  # kn d0 per unit mass, along -y (2D) or -z (3D)


def _layers(dim):
    """(positions (N, D), sides (D,), ceiling) of the two layers before relaxing."""
    a = SPACING
    if dim == 2:
        bottom = np.array([[a * i, 0.495] for i in range(4)])
        top = bottom + [0.5 * a, a * np.sqrt(0.75)]
        sides = np.array([4 * a, 0.0])
    else:
        bottom = np.array([[a * i, a * j, 0.495] for i in range(3) for j in range(3)])
        top = bottom + [0.5 * a, 0.5 * a, a / np.sqrt(2.0)]
        sides = np.array([3 * a, 3 * a, 0.0])
    positions = np.concatenate((bottom, top))
    ceiling = top[0, -1] + 0.48  # the top layer pressed by the ceiling too
    sides[-1] = ceiling
    return positions, sides, ceiling


def settled(dim, gravity=GRAVITY):
    """The packing (``mechanics.with_walls``) at rest to a net force of ~1e-12."""
    start, sides, ceiling = _layers(dim)
    n = start.shape[0]
    diameters = np.ones(n)
    periodic = np.ones(dim, dtype=bool)
    periodic[-1] = False
    cell = Cell(sides, np.zeros(len(geometry.TILTS[dim])), periodic)
    g = np.zeros(dim)
    g[-1] = -gravity
    wall_set = walls.build([dim - 1, dim - 1], [0.0, ceiling], start, diameters, periodic, "walled")
    pairs = geometry.candidate_pairs(start, cell, 1.5)

    def energy(flat):
        x = flat.reshape(n, dim)
        separation = geometry.minimum_image(x[pairs[:, 0]] - x[pairs[:, 1]], cell)
        force, e = contact_law.normal_pair(separation, np.ones(len(pairs)))
        grad = np.zeros((n, dim))
        for axis in range(dim):
            grad[:, axis] = -(np.bincount(pairs[:, 0], force[:, axis], n) - np.bincount(pairs[:, 1], force[:, axis], n))
        touch, push, _ = walls.loads(x, diameters, wall_set, None, "harmonic")
        total = e.sum() + contact_law.normal_energy(touch.overlap).sum() - np.sum(x @ g)
        for axis in range(dim):
            grad[:, axis] -= np.bincount(touch.particle, push[:, axis], n)
        return total, (grad - g).ravel()

    found = scipy.optimize.minimize(energy, start.ravel(), jac=True, method="BFGS", options={"gtol": 1e-13})
    positions = found.x.reshape(n, dim)
    packing = from_arrays(positions, diameters, sides)  # periodic: with_walls makes the walled axis not
    return mechanics.with_walls(packing, wall_set, None, g)
