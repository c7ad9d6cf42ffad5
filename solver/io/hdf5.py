"""HDF5 files: packing files (input and output) and the results file. Rank 0 writes.  Packing
files of LAMMPS, LIGGGHTS, YADE and MercuryDPM are read through ``dem_formats`` into the same checks.

Packing file format (input from any code, and what rotsound writes under ``/packings``):
  one configuration at the top level, or several as groups ``/packings/<i>`` (sorted by
  name), each holding
    positions   (N, D) float64   centres of disks (D = 2) or spheres (D = 3), any real values
                                 (folded into [0, L)); the dimension is read from this shape
    diameters   (N,)   float64   > 0, units of the mean diameter d0
    rattler     (N,)   bool      optional; computed (iterative < D + 1 contacts rule; with stored
                                 tangential forces, particles that carry none) if absent
    masses      (N,)   float64   optional, > 0; used with model.masses: density (scaled to mean 1)
    tangential/ optional group: the stored tangential forces of a packing made with friction
                (docs/stressed_contacts.md): pairs (C, 2) int64 0-based indices i < j, force
                (C, D) float64 the tangential force on i from j (kn d0), attribute friction
                (the Coulomb mu, optional)
    bridges     (B, 2) int64     a wet packing's bridged pairs apart (0-based indices; B may be 0):
                                 required with model.cohesion, refused without it
                                 (docs/capillary_bridges.md); the packing's attributes
                                 cohesion_law, surface_tension, ... record the law it was made with
    attribute box   (D,) float64 side lengths (L_x, L_y[, L_z]) of the periodic box (orthogonal, or tilted by tilt)
                                 (origin at 0), each > 2 max(diameters) (a pair then touches
                                 through one image only)
    or attribute box_length float  the side L of a square or cubic box (files written before
                                 rectangular boxes; rotsound writes it too when the box is one)
    attribute tilt  (T,) float64 optional: the cell's tilt factors xy (2D) or xy, xz, yz (3D), LAMMPS's
                                 (``geometry.Cell``: edges a = (L_x, 0, 0), b = (xy, L_y, 0),
                                 c = (xz, yz, L_z)), each at most half the side it shears; absent: orthogonal
    attribute periodic (D,) bool optional: which axes are periodic (False: walls, no images); absent: all
    walls/      optional group: flat walls (docs/walls.md): axis (W,) int64 (0 = x), position (W,)
                float64 (d0); their axes are not periodic
    wall_contacts/ optional group: the stored tangential forces of the wall contacts: particle (C,)
                int64 0-based, wall (C,) int64, force (C, D) float64 on the particle (kn d0)
    attribute gravity (D,) float64  optional: the body force per unit mass (kn d0 per unit of masses)
"""

from __future__ import annotations

import json
import os

import h5py
import numpy as np

from ..errors import InputError
from .. import profiling
from . import contact_files, dem_formats, wall_files
from .atomic import atomic_write
from ..contact_law import ContactModel
from ..packing import bridges as bridging
from ..packing import geometry, mechanics, stressed
from ..packing import walls as walling
from ..packing.configuration import Packing
from ..packing.jammed import from_arrays
from ..wording import counted

FORMAT_VERSION = 1


def _open(path: str):
    if not os.path.isfile(path):
        raise InputError(f"packing file {path}: not found")
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"packing file {path}: not a readable HDF5 file ({exc})") from None


def _read_one(group, where: str, check_equilibrium: bool, model: ContactModel) -> Packing:
    def fail(msg):
        raise InputError(f"packing file {where}: {msg}")

    for name in ("positions", "diameters"):
        if name not in group or not isinstance(group[name], h5py.Dataset):
            fail(f"dataset '{name}' is missing")
    if "box" not in group.attrs and "box_length" not in group.attrs:
        fail("attribute 'box' (the (D,) side lengths) or 'box_length' (one side of a square or cubic box) "
             "is missing")
    try:
        positions = np.asarray(group["positions"][()], dtype=float)
        diameters = np.asarray(group["diameters"][()], dtype=float)
        box = np.asarray(group.attrs["box"] if "box" in group.attrs else group.attrs["box_length"], dtype=float)
        rattler = np.asarray(group["rattler"][()], dtype=bool) if "rattler" in group else None
        masses = np.asarray(group["masses"][()], dtype=float) if "masses" in group else None
    except (OSError, ValueError, TypeError) as exc:
        fail(f"cannot read data ({exc})")
    n = diameters.shape[0] if diameters.ndim == 1 else -1
    if diameters.ndim != 1 or n < 2:
        fail(f"'diameters' has shape {diameters.shape}; need (N,) with N >= 2")
    if positions.shape not in ((n, 2), (n, 3)):
        fail(f"'positions' has shape {positions.shape}; need ({n}, 2) (disks) or ({n}, 3) (spheres) to "
             f"match 'diameters'")
    if rattler is not None and rattler.shape != (n,):
        fail(f"'rattler' has shape {rattler.shape}; need ({n},)")
    if masses is not None and (masses.shape != (n,) or not np.all(np.isfinite(masses)) or np.any(masses <= 0)):
        fail(f"'masses' (shape {masses.shape}) must be ({n},), finite and > 0")
    stored = _read_tangential(group, where, n, positions.shape[1]) if "tangential" in group else None
    gap = _read_bridges(group, where, model)
    if not np.all(np.isfinite(positions)):
        fail("'positions' contains NaN or inf")
    if not np.all(np.isfinite(diameters)) or np.any(diameters <= 0):
        fail("'diameters' must be finite and > 0")
    dim = positions.shape[1]
    name = "box" if "box" in group.attrs else "box_length"
    if box.shape not in ((dim,), ()) or (name == "box_length" and box.shape != ()):
        fail(f"'{name}' has shape {box.shape}; need ({dim},) for 'box' or one number for 'box_length'")
    if "box" in group.attrs and "box_length" in group.attrs and np.any(box != group.attrs["box_length"]):
        fail(f"'box' = {box.tolist()} and 'box_length' = {group.attrs['box_length']} disagree")
    box = _cell_of(group, box, dim, where)
    if stored is not None:
        _check_box(box, diameters, where, name)
        _check_distinct(positions, diameters, box, where)
        pairs, force, friction = stored
        stored = stressed.build(pairs, force, _folded(positions, box), diameters, _sides(box, dim),
                                model.law, friction, f"packing file {where}:/tangential")
    if gap is not None:
        _check_box(box, diameters, where, name)
        gap = bridging.build(gap, _folded(positions, box), diameters, _sides(box, dim), model.cohesion,
                             f"packing file {where}:/bridges")
    walled = _read_walls(group, where, _folded(positions, box), diameters) if "walls" in group else None
    return _finish(positions, diameters, box, rattler, masses, {"source": where}, where, name,
                   check_equilibrium, model, stored, gap, walled)


def _read_walls(group, where: str, positions: np.ndarray, diameters: np.ndarray) -> tuple:
    """(walls, wall contacts or None, gravity or None) of a packing group's ``walls`` and
    ``wall_contacts`` groups and ``gravity`` attribute (format above)."""
    try:
        axis = np.asarray(group["walls/axis"][()], dtype=np.int64)
        position = np.asarray(group["walls/position"][()], dtype=float)
        contacts = group.get("wall_contacts")
        stored = None if contacts is None else tuple(np.asarray(contacts[k][()]) for k in ("particle", "wall", "force"))
        gravity = np.asarray(group.attrs["gravity"], dtype=float) if "gravity" in group.attrs else None
    except (KeyError, OSError, ValueError, TypeError) as exc:
        raise InputError(f"packing file {where}: group 'walls' needs datasets 'axis' (W,) and 'position' (W,), group "
                         f"'wall_contacts' datasets 'particle', 'wall', 'force' ({exc})") from None
    periodic = np.ones(positions.shape[1], dtype=bool)
    periodic[axis[(axis >= 0) & (axis < periodic.size)]] = False
    walls = walling.build(axis, position, positions, diameters, periodic, f"packing file {where}:/walls")
    if stored is not None:
        stored = walling.build_contacts(*stored, positions, diameters, walls, f"packing file {where}:/wall_contacts")
    _check_gravity(gravity, walls, periodic, f"packing file {where}")
    return walls, stored, gravity


def _cell_of(group, box: np.ndarray, dim: int, where: str):
    """The box of a packing group as the geometry takes it: a ``geometry.Cell`` when the group has
    attribute ``tilt`` or ``periodic`` (format above), else ``box`` as read (files without them read
    as before).  InputError naming the file when either is malformed or the tilt is beyond what
    rotsound takes (``Cell.tilt_problem``)."""
    if "tilt" not in group.attrs and "periodic" not in group.attrs:
        return box
    names = geometry.TILTS[dim]
    cell = geometry.Cell.of(np.broadcast_to(box, (dim,)), dim)
    tilt, periodic = cell.tilt, cell.periodic
    if "tilt" in group.attrs:
        tilt = np.atleast_1d(np.asarray(group.attrs["tilt"]))
        if tilt.shape != (len(names),) or not np.issubdtype(tilt.dtype, np.number) or not np.all(np.isfinite(tilt)):
            plural = "s" if len(names) > 1 else ""
            raise InputError(f"packing file {where}: attribute 'tilt' = {tilt.tolist()}: need {len(names)} finite "
                             f"number{plural}, the cell's tilt factor{plural} {', '.join(names)} (LAMMPS's) in d0")
    if "periodic" in group.attrs:
        periodic = np.atleast_1d(np.asarray(group.attrs["periodic"]))
        if periodic.shape != (dim,) or periodic.dtype != bool:
            raise InputError(f"packing file {where}: attribute 'periodic' = {periodic.tolist()}: need {dim} booleans, "
                             f"whether each axis is periodic (False: walls)")
    cell = geometry.Cell(cell.sides, tilt.astype(float), periodic)
    problem = cell.tilt_problem()
    if problem is not None:
        raise InputError(f"packing file {where}: attribute 'tilt' = {cell.tilt.tolist()}: {problem}")
    return cell


def _folded(positions: np.ndarray, box) -> np.ndarray:
    """``positions`` folded into the cell ``box`` (a ``geometry.Cell``, sides, or one side)."""
    return geometry.wrap(positions, box) if isinstance(box, geometry.Cell) else np.mod(positions, box)


def _sides(box, dim: int):
    """``box`` as the geometry functions take it: a ``geometry.Cell`` as it is, else its (dim,) sides."""
    return box if isinstance(box, geometry.Cell) else np.broadcast_to(box, (dim,))


def _read_bridges(group, where: str, model: ContactModel):
    """The ``bridges`` dataset (B, 2) of a packing group, or None when the scene is dry; InputError
    when one is given without the other."""
    if model.cohesion is None:
        if "bridges" in group:
            raise InputError(f"packing file {where}: a wet packing (dataset 'bridges'), but the scene is dry: give "
                             f"model.cohesion, the law the packing was made with (its attributes cohesion_law, "
                             f"surface_tension, ... record it)")
        return None
    if "bridges" not in group:
        raise InputError(f"packing file {where}: model.cohesion asks for a wet packing, but the file has no dataset "
                         f"'bridges' (B, 2): the bridged pairs apart, 0-based, written with the packing (empty "
                         f"when every bridge is a contact; docs/capillary_bridges.md)")
    made_with = bridging.cohesion_of(dict(group.attrs))
    if made_with is not None and made_with != model.cohesion:
        raise InputError(f"packing file {where}: the packing was made with the bridges {made_with}, but "
                         f"model.cohesion gives {model.cohesion}: its bridged pairs and its rest hold under its own "
                         f"law; give that one")
    try:
        pairs = np.asarray(group["bridges"][()])
    except (OSError, ValueError, TypeError) as exc:
        raise InputError(f"packing file {where}: cannot read dataset 'bridges' ({exc})") from None
    if pairs.ndim != 2 or pairs.shape[1] != 2 or not (pairs.size == 0 or np.issubdtype(pairs.dtype, np.integer)):
        raise InputError(f"packing file {where}: 'bridges' has shape {pairs.shape} and type {pairs.dtype}; need "
                         f"(B, 2) integers (0-based particle indices)")
    return pairs


def _read_tangential(group, where: str, n: int, dim: int):
    """(pairs, force, friction) of a packing group's ``tangential`` group (format above)."""
    sub = group["tangential"]
    try:
        pairs = np.asarray(sub["pairs"][()])
        force = np.asarray(sub["force"][()], dtype=float)
        friction = float(sub.attrs["friction"]) if "friction" in sub.attrs else None
    except (KeyError, OSError, ValueError, TypeError) as exc:
        raise InputError(f"packing file {where}: group 'tangential' needs datasets 'pairs' (C, 2) and 'force' "
                         f"(C, D) ({exc})") from None
    if pairs.ndim != 2 or pairs.shape[1] != 2 or not np.issubdtype(pairs.dtype, np.integer):
        raise InputError(f"packing file {where}: 'tangential/pairs' has shape {pairs.shape} and type {pairs.dtype}; "
                         f"need (C, 2) integers (0-based particle indices)")
    if force.shape != (pairs.shape[0], dim):
        raise InputError(f"packing file {where}: 'tangential/force' has shape {force.shape}; need "
                         f"({pairs.shape[0]}, {dim}), one tangential force per pair")
    if friction is not None and not friction >= 0:
        raise InputError(f"packing file {where}: 'tangential' attribute friction = {friction}: must be >= 0")
    return pairs, force, friction


def _check_box(box, diameters, where: str, box_name: str, walled_axes=()) -> None:
    """InputError unless every side is finite and > 2 max(diameters) (but along ``walled_axes``,
    which have no images), and so is every height of a tilted cell (``box`` a ``geometry.Cell``, the
    sides, or one side)."""
    sides = box.sides if isinstance(box, geometry.Cell) else np.broadcast_to(np.asarray(box, dtype=float), (np.size(box),))
    imaged = np.delete(sides, list(walled_axes))
    if not np.all(np.isfinite(sides)) or np.any(imaged <= 2 * diameters.max()):
        raise InputError(f"packing file {where}: {box_name} = {np.asarray(sides).tolist()}: every side must be "
                         f"finite and > 2 max(diameters) = {2 * diameters.max():.4g}")
    if isinstance(box, geometry.Cell) and geometry.narrowest(box) <= 2 * diameters.max():
        raise InputError(f"packing file {where}: the cell of {box_name} = {sides.tolist()} tilted by tilt = "
                         f"{box.tilt.tolist()} is {geometry.narrowest(box):.4g} across at its narrowest: every "
                         f"height must be > 2 max(diameters) = {2 * diameters.max():.4g}, so that a pair touches "
                         f"through one image only")


COINCIDENT = 1e-9
"""Centres closer than this many smallest diameters (periodic distance) coincide: their contact
normal is undefined."""


def _check_distinct(positions, diameters, box, where: str) -> None:
    """InputError naming the first pair (0-based, in the order read) of particles whose centres
    coincide (``COINCIDENT``), under the periodic box."""
    pairs = geometry.candidate_pairs(positions, box, COINCIDENT * diameters.min())  # sorted, i < j
    if len(pairs):
        i, j = pairs[0]
        raise InputError(f"packing file {where}: particles {i} and {j} (0-based, in the order read) have the same "
                         f"centre {positions[i].tolist()} (closer than {COINCIDENT:g} of the smallest diameter, "
                         f"across the periodic box): their contact normal is undefined; move or remove one")


def _check_gravity(gravity, walls, periodic: np.ndarray, where: str) -> None:
    """InputError naming ``where`` when ``gravity`` (D,) has another dimension than the packing or
    cannot be held (``walls.gravity_problem``)."""
    if gravity is not None and gravity.shape != periodic.shape:
        raise InputError(f"{where}: packing.gravity has {gravity.size} components, the packing is {periodic.size}D")
    problem = walling.gravity_problem(gravity, walls, periodic)
    if problem:
        raise InputError(f"{where}: {problem}")


def _finish(positions, diameters, box, rattler, masses, info: dict, where: str, box_name: str,
            check_equilibrium: bool, model: ContactModel, tangential=None, bridges=None, walled=None) -> Packing:
    """The checks every format shares (box > 2 max d, no two centres on one point, not all rattlers, equilibrium under
    ``model``'s normal law and lever with the stored ``tangential`` forces if any), then the Packing, which keeps
    ``model`` (``Packing.model``).  ``info`` of a DEM
    file holds its ``length_unit`` (then a contact file is what a frictional packing lacks)."""
    _check_box(box, diameters, where, box_name, () if walled is None else set(walled[0].axis.tolist()))
    _check_distinct(positions, diameters, box, where)
    if tangential is not None:
        info = {**info, "n_stored": len(tangential),
                "n_mobilised": int(stressed.mobilised(tangential, positions, diameters, _sides(box, positions.shape[1]),
                                                      model.law).sum())}
    packing = from_arrays(positions, diameters, box, rattler, info, masses, model, tangential, bridges)
    if walled is not None:  # (walls, wall contacts, gravity): docs/walls.md
        packing = mechanics.with_walls(packing, *walled)
    if packing.rattler.all():
        name = mechanics.NAMES[packing.dim]
        needed = mechanics.min_contacts(packing.dim)
        raise InputError(f"packing file {where}: no {name[:-1]} has {needed} or more contacts "
                         f"(not a jammed packing: all {name} are rattlers); a packing made with friction "
                         f"carries load on fewer contacts: give its stored tangential forces "
                         + ("with its contact file, packing.contacts" if info.get("length_unit") else
                            "in the file's 'tangential' group (the manual, docs/packing_files.md)"))
    if check_equilibrium:
        mechanics.require_equilibrium(packing, where)
    return packing


def _from_dem(path: str, fmt: str, check_equilibrium: bool, model: ContactModel, contacts: str | None = None,
              friction: float | None = None, contacts_format: str = "lammps-local", walls: list | None = None,
              wall_contacts: str | None = None, gravity: list | None = None) -> Packing:
    """A LAMMPS/LIGGGHTS/YADE file (``dem_formats``) in rotsound's units: lengths divided by the
    file's mean diameter (d0 = 1), positions taken from the box's lower corner (the cell's origin;
    a triclinic file's tilt gives the packing's ``geometry.Cell``, periodic along every axis); the file's
    masses kept as they are (``model.masses: density`` scales them to a mean of 1).  With a
    ``contacts`` file (``contact_files``), its stored tangential forces, divided by kn d0 of the
    file's units with kn = 1 there (LAMMPS units lj with kn = 1): by the length unit (harmonic)
    or its square (hertz, whose kn carries a length^1/2 more); a YADE or MercuryDPM file gives its
    kn itself (``contact_files.KN_FROM_FILE``).  ``walls``, ``wall_contacts``, ``gravity``: the
    scene's (``packing.walls`` ...; :func:`_dem_walls`)."""
    raw = dem_formats.read(path, fmt)
    if raw.box_lo is None:
        raise InputError(f"packing file {path}: the {raw.source} file records no periodic box; rotsound needs "
                         f"one (YADE: write it with SpherePack.save, or put its '##PERIODIC:: Lx Ly Lz' line "
                         f"in textExt's comment)")
    unit = float(raw.diameters.mean())
    info = {"source": f"{path} ({raw.source})", "length_unit": unit}
    positions, diameters = (raw.positions - raw.box_lo) / unit, raw.diameters / unit
    box = (raw.box_hi - raw.box_lo) / unit
    walled = _dem_walls(path, raw, positions, diameters, unit, model.law, walls, wall_contacts, gravity)
    walled_axes = () if walled is None else set(walled[0].axis.tolist())
    if raw.tilt is not None or walled_axes:  # no images across a wall
        periodic = np.ones(raw.dim, dtype=bool)
        periodic[list(walled_axes)] = False
        tilt = np.zeros(len(geometry.TILTS[raw.dim])) if raw.tilt is None else raw.tilt / unit
        box = geometry.Cell(box, tilt, periodic)
        problem = box.tilt_problem() if walled_axes else None  # no tilt may shear across a wall
        if problem is not None:
            raise InputError(f"packing file {path}: the triclinic box's {problem} (packing.walls or the file's f "
                             f"bounds); a tilt may shear only along periodic axes")
    stored = gap = None
    if contacts is not None:
        _check_box(box, diameters, path, "box", walled_axes)
        _check_distinct(positions, diameters, box, path)
        stored, gap = _stored_forces(contacts, raw, positions, diameters, box, model, friction, unit,
                                     contacts_format)
        info.update(contacts=contacts)
    return _finish(positions, diameters, box, None, raw.masses, info, path, "box", check_equilibrium, model, stored,
                   gap, walled)


def _dem_walls(path: str, raw: dem_formats.RawPacking, positions: np.ndarray, diameters: np.ndarray, unit: float,
               law: str, walls: list | None, wall_contacts: str | None, gravity: list | None) -> tuple | None:
    """(walls, wall contacts, gravity) of a DEM packing in rotsound's units (docs/walls.md), or None
    when it has none: the scene's ``walls`` (``packing.walls``: axis and position in the file's
    units and coordinates) on axes the file does not make periodic (a file that records no
    boundary, a LAMMPS data file: the axes the walls stand on), else a wall at each f bound of the
    file's boundary flags (``RawPacking.boundary``); the ``wall_contacts`` file's forces (ids
    mapped to particles, divided by kn d0 as the contact files' are), ``gravity`` divided likewise
    (force = mass g with the file's masses)."""
    dim = raw.dim
    flags = raw.boundary or ("pp",) * dim
    periodic = np.array([flag == "pp" for flag in flags])
    if walls is not None:
        axis = np.array([walling.AXES.index(w["axis"]) for w in walls], dtype=np.int64)
        position = np.array([w["position"] for w in walls], dtype=float)
        if raw.boundary is None:
            periodic[axis[axis < dim]] = False
    else:
        bounds = [(a, (raw.box_lo, raw.box_hi)[end][a]) for a in range(dim) for end, flag in enumerate(flags[a])
                  if flag == "f"]
        axis = np.array([a for a, _ in bounds], dtype=np.int64)
        position = np.array([p for _, p in bounds], dtype=float)
    if not axis.size and wall_contacts is None and gravity is None:
        return None
    in_file = walling.build(axis, position, raw.positions, raw.diameters, periodic,  # messages in the file's terms
                            f"packing file {path} (packing.walls)")
    built = walling.Walls(in_file.axis, (in_file.position - raw.box_lo[in_file.axis]) / unit, in_file.facing)
    _check_gravity(None if gravity is None else np.asarray(gravity, dtype=float), built, periodic,
                   f"packing file {path}")
    scale = unit if law == "harmonic" else unit ** 2  # kn d0 of the file's units (kn = 1 there)
    g = None if gravity is None else np.asarray(gravity, dtype=float) / scale
    stored = None
    if wall_contacts is not None:
        found = wall_files.read(wall_contacts)
        where = f"wall contact file {wall_contacts}"
        force = _in_plane(found.force / scale, dim, where)
        stored = walling.build_contacts(_indices(raw, found.ids, where), found.wall, force, positions, diameters, built,
                                        where)
    return built, stored, g


def _indices(raw: dem_formats.RawPacking, ids: np.ndarray, where: str) -> np.ndarray:
    """The particle indices (same shape) of the atom ``ids`` a file (``where``) names; InputError
    for an id the packing ``raw`` lacks."""
    at = np.minimum(np.searchsorted(raw.ids, ids), raw.ids.size - 1)
    missing = np.flatnonzero(raw.ids[at].ravel() != ids.ravel())
    if missing.size:
        raise InputError(f"{where}: atom id {ids.ravel()[missing[0]]} is not in the packing file ({raw.ids.size} "
                         f"atoms, ids {raw.ids.min()}..{raw.ids.max()}); the two files must describe the same packing")
    return at


def _in_plane(force: np.ndarray, dim: int, where: str) -> np.ndarray:
    """Forces (C, 3) as (C, dim): in 2D, InputError naming ``where`` unless every z component is
    round-off (1e-12 of the largest), then dropped."""
    if dim == 3:
        return force
    if np.any(np.abs(force[:, 2]) > 1e-12 * max(np.abs(force).max(), 1e-300)):
        raise InputError(f"{where}: a force has a z component, but the packing is 2D")
    return force[:, :2]


def _stored_forces(path: str, raw: dem_formats.RawPacking, positions: np.ndarray, diameters: np.ndarray,
                   box, model: ContactModel, friction: float | None, unit: float, fmt: str):
    """The contact file ``path`` (format ``fmt``) of the packing ``raw`` (``box``: its (D,) sides or
    its ``geometry.Cell``; the pairs' geometry is taken in it) as rotsound's stored
    tangential forces and, under ``model.cohesion``, the bridged pairs apart (LIGGGHTS's
    pair/gran/local lists every bridged pair, touching or not; None when dry)."""
    law = model.law
    found = contact_files.read(path, fmt)
    at = _indices(raw, found.ids, f"contact file {path}")
    if found.source in contact_files.KN_FROM_FILE:  # YADE, MercuryDPM: kn from the file's normal forces
        force = contact_files.KN_FROM_FILE[found.source](path, found, at, positions, diameters, box, unit, law)
    else:
        force = found.force / (unit if law == "harmonic" else unit ** 2)
    force = _in_plane(force, raw.dim, f"contact file {path}")
    gap = None
    if model.cohesion is not None:  # the listed pairs apart are bridged (checks: bridges.build)
        _, _, overlap = geometry.pair_geometry(positions, diameters, box, np.sort(at, axis=1))
        apart = overlap <= 0.0
        gap = bridging.build(at[apart], positions, diameters, box, model.cohesion, f"contact file {path}")
        # LIGGGHTS's tangential part of a pull along the centre line is round-off (measured 2e-17 on
        # bridges and contacts of a packing without a tangential spring): no stored force
        noise = np.linalg.norm(force, axis=1) <= stressed.NORMAL_PART_FLOOR
        force = np.where(noise[:, None], 0.0, force)
    return stressed.build(at, force, positions, diameters, box, law, friction, f"contact file {path}"), gap


def read_packings(paths: str | list[str], count: int | None = None, check_equilibrium: bool = True,
                  model: ContactModel = ContactModel(), fmt: str | None = None,
                  contacts: str | list[str] | None = None, friction: float | None = None,
                  contacts_format: str = "lammps-local", walls: list | None = None,
                  wall_contacts: str | list[str] | None = None, gravity: list | None = None) -> list[Packing]:
    """Read configurations from one or more packing files (first ``count``); each must be in
    equilibrium under its normal forces (and its stored tangential forces, if any) unless
    ``check_equilibrium`` is False (``packing.relax`` re-minimises it), under the contact
    ``model``'s normal law and lever (``ContactModel.at_rest``; each packing keeps it as
    ``Packing.model``);
    ``fmt`` is ``packing.format`` (None: each file's format is detected from its content);
    ``contacts`` (``packing.contacts``) one contact file per DEM packing file, whose stored
    tangential forces join it, ``friction`` the mu they were made with (or None),
    ``contacts_format`` their format; ``walls``, ``wall_contacts`` (one file per DEM packing file),
    ``gravity``: ``packing.walls``, ``packing.wall_contacts``, ``packing.gravity`` (docs/walls.md).
    rotsound's own files carry their stored forces, walls and gravity inside.  Not collective."""
    packings: list[Packing] = []
    paths = [paths] if isinstance(paths, str) else paths
    contacts = [contacts] if isinstance(contacts, str) else contacts
    wall_contacts = [wall_contacts] if isinstance(wall_contacts, str) else wall_contacts
    if wall_contacts is not None and len(wall_contacts) != len(paths):
        raise InputError(f"packing.wall_contacts: {len(wall_contacts)} wall contact file(s) for {len(paths)} packing "
                         f"file(s); give one per packing file, in the same order")
    if contacts is not None and len(contacts) != len(paths):
        raise InputError(f"packing.contacts: {len(contacts)} contact file(s) for {len(paths)} packing file(s); give "
                         f"one contact file per packing file, in the same order")
    for index, path in enumerate(paths):
        kind = fmt or dem_formats.detect_format(path)
        if kind != "rotsound" and model.cohesion is not None and (contacts is None or
                                                                   contacts_format != "liggghts-local"):
            raise InputError(f"packing file {path}: a {kind} file gives no bridged pairs apart, which model.cohesion "
                             f"needs (docs/capillary_bridges.md); give LIGGGHTS's contact file with it "
                             f"(packing.contacts, contacts_format: liggghts-local), or a wet packing in rotsound's "
                             f"HDF5 format")
        if kind != "rotsound":
            packings.append(_from_dem(path, kind, check_equilibrium, model, contacts[index] if contacts else None,
                                      friction, contacts_format, walls,
                                      wall_contacts[index] if wall_contacts else None, gravity))
            continue
        if walls is not None or wall_contacts is not None or gravity is not None:
            raise InputError(f"packing.walls, packing.wall_contacts, packing.gravity: {path} is a rotsound HDF5 packing "
                             f"file, which holds its walls and gravity itself (groups 'walls', 'wall_contacts', "
                             f"attribute gravity); these keys go with LAMMPS and LIGGGHTS packing files")
        if contacts is not None:
            raise InputError(f"packing.contacts: {path} is a rotsound HDF5 packing file, which holds its stored "
                             f"tangential forces itself (group 'tangential'); contact files go with LAMMPS, "
                             f"LIGGGHTS and YADE packing files")
        with _open(path) as f:
            if "positions" in f:
                packings.append(_read_one(f, path, check_equilibrium, model))
            elif "packings" in f and len(f["packings"]):
                for name in sorted(f["packings"]):
                    packings.append(_read_one(f["packings"][name], f"{path}:/packings/{name}", check_equilibrium,
                                              model))
            else:
                raise InputError(f"packing file {path}: no 'positions' dataset at the top level "
                                 f"and no '/packings/<i>' groups")
    other = next((i for i, p in enumerate(packings) if p.dim != packings[0].dim), None)
    if other is not None:  # one scene is one dimension: its matrices, waves and analysis assume it
        raise InputError(f"packing.file: the files mix disks (2D) and spheres (3D): configuration 0 has "
                         f"positions (N, {packings[0].dim}), configuration {other} (N, {packings[other].dim}); "
                         f"give the files of one dimension per scene")
    if count is not None:
        if count > len(packings):
            raise InputError(f"packing.count = {count}: the file(s) hold only {counted(len(packings), 'configuration')}")
        packings = packings[:count]
    return packings


def write_packing(group, packing: Packing) -> None:
    """Write one configuration into an open h5py group (file format above)."""
    group.create_dataset("positions", data=packing.positions)
    group.create_dataset("diameters", data=packing.diameters)
    group.create_dataset("rattler", data=packing.rattler)
    if packing.masses is not None:
        group.create_dataset("masses", data=packing.masses)
    group.attrs["box"] = packing.box
    if np.all(packing.box == packing.box[0]):
        group.attrs["box_length"] = packing.box[0]  # square or cubic: readers of the older layout go on
    if packing.tilt is not None:
        group.attrs["tilt"] = packing.tilt
    if packing.periodic is not None:
        group.attrs["periodic"] = packing.periodic
    group.attrs["phi"] = packing.phi
    for key, value in packing.info.items():
        group.attrs[key] = value
    if packing.tangential is not None:
        sub = group.create_group("tangential")
        sub.create_dataset("pairs", data=packing.tangential.pairs)
        sub.create_dataset("force", data=packing.tangential.force)
        if packing.tangential.friction is not None:
            sub.attrs["friction"] = packing.tangential.friction
    if packing.bridges is not None:
        group.create_dataset("bridges", data=packing.bridges.reshape(-1, 2).astype(np.int64))
    if packing.walls is not None:
        group.create_dataset("walls/axis", data=packing.walls.axis)
        group.create_dataset("walls/position", data=packing.walls.position)
    if packing.wall_contacts is not None:
        for key in ("particle", "wall", "force"):
            group.create_dataset(f"wall_contacts/{key}", data=getattr(packing.wall_contacts, key))
    if packing.gravity is not None:
        group.attrs["gravity"] = packing.gravity


def box_of(group, dim: int) -> np.ndarray:
    """The (``dim``,) box sides of a packing group written by rotsound (``box``, or ``box_length``
    in files written before rectangular boxes)."""
    return np.broadcast_to(group.attrs["box"] if "box" in group.attrs else group.attrs["box_length"],
                           (dim,)).astype(float)


def save_packings(path: str, packings: list[Packing]) -> None:
    """Write a stand-alone packing file with groups /packings/<i>. Not collective."""
    with h5py.File(path, "w") as f:
        for index, packing in enumerate(packings):
            write_packing(f.create_group(f"packings/{index:04d}"), packing)


@profiling.logged("rsWriteResults")
def write_results(path: str, provenance: dict, packings: list[Packing], units: dict) -> None:
    """Write the results file atomically (temporary file, then rename). Rank 0 only.

    ``units`` maps a group path to (datasets dict, attrs dict).  On any error the temporary
    file is removed and the error raised: nothing is left behind (the caller raises it on
    every rank).
    """
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    with atomic_write(path) as partial, h5py.File(partial, "w") as f:
        f.attrs["format_version"] = FORMAT_VERSION
        for key, value in provenance.items():
            f.attrs[key] = value if isinstance(value, (str, int, float)) else json.dumps(value)
        for index, packing in enumerate(packings):
            write_packing(f.create_group(f"packings/{index:04d}"), packing)
        for name, (datasets, attrs) in units.items():
            group = f.create_group(name)
            for key, value in datasets.items():
                group.create_dataset(key, data=value)
            for key, value in attrs.items():
                group.attrs[key] = value
