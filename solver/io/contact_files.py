"""Contact files of DEM codes: the stored tangential force of every contact of a packing made
with friction (``packing.contacts``, beside ``packing.file``; docs/stressed_contacts.md).  Not
collective (plain file reading).

Readers return a :class:`RawContacts`: the file's atom ids and forces in the file's units; the
caller maps ids to the packing's particles and rescales (``hdf5``).

* ``lammps-local`` -- a LAMMPS text ``dump local`` whose first six columns are, in this order,
  the dump's index, ``compute property/local patom1 patom2`` and ``compute pair/local p1 p2 p3``:
  for ``pair_style gran/hooke/history`` and ``gran/hertz/history`` the pair's ``single()`` gives
  p1..p3 = the tangential force on patom1 from patom2.  Further columns are allowed and ignored.
  ``ITEM: TIMESTEP``, ``ITEM: NUMBER OF ENTRIES``, ``ITEM: BOX BOUNDS``, ``ITEM: ENTRIES``; the
  last frame is read.  The LAMMPS lines that write it are in the README ("Stressed packings").
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .dem_formats import number_table, read_text

KIND = "contact file"
LOCAL_COLUMNS = ("index", "patom1", "patom2", "fx", "fy", "fz")
LOCAL_LAYOUT = ("the dump's index, patom1 patom2 (compute property/local), then p1 p2 p3 (compute pair/local: "
                "the tangential force on patom1 from patom2)")


@dataclass(frozen=True, eq=False)
class RawContacts:
    """ids (C, 2) int64 the two atoms of each contact (file ids); force (C, 3) float64 the
    tangential force on the first from the second, in the file's units; source: the format."""

    ids: np.ndarray
    force: np.ndarray
    source: str


def _fail(path, what: str):
    raise InputError(f"{KIND} {path}: {what}")


def read_lammps_local(path) -> RawContacts:
    """The last frame of a LAMMPS ``dump local`` of contacts (layout above) -> :class:`RawContacts`."""
    text = read_text(path, KIND)
    starts = [m.start() for m in re.finditer(r"^ITEM: TIMESTEP[ \t]*$", text, re.M)]
    if not starts or text[:starts[0]].strip():
        _fail(path, "does not start with 'ITEM: TIMESTEP'; a LAMMPS dump local starts every frame with it")
    chunk = text[starts[-1]:]
    head, sep, entries = chunk.partition("\nITEM: ENTRIES")
    if not sep:
        _fail(path, "the last frame has no 'ITEM: ENTRIES' line: not a dump local (a 'dump custom' of atoms has "
                    "'ITEM: ATOMS'), or truncated")
    count = re.search(r"^ITEM: NUMBER OF ENTRIES[ \t]*\n[ \t]*(\S+)", head, re.M)
    if count is None or not count.group(1).isdigit():
        _fail(path, "'ITEM: NUMBER OF ENTRIES' must be followed by one whole number")
    expected = int(count.group(1))
    names, _, rows = entries.partition("\n")
    lines = rows.rstrip().splitlines() if rows.strip() else []
    if len(lines) != expected:
        _fail(path, f"the last frame has {len(lines)} entry lines where 'ITEM: NUMBER OF ENTRIES' says {expected} "
                    f"(truncated or damaged file)")
    if expected == 0:
        return RawContacts(np.zeros((0, 2), dtype=np.int64), np.zeros((0, 3)), "lammps-local")
    first = text[:starts[-1]].count("\n") + chunk[:len(chunk) - len(rows)].count("\n") + 1
    table = number_table(path, lines, first, "the entries", f"at least 6 columns: {LOCAL_LAYOUT}", KIND)
    if table.shape[1] < 6:
        _fail(path, f"entries have {table.shape[1]} columns (named: {names.split() or 'none'}); a contact file needs "
                    f"at least 6: {LOCAL_LAYOUT}")
    ids = table[:, 1:3]
    if np.any(ids != np.rint(ids)) or np.any(ids < 1):
        row = int(np.flatnonzero(np.any((ids != np.rint(ids)) | (ids < 1), axis=1))[0])
        _fail(path, f"line {first + row}: columns 2 and 3 must be atom ids (whole numbers >= 1, patom1 patom2), "
                    f"not {ids[row].tolist()}; the columns are {LOCAL_LAYOUT}")
    return RawContacts(ids.astype(np.int64), np.ascontiguousarray(table[:, 3:6]), "lammps-local")


READERS = {"lammps-local": read_lammps_local}
FORMATS = tuple(READERS)


def detect_format(path) -> str:
    """The contact file's format from its content; InputError when it is none of ``FORMATS``."""
    text = read_text(path, KIND)
    if re.search(r"^ITEM: ENTRIES", text, re.M):
        return "lammps-local"
    _fail(path, f"unknown format; the formats read are: lammps-local (a LAMMPS 'dump local' with columns "
                f"{LOCAL_LAYOUT})")


def read(path) -> RawContacts:
    """Read a contact file of any supported format (detected from its content)."""
    return READERS[detect_format(path)](path)
