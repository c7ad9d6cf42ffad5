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
  last frame is read.  The LAMMPS lines that write it are in the manual, docs/stressed_packings.md.
* ``liggghts-local`` -- a LIGGGHTS ``dump local`` of ``compute pair/gran/local pos id force
  force_tangential`` (the same frame layout): after the index, x_i y_i z_i x_j y_j z_j, id_i
  id_j, a periodic flag, the total force and the tangential force on id_i from id_j (LIGGGHTS
  3.8.0 writes its values in a fixed order whatever the keywords' order; these four keywords
  give exactly 16 columns).  LIGGGHTS (like YADE) applies the tangential force at the middle of
  the overlap: read it with ``model.lever: contact``.
* ``yade`` -- YADE has no contact export of its own; this is the plain table that a few lines of
  a YADE script write (``tests/data/dem/yade_3d_friction.py``): ``#`` comment lines, then one
  line per real interaction, ``id1 id2 fsx fsy fsz fnx fny fnz``: the body ids (0-based, the
  line order of the spheres file), ``i.phys.shearForce`` and ``i.phys.normalForce`` (both the
  force on id2 from id1).  The normal forces give each contact's kn, which must be the same for
  every contact (:func:`yade_forces`).  Read it with ``model.lever: contact`` and
  ``model.history: yade``.
* ``mercury-fstat`` -- MercuryDPM's ``.fstat`` file (``DPMBase::writeFstatHeader``): per saved
  step three ``#`` lines (time and the marker 1; the domain; the radii), then two lines per
  contact, one from each particle's side: ``time i j cx cy cz overlap tangential_overlap fn ft
  nx ny nz tx ty tz`` with i, j particle indices from 0 (a negative j is a wall), the contact
  point, the overlap, the normal force fn (along n, from j to i) and the size ft of the
  tangential force (along the unit vector t), both on i from j.  The last frame is read.  The
  normal forces give kn (:func:`mercury_forces`).  MercuryDPM applies the tangential force at the
  contact point, the middle of the overlap: read it with ``model.lever: contact``.
The format is not detected: ``packing.contacts_format`` names it (default lammps-local); a
LIGGGHTS file read as LAMMPS's fails on its columns 2 and 3, which are positions, not ids.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..packing import geometry
from .dem_formats import after_comments, number_table, read_text

KIND = "contact file"
LOCAL_COLUMNS = ("index", "patom1", "patom2", "fx", "fy", "fz")
LOCAL_LAYOUT = ("the dump's index, patom1 patom2 (compute property/local), then p1 p2 p3 (compute pair/local: "
                "the tangential force on patom1 from patom2)")


@dataclass(frozen=True, eq=False)
class RawContacts:
    """ids (C, 2) int64 the two atoms of each contact (file ids); force (C, 3) float64 the
    tangential force on the first from the second, in the file's units; source: the format;
    normal_force (C, 3) float64 or None: the normal force on the first from the second, when the
    file holds it (yade, mercury-fstat); overlap (C,) float64 or None: each contact's overlap as
    the file states it (mercury-fstat)."""

    ids: np.ndarray
    force: np.ndarray
    source: str
    normal_force: np.ndarray | None = None
    overlap: np.ndarray | None = None


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


def _ids(path, table: np.ndarray, columns: slice, first: int, layout: str, lowest: int = 1) -> np.ndarray:
    """The two atom-id columns ``columns`` of ``table`` as int64; InputError unless whole numbers >= ``lowest``."""
    ids = table[:, columns]
    bad = np.flatnonzero(np.any((ids != np.rint(ids)) | (ids < lowest), axis=1))
    if bad.size:
        _fail(path, f"line {first + bad[0]}: the id columns must hold whole numbers >= {lowest}, not "
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
YADE_LAYOUT = "id1 id2 fsx fsy fsz fnx fny fnz (body ids, i.phys.shearForce, i.phys.normalForce)"


def read_yade(path) -> RawContacts:
    """YADE's interactions as a plain table (layout above) -> :class:`RawContacts`, the forces
    turned to act on id1 (YADE's act on id2)."""
    text = read_text(path, KIND)
    if re.search(r"^ITEM:", text, re.M):
        _fail(path, "is a LAMMPS/LIGGGHTS dump ('ITEM:' lines), not YADE's table; set packing.contacts_format to "
                    "lammps-local or liggghts-local")
    rows, first = after_comments(text)
    if not rows:
        return RawContacts(np.zeros((0, 2), dtype=np.int64), np.zeros((0, 3)), "yade", np.zeros((0, 3)))
    table = number_table(path, rows, first, "the interaction lines", YADE_LAYOUT, KIND)
    if table.shape[1] != 8:
        _fail(path, f"interaction lines have {table.shape[1]} columns; packing.contacts_format yade reads 8: "
                    f"{YADE_LAYOUT}")
    ids = _ids(path, table, slice(0, 2), first, YADE_LAYOUT, lowest=0)
    return RawContacts(ids, -np.ascontiguousarray(table[:, 2:5]), "yade", -np.ascontiguousarray(table[:, 5:8]))


MERCURY_LAYOUT = ("time i j cx cy cz overlap tangential_overlap fn ft nx ny nz tx ty tz (MercuryDPM's .fstat: "
                  "particle indices from 0, contact point, overlap, |normal force| along n, |tangential force| "
                  "along t, both on i from j)")


def read_mercury_fstat(path) -> RawContacts:
    """The last frame of MercuryDPM's ``.fstat`` (layout above) -> :class:`RawContacts` with one
    row per contact (i < j; MercuryDPM lists each twice, once from each side), its normal force
    and overlap.  InputError on a wall contact or a contact listed from one side only."""
    text = read_text(path, KIND)
    lines = text.rstrip().splitlines()
    heads = [k for k, line in enumerate(lines) if line.lstrip().startswith("#")]
    if not heads or heads[0] != 0:
        _fail(path, "does not start with '#' header lines; MercuryDPM's .fstat starts every saved step with three "
                    "('# time 1', '# xmin ymin zmin xmax ymax zmax', '# radii')")
    first = heads[-1] + 1
    if first == len(lines):
        return RawContacts(np.zeros((0, 2), dtype=np.int64), np.zeros((0, 3)), "mercury-fstat", np.zeros((0, 3)),
                           np.zeros(0))
    table = number_table(path, lines[first:], first + 1, "the last frame's contact lines", MERCURY_LAYOUT, KIND)
    if table.shape[1] != 16:
        _fail(path, f"contact lines have {table.shape[1]} columns; packing.contacts_format mercury-fstat reads 16: "
                    f"{MERCURY_LAYOUT}")
    wall = np.flatnonzero(table[:, 2] < 0)
    if wall.size:
        _fail(path, f"line {first + 1 + wall[0]} is a contact with a wall (j = {table[wall[0], 2]:g} < 0); rotsound's "
                    f"packings are periodic, without walls")
    ids = _ids(path, table, slice(1, 3), first + 1, MERCURY_LAYOUT, lowest=0)
    forward, backward = ids[:, 0] < ids[:, 1], ids[:, 0] > ids[:, 1]
    one_side = set(map(tuple, ids[forward])) ^ set(map(tuple, ids[backward][:, ::-1]))
    if one_side:
        _fail(path, f"the contact of particles {list(sorted(one_side)[0])} is not listed once from each side "
                    f"(MercuryDPM writes every contact twice, i j and j i): a truncated or edited file")
    if forward.sum() != backward.sum() or forward.sum() + backward.sum() != len(ids):
        _fail(path, "a contact is listed more than twice, or a particle with itself (MercuryDPM writes every contact "
                    "twice, i j and j i, in each frame): an edited file")
    rows = table[forward]
    return RawContacts(ids[forward], rows[:, [9]] * rows[:, 13:16], "mercury-fstat", rows[:, [8]] * rows[:, 10:13],
                       np.ascontiguousarray(rows[:, 6]))


READERS = {"lammps-local": read_lammps_local, "liggghts-local": read_liggghts_local, "yade": read_yade,
           "mercury-fstat": read_mercury_fstat}
FORMATS = tuple(READERS)
DUMP_LOCAL = ("lammps-local", "liggghts-local")


def read(path, fmt: str = "lammps-local") -> RawContacts:
    """Read a contact file of format ``fmt`` (``packing.contacts_format``).  A file that is not a
    text dump local, read as one, gets InputError naming the formats."""
    text = read_text(path, KIND)
    if fmt in DUMP_LOCAL and not re.search(r"^ITEM: ENTRIES", text, re.M):
        _fail(path, f"unknown format: not a text 'dump local' (no 'ITEM: ENTRIES' line); the formats read are "
                    f"lammps-local ({LOCAL_LAYOUT}), liggghts-local ({LIGGGHTS_LAYOUT}), yade ({YADE_LAYOUT}) and "
                    f"mercury-fstat ({MERCURY_LAYOUT}), named by packing.contacts_format")
    return READERS[fmt](path)


KN_SPREAD_TOL = 1e-6   # relative spread of kn = |f_n| / overlap accepted as one stiffness
SHEAR_NORMAL_TOL = 1e-3  # largest |f_s . n| / |f_s| of a YADE shear force projected away


def yade_forces(path, found: RawContacts, pairs: np.ndarray, positions: np.ndarray, diameters: np.ndarray,
                box, unit: float, law: str) -> np.ndarray:
    """The tangential forces (C, 3) of a YADE contact file in rotsound's units kn d0, with pairs
    (C, 2) the contacts' particle indices and positions, diameters, box (its ``geometry.Cell`` or
    sides) the packing in units of d0 = ``unit`` file lengths.  kn = |normalForce| / overlap is taken from the file, and must
    be one number (to 1e-6): YADE's FrictPhys gives kn = 2 E1 R1 E2 R2 / (E1 R1 + E2 R2), one
    kn only when E R is the same for every sphere, and rotsound's harmonic law has one.  YADE's
    ScGeom::rotate never projects a shear force back onto the tangent plane; a normal part up to
    1e-3 of it is projected away here, a larger one refused.  Not collective."""
    if law != "harmonic":
        _fail(path, "YADE's FrictPhys contacts are linear (kn xi); read this file with model.law: harmonic")
    if pairs.shape[0] == 0:
        return found.force
    normal, _, overlap = geometry.pair_geometry(positions, diameters, box, pairs)
    size = np.linalg.norm(found.normal_force, axis=1)
    touching = overlap > 0.0
    if not np.any(touching):
        _fail(path, "no listed interaction touches in the packing file; the two files must be written at the same "
                    "step")
    tilt = np.abs(np.einsum("cd,cd->c", found.normal_force, normal))
    off = np.flatnonzero(touching & (tilt < (1.0 - 1e-9) * size))
    if off.size:
        _fail(path, f"the normal force of ids {found.ids[off[0]].tolist()} is not along their centre line in the "
                    f"packing file; the two files must be written at the same step")
    kn = _one_kn(path, size[touching] / (overlap[touching] * unit), "|normalForce| / overlap",
                 "YADE's FrictPhys makes kn = 2 E1 R1 E2 R2 / (E1 R1 + E2 R2): one kn needs E R the same for every "
                 "sphere (one radius, or a FrictMat per sphere with young proportional to 1/R, as "
                 "tests/data/dem/yade_3d_friction.py uniform does)")
    force = found.force / (kn * unit)
    along = np.einsum("cd,cd->c", force, normal)
    shear = np.linalg.norm(force, axis=1)
    tilted = np.flatnonzero(np.abs(along) > SHEAR_NORMAL_TOL * shear)
    if tilted.size:
        k = tilted[0]
        _fail(path, f"the shear force of ids {found.ids[k].tolist()} has a part along the contact normal of "
                    f"{abs(along[k]) / shear[k]:.2e} of itself (> {SHEAR_NORMAL_TOL:g}, the drift YADE's "
                    f"approximate rotation leaves); the file is not a YADE shear force at rest")
    return force - along[:, None] * normal


def _one_kn(path, kn: np.ndarray, what: str, advice: str) -> float:
    """The mean of the contacts' stiffnesses ``kn`` (``what`` says how they were found); InputError
    with ``advice`` unless they are one number to ``KN_SPREAD_TOL``."""
    if kn.max() > (1.0 + KN_SPREAD_TOL) * kn.min():
        _fail(path, f"kn = {what} differs between contacts ({kn.min():.6g} to {kn.max():.6g}); rotsound's harmonic "
                    f"law has one kn. {advice}")
    return float(kn.mean())


SAME_STEP_TOL = 1e-9  # d0: largest difference of a contact's overlap between MercuryDPM's .fstat and .data


def mercury_forces(path, found: RawContacts, pairs: np.ndarray, positions: np.ndarray, diameters: np.ndarray,
                   box, unit: float, law: str) -> np.ndarray:
    """The tangential forces (C, 3) of a MercuryDPM ``.fstat`` in rotsound's units kn d0, with
    pairs (C, 2) the contacts' particle indices and positions, diameters, box (its ``geometry.Cell``
    or sides) the packing in units of d0 = ``unit`` file lengths.  kn = fn / overlap from the file's own columns, which must be
    one number (a linear species: LinearViscoelastic*Species, force k overlap); each contact's
    overlap and normal must be the packing file's (the two files written at the same step).  Not
    collective."""
    if law != "harmonic":
        _fail(path, "MercuryDPM's linear species (force k * overlap) are read with model.law: harmonic")
    if pairs.shape[0] == 0:
        return found.force
    apart = np.flatnonzero(~(found.overlap > 0.0))
    if apart.size:
        _fail(path, f"the contact of particles {found.ids[apart[0]].tolist()} has overlap {found.overlap[apart[0]]:g} "
                    f"<= 0; MercuryDPM lists touching pairs only")
    normal, _, overlap = geometry.pair_geometry(positions, diameters, box, pairs)
    off = np.flatnonzero(np.abs(found.overlap / unit - overlap) > SAME_STEP_TOL)
    if off.size:
        k = off[0]
        _fail(path, f"the overlap of particles {found.ids[k].tolist()} is {found.overlap[k] / unit:.6g} d0 here but "
                    f"{overlap[k]:.6g} d0 in the packing file; the .data and .fstat files must be written at the same "
                    f"step")
    fn = np.linalg.norm(found.normal_force, axis=1)
    tilted = np.flatnonzero(np.einsum("cd,cd->c", found.normal_force, normal) < (1.0 - 1e-9) * fn)
    if tilted.size:
        _fail(path, f"the normal force of particles {found.ids[tilted[0]].tolist()} is not along their centre line "
                    f"(from the second to the first) in the packing file; the .data and .fstat files must be written "
                    f"at the same step")
    kn = _one_kn(path, fn / found.overlap, "fn / overlap", "MercuryDPM's LinearViscoelastic species have one "
                 "stiffness k: give all particles one species")
    return found.force / (kn * unit)


KN_FROM_FILE = {"yade": yade_forces, "mercury-fstat": mercury_forces}
"""Formats whose files hold the normal forces, so kn too -> the function that gives their tangential forces in kn d0."""
