"""One packing configuration (:class:`Packing`), the record every stage passes on: a leaf module,
so that the modules that make, check and read packings import it and not each other.
Units d0 = m = kn = 1.  Not collective.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..contact_law import ContactModel
from .geometry import Cell
from .stressed import TangentialForces
from .walls import WallContacts, Walls


def solid_volume(diameters: np.ndarray, dim: int) -> float:
    """Total area (2D: sum pi d^2 / 4) or volume (3D: sum pi d^3 / 6) of the particles."""
    return float(np.pi * np.sum(diameters**2) / 4.0 if dim == 2 else np.pi * np.sum(diameters**3) / 6.0)


@dataclass(frozen=True)
class Packing:
    """One configuration (units d0 = m = kn = 1).

    positions : (N, D) float64 in the box, D = 2 or 3;  diameters : (N,) float64;
    box : (D,) float64 side lengths (L_x, L_y[, L_z]) of the cell, origin at 0;  tilt : (T,) float64
    the cell's tilt factors (``geometry.TILTS``: xy, or xy, xz, yz), or None (orthogonal);  periodic :
    (D,) bool, which axes are periodic, or None (all);  ``cell`` is the three as a ``geometry.Cell``;
    rattler : (N,) bool;  info : provenance and statistics (energy, pressure, z, ...);
    masses : (N,) float64 the masses a file gave (its own units), or None (generated packings, and
    files without them); ``model.masses`` decides what the matrix uses (``dynmat.particle_masses``);
    tangential : the stored tangential forces of a packing made with friction
    (docs/stressed_contacts.md), or None (unstressed springs);  model : what its forces are
    computed with and what it was checked under (``ContactModel.at_rest``: the normal law, and the
    lever of the stored forces' torques, and the capillary bridges' cohesion): the scene's for a
    file read, the engine's for a generated packing;  bridges : (B, 2) int64 the pairs of a wet
    packing that are apart but still bridged (``bridges.build``; every contact is bridged too), or
    None (dry);  walls : the flat walls on its axes that are not periodic (``walls.Walls``), or None;
    wall_contacts : the stored tangential forces of its wall contacts (``walls.WallContacts``), or
    None;  gravity : (D,) float64 the body force per unit mass (kn d0 per unit of ``masses``, 1 when
    None), or None (docs/walls.md).
    """

    positions: np.ndarray
    diameters: np.ndarray
    box: np.ndarray
    rattler: np.ndarray
    info: dict = field(default_factory=dict)
    masses: np.ndarray | None = None
    tangential: TangentialForces | None = None
    model: ContactModel = ContactModel()
    bridges: np.ndarray | None = None
    tilt: np.ndarray | None = None
    periodic: np.ndarray | None = None
    walls: Walls | None = None
    wall_contacts: WallContacts | None = None
    gravity: np.ndarray | None = None

    @property
    def cell(self) -> Cell:
        """The cell (``geometry.Cell``): sides, tilt and periodic axes."""
        cell = Cell.of(self.box, self.dim)
        return Cell(cell.sides,
                    cell.tilt if self.tilt is None else np.asarray(self.tilt, dtype=float),
                    cell.periodic if self.periodic is None else np.asarray(self.periodic, dtype=bool))

    @property
    def stressed(self) -> bool:
        """Whether some stored tangential force is not zero between particles, or on a wall under
        the Hertz law (the matrix is then not symmetric; a wall's stored force adds nothing to it
        under the harmonic law: docs/walls.md section 4)."""
        return ((self.tangential is not None and self.tangential.nonzero())
                or (self.wall_contacts is not None and self.wall_contacts.nonzero() and self.model.law == "hertz"))

    @property
    def n(self) -> int:
        return int(self.diameters.size)

    @property
    def dim(self) -> int:
        """Dimension D (2 or 3), read from the shape of ``positions``."""
        return int(self.positions.shape[1])

    @property
    def box_length(self) -> float:
        """Side L of a square or cubic box; ValueError when the sides differ."""
        if np.any(self.box != self.box[0]):
            raise ValueError(f"the box has sides {self.box.tolist()}, not one side length")
        return float(self.box[0])

    @property
    def phi(self) -> float:
        """Area (2D) or volume (3D) fraction."""
        return solid_volume(self.diameters, self.dim) / self.cell.volume
