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
* ``liggghts-local`` -- a LIGGGHTS ``dump local`` of ``compute pair/gran/local pos id force
  force_tangential`` (the same frame layout): after the index, x_i y_i z_i x_j y_j z_j, id_i
  id_j, a periodic flag, the total force and the tangential force on id_i from id_j (LIGGGHTS
  3.8.0 writes its values in a fixed order whatever the keywords' order; these four keywords
  give exactly 16 columns).  LIGGGHTS (like YADE) applies the tangential force at the middle of
  the overlap: read it with ``model.lever: contact``.
The format is not detected: ``packing.contacts_format`` names it (default lammps-local); a
LIGGGHTS file read as LAMMPS's fails on its columns 2 and 3, which are positions, not ids.
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


def _last_frame(path) -> tuple[np.ndarray, int, str]:
    """(table (C, K), the file line of its first row, the column names) of the last frame of a
    text ``dump local``; a frame with no entries gives a (0, 0) table."""
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
        return np.zeros((0, 0)), 0, names
    first = text[:starts[-1]].count("\n") + chunk[:len(chunk) - len(rows)].count("\n") + 1
    return number_table(path, lines, first, "the entries", "one number per column", KIND), first, names


def _ids(path, table: np.ndarray, columns: slice, first: int, layout: str) -> np.ndarray:
    """The two atom-id columns ``columns`` of ``table`` as int64; InputError unless whole numbers >= 1."""
    ids = table[:, columns]
    bad = np.flatnonzero(np.any((ids != np.rint(ids)) | (ids < 1), axis=1))
    if bad.size:
        _fail(path, f"line {first + bad[0]}: the atom-id columns must hold whole numbers >= 1, not "
                    f"{ids[bad[0]].tolist()}; the columns are {layout}")
    return ids.astype(np.int64)


def read_lammps_local(path) -> RawContacts:
    """The last frame of a LAMMPS ``dump local`` of contacts (layout above) -> :class:`RawContacts`."""
    table, first, names = _last_frame(path)
    if table.size == 0:
        return RawContacts(np.zeros((0, 2), dtype=np.int64), np.zeros((0, 3)), "lammps-local")
    if table.shape[1] < 6:
        _fail(path, f"entries have {table.shape[1]} columns (named: {names.split() or 'none'}); a contact file needs "
                    f"at least 6: {LOCAL_LAYOUT}")
    ids = _ids(path, table, slice(1, 3), first, f"{LOCAL_LAYOUT} (packing.contacts_format: lammps-local)")
    return RawContacts(ids, np.ascontiguousarray(table[:, 3:6]), "lammps-local")


def read_liggghts_local(path) -> RawContacts:
    """The last frame of a LIGGGHTS ``dump local`` of ``compute pair/gran/local pos id force
    force_tangential`` (layout above) -> :class:`RawContacts`."""
    table, first, names = _last_frame(path)
    if table.size == 0:
        return RawContacts(np.zeros((0, 2), dtype=np.int64), np.zeros((0, 3)), "liggghts-local")
    if table.shape[1] != 16:
        _fail(path, f"entries have {table.shape[1]} columns; packing.contacts_format liggghts-local reads the dump "
                    f"local of 'compute pair/gran/local pos id force force_tangential': 16 columns ({LIGGGHTS_LAYOUT})")
    ids = _ids(path, table, slice(7, 9), first, LIGGGHTS_LAYOUT)
    return RawContacts(ids, np.ascontiguousarray(table[:, 13:16]), "liggghts-local")


LIGGGHTS_LAYOUT = ("index, x_i y_i z_i x_j y_j z_j, id_i id_j periodic-flag, fx fy fz (total), ftx fty ftz "
                   "(tangential, on id_i)")
READERS = {"lammps-local": read_lammps_local, "liggghts-local": read_liggghts_local}
FORMATS = tuple(READERS)


def read(path, fmt: str = "lammps-local") -> RawContacts:
    """Read a contact file of format ``fmt`` (``packing.contacts_format``).  A file that is not a
    text dump local gets InputError naming the formats."""
    text = read_text(path, KIND)
    if not re.search(r"^ITEM: ENTRIES", text, re.M):
        _fail(path, f"unknown format: not a text 'dump local' (no 'ITEM: ENTRIES' line); the formats read are "
                    f"lammps-local ({LOCAL_LAYOUT}) and liggghts-local ({LIGGGHTS_LAYOUT})")
    return READERS[fmt](path)
