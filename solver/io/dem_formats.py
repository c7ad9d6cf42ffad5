"""Packings written by DEM codes: LAMMPS and LIGGGHTS data files and text dumps of
``atom_style sphere``, and YADE's sphere text exports.  Not collective (plain file reading).

Readers return a :class:`RawPacking`: the file's own numbers in the file's own units, nothing
rescaled, rows as the file lists them except that LAMMPS/LIGGGHTS atoms are sorted by atom id
(write_data lists them in memory order, dumps in any order).  Positions are as written: LAMMPS
wraps atoms into the box only when it rebuilds its neighbour lists, so a dump may hold atoms
up to half the neighbour skin outside [lo, hi); YADE writes unwrapped positions unless the
script wraps them.  The caller wraps and rescales.

Formats (tests/data/dem/README.md shows real files of each, made by the programs):

* ``lammps-data`` -- ``write_data`` of LAMMPS or LIGGGHTS.  Header ``N atoms``, ``xlo xhi``,
  ``ylo yhi``, ``zlo zhi`` and, for a triclinic box, ``xy xz yz`` (the tilt factors); ``Atoms # sphere`` section with columns ``id type diameter density
  x y z`` and optionally the image flags ``ix iy iz``.  LIGGGHTS (and older LAMMPS) write a bare
  ``Atoms`` line without the style comment: then a section of 7 or 10 columns is read as
  sphere's.  The file holds densities, not masses: ``masses = density * pi d^3 / 6``, the mass
  LAMMPS gives the atom (it uses the sphere's volume in 2D too, unless ``set density/disc``
  was used, in which case write_data's density is still mass / (pi d^3 / 6)).
* ``lammps-dump`` -- a text ``dump custom`` / ``write_dump``: ``ITEM: TIMESTEP``, ``ITEM:
  NUMBER OF ATOMS``, ``ITEM: BOX BOUNDS pp pp pp`` (``pp pp ff`` for disks, all at z = 0, as
  rotsound's 2D export writes) with three ``lo hi`` lines, or a triclinic box's ``ITEM: BOX BOUNDS
  xy xz yz pp pp pp`` with three lines ``xlo_bound xhi_bound xy``, ``ylo_bound yhi_bound xz``,
  ``zlo_bound zhi_bound yz``: the bounding box of the tilted cell, from which the cell's own bounds
  are xlo = xlo_bound - min(0, xy, xz, xy + xz), xhi = xhi_bound - max(0, xy, xz, xy + xz), ylo =
  ylo_bound - min(0, yz), yhi = yhi_bound - max(0, yz), z as given (LAMMPS's dump and read_dump
  pages); LAMMPS's general triclinic ``BOX BOUNDS abc origin`` is refused.  ``ITEM: ATOMS`` and its column names;
  columns not read may hold words (``dump_modify element``).  Needs ``id``, ``diameter`` or ``radius`` (LIGGGHTS scripts usually
  dump radius), and ``x y z`` (or unwrapped ``xu yu zu``, or scaled ``xs ys zs``, converted to
  lo + H s, H the cell's matrix: lo + s (hi - lo) in an orthogonal box); takes ``mass`` when present, else ``density`` (LIGGGHTS), else masses are
  None.  Any number of frames; one is read.
* ``yade`` -- ``yade.export.textExt`` (first line ``#format x_y_z_r``, or ``x_y_z_r_matId``,
  ``id_x_y_z_r_matId``, ``x_y_z_r_attrs`` whose first four columns are x y z r, or textClumps'
  ``x_y_z_r_clumpId``), or ``SpherePack.save`` (columns x y z r clumpId, no ``#format``).
  Radii, not diameters; no masses; always 3D.  The periodic cell: textExt does not record it;
  SpherePack.save writes ``##PERIODIC:: Lx Ly Lz`` as its first line (YADE's cell spans 0 to L),
  and the same line passed through textExt's ``comment`` is found too.  Without it, box_lo and
  box_hi are None.  Ids are the file's when it has them (``id_x_y_z_r_matId``), else the line
  order from 0 (YADE's body ids when every body is a sphere).  Both YADE writers print ``%g``:
  six significant digits.
* ``mercury`` -- MercuryDPM's ``.data`` file of a 3D simulation (``DPMBase::outputXBallsData``,
  XBalls format 14): one frame per saved step, each a header line ``N time xmin ymin zmin xmax
  ymax zmax`` (the domain, which rotsound takes as the periodic box) and N lines ``x y z vx vy vz
  radius euler(3) omega(3) info``; the last frame is read.  Radii, not diameters; no masses (one
  species of one density: m proportional to d^3); ids are the particles' indices from 0 (the
  line order), as MercuryDPM's ``.fstat`` names them.  Positions are printed with 15 significant
  digits, the rest with the stream's precision (10 by default; a driver can set 17).  The 2D
  format (8: header ``N time xmin ymin xmax ymax``, 8 columns) is refused.

2D: a LAMMPS/LIGGGHTS packing is 2D (D = 2, the z column and z bounds dropped) when every
atom's z is exactly 0, as ``dimension 2`` (fix enforce2d) leaves it; else 3D.  YADE and
MercuryDPM are 3D.

Triclinic boxes (LAMMPS's restricted triclinic cell, ``geometry.Cell``): a tilt line or tilted
``BOX BOUNDS`` gives ``RawPacking.tilt``; LIGGGHTS writes both formats as LAMMPS does.  A tilt beyond
half the side it shears (``Cell.tilt_problem``) is refused, and so is a 2D packing whose xz or yz is
not 0 (in 2D only xy shears the cell).  YADE's cell: SpherePack.save's ``##PERIODIC::`` line holds
the cell's sizes only, not its ``hSize``, so a YADE file read here is orthogonal.

Written by hand: lammpsio 0.9 (PyPI) has no atom_style sphere and no diameter/radius field, and
ASE's lammps-data reader rejects atom_style sphere.  Numbers go through np.loadtxt (no Python
loop over atoms).  Every bad or damaged file raises :class:`solver.errors.InputError` with one
message naming the file, what is wrong and what is allowed.
"""

from __future__ import annotations

import dataclasses
import pathlib
import re
from dataclasses import dataclass

import numpy as np

from solver.errors import InputError

from ..packing.geometry import TILTS, Cell
from ..wording import counted

FORMATS = ("rotsound", "lammps-data", "lammps-dump", "yade", "mercury")
SPHERE_COLUMNS = "id type diameter density x y z (and optionally the image flags ix iy iz)"
YADE_FORMATS = {  # textExt '#format' name -> (number of columns or None for 'at least 4', id column)
    "x_y_z_r": (4, None),
    "x_y_z_r_matId": (5, None),
    "id_x_y_z_r_matId": (6, 0),
    "x_y_z_r_attrs": (None, None),
    "x_y_z_r_clumpId": (5, None),
}
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


@dataclass(frozen=True, eq=False)
class RawPacking:
    """A packing as a file holds it, in the file's units.

    positions (N, D) float64: D = 2 when every z of a LAMMPS/LIGGGHTS file is exactly 0, else
        3 (YADE is always 3D).
    diameters (N,) float64, all > 0.
    masses (N,) float64 or None when the file has none (LAMMPS data: density * pi d^3 / 6).
    box_lo, box_hi (D,) float64, or both None when the format does not record the box (YADE
        without its ``##PERIODIC::`` line); periodic; the cell's origin is box_lo and its sides
        box_hi - box_lo (a triclinic dump's bounding box converted to these).
    tilt (T,) float64 the tilt factors of a triclinic box (``geometry.TILTS[D]``: xy, or xy xz yz),
        in the file's units, or None (an orthogonal box).
    ids (N,) int64: atom ids (YADE: the file's ids or the line order from 0).
    source: the format read, "lammps-data", "lammps-dump", "yade" or "mercury".
    boundary: (D,) the LAMMPS boundary flags of each axis as a dump records them ("pp" periodic;
        "ff", "fm", "fs", ... not: a wall at each f bound, docs/walls.md), or None when the file
        does not record them (then every axis is periodic unless packing.walls says otherwise).
    """

    positions: np.ndarray
    diameters: np.ndarray
    masses: np.ndarray | None
    box_lo: np.ndarray | None
    box_hi: np.ndarray | None
    ids: np.ndarray
    source: str
    tilt: np.ndarray | None = None
    boundary: tuple[str, ...] | None = None

    @property
    def dim(self) -> int:
        return self.positions.shape[1]


def _fail(path, what: str, kind: str = "packing file"):
    raise InputError(f"{kind} {path}: {what}")


def read_text(path, kind: str = "packing file") -> str:
    """The file's text; InputError (naming the ``kind`` of file) if it is missing, not a regular
    file, not text or empty."""
    p = pathlib.Path(path)
    if not p.exists():
        _fail(path, "not found", kind)
    if not p.is_file():
        _fail(path, "not a regular file", kind)
    try:
        text = p.read_text()
    except UnicodeDecodeError:
        _fail(path, "not a text file (LAMMPS data files and text dumps and YADE exports are text)", kind)
    if not text.strip():
        _fail(path, "the file is empty", kind)
    return text


def after_comments(text: str) -> tuple[list[str], int]:
    """(the lines after the leading '#' comments and blank lines, the file line of the first of
    them, from 1) of a YADE-style text file; trailing blank lines dropped."""
    head = re.match(r"(?:[ \t]*(?:#[^\n]*)?(?:\n|\Z))*", text).group(0)
    return text[len(head):].rstrip().splitlines(), head.count("\n") + 1


def number_table(path, lines: list[str], first: int, where: str, expect: str, kind: str = "packing file",
                 usecols: list[int] | None = None) -> np.ndarray:
    """(len(lines), C) float64 table of ``lines`` (of their columns ``usecols`` only, when given:
    the others may hold words), which start at line ``first`` (from 1) of the file; InputError
    naming the first bad line on blank lines, ragged rows, non-numeric or non-finite values.
    ``where`` names the block, ``expect`` says what its rows hold."""
    try:
        table = np.loadtxt(lines, dtype=np.float64, comments="#", ndmin=2, usecols=usecols)
    except ValueError:
        table = None
    if table is None or table.shape[0] != len(lines):
        row, problem = _first_bad_row(lines)
        _fail(path, f"line {first + row} of the file, in {where}, {problem}; each row must hold {expect}", kind)
    if not np.all(np.isfinite(table)):
        row = int(np.argwhere(~np.isfinite(table))[0, 0])
        _fail(path, f"line {first + row} of the file, in {where}, holds a non-finite value (nan or inf); "
                    f"values must be finite numbers", kind)
    return table


def _first_bad_row(lines: list[str]) -> tuple[int, str]:
    """(index, what is wrong) of the first of ``lines`` that is blank, holds a non-number or has
    another number of values than most lines; a Python scan, on the error path only."""
    rows = [line.split("#", 1)[0].split() for line in lines]
    widths = [len(words) for words in rows]
    width = max(set(widths), key=widths.count)
    for row, words in enumerate(rows):
        if not words:
            return row, "is blank or only a comment"
        bad = next((w for w in words if not _is_number(w)), None)
        if bad is not None:
            return row, f"'{bad}' is not a number"
        if len(words) != width:
            return row, f"has {counted(len(words), 'value')} where the other lines have {width}"
    return 0, "is not a table of numbers"


def _ids(path, column: np.ndarray, where: str) -> np.ndarray:
    ids = column.astype(np.int64)
    if not np.array_equal(ids, column):
        _fail(path, f"{where}: atom ids must be whole numbers")
    if np.unique(ids).size != ids.size:
        _fail(path, f"{where}: atom ids repeat; each atom must have its own id")
    return ids


def _check_sizes(path, diameters: np.ndarray, masses: np.ndarray | None, ids: np.ndarray, where: str) -> None:
    bad = np.flatnonzero(~(diameters > 0))
    if bad.size:
        _fail(path, f"{where}: {bad.size} particle(s) have a non-positive diameter (first: id {ids[bad[0]]}, "
                    f"diameter {diameters[bad[0]]:g}); diameters must be > 0")
    if masses is not None:
        bad = np.flatnonzero(~(masses > 0))
        if bad.size:
            _fail(path, f"{where}: {bad.size} particle(s) have a non-positive mass or density (first: id "
                        f"{ids[bad[0]]}); masses and densities must be > 0")


def _check_box(path, lo: np.ndarray, hi: np.ndarray) -> None:
    bad = np.flatnonzero(~(hi > lo))
    if bad.size:
        _fail(path, f"the box has hi <= lo along {'xyz'[bad[0]]} ({lo[bad[0]]:g} to {hi[bad[0]]:g}); "
                    f"each box side must have positive length")


def _packing(path, ids, positions, diameters, masses, lo, hi, source, where, tilt=None, periodic=None) -> RawPacking:
    """Sort by id, drop z when every z is 0, check sizes (``where`` names the rows), box and
    ``tilt`` (3,) xy xz yz of a triclinic box (or None) in the cell periodic along ``periodic`` (3,)
    bool (None: every axis)."""
    order = np.argsort(ids, kind="stable")
    ids, positions, diameters = ids[order], positions[order], diameters[order]
    masses = None if masses is None else masses[order]
    _check_sizes(path, diameters, masses, ids, where)
    _check_box(path, lo, hi)
    dim = 2 if np.all(positions[:, 2] == 0.0) else 3
    if tilt is not None:
        tilt = _check_tilt(path, tilt, hi[:dim] - lo[:dim], np.ones(dim, dtype=bool) if periodic is None
                           else np.asarray(periodic[:dim], dtype=bool))
    return RawPacking(positions=np.ascontiguousarray(positions[:, :dim]), diameters=diameters, masses=masses,
                      box_lo=lo[:dim].copy(), box_hi=hi[:dim].copy(), ids=ids, source=source, tilt=tilt)


def _check_tilt(path, tilt: np.ndarray, sides: np.ndarray, periodic: np.ndarray) -> np.ndarray:
    """The (T,) tilt factors of a cell of ``sides`` (D,), periodic along ``periodic`` (D,), from a
    file's xy xz yz (3,); InputError when xz or yz is not 0 in 2D, a tilt is beyond half its side or
    shears across an axis with walls (``Cell.tilt_problem``)."""
    dim = sides.size
    if dim == 2 and np.any(tilt[1:] != 0.0):
        _fail(path, f"the packing is 2D (every z is 0) but the box's tilt xz = {tilt[1]:g}, yz = {tilt[2]:g}: in 2D "
                    f"only xy shears the cell, so xz and yz must be 0")
    tilt = tilt[:len(TILTS[dim])].copy()
    problem = Cell(sides, tilt, periodic).tilt_problem()
    if problem is not None:
        _fail(path, f"the triclinic box's {problem}")
    return tilt


# --- LAMMPS / LIGGGHTS data file -------------------------------------------------------------

_SECTION = re.compile(r"^[ \t]*([A-Za-z][A-Za-z ]*?)[ \t]*(#.*)?$", re.M)
_BLANK_THEN = re.compile(r"\n[ \t]*(?:\n|$)")


def read_lammps_data(path) -> RawPacking:
    """A LAMMPS or LIGGGHTS ``write_data`` file of atom_style sphere -> :class:`RawPacking`
    (source "lammps-data"; masses from the densities).  Not collective."""
    text = read_text(path)
    body = text.split("\n", 1)[1] if "\n" in text else ""  # the first line is a free title
    first = _SECTION.search(body)
    header = body[:first.start()] if first else body
    counts, bounds, tilt = {}, {}, None
    for raw in header.splitlines():
        words = raw.split("#", 1)[0].split()
        if not words:
            continue
        key = " ".join(w for w in words if not _is_number(w))
        values = [w for w in words if _is_number(w)]
        if key in ("xlo xhi", "ylo yhi", "zlo zhi") and len(values) == 2:
            bounds[key[0]] = (float(values[0]), float(values[1]))
        elif key == "xy xz yz" and len(values) == 3:
            tilt = np.array(values, dtype=np.float64)
            if not np.all(np.isfinite(tilt)):
                _fail(path, f"header line '{raw.strip()}': the tilt factors xy xz yz must be finite numbers")
        elif key in ("atoms", "atom types") and len(values) == 1:
            counts[key] = values[0]
        elif not values:
            _fail(path, f"header line '{raw.strip()}' has no number; header lines are '<numbers> <keyword>' "
                        f"such as '128 atoms' or '-3 9.5 xlo xhi'")
    if "atoms" not in counts:
        _fail(path, "no 'N atoms' line in the header; a LAMMPS data file states its atom count there")
    natoms = counts["atoms"]
    if not natoms.isdigit() or int(natoms) == 0:
        _fail(path, f"the header's atom count '{natoms}' is not a positive whole number")
    natoms = int(natoms)
    missing = [k + "lo " + k + "hi" for k in "xyz" if k not in bounds]
    if missing:
        _fail(path, f"the header has no {', '.join(repr(m) for m in missing)} line(s); the box needs all three")
    atoms = next((m for m in _SECTION.finditer(body) if m.group(1) == "Atoms"), None)
    if atoms is None:
        _fail(path, "no 'Atoms' section (truncated file?); a data file lists its atoms under 'Atoms # sphere'")
    style = (atoms.group(2) or "#").lstrip("#").strip()
    if style and style.split()[0] != "sphere":
        _fail(path, f"atom_style {style}: only atom_style sphere is read (Atoms columns {SPHERE_COLUMNS})")
    rest = body[atoms.end():].lstrip(" \t\r\n")
    end = _BLANK_THEN.search(rest)
    lines = (rest[:end.start()] if end else rest).splitlines()
    if not lines or _SECTION.match(lines[0]):
        lines = []
    if len(lines) != natoms:
        _fail(path, f"the Atoms section has {len(lines)} atom lines where the header says {natoms} atoms "
                    f"(truncated or damaged file); it must list every atom once")
    table = number_table(path, lines, text[:len(text) - len(rest)].count("\n") + 1, "the Atoms section", SPHERE_COLUMNS)
    if table.shape[1] not in (7, 10):
        _fail(path, f"Atoms lines have {table.shape[1]} columns; atom_style sphere has 7 or 10: {SPHERE_COLUMNS}")
    ids = _ids(path, table[:, 0], "the Atoms section")
    diameters, density = table[:, 2], table[:, 3]
    lo = np.array([bounds[k][0] for k in "xyz"])
    hi = np.array([bounds[k][1] for k in "xyz"])
    masses = density * (np.pi / 6.0) * diameters ** 3
    bad = np.flatnonzero(~(density > 0))
    if bad.size:
        _fail(path, f"the Atoms section: {bad.size} atom(s) have a non-positive density (first: id {ids[bad[0]]}); "
                    f"densities must be > 0")
    return _packing(path, ids, table[:, 4:7], diameters, masses, lo, hi, "lammps-data", "the Atoms section", tilt)


def _is_number(word: str) -> bool:
    try:
        float(word)
    except ValueError:
        return False
    return True


# --- LAMMPS / LIGGGHTS text dump -------------------------------------------------------------

_POSITION_SETS = (("x", "y", "z"), ("xu", "yu", "zu"), ("xs", "ys", "zs"), ("xsu", "ysu", "zsu"))


def read_lammps_dump(path, frame: int = -1) -> RawPacking:
    """One frame (Python index; the last by default) of a LAMMPS or LIGGGHTS text dump ->
    :class:`RawPacking` (source "lammps-dump").  Not collective."""
    text = read_text(path)
    starts = [m.start() for m in re.finditer(r"^ITEM: TIMESTEP[ \t]*$", text, re.M)]
    if not starts or text[:starts[0]].strip():
        _fail(path, "does not start with 'ITEM: TIMESTEP'; a LAMMPS text dump starts every frame with it")
    if not -len(starts) <= frame < len(starts):
        _fail(path, f"frame {frame} asked for, but the dump has {len(starts)} frame(s); "
                    f"frame must be in [{-len(starts)}, {len(starts) - 1}]")
    frame = frame % len(starts)
    chunk = text[starts[frame]:starts[frame + 1] if frame + 1 < len(starts) else len(text)]
    where = f"frame {frame}"
    head, sep, atoms = chunk.partition("\nITEM: ATOMS")
    if not sep:
        _fail(path, f"{where} has no 'ITEM: ATOMS' line (truncated file?); each frame lists its atoms after it")
    items = {}
    for part in head.split("ITEM: ")[1:]:
        title, _, rest = part.partition("\n")
        items[title.strip()] = rest.split()
    count = items.get("NUMBER OF ATOMS")
    if not count or len(count) != 1 or not count[0].isdigit() or int(count[0]) == 0:
        _fail(path, f"{where}: 'ITEM: NUMBER OF ATOMS' must be followed by one positive whole number")
    natoms = int(count[0])
    box = next((k for k in items if k.startswith("BOX BOUNDS")), None)
    if box is None:
        _fail(path, f"{where} has no 'ITEM: BOX BOUNDS' line; a dump records its box there")
    flags = box.split()[2:]
    triclinic = flags[:3] == ["xy", "xz", "yz"]
    if "abc" in flags:
        _fail(path, f"{where}: the box is LAMMPS's general triclinic cell ('ITEM: {box}'); rotsound reads the "
                    f"restricted one, 'ITEM: BOX BOUNDS xy xz yz pp pp pp' (dump without dump_modify triclinic/general)")
    if triclinic:
        flags = flags[3:]
    if len(flags) != 3 or any(not re.fullmatch("pp|[fsm]{2}", f) for f in flags):
        _fail(path, f"{where}: the boundary flags ('ITEM: {box}') must be three LAMMPS boundary styles: pp (periodic) "
                    f"or two of f, s, m (a wall at each f bound: docs/walls.md)")
    try:
        values = np.array(items[box], dtype=np.float64)
    except ValueError:
        _fail(path, f"{where}: the box bounds are not numbers; 'ITEM: {box}' is followed by three lines 'lo hi'")
    width = 3 if triclinic else 2
    if values.size != 3 * width or not np.all(np.isfinite(values)):
        _fail(path, f"{where}: 'ITEM: {box}' must be followed by three lines of {width} finite numbers "
                    + ("'lo_bound hi_bound tilt'" if triclinic else "'lo hi'"))
    lo, hi = values[0::width].copy(), values[1::width].copy()
    tilt = values[2::3].copy() if triclinic else None
    if triclinic:  # the bounding box -> the cell's bounds (LAMMPS's dump page)
        xy, xz, yz = tilt
        lo -= [min(0.0, xy, xz, xy + xz), min(0.0, yz), 0.0]
        hi -= [max(0.0, xy, xz, xy + xz), max(0.0, yz), 0.0]
    names, _, rows = atoms.partition("\n")
    names = names.split()
    lines = rows.rstrip().splitlines()
    if len(lines) < natoms:
        _fail(path, f"{where} has {len(lines)} atom lines where 'ITEM: NUMBER OF ATOMS' says {natoms} "
                    f"(truncated or damaged file); it must list every atom once")
    if len(lines) > natoms:
        _fail(path, f"{where} has {len(lines)} atom lines where 'ITEM: NUMBER OF ATOMS' says {natoms}")
    size = next((c for c in ("diameter", "radius") if c in names), None)
    position = next((s for s in _POSITION_SETS if set(s) <= set(names)), None)
    missing = ([] if "id" in names else ["id"]) + ([] if size else ["diameter or radius"]) \
        + ([] if position else ["x y z"])
    if missing:
        _fail(path, f"{where}: the ATOMS columns ({' '.join(names) or 'none'}) lack {', '.join(missing)}; "
                    f"a packing dump needs id, diameter or radius, and x y z (or xu yu zu, or xs ys zs)")
    first = text[:starts[frame]].count("\n") + chunk[:len(chunk) - len(rows)].count("\n") + 1
    width = len(lines[0].split()) if natoms else len(names)
    if width != len(names):
        _fail(path, f"{where}: atom lines have {width} columns but 'ITEM: ATOMS' names {len(names)} "
                    f"({' '.join(names)}); each line must hold one value per name")
    # only the columns read are numbers: others may hold words (an 'element' column, dump_modify element)
    read = [n for n in names if n in ("id", size, *position, "mass", "density")]
    table = number_table(path, lines[:natoms], first, f"{where}'s atom lines",
                         f"the {len(names)} columns {' '.join(names)}", usecols=[names.index(n) for n in read])
    col = {n: table[:, i] for i, n in enumerate(read)}
    ids = _ids(path, col["id"], f"{where}'s atom lines")
    diameters = col[size] * (2.0 if size == "radius" else 1.0)
    positions = np.column_stack([col[c] for c in position])
    if position[0].startswith("xs"):
        cell = Cell(hi - lo, np.zeros(3) if tilt is None else tilt, np.ones(3, dtype=bool))
        positions = lo + positions @ cell.matrix.T
    if "mass" in col:
        masses = col["mass"].copy()
    elif "density" in col:
        masses = col["density"] * (np.pi / 6.0) * diameters ** 3
    else:
        masses = None
    raw = _packing(path, ids, positions, diameters, masses, lo, hi, "lammps-dump", f"{where}'s atom lines", tilt,
                   np.array([flag == "pp" for flag in flags]))
    return dataclasses.replace(raw, boundary=tuple(flags[:raw.dim]))


# --- YADE ---------------------------------------------------------------------------------------

_PERIODIC = re.compile(r"^#*[ \t]*##PERIODIC::(.*)$", re.M)  # also after textExt's '# ' comment prefix


def read_yade_text(path) -> RawPacking:
    """A YADE sphere text export (export.textExt / export.text, or SpherePack.save) ->
    :class:`RawPacking` (source "yade", 3D, masses None).  Not collective."""
    text = read_text(path)
    first = _first_line(text).split()
    fmt = first[1] if first[0] == "#format" and len(first) > 1 else None
    if first[0] == "#format" and fmt not in YADE_FORMATS:
        _fail(path, f"YADE text format '{fmt or ''}' is not read; the formats read are "
                    f"{', '.join(YADE_FORMATS)} (yade.export.textExt) and SpherePack.save's x y z r clumpId")
    columns, id_column = YADE_FORMATS[fmt] if fmt else (None, None)
    cells = _PERIODIC.findall(text)
    lo = hi = None
    if cells:
        try:
            hi = np.array(cells[0].split(), dtype=np.float64)
        except ValueError:
            hi = np.array([])
        if hi.size != 3 or not np.all(np.isfinite(hi)) or not np.all(hi > 0):
            _fail(path, f"the line '##PERIODIC::{cells[0]}' must give the periodic cell's three positive side "
                        f"lengths Lx Ly Lz")
        lo = np.zeros(3)
    rows, first = after_comments(text)
    if not rows:
        _fail(path, "no sphere lines, only comments; a YADE export lists one sphere per line (x y z r ...)")
    expect = f"the columns of format {fmt}" if fmt else "x y z r (and clumpId), as SpherePack.save writes"
    table = number_table(path, rows, first, "the sphere lines", expect)
    width = table.shape[1]
    if (columns is not None and width != columns) or width < 4 or (fmt is None and width > 5):
        _fail(path, f"sphere lines have {width} columns; {expect} "
                    f"({columns if columns else '4 or 5' if fmt is None else 'at least 4'} columns)")
    if id_column is None:
        ids = np.arange(len(table), dtype=np.int64)
        xyzr = table[:, :4]
    else:
        ids = _ids(path, table[:, id_column], "the sphere lines")
        xyzr = table[:, 1:5]
    diameters = 2.0 * xyzr[:, 3]
    _check_sizes(path, diameters, None, ids, "the sphere lines")
    return RawPacking(positions=np.ascontiguousarray(xyzr[:, :3]), diameters=diameters, masses=None,
                      box_lo=lo, box_hi=hi, ids=ids, source="yade")


def _first_line(text: str) -> str:
    """The first non-blank line of ``text`` (which is not blank)."""
    return re.search(r"\S.*", text).group(0)


# --- MercuryDPM ----------------------------------------------------------------------------------

MERCURY_HEADER = "N time xmin ymin zmin xmax ymax zmax"
MERCURY_COLUMNS = "x y z vx vy vz radius euler_x euler_y euler_z omega_x omega_y omega_z info"


def read_mercury_data(path) -> RawPacking:
    """The last frame of a MercuryDPM ``.data`` file of a 3D simulation (format above) ->
    :class:`RawPacking` (source "mercury", masses None, ids the particle indices from 0).  A
    Python loop over frames only.  Not collective."""
    text = read_text(path)
    lines = text.rstrip().splitlines()
    start, frame, count, first = 0, 0, 0, 0
    while True:
        header = lines[start].split()
        if len(header) == 6 and all(_is_number(w) for w in header):
            _fail(path, f"line {start + 1} is the header of a 2D MercuryDPM data file (N time xmin ymin xmax ymax); "
                        f"rotsound reads MercuryDPM's 3D format, whose header is '{MERCURY_HEADER}'")
        if len(header) != 8 or not all(_is_number(w) for w in header) or not header[0].isdigit() \
                or int(header[0]) == 0:
            more = f" (after the {count} particle lines that the header of frame {frame - 1}, at line {first + 1}, " \
                   f"announces: that frame has more particle lines than its header says)" if frame else ""
            _fail(path, f"line {start + 1} is not a frame header '{MERCURY_HEADER}' with N a positive whole number"
                        f"{more}; a MercuryDPM data file has a header line before every frame's N particle lines")
        count, first = int(header[0]), start
        if start + 1 + count > len(lines):
            _fail(path, f"frame {frame} (header at line {start + 1}) has {len(lines) - start - 1} particle lines where its "
                        f"header says N = {count} (truncated or damaged file); it must list every particle once")
        start += 1 + count
        if start == len(lines):
            break
        frame += 1
    rows = lines[first + 1:]
    table = number_table(path, rows, first + 2, f"frame {frame}'s particle lines", f"the 14 columns {MERCURY_COLUMNS}")
    if table.shape[1] != 14:
        _fail(path, f"frame {frame}'s particle lines have {table.shape[1]} columns; MercuryDPM's 3D data file has 14: "
                    f"{MERCURY_COLUMNS}")
    values = np.array(lines[first].split(), dtype=np.float64)
    if not np.all(np.isfinite(values)):
        _fail(path, f"line {first + 1}, the header of frame {frame}, holds a non-finite value; '{MERCURY_HEADER}' "
                    f"must be finite numbers")
    ids = np.arange(count, dtype=np.int64)
    return _packing(path, ids, table[:, :3], 2.0 * table[:, 6], None, values[2:5], values[5:8], "mercury",
                    f"frame {frame}'s particle lines")


# --- detection and dispatch --------------------------------------------------------------------


def detect_format(path) -> str:
    """"rotsound" (an HDF5 file), "lammps-data", "lammps-dump", "yade" or "mercury", from the file's
    content (never its name).  InputError when it is none of them.  Not collective."""
    p = pathlib.Path(path)
    if not p.exists():
        _fail(path, "not found")
    if not p.is_file():
        _fail(path, "not a regular file")
    with open(p, "rb") as f:
        start = f.read(8)
        if start == _HDF5_SIGNATURE:
            return "rotsound"
        offset = 512  # HDF5 allows a user block of 512 * 2^k bytes before its signature
        size = p.stat().st_size
        while offset + 8 <= size:
            f.seek(offset)
            if f.read(8) == _HDF5_SIGNATURE:
                return "rotsound"
            offset *= 2
        f.seek(0)
        head = f.read(65536)
    if not head.strip():
        _fail(path, "the file is empty")
    try:
        head = head.decode()
    except UnicodeDecodeError as exc:
        if exc.start < len(head) - 4:  # not just a multi-byte character cut at the end
            _fail(path, f"unknown format: neither HDF5 nor text; {_FORMATS_TEXT}")
        head = head[:exc.start].decode()
    first = _first_line(head).strip()
    if first.startswith("ITEM:"):
        return "lammps-dump"
    if first.startswith(("#format", "##PERIODIC::")):
        return "yade"
    words = first.split()
    if 4 <= len(words) <= 5 and all(_is_number(w) for w in words):
        return "yade"  # SpherePack.save of a non-periodic packing: bare 'x y z r clumpId' lines
    if len(words) in (6, 8) and words[0].isdigit() and all(_is_number(w) for w in words):
        return "mercury"  # 'N time xmin ymin zmin xmax ymax zmax' (3D; 6 numbers: 2D, refused by the reader)
    if re.search(r"^[ \t]*\d+[ \t]+atoms[ \t]*(#.*)?$", head, re.M):
        return "lammps-data"
    _fail(path, f"unknown format; {_FORMATS_TEXT}")


_FORMATS_TEXT = ("the formats read are rotsound (HDF5), lammps-data (LAMMPS/LIGGGHTS write_data, atom_style "
                 "sphere), lammps-dump (LAMMPS/LIGGGHTS text dump starting 'ITEM: TIMESTEP'), yade "
                 "(yade.export.textExt or SpherePack.save) and mercury (MercuryDPM's 3D .data file)")

READERS = {"lammps-data": read_lammps_data, "lammps-dump": read_lammps_dump, "yade": read_yade_text,
           "mercury": read_mercury_data}


def read(path, fmt: str | None = None) -> RawPacking:
    """Read a DEM packing file of format ``fmt`` (detected from the content when None).  rotsound's
    own HDF5 files are read by solver.io.hdf5, not here (ValueError).  Not collective."""
    fmt = detect_format(path) if fmt is None else fmt
    if fmt == "rotsound":
        raise ValueError(f"{path} is a rotsound HDF5 packing file: read it with solver.io.hdf5")
    if fmt not in READERS:
        raise InputError(f"packing.format = {fmt!r}: not a known format; allowed: {', '.join(FORMATS)}")
    return READERS[fmt](path)
