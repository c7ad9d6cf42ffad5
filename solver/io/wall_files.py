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

The same five columns may come as one frame of a LAMMPS or LIGGGHTS text ``dump custom`` (its
``ITEM: TIMESTEP``, ``ITEM: NUMBER OF ATOMS``, ``ITEM: BOX BOUNDS`` and ``ITEM: ATOMS ...`` lines,
whatever the columns' names, then one line per contact): LIGGGHTS 3.8.0's dump has no
``dump_modify header no``, so its wall contact file is such a dump (``fix wall/gran ... store_force
yes``; tests/data/dem/liggghts_3d_walls.in, docs/walls.md).
"""

from __future__ import annotations

import re
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
    """The wall contact file ``path`` (format above, or a one-frame dump of it) -> :class:`RawWallContacts`;
    InputError naming the file and line for a row that is not 5 numbers, an id or wall index that is not a whole
    number (ids >= 0, walls >= 0)."""
    text = read_text(path, KIND)
    lines, first = _dump_lines(path, text) if text.lstrip().startswith("ITEM:") else after_comments(text)
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


def _dump_lines(path, text: str) -> tuple[list[str], int]:
    """(the contact lines, the file line of the first, from 1) of a wall contact file written as a
    LAMMPS/LIGGGHTS text dump; InputError naming the file unless it is one frame whose ``ITEM: NUMBER
    OF ATOMS`` counts its lines."""
    frames = len(re.findall(r"^ITEM: TIMESTEP[ \t]*$", text, re.M))
    count = re.search(r"^ITEM: NUMBER OF ATOMS[ \t]*\n[ \t]*(\d+)[ \t]*$", text, re.M)
    atoms = re.search(r"^ITEM: ATOMS[^\n]*(?:\n|\Z)", text, re.M)
    if frames != 1 or count is None or atoms is None:
        found = f"{frames} frames" if frames != 1 else "a frame without 'ITEM: NUMBER OF ATOMS' and 'ITEM: ATOMS' lines"
        raise InputError(f"{KIND} {path}: a dump ('ITEM:' lines) with {found}; a wall contact dump holds one frame, "
                         f"the step of the packing file, of the columns {LAYOUT}")
    lines = text[atoms.end():].rstrip().splitlines()
    if len(lines) != int(count.group(1)):
        raise InputError(f"{KIND} {path}: the dump lists {len(lines)} contact line(s) where 'ITEM: NUMBER OF ATOMS' "
                         f"says {count.group(1)} (truncated or damaged file)")
    return lines, text[:atoms.end()].count("\n") + 1


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
