"""Athermal quasistatic shear of a packing in an orthogonal periodic cell (``packing.shear``,
docs/dem_packings.md).

Simple shear along x with the gradient along y at fixed volume: the cell's tilt xy grows from 0 to
gamma L_x (:func:`sheared_cell`; xz = yz = 0) in steps of ``step`` (the last one shorter);
at each step every particle moves with the cell (x += d_gamma y, an affine shear that maps the
cell's periodic images onto the new cell's), then FIRE on the packing's normal energy (and, wet,
its capillary bridges, carried from step to step) brings it to rest in the new cell.  The result
carries the stress the shear built (sigma_xy, ``mechanics.stress``), unlike FIRE from a random
start in the tilted cell.  Lengths in d0, forces in kn d0, strains dimensionless.  Not collective.
"""

from __future__ import annotations

import numpy as np

from . import bridges, fire, geometry, mechanics, wet
from .configuration import Packing


def sheared_cell(box: np.ndarray, shear: float) -> geometry.Cell:
    """The periodic cell of sides ``box`` (D,) tilted by xy = ``shear`` L_x (``packing.shear``: the tilt
    over the side, |shear| <= 1/2), xz = yz = 0; orthogonal at shear 0."""
    tilt = np.zeros(len(geometry.TILTS[box.size]))
    tilt[0] = shear * box[0]
    return geometry.Cell(box, tilt, np.ones(box.size, dtype=bool))


def strains(strain: float, step: float) -> np.ndarray:
    """The shear strains (S,) of the steps from 0 to ``strain`` (sign included): step, 2 step, ...,
    the last one ``strain`` itself (a shorter step when ``step`` does not divide it)."""
    size = abs(strain)
    return np.sign(strain) * np.append(np.arange(step, size, step), size)


def quasistatic(packing: Packing, strain: float, step: float = 0.01, force_tol: float = 1e-6,
                max_steps: int = 2_000_000) -> Packing:
    """``packing`` (an orthogonal periodic cell, frictionless: no stored tangential forces, no walls)
    sheared quasi-statically to the shear strain ``strain`` (|strain| <= 1/2) in steps of at most
    ``step`` (module docstring), each FIRE to max |F| < ``force_tol`` (kn d0) within ``max_steps``
    under the packing's model (its normal law and cohesion).  Returns the packing at rest in the cell
    tilted by xy = strain L_x, its particles in the same order (an affine shear keeps the fractional
    coordinates, so the spatial order holds), its rattlers found again, and its info: the statistics
    of the sheared state (``mechanics.describe``) with ``shear`` = strain, ``shear_step``,
    ``shear_steps`` (S, how many), ``shear_fire_steps`` (FIRE's steps summed over them) and FIRE's
    Verlet list rebuilds and partial refreshes summed (``shear_neighbour_*``), ``max_force``
    of the last FIRE and ``sigma_xy`` (kn d0^(1-D), compressive positive).  RuntimeError if a
    FIRE does not converge."""
    if packing.tilt is not None or packing.tangential is not None or packing.walls is not None:
        raise ValueError("quasistatic shear starts from a frictionless packing in an orthogonal periodic cell")
    x, diameters, n = packing.positions.copy(), packing.diameters, packing.n
    law, cohesion = packing.model.law, packing.model.cohesion
    bridged = packing.bridges  # wet: the pairs bridged across a gap, carried from step to step
    before, fire_steps, rebuilds, refreshes = 0.0, 0, 0, 0
    for gamma in strains(strain, step):
        x[:, 0] += (gamma - before) * x[:, 1]
        cell = sheared_cell(packing.box, gamma)
        if cohesion is None:
            forces = mechanics.FrictionlessForces(diameters, cell, law=law)
        else:
            forces = wet.WetForces(diameters, cell, cohesion, law, bridged)
        result = fire.minimize(x, forces, force_tol, max_steps)
        if not result.converged:
            raise RuntimeError(f"quasistatic shear: FIRE at strain {gamma:.3f} did not converge: max |F| = "
                               f"{result.max_force:.3e} > {force_tol:.1e} after {result.steps} steps (n = {n})")
        x, before, fire_steps = result.x, gamma, fire_steps + result.steps
        dry = forces if cohesion is None else forces.dry
        rebuilds, refreshes = rebuilds + dry.rebuilds, refreshes + dry.refreshes
        if cohesion is not None:
            bridged = forces.bridged(n)
    gap = None if cohesion is None else bridges.build(bridged, x, diameters, cell, cohesion, "the sheared wet packing")
    info = {key: packing.info[key] for key in ("force_tol", "law") if key in packing.info}
    info.update(shear=strain, shear_step=step, shear_steps=len(strains(strain, step)), shear_fire_steps=fire_steps,
                shear_neighbour_rebuilds=rebuilds, shear_neighbour_refreshes=refreshes, max_force=result.max_force)
    positions = geometry.wrap(x, cell)
    rattler = mechanics.find_rattlers(positions, diameters, cell, law=law, cohesion=cohesion, bridges=gap)
    stats = mechanics.describe(positions, diameters, cell, rattler, law, cohesion, gap)
    sheared = Packing(positions, diameters, packing.box, rattler, {**stats, **info}, packing.masses,
                      model=packing.model.at_rest(), bridges=gap, tilt=cell.tilt)
    sheared.info["sigma_xy"] = float(mechanics.stress(sheared)["stress"][0, 1])
    return sheared
