"""Wall contact files (``packing.wall_contacts``, beside ``packing.file``; docs/walls.md): the force
on every particle touching a wall, as a DEM code leaves it at rest.  Not collective (plain file
reading).

Format (text): leading ``#`` comment lines and blank lines, then one line per particle-wall
contact, whitespace-separated, comments after ``#`` allowed at a line's end:

    id  wall  fx  fy  fz

``id`` the particle's atom id in the packing file (LAMMPS's ``id``; a rotsound HDF5 packing: the
0-based particle index), ``wall`` the wall's index from 0 (in the order of ``packing.walls``; the
walls a LAMMPS box's f bounds imply: per walled axis x, y, z, its lower then its upper bound),
``fx fy fz`` the force on the particle from the wall in the packing file's units (a 2D packing:
fz = 0), the whole force (normal and tangential, as LAMMPS's ``fix wall/gran`` gives it) or its
tangential part: rotsound keeps the tangential part as the contact's stored force and takes the
normal part from the overlap and the normal law.  A file of comments only lists no contact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .dem_formats import after_comments, number_table, read_text

KIND = "wall contact file"
LAYOUT = "id wall fx fy fz (the particle's id, the wall's index from 0, the force on the particle from the wall)"


@dataclass(frozen=True, eq=False)
class RawWallContacts:
    """ids (C,) int64 the particles' ids as the file gives them; wall (C,) int64 the walls'
    indices; force (C, 3) float64 the force on each particle from its wall, in the file's units."""

    ids: np.ndarray
    wall: np.ndarray
    force: np.ndarray


def read(path) -> RawWallContacts:
    """The wall contact file ``path`` (format above) -> :class:`RawWallContacts`; InputError naming
    the file and line for a row that is not 5 numbers, an id or wall index that is not a whole
    number (ids >= 0, walls >= 0)."""
    lines, first = after_comments(read_text(path, KIND))
    if not lines:
        return RawWallContacts(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3)))
    table = number_table(path, lines, first, "the contact lines", LAYOUT, KIND)
    if table.shape[1] != 5:
        raise InputError(f"{KIND} {path}: contact lines have {table.shape[1]} columns; each line holds 5: {LAYOUT}")
    whole = table[:, :2]
    bad = np.flatnonzero(np.any((whole != np.rint(whole)) | (whole < 0), axis=1))
    if bad.size:
        raise InputError(f"{KIND} {path}: line {first + bad[0]}: the id and wall columns must hold whole numbers "
                         f">= 0, not {whole[bad[0]].tolist()}; the columns are {LAYOUT}")
    return RawWallContacts(whole[:, 0].astype(np.int64), whole[:, 1].astype(np.int64), table[:, 2:].copy())


def write(path, particle_ids: np.ndarray, wall: np.ndarray, force: np.ndarray) -> None:
    """Write a wall contact file (format above): ``particle_ids`` (C,), ``wall`` (C,), ``force`` (C, D),
    D = 2 (fz written as 0) or 3, with 17 significant digits."""
    force = np.asarray(force, dtype=float)
    if force.shape[1] == 2:
        force = np.column_stack((force, np.zeros(force.shape[0])))
    with open(path, "w") as f:
        f.write(f"# rotsound wall contact file: {LAYOUT}\n")
        for i, w, row in zip(particle_ids, wall, force):
            f.write(f"{int(i)} {int(w)} {row[0]:.17g} {row[1]:.17g} {row[2]:.17g}\n")
