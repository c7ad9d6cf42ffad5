"""``rotsound export``: a packing of a results file, and optionally one of its kept modes, as
files that OVITO and ParaView open.

Formats, each by the library made for it (or the format's own conventions), each field under the
name OVITO's reader of that format takes it for:
  extxyz       extended XYZ by ASE (``ase.io.write``): one file, one frame per phase, the cell as
               ``Lattice="ax ay az bx by bz cx cy cz"`` (its three edge vectors, :func:`cell_vectors`;
               ``pbc`` the cell's periodic axes, ``F`` along walls and along z in 2D: ``"T T F"``).  The first
               column is ``type``, ``small`` or ``large`` (instead of ASE's species "X"): OVITO
               reads a Particle Type of two named types, ASE a string array.
  vtp          VTK XML PolyData of vertex cells by VTK's ``vtkXMLPolyDataWriter``: one file per
               frame (``<stem>_<frame>.vtp`` when there are several, a series ParaView and OVITO
               open as one).  The one VTK format both read as particles: OVITO 3.17 reads legacy
               ``.vtk`` only as text meshes and has no ``.vtu`` reader (meshio's); hence the
               format's name ``vtp``, like the other two the name of the file format, and
               ``--format vtk`` is refused with that reason.  OVITO's reader takes neither
               compressed nor appended data nor a FieldData block: arrays are inline base64,
               uncompressed, and the mode's numbers stay out.  ``type`` is ``shapetype`` here
               (Aspherix's name, read by OVITO as Particle Type; ``type`` would be a "Material Type").
               The types' names are ``type_name``, a string array on the vertex cells (one per
               particle), which ParaView shows; OVITO's reader skips cell data (a string point array
               would stop it) and names VTP types only by Aspherix's shape files, so OVITO's two
               types stay unnamed.  A wet packing's bridges apart (``Packing.bridges``) are a
               contact network as Aspherix writes one, ``<stem>.bridges.vtp`` (``_<frame>`` before
               .vtp over frames): a line per bridge from the centre of i to that of j's periodic image
               nearest to i, cell arrays ``id1`` and ``id2`` (1-based particle ids) and ``gap`` (the
               packing's, d0).  No bridge files for a dry packing or one whose every bridge is a
               contact.  The cell is ``<stem>.cell.vtp``, its outline (the 12 edges of the
               parallelepiped, 2D: the 4 of the parallelogram) with the field data ``cell``, its edge
               vectors a, b, c as the rows of a 3 x 3 matrix (9 values; OVITO's particle reader stops
               at field data, hence a file of its own).  ``<stem>.vtm`` (``_<frame>`` before .vtm over
               frames), a VTK multiblock file, names the particles, the cell and the bridges; ParaView
               and OVITO open it as one (OVITO: the particles and a Lines object of particle-particle
               contacts; it skips the outline and has no cell from a vtp: extxyz and the dump give
               OVITO the cell).
  lammps-dump  LAMMPS's text dump (``ITEM: TIMESTEP``, ``ITEM: BOX BOUNDS pp pp pp``, in 2D ``pp pp
               ff``, open in z as the extxyz's pbc, ``ff`` along an axis with walls; a tilted cell's ``ITEM: BOX BOUNDS xy xz yz pp pp
               pp`` with LAMMPS's bounding box and the tilts, :func:`_box_bounds`, which rotsound's
               own dump reader reads back; ``ITEM: ATOMS id type element x y z ...``, the
               ``element`` column the types' names, as LAMMPS's ``dump_modify element`` writes them,
               which OVITO takes as its Particle Type names), written here (no maintained writer
               exists outside LAMMPS): one file, one timestep per frame.  OVITO's dump reader makes
               vectors and integers only of the columns of its standard properties (it reads any
               other column as a float scalar), so ``displacement`` is ``displacementx
               displacementy displacementz`` (OVITO: Displacement), ``contacts`` is
               ``coordination`` (Coordination, an integer) and ``rotation`` is the unit quaternion
               of the rotation vector theta, ``rotationx rotationy rotationz rotationw`` = (n
               sin(|theta|/2), cos(|theta|/2)), n = theta / |theta| (OVITO: Rotation; it has no
               property for a rotation vector); ``rattler`` is a float to OVITO.
The bridges go into the vtp alone: extended XYZ has no standard for pairs, and a dump holds atoms
only (LAMMPS writes pairs to a separate ``dump local``, which OVITO reads only through its Load
trajectory modifier).

Per-particle fields: ``type`` (1 small, 2 large: ``TYPE_NAMES``), ``radius`` and ``diameter`` (d0),
``rattler`` (0/1), ``contacts`` (contacts among non-rattlers), ``force_normal`` (the sum of |f_n|
over them under the scene's ``model.law``, kn d0) and, for a stressed packing, ``force_tangential``
(the sum of the stored |f_t|); with a mode also ``displacement`` and ``rotation`` (3-vectors: d0
and rad; in 2D z is 0 and the rotation is (0, 0, theta)), ``share`` (the particle's part of the
mode's kinetic energy, sums to 1) and ``rotational_share`` (the part of that in its rotations; 0
where the share is 0).  2D packings get z = 0 and a box of height 1 in z (edge c = (0, 0, 1)).  A mode is animated over
``frames`` phases of one period: frame f has positions r + a u cos(2 pi f / frames), a such that
the largest displacement is ``amplitude`` d0, so that frame 0 (the only one when ``frames`` is 1)
shows the largest displacement and ``frames`` frames make one whole period; rotation vectors are
scaled the same way.  The mode's omega, K, Q, K/Q and participation ratio, with rho, the packing
index and phi, go into the extxyz comment line (``Atoms.info``) and into :func:`describe` (the
command prints it); the VTP files and the dump carry the per-particle fields only, the dump's
TIMESTEP being the frame index.

No PETSc, no MPI; not collective.  Units: d0, rad, 1/t0.
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import InputError
from ..packing import geometry, mechanics
from . import hdf5, results
from .atomic import atomic_write

FORMATS = ("extxyz", "vtp", "lammps-dump")
TYPE_NAMES = ("small", "large")  # the names of types 1 and 2 (smaller and larger than the mean diameter)


def particle_fields(packing) -> dict[str, np.ndarray]:
    """The per-particle fields (N,) each of a ``Packing`` under its normal law (``packing.model``): type,
    radius, diameter, rattler, contacts, force_normal (the sum of |f_n| over its contacts, kn d0)
    and, for a stressed packing, force_tangential (the sum of its stored |f_t|)."""
    d, n = packing.diameters, packing.n
    found, f_n, f_t = mechanics.force_magnitudes(packing)
    fields = {"type": np.where(d > d.mean(), 2, 1), "radius": 0.5 * d, "diameter": d,
              "rattler": packing.rattler.astype(np.int64), "contacts": found.count_per_particle(n),
              "force_normal": np.bincount(found.i, f_n, n) + np.bincount(found.j, f_n, n)}
    if packing.tangential is not None:
        fields["force_tangential"] = np.bincount(found.i, f_t, n) + np.bincount(found.j, f_t, n)
    return fields


def bridges_of(packing) -> dict | None:
    """A wet packing's bridged pairs apart as the vtp export writes them: {"pairs": (B, 2) 0-based,
    "gap": (B,) d0, "cell": the packing's ``geometry.Cell``}; None for a dry packing or one whose every
    bridge is a contact."""
    if packing.bridges is None or len(packing.bridges) == 0:
        return None
    _, _, overlap = geometry.pair_geometry(packing.positions, packing.diameters, packing.cell, packing.bridges)
    return {"pairs": packing.bridges, "gap": -overlap, "cell": packing.cell}


def mode_fields(shapes: results.ModeShapes, m: int) -> dict[str, np.ndarray]:
    """Mode ``m``'s per-particle fields: displacement, rotation (N, 3), share, rotational_share (N,)."""
    n, dim = shapes.displacement.shape[1:]
    displacement = np.zeros((n, 3))
    displacement[:, :dim] = shapes.displacement[m]
    rotation = np.zeros((n, 3))
    if shapes.rotation is not None:
        rotation[:, 3 - shapes.rotation.shape[2]:] = shapes.rotation[m]  # 2D: the angle about z
    share, rotational = shapes.share[m, :, 0], shapes.share[m, :, 1]
    return {"displacement": displacement, "rotation": rotation, "share": share,
            "rotational_share": np.divide(rotational, share, out=np.zeros_like(share), where=share > 0)}


def _frames(positions3: np.ndarray, fields: dict, frames: int, amplitude: float) -> list[tuple[np.ndarray, dict]]:
    """[(positions (N, 3), fields)] per frame: the mode's displacement and rotation times
    cos(2 pi f / frames), scaled so that the largest displacement is ``amplitude`` (frame 0); the
    packing alone (one frame) without a mode."""
    if "displacement" not in fields:
        return [(positions3, fields)]
    largest = np.linalg.norm(fields["displacement"], axis=1).max()
    scale = amplitude / largest if largest > 0 else 0.0
    out = []
    for f in range(frames):
        phase = np.cos(2.0 * np.pi * f / frames)
        now = {**fields, "displacement": phase * scale * fields["displacement"],
               "rotation": phase * scale * fields["rotation"]}
        out.append((positions3 + now["displacement"], now))
    return out


def cell_vectors(cell: geometry.Cell) -> np.ndarray:
    """(3, 3) the cell's edge vectors a, b, c as rows (d0), what the exports write: ``cell.matrix``'s
    columns; a 2D cell padded with c = (0, 0, 1), the disks' plane inside a box of height 1."""
    vectors = np.eye(3)
    vectors[:cell.dim, :cell.dim] = cell.matrix.T
    return vectors


def _extxyz(path: str, vectors: np.ndarray, pbc, frames, info: dict) -> list[str]:
    import ase
    import ase.io

    atoms = []
    for positions, fields in frames:
        a = ase.Atoms(["X"] * len(positions), positions=positions, cell=vectors, pbc=pbc, info=dict(info))
        for name, value in fields.items():
            a.new_array(name, np.array(TYPE_NAMES)[value - 1] if name == "type" else np.asarray(value))
        atoms.append(a)
    # the type names as the first column, where ASE would put its species "X" and OVITO looks for types
    columns = ["type", "positions", *[name for name in frames[0][1] if name != "type"]]
    with atomic_write(path) as partial:
        ase.io.write(partial, atoms, format="extxyz", columns=columns)
    return [path]


def _polydata(positions: np.ndarray, cells: str, connectivity: np.ndarray):
    """A vtkPolyData of ``positions`` (P, 3) whose cells (``cells``: "verts" or "lines") are
    ``connectivity`` (C, k) point indices, k points each."""
    from vtkmodules.util import numpy_support
    from vtkmodules.vtkCommonCore import vtkPoints
    from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData

    data = vtkPolyData()
    points = vtkPoints()
    points.SetData(numpy_support.numpy_to_vtk(np.ascontiguousarray(positions, dtype=np.float64), deep=True))
    data.SetPoints(points)
    count, k = connectivity.shape
    array = vtkCellArray()
    array.SetData(numpy_support.numpy_to_vtkIdTypeArray(np.arange(0, k * count + 1, k, dtype=np.int64), deep=True),
                  numpy_support.numpy_to_vtkIdTypeArray(connectivity.astype(np.int64).ravel(), deep=True))
    if cells == "verts":
        data.SetVerts(array)
    else:
        data.SetLines(array)
    return data


def _add_arrays(attributes, arrays: dict) -> None:
    """Add ``arrays`` ({name: (C,) or (C, k)}) to VTK point or cell ``attributes``: integers as Int64,
    the rest as Float64 (OVITO reads no Int8/UInt8 arrays), strings as a vtkStringArray."""
    from vtkmodules.util import numpy_support
    from vtkmodules.vtkCommonCore import vtkStringArray

    for name, value in arrays.items():
        value = np.asarray(value)
        if value.dtype.kind == "U":
            array = vtkStringArray()
            for word in value:
                array.InsertNextValue(str(word))
        else:
            kind = np.int64 if value.dtype.kind in "iub" else np.float64
            array = numpy_support.numpy_to_vtk(np.ascontiguousarray(value, dtype=kind), deep=True)
        array.SetName(name)
        attributes.AddArray(array)


def _write_polydata(data, target: str) -> None:
    """Write ``data`` to ``target`` by VTK's XML writer, as OVITO's reader takes it."""
    from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

    writer = vtkXMLPolyDataWriter()
    writer.SetInputData(data)
    writer.SetDataModeToBinary()  # inline base64, uncompressed: what OVITO's reader takes
    writer.SetCompressorTypeToNone()
    with atomic_write(target) as partial:
        writer.SetFileName(partial)
        if writer.Write() != 1:
            raise OSError(f"VTK's vtkXMLPolyDataWriter failed on {partial}")


def _bundle(target: str, blocks: dict[str, str]) -> None:
    """A VTK multiblock index (.vtm) naming the files ``blocks`` ({block name: path in its folder})."""
    from xml.sax.saxutils import quoteattr

    sets = "".join(f'    <DataSet index="{k}" name={quoteattr(name)} file={quoteattr(os.path.basename(path))}/>\n'
                   for k, (name, path) in enumerate(blocks.items()))
    with atomic_write(target) as partial, open(partial, "w", encoding="utf-8") as out:
        out.write('<?xml version="1.0"?>\n<VTKFile type="vtkMultiBlockDataSet" version="1.0" '
                  f'byte_order="LittleEndian" header_type="UInt64">\n  <vtkMultiBlockDataSet>\n{sets}'
                  '  </vtkMultiBlockDataSet>\n</VTKFile>\n')


def _network(positions: np.ndarray, bridges: dict):
    """The bridges (:func:`bridges_of`) between particles at ``positions`` (N, 3) as Aspherix's
    contact network: two points per line, the centre of i and that of j's image nearest to i."""
    pairs, cell = bridges["pairs"], bridges["cell"]
    ends = positions[pairs[:, 1]] - positions[pairs[:, 0]]
    ends[:, :cell.dim] = geometry.minimum_image(ends[:, :cell.dim], cell)
    ends += positions[pairs[:, 0]]
    network = _polydata(np.stack((positions[pairs[:, 0]], ends), axis=1).reshape(-1, 3), "lines",
                        np.arange(2 * len(pairs)).reshape(-1, 2))
    _add_arrays(network.GetCellData(), {"id1": pairs[:, 0] + 1, "id2": pairs[:, 1] + 1, "gap": bridges["gap"]})
    return network


def _outline(vectors: np.ndarray, dim: int):
    """The cell of edge vectors ``vectors`` (rows, :func:`cell_vectors`) from the origin as a
    vtkPolyData of its edges (3D: the 12 of the parallelepiped; 2D: the 4 of the parallelogram at
    z = 0), its field data ``cell`` the matrix of the edge vectors as rows (1 tuple of 9: a, b, c)."""
    from vtkmodules.util import numpy_support

    steps = np.array(np.meshgrid(*[[0, 1]] * dim, indexing="ij")).reshape(dim, -1).T  # corners, fractional
    corners = steps @ vectors[:dim]
    edges = np.array([(a, b) for a in range(len(steps)) for b in range(a + 1, len(steps))
                      if np.abs(steps[a] - steps[b]).sum() == 1])
    outline = _polydata(corners, "lines", edges)
    matrix = numpy_support.numpy_to_vtk(vectors.reshape(1, 9).copy(), deep=True)
    matrix.SetName("cell")
    outline.GetFieldData().AddArray(matrix)
    return outline


def _vtp(path: str, frames, vectors: np.ndarray, dim: int, bridges: dict | None) -> list[str]:
    """The vtp files of ``frames`` (the module docstring), the cell of edge vectors ``vectors`` as
    ``<stem>.cell.vtp`` and each frame's .vtm bundle; with ``bridges`` ({"pairs": (B, 2), "gap":
    (B,), "cell": the packing's cell}, B > 0) also each frame's bridges, in its bundle."""
    stem = path[:-4]
    paths = [path] if len(frames) == 1 else [f"{stem}_{f:04d}.vtp" for f in range(len(frames))]
    outline = f"{stem}.cell.vtp"
    _write_polydata(_outline(vectors, dim), outline)
    lines, bundles = [], []
    for f, (target, (positions, fields)) in enumerate(zip(paths, frames)):
        # one vertex cell per particle: OVITO recognises particles by them
        cloud = _polydata(positions, "verts", np.arange(len(positions))[:, None])
        _add_arrays(cloud.GetPointData(), {("shapetype" if name == "type" else name): value
                                           for name, value in fields.items()})
        # the types' names on the vertex cells: ParaView shows them; OVITO skips cell data (a string
        # point array would stop its reader)
        _add_arrays(cloud.GetCellData(), {"type_name": np.array(TYPE_NAMES)[fields["type"] - 1]})
        _write_polydata(cloud, target)
        blocks = {"particles": target, "cell": outline}
        if bridges is not None:
            lines.append(f"{stem}.bridges{'' if len(frames) == 1 else f'_{f:04d}'}.vtp")
            _write_polydata(_network(positions, bridges), lines[-1])
            blocks["bridges"] = lines[-1]
        bundles.append(f"{target[:-4]}.vtm")
        _bundle(bundles[-1], blocks)
    return paths + [outline] + lines + bundles


def _quaternion(rotation: np.ndarray) -> np.ndarray:
    """Unit quaternions (N, 4), (x, y, z, w), of rotation vectors (N, 3) (rad): (n sin(|theta|/2),
    cos(|theta|/2)), n = theta / |theta|."""
    angle = np.linalg.norm(rotation, axis=1)
    # sin(|theta|/2) / |theta| = sinc(|theta| / 2 pi) / 2, finite at theta = 0
    return np.column_stack((0.5 * np.sinc(angle / (2.0 * np.pi))[:, None] * rotation, np.cos(0.5 * angle)))


_DUMP_NAMES = {"contacts": "coordination"}  # OVITO's integer Coordination


def _dump_columns(fields: dict) -> tuple[list[str], list[str], np.ndarray]:
    """LAMMPS dump column names, their printf formats (integers as integers) and their values
    (N, C) of ``fields`` but type, named for OVITO's dump reader (see the module docstring):
    vectors as name + x, y, z (w), the rotation as a quaternion, contacts as coordination."""
    names, formats, columns = [], [], []
    for name, value in fields.items():
        if name == "type":  # the dump's own second column
            continue
        value = _quaternion(value) if name == "rotation" else np.asarray(value)
        form = "%d" if value.dtype.kind in "iub" else "%.16e"
        if value.ndim == 2:
            names += [f"{name}{axis}" for axis in "xyzw"[:value.shape[1]]]
            columns += list(value.T)
            formats += [form] * value.shape[1]
        else:
            names.append(_DUMP_NAMES.get(name, name))
            columns.append(value)
            formats.append(form)
    return names, formats, np.stack(columns, axis=1).astype(float)


def _box_bounds(vectors: np.ndarray, dim: int, pbc: list[bool]) -> str:
    """The dump's ``ITEM: BOX BOUNDS`` line and its three lines of the cell of edge vectors
    ``vectors`` (rows, :func:`cell_vectors`) from the origin (2D: z from -1/2 to 1/2, the disks'
    plane inside the box, as LAMMPS's 2D boxes have it), each axis ``pp`` where ``pbc`` (3,) says
    periodic, else ``ff`` (2D: z; a walled axis): ``lo hi`` per axis, or for a tilted cell
    LAMMPS's ``xy xz yz`` form, the bounding box and the tilt on each line (xlo_bound = xlo +
    min(0, xy, xz, xy + xz), xhi_bound = xhi + max(0, xy, xz, xy + xz), ylo_bound = ylo + min(0,
    yz), yhi_bound = yhi + max(0, yz))."""
    lo = np.zeros(3)
    if dim == 2:
        lo[2] = -0.5 * vectors[2, 2]
    hi = lo + np.diag(vectors)
    flags = " ".join("pp" if periodic else "ff" for periodic in pbc)  # as the extxyz's pbc
    xy, xz, yz = vectors[1, 0], vectors[2, 0], vectors[2, 1]
    if xy == xz == yz == 0.0:
        return f"ITEM: BOX BOUNDS {flags}\n" + "".join(f"{lo[a]:.16e} {hi[a]:.16e}\n" for a in range(3))
    low = lo + [min(0.0, xy, xz, xy + xz), min(0.0, yz), 0.0]
    high = hi + [max(0.0, xy, xz, xy + xz), max(0.0, yz), 0.0]
    return f"ITEM: BOX BOUNDS xy xz yz {flags}\n" + "".join(
        f"{low[a]:.16e} {high[a]:.16e} {tilt:.16e}\n" for a, tilt in enumerate((xy, xz, yz)))


def _lammps_dump(path: str, vectors: np.ndarray, dim: int, pbc: list[bool], frames) -> list[str]:
    bounds = _box_bounds(vectors, dim, pbc)
    with atomic_write(path) as partial, open(partial, "w", encoding="ascii") as out:
        for step, (positions, fields) in enumerate(frames):
            names, formats, values = _dump_columns(fields)
            out.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{len(positions)}\n{bounds}")
            out.write("ITEM: ATOMS id type element x y z " + " ".join(names) + "\n")
            table = np.empty((len(positions), 6 + len(names)), dtype=object)
            table[:, 0] = np.arange(1, len(positions) + 1)
            table[:, 1] = fields["type"]
            table[:, 2] = np.array(TYPE_NAMES)[fields["type"] - 1]  # dump_modify element's names
            table[:, 3:6] = positions
            table[:, 6:] = values
            np.savetxt(out, table, fmt=["%d", "%d", "%s"] + ["%.16e"] * 3 + formats)
    return [path]


def describe(info: dict) -> str:
    """One line of what an export holds (``info`` as the extxyz comment line has it)."""
    text = f"packing {info['packing']} (phi = {info['phi']:.4f})"
    if "omega" in info:
        text += (f", mode {info['mode']} at rho = {info['rho']:g}: omega = {info['omega']:.6g}/t0, K/Q = "
                 f"{info['K_over_Q']:.4g}, participation = {info['participation']:.4f}")
    return text


def export(path: str, fmt: str, output: str, packing: int = 0, rho: float | None = None, mode: int | None = None,
           frames: int = 1, amplitude: float = 0.1) -> tuple[list[str], str]:
    """Write configuration ``packing`` of results file ``path`` in ``fmt`` (``FORMATS``) to
    ``output``; with ``mode`` (an index among the modes kept for ``packing`` at ``rho``; rho may be
    omitted when one rho has modes) that mode too, over ``frames`` phases.  Returns the paths
    written and :func:`describe`'s line.  InputError, naming the file or option, for an unknown
    format, a vtp ``output`` not ending in .vtp, a missing packing, rho or mode, or a folder that
    cannot take the files."""
    if fmt not in FORMATS:
        legacy = " (legacy .vtk, which OVITO cannot read, became vtp: VTK's XML PolyData)" if fmt == "vtk" else ""
        raise InputError(f"export --format {fmt}: must be one of {', '.join(FORMATS)}{legacy}")
    if fmt == "vtp" and not output.endswith(".vtp"):
        raise InputError(f"export --output {output}: a vtp export's name ends in .vtp (ParaView picks its reader "
                         f"by the extension)")
    if frames < 1 or not 0.0 < amplitude < 10.0:
        raise InputError(f"export: --frames must be >= 1 and --amplitude in (0, 10) d0 (got {frames}, {amplitude})")
    with results.open_results(path) as f:
        results.packing(f, packing)  # InputError if there is no such configuration
        groups = [g for g in results.mode_shapes(f) if g.packing == packing]
        model = results.contact_model(f)
    config = hdf5.read_packings(path, count=packing + 1, check_equilibrium=False, model=model)[packing]
    fields = particle_fields(config)
    info = {"packing": packing, "phi": config.phi, "source": os.path.basename(path)}
    if mode is not None:
        rhos = sorted({g.rho for g in groups})
        if not rhos:
            raise InputError(f"results file {path}: no modes kept for packing {packing} (the scene needs a modes "
                             f"section); export without --mode writes the packing alone")
        if rho is None and len(rhos) > 1:
            raise InputError(f"export: results file {path} has modes at rho = {', '.join(f'{r:g}' for r in rhos)}: "
                             f"choose one with --rho")
        chosen = [g for g in groups if rho is None or np.isclose(g.rho, rho, rtol=1e-12, atol=0.0)]
        if not chosen:
            raise InputError(f"export --rho {rho:g}: results file {path} has modes at rho = "
                             f"{', '.join(f'{r:g}' for r in rhos)} only")
        shapes = chosen[0]
        if not 0 <= mode < shapes.omega.size:
            raise InputError(f"export --mode {mode}: packing {packing} at rho = {shapes.rho:g} has modes 0 to "
                             f"{shapes.omega.size - 1} (omega = {', '.join(f'{w:.4g}' for w in shapes.omega)})")
        fields.update(mode_fields(shapes, mode))
        ratio = shapes.K[mode] / shapes.Q[mode] if shapes.Q[mode] > 0 else np.inf
        info.update(rho=shapes.rho, mode=mode, omega=float(shapes.omega[mode]), K=float(shapes.K[mode]),
                    Q=float(shapes.Q[mode]), K_over_Q=float(ratio), participation=float(shapes.participation[mode]))
    positions, dim = config.positions, config.dim
    positions3 = np.zeros((len(positions), 3))
    positions3[:, :dim] = positions
    vectors = cell_vectors(config.cell)
    pbc = [bool(periodic) for periodic in config.cell.periodic] + [False] * (3 - dim)  # walls and 2D's z: open
    steps = _frames(positions3, fields, frames if mode is not None else 1, amplitude)
    try:
        os.makedirs(os.path.dirname(os.path.abspath(output)), exist_ok=True)
        if fmt == "extxyz":
            written = _extxyz(output, vectors, pbc, steps, info)
        elif fmt == "vtp":
            written = _vtp(output, steps, vectors, dim, bridges_of(config))
        else:
            written = _lammps_dump(output, vectors, dim, pbc, steps)
    except OSError as exc:
        raise InputError(f"export --output {output}: cannot write ({exc})") from None
    return written, describe(info)
