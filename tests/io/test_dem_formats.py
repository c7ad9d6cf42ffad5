"""DEM packing files made by LAMMPS, LIGGGHTS and YADE themselves (tests/data/dem/, see its
README.md) load with the numbers their input scripts asked for, and damaged copies of them are
refused with one message naming the file and what is wrong.  Reads committed files only: none of
the programs is needed."""

import pathlib
import re

import h5py
import numpy as np
import pytest
from conftest import REPO, assert_close

from solver.errors import InputError
from solver.io import dem_formats
from solver.packing import geometry

pytestmark = pytest.mark.serial_only  # file reading, no communicator: nothing to gain from a second rank

DATA = REPO / "tests" / "data" / "dem"


def normal_residual(p, yade_law: bool = False) -> tuple[float, float]:
    """(largest net force on a particle, mean contact force) from the harmonic normal forces
    alone, k * overlap along the centre line, minimum image in p's box; O(N^2), N <= 256.
    k = 1 (LAMMPS gran/hooke, LIGGGHTS hooke/stiffness), or with ``yade_law`` YADE FrictPhys's
    k = 2 E r_i r_j / (r_i + r_j) with E = 1 (E cancels in the ratio of the two)."""
    length = p.box_hi - p.box_lo
    dx = p.positions[:, None, :] - p.positions[None, :, :]
    dx -= length * np.round(dx / length)
    r = np.linalg.norm(dx, axis=2)
    np.fill_diagonal(r, np.inf)
    a = 0.5 * p.diameters
    force = np.clip(a[:, None] + a[None, :] - r, 0.0, None)
    if yade_law:
        force *= 2 * a[:, None] * a[None, :] / (a[:, None] + a[None, :])
    net = np.linalg.norm(((force / r)[:, :, None] * dx).sum(axis=1), axis=1)
    return float(net.max()), float(force[force > 0].mean())


def inside(p) -> bool:
    return bool(np.all(p.positions >= p.box_lo) and np.all(p.positions < p.box_hi))


def densities(p) -> np.ndarray:
    """The density each mass implies with LAMMPS's convention m = rho pi d^3 / 6."""
    return p.masses / (np.pi / 6.0 * p.diameters ** 3)


# --- the real files ----------------------------------------------------------------------------


def test_lammps_2d_data_and_dump_hold_the_packing_the_script_made():
    data = dem_formats.read_lammps_data(DATA / "lammps_2d.data")
    dump = dem_formats.read_lammps_dump(DATA / "lammps_2d.dump")
    for p, source in ((data, "lammps-data"), (dump, "lammps-dump")):
        assert p.source == source
        assert p.positions.shape == (128, 2), "every z is 0: a 2D packing"
        assert np.array_equal(p.ids, np.arange(1, 129))
        small = p.diameters == 0.8
        assert small.sum() == 64 and np.sum(p.diameters == 1.2) == 64, "64 + 64 bidisperse discs"
        # types 1 (d = 0.8) and 2 (d = 1.2) have densities 1.3 and 0.9, mass = rho pi d^3 / 6
        assert_close(densities(p), np.where(small, 1.3, 0.9), rtol=1e-15, what=f"{source} densities")
        assert_close(p.box_lo, np.array([-3.0, 1.25]), rtol=0.0, what="box_lo")
        assert_close(p.box_hi, np.array([9.5, 11.0]), rtol=0.0, what="box_hi")
        assert inside(p)
    # both hold round-trip (17-digit) numbers of the same state: the same doubles
    assert_close(dump.positions, data.positions, rtol=0.0, what="data vs dump positions")
    assert_close(dump.diameters, data.diameters, rtol=0.0, what="data vs dump diameters")
    # the data file's masses come from its densities: one rounding each way
    assert_close(dump.masses, data.masses, rtol=1e-15, what="data vs dump masses")


def test_lammps_3d_data_and_radius_dump_hold_the_polydisperse_packing():
    data = dem_formats.read_lammps_data(DATA / "lammps_3d.data")
    dump = dem_formats.read_lammps_dump(DATA / "lammps_3d.dump")  # radius column
    for p in (data, dump):
        assert p.positions.shape == (128, 3)
        assert np.all((p.diameters >= 0.8) & (p.diameters <= 1.2)), "0.8 + 0.4 random(0, 1)"
        assert len(np.unique(p.diameters)) == 128, "polydisperse"
        rho = densities(p)
        light = np.abs(rho - 0.6) < 1e-12
        assert light.sum() == 64, "64 atoms of type 2 (density 0.6)"
        assert_close(rho, np.where(light, 0.6, 1.7), rtol=1e-15, what="densities")
        assert_close(p.box_lo, np.array([-1.5, 2.0, 0.25]), rtol=0.0, what="box_lo")
        assert_close(p.box_hi, np.array([4.0, 6.6, 4.3]), rtol=0.0, what="box_hi")
        assert inside(p)
    assert_close(dump.positions, data.positions, rtol=0.0, what="data vs dump positions")
    assert_close(dump.diameters, data.diameters, rtol=0.0, what="2 * radius vs diameter")
    assert_close(dump.masses, data.masses, rtol=1e-15, what="data vs dump masses")


@pytest.mark.parametrize("name", ["lammps_2d.data", "lammps_3d.data", "liggghts_3d.data"])
def test_frictionless_packings_balance_on_normal_forces(name):
    """The README's claim: FIRE (LAMMPS) and damped dynamics (LIGGGHTS) left max|F| < 1e-12 kn d0."""
    residual, mean_force = normal_residual(dem_formats.read(DATA / name))
    assert residual < 1e-12 and mean_force > 1e-3, (residual, mean_force)


def test_frictional_packing_stands_only_on_its_tangential_forces():
    p = dem_formats.read(DATA / "lammps_3d_friction.data")
    assert p.positions.shape == (128, 3)
    residual, mean_force = normal_residual(p)
    assert residual > 0.5 * mean_force, (residual, mean_force)
    # LAMMPS's total forces and torques (normal + tangential) at the same state
    total = np.loadtxt(DATA / "lammps_3d_friction.forces", skiprows=9)
    assert np.abs(total[:, 1:]).max() < 1e-15
    # the .forces file is itself a real dump, without the columns a packing needs
    with pytest.raises(InputError, match=r"lammps_3d_friction\.forces: frame 0: the ATOMS columns "
                                         r"\(id fx fy fz tqx tqy tqz\) lack diameter or radius, x y z"):
        dem_formats.read(DATA / "lammps_3d_friction.forces")


TRICLINIC = {"lo": np.array([-1.5, 2.0, 0.25]), "hi": np.array([4.0, 6.6, 4.3]), "tilt": np.array([-1.3, 0.9, -0.8])}
"""lammps_triclinic.in's cell: region prism -1.5 4.0 2.0 6.6 0.25 4.3 -1.3 0.9 -0.8."""


def _triclinic_dump_text(keep=lambda names: names) -> str:
    """lammps_triclinic.dump's text with its ATOMS names passed through ``keep`` (a list -> a list)."""
    text = (DATA / "lammps_triclinic.dump").read_text()
    head, sep, rest = text.partition("ITEM: ATOMS ")
    names, _, rows = rest.partition("\n")
    return head + sep + " ".join(keep(names.split())) + "\n" + rows


@pytest.mark.parametrize("name", ["lammps_triclinic.data", "lammps_triclinic.dump", "liggghts_triclinic.data",
                                  "liggghts_triclinic.dump"])
def test_triclinic_files_hold_the_cell_the_script_made(name):
    """The data file's 'xy xz yz' line and the dump's bounding box (xlo_bound = xlo + min(0, xy, xz,
    xy + xz), ...) give the prism of the input script; LAMMPS placed every sphere inside it."""
    p = dem_formats.read(DATA / name)
    assert p.positions.shape == (128, 3) and np.array_equal(p.ids, np.arange(1, 129))
    # the dump's bounding box holds -2.8 = -1.5 + (-1.3) as the double nearest to it: one rounding of
    # O(4) numbers on the way back, 2 ulp
    assert_close(p.box_lo, TRICLINIC["lo"], rtol=0.0, atol=1e-15, what=f"{name} box_lo")
    assert_close(p.box_hi, TRICLINIC["hi"], rtol=0.0, atol=1e-15, what=f"{name} box_hi")
    assert_close(p.tilt, TRICLINIC["tilt"], rtol=0.0, what=f"{name} tilt")
    cell = geometry.Cell(p.box_hi - p.box_lo, p.tilt, np.ones(3, dtype=bool))
    fractional = cell.fractional(p.positions - p.box_lo)
    # LAMMPS keeps atoms in the cell (lo <= s < 1 after its last re-neighbouring); the LIGGGHTS dump's
    # %g moves a position by up to 5e-6 relative
    slack = 1e-5 if name == "liggghts_triclinic.dump" else 0.0
    assert np.all(fractional >= -slack) and np.all(fractional < 1.0 + slack), (fractional.min(), fractional.max())
    assert not np.all((p.positions >= p.box_lo) & (p.positions < p.box_hi)), "a tilted cell leaves its bounds"


def test_triclinic_data_dump_and_scaled_coordinates_agree(tmp_path):
    """The data file, the dump's x y z and its scaled xs ys zs (converted by lo + H s) and LIGGGHTS's
    files of the same state (read from LAMMPS's data file) give the same packing."""
    data = dem_formats.read(DATA / "lammps_triclinic.data")
    dump = dem_formats.read(DATA / "lammps_triclinic.dump")
    # both %.17g, but write_data (after the dump) remaps the atoms into the cell through fractional
    # coordinates (x -> lamda -> x): a few ulp of O(5) (measured 1.8e-15)
    assert_close(dump.positions, data.positions, rtol=0.0, atol=1e-14, what="dump vs data positions")
    assert_close(dump.diameters, data.diameters, rtol=0.0, what="dump vs data diameters")
    assert_close(dump.masses, data.masses, rtol=1e-15, what="data vs dump masses")
    scaled = _triclinic_dump_text(lambda names: [{"x": "ux", "y": "uy", "z": "uz"}.get(n, n) for n in names])
    path = tmp_path / "scaled.dump"
    path.write_text(scaled)
    from_s = dem_formats.read(path)
    # LAMMPS computes xs from x in double precision (H^-1 (x - lo)); back through lo + H s: a few ulp of O(5)
    assert_close(from_s.positions, data.positions, rtol=0.0, atol=1e-14, what="lo + H s vs x y z")
    liggghts_data = dem_formats.read(DATA / "liggghts_triclinic.data")  # %.16e, remapped once more: ulp
    assert_close(liggghts_data.positions, data.positions, rtol=0.0, atol=1e-14, what="LIGGGHTS data positions")
    assert_close(liggghts_data.tilt, data.tilt, rtol=0.0, what="LIGGGHTS data tilt")
    liggghts_dump = dem_formats.read(DATA / "liggghts_triclinic.dump")  # %g: six significant digits
    assert_close(liggghts_dump.positions, data.positions, rtol=5e-6, atol=1e-6, what="LIGGGHTS dump positions (%g)")
    assert_close(liggghts_dump.box_lo, data.box_lo, rtol=0.0, atol=1e-15, what="LIGGGHTS dump box_lo")
    assert_close(liggghts_dump.tilt, data.tilt, rtol=0.0, what="LIGGGHTS dump tilt")


def test_triclinic_contacts_are_lammps_contacts():
    """The contacts found in the tilted cell (positions from its origin) are, sphere by sphere, the
    ones LAMMPS counted (compute contact/atom, column c_touch); in the orthogonal box of the same
    sides they are not."""
    p = dem_formats.read(DATA / "lammps_triclinic.dump")
    touch = np.loadtxt(DATA / "lammps_triclinic.dump", skiprows=9, usecols=10)
    cell = geometry.Cell(p.box_hi - p.box_lo, p.tilt, np.ones(3, dtype=bool))
    found = geometry.find_contacts(p.positions - p.box_lo, p.diameters, cell)
    assert found.count_per_particle(p.diameters.size).sum() == touch.sum() == 944
    assert np.array_equal(found.count_per_particle(p.diameters.size), touch)
    orthogonal = geometry.find_contacts(p.positions - p.box_lo, p.diameters, p.box_hi - p.box_lo)
    assert not np.array_equal(orthogonal.count_per_particle(p.diameters.size), touch)


def _edit(tmp_path, name, old, new) -> pathlib.Path:
    path = tmp_path / name
    text = (DATA / name).read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize("name, old, new, problem", [
    ("lammps_triclinic.data", "-1.3 0.9 -0.8 xy xz yz", "-2.8 0.9 -0.8 xy xz yz",
     "tilt xy = -2.8 is beyond half the side L_x = 5.5"),
    ("lammps_triclinic.data", "-1.3 0.9 -0.8 xy xz yz", "-1.3 0.9 2.4 xy xz yz",
     "tilt yz = 2.4 is beyond half the side L_y = 4.6"),
    # xy = 2.9 with the same bounding box: xlo = -2.8, xhi = 4.9 - 3.8 = 1.1, L_x = 3.9
    ("lammps_triclinic.dump", "-2.7999999999999998e+00 4.9000000000000004e+00 -1.3000000000000000e+00",
     "-2.8 4.9 2.9", "tilt xy = 2.9 is beyond half the side L_x = 3.9"),
])
def test_tilt_beyond_half_a_side_is_refused(tmp_path, name, old, new, problem):
    path = _edit(tmp_path, name, old, new)
    with pytest.raises(InputError, match=re.escape(f"packing file {path}: the triclinic box's {problem}")):
        dem_formats.read(path)


def test_2d_tilt_xy_is_read_and_xz_yz_refused(tmp_path):
    """A 2D file's cell shears by xy alone; xz or yz (which shear along z) are refused."""
    path = _edit(tmp_path, "lammps_2d.data", "1.25 11 ylo yhi", "1.25 11 ylo yhi\n0.75 0 0 xy xz yz")
    p = dem_formats.read(path)
    assert p.dim == 2 and np.array_equal(p.tilt, [0.75])
    path = _edit(tmp_path, "lammps_2d.data", "1.25 11 ylo yhi", "1.25 11 ylo yhi\n0.75 0 0.5 xy xz yz")
    with pytest.raises(InputError, match=re.escape(f"packing file {path}: the packing is 2D (every z is 0) but the "
                                                   f"box's tilt xz = 0, yz = 0.5: in 2D only xy shears the cell")):
        dem_formats.read(path)


def test_general_triclinic_dump_is_refused(tmp_path):
    path = _edit(tmp_path, "lammps_triclinic.dump", "BOX BOUNDS xy xz yz pp pp pp", "BOX BOUNDS abc origin pp pp pp")
    with pytest.raises(InputError, match=re.escape(f"packing file {path}: frame 0: the box is LAMMPS's general "
                                                   f"triclinic cell")):
        dem_formats.read(path)


def test_liggghts_data_and_dump_hold_the_bidisperse_packing():
    data = dem_formats.read_lammps_data(DATA / "liggghts_3d.data")  # bare 'Atoms', no style comment
    dump = dem_formats.read_lammps_dump(DATA / "liggghts_3d.dump")  # radius, %g, unsorted, 19 columns
    for p in (data, dump):
        assert p.positions.shape == (128, 3)
        assert np.array_equal(p.ids, np.arange(1, 129))
        small = p.diameters == 0.9
        assert small.sum() == 64 and np.sum(p.diameters == 1.1) == 64, "radii 0.45 and 0.55, 64 each"
        assert_close(p.box_lo, np.array([-1.0, 0.5, -0.25]), rtol=0.0, what="box_lo")
        assert_close(p.box_hi, np.array([4.5, 5.3, 3.7]), rtol=0.0, what="box_hi")
        assert inside(p)
    assert_close(densities(data), np.where(data.diameters == 0.9, 1.4, 0.8), rtol=1e-15, what="densities")
    # the dump's %g keeps six significant digits: half a unit in the sixth is <= 5e-6 relative
    assert_close(dump.positions, data.positions, rtol=5e-6, what="data vs %g dump positions")
    assert_close(dump.masses, data.masses, rtol=5e-6, what="data vs %g dump masses")


def test_yade_exports_hold_the_periodic_packing_and_its_cell():
    text = dem_formats.read_yade_text(DATA / "yade_3d.txt")  # textExt, cell in its comment
    spheres = dem_formats.read_yade_text(DATA / "yade_3d.spheres")  # SpherePack.save
    for p in (text, spheres):
        assert p.source == "yade" and p.masses is None
        assert p.positions.shape == (128, 3)
        assert np.array_equal(p.ids, np.arange(128))
        assert np.all((p.diameters >= 0.8) & (p.diameters <= 1.2)), "radii 0.5 +- 20 %"
        assert_close(p.box_lo, np.zeros(3), rtol=0.0, what="YADE's cell starts at the origin")
        assert inside(p), "wrapped into the cell by the script"
    assert_close(text.box_hi, np.array([5.375053327142563, 4.777825179682304, 4.180597032221948]),
                 rtol=0.0, what="cell from textExt's comment, at full precision")
    # both writers print six significant digits: <= 5e-6 relative apart
    assert_close(spheres.box_hi, text.box_hi, rtol=5e-6, what="SpherePack's ##PERIODIC:: cell")
    assert_close(spheres.positions, text.positions, rtol=5e-6, what="textExt vs SpherePack positions")
    assert_close(spheres.diameters, text.diameters, rtol=5e-6, what="textExt vs SpherePack diameters")
    residual, mean_force = normal_residual(text, yade_law=True)
    assert residual < 0.02 * mean_force, "at rest but for the six-digit rounding"


@pytest.mark.parametrize("name, fmt", [
    ("lammps_2d.data", "lammps-data"), ("lammps_3d.dump", "lammps-dump"),
    ("liggghts_3d.data", "lammps-data"), ("liggghts_3d.dump", "lammps-dump"),
    ("yade_3d.txt", "yade"), ("yade_3d.spheres", "yade"),
])
def test_format_is_detected_from_the_content(tmp_path, name, fmt):
    blind = tmp_path / "packing.h5"  # a misleading extension: the content decides
    blind.write_bytes((DATA / name).read_bytes())
    assert dem_formats.detect_format(blind) == fmt
    assert dem_formats.read(blind).source == fmt


def test_hdf5_is_rotsound_and_not_read_here(tmp_path):
    path = tmp_path / "packing.data"
    with h5py.File(path, "w") as f:
        f["positions"] = np.zeros((2, 2))
    assert dem_formats.detect_format(path) == "rotsound"
    with pytest.raises(ValueError, match="rotsound HDF5"):
        dem_formats.read(path)


def test_a_dump_frame_is_chosen_by_index(tmp_path):
    path = tmp_path / "two.dump"
    path.write_text((DATA / "lammps_2d.dump").read_text() + (DATA / "lammps_3d.dump").read_text())
    assert dem_formats.read_lammps_dump(path).dim == 3, "the last frame by default"
    assert dem_formats.read_lammps_dump(path, frame=0).dim == 2
    with pytest.raises(InputError, match=r"frame 2 asked for, but the dump has 2 frame\(s\); "
                                         r"frame must be in \[-2, 1\]"):
        dem_formats.read_lammps_dump(path, frame=2)


def test_scaled_and_unwrapped_dump_columns_give_the_same_positions(tmp_path):
    """xs ys zs (scaled, x = lo + xs (hi - lo)) and xu yu zu (unwrapped) instead of x y z."""
    real = dem_formats.read_lammps_dump(DATA / "lammps_3d.dump")
    lines = (DATA / "lammps_3d.dump").read_text().split("\n")
    table = np.loadtxt(lines[9:9 + 128])
    table[:, 4:7] = (table[:, 4:7] - real.box_lo) / (real.box_hi - real.box_lo)
    scaled = tmp_path / "scaled.dump"
    scaled.write_text("\n".join(lines[:8] + ["ITEM: ATOMS id type radius mass xs ys zs"]
                                + [" ".join(f"{v:.17g}" for v in row) for row in table]) + "\n")
    # two roundings (to s and back), each within half an ulp of numbers below 10
    assert_close(dem_formats.read(scaled).positions, real.positions, rtol=0.0, atol=4e-15,
                 what="positions from scaled coordinates")
    unwrapped = tmp_path / "unwrapped.dump"
    unwrapped.write_text((DATA / "lammps_3d.dump").read_text().replace("mass x y z", "mass xu yu zu"))
    assert_close(dem_formats.read(unwrapped).positions, real.positions, rtol=0.0, what="xu yu zu")


def test_a_dump_density_column_gives_masses_and_no_column_none(tmp_path):
    """LIGGGHTS can dump density instead of mass: m = rho pi d^3 / 6 as LIGGGHTS computes it."""
    data = dem_formats.read_lammps_data(DATA / "liggghts_3d.data")
    lines = (DATA / "liggghts_3d.dump").read_text().split("\n")
    table = np.loadtxt(lines[9:9 + 128])
    table[:, -1] = np.where(table[:, -2] == 0.45, 1.4, 0.8)  # the templates' densities
    with_density = tmp_path / "density.dump"
    with_density.write_text("\n".join(lines[:8] + [lines[8].replace("radius mass", "radius density")]
                                     + [" ".join(f"{v:.17g}" for v in row) for row in table]) + "\n")
    assert_close(dem_formats.read(with_density).masses, data.masses, rtol=1e-15, what="masses from densities")
    bare = tmp_path / "bare.dump"
    bare.write_text("\n".join(lines[:8] + [lines[8].replace(" mass", "")]
                             + [" ".join(f"{v:.17g}" for v in row[:-1]) for row in table]) + "\n")
    assert dem_formats.read(bare).masses is None


# --- damaged copies ------------------------------------------------------------------------------


def _replace(old, new, count=1):
    def edit(text):
        assert old in text, old  # the damage must really be made
        return text.replace(old, new, count)
    return edit


def _cut(fraction):
    return lambda text: text[:int(len(text) * fraction)]


def _drop_last_column_of_line(index):
    def edit(text):
        lines = text.split("\n")
        lines[index] = lines[index].rsplit(maxsplit=1)[0]
        return "\n".join(lines)
    return edit


def _set_atom_value(index, column, value):
    def edit(text):
        lines = text.split("\n")
        words = lines[index].split()
        words[column] = value
        lines[index] = " ".join(words)
        return "\n".join(lines)
    return edit


# (case, real file, damage, reader or None for read() with detection, message pattern)
DAMAGED = [
    ("data: truncated in Atoms", "lammps_2d.data", _cut(0.3), None,
     r"the Atoms section has \d+ atom lines where the header says 128 atoms \(truncated or damaged file\)"),
    ("data: truncated in header", "lammps_2d.data", _cut(0.005), dem_formats.read_lammps_data,
     r"no 'N atoms' line in the header"),
    ("data: header promises more atoms", "lammps_3d.data", _replace("128 atoms", "129 atoms"), None,
     r"the Atoms section has 128 atom lines where the header says 129 atoms"),
    ("data: not atom_style sphere", "lammps_3d.data", _replace("Atoms # sphere", "Atoms # atomic"), None,
     r"atom_style atomic: only atom_style sphere is read \(Atoms columns id type diameter density x y z"),
    ("data: box line missing", "lammps_3d.data", _replace("2 6.6 ylo yhi\n", ""), None,
     r"the header has no 'ylo yhi' line\(s\); the box needs all three"),
    ("data: non-numeric value", "lammps_3d.data", _set_atom_value(12, 4, "1.2.3"), None,
     r"line 13 of the file, in the Atoms section, '1\.2\.3' is not a number; "
     r"each row must hold id type diameter density"),
    ("data: a column missing", "lammps_3d.data", _drop_last_column_of_line(14), None,
     r"line 15 of the file, in the Atoms section, has 9 values where the other lines have 10"),
    ("data: wrong column count", "liggghts_3d.data",
     lambda t: re.sub(r"^((?:\S+ ){8}\S+) \S+$", r"\1", t, flags=re.M), None,
     r"Atoms lines have 9 columns; atom_style sphere has 7 or 10"),
    ("data: zero diameter", "lammps_2d.data", _set_atom_value(11, 2, "0"), None,
     r"the Atoms section: 1 particle\(s\) have a non-positive diameter \(first: id \d+, diameter 0\); "
     r"diameters must be > 0"),
    ("data: negative density", "lammps_2d.data", _set_atom_value(11, 3, "-1.3"), None,
     r"the Atoms section: 1 atom\(s\) have a non-positive density \(first: id \d+\); densities must be > 0"),
    ("data: nan position", "lammps_2d.data", _set_atom_value(11, 5, "nan"), None,
     r"line 12 of the file, in the Atoms section, holds a non-finite value \(nan or inf\); values must be finite"),
    ("data: repeated id", "lammps_2d.data", _set_atom_value(12, 0, "24"), None,
     r"atom ids repeat; each atom must have its own id"),
    ("dump: truncated", "lammps_2d.dump", _cut(0.5), None,
     r"frame 0 has \d+ atom lines where 'ITEM: NUMBER OF ATOMS' says 128 \(truncated or damaged file\)"),
    ("dump: cut before its atoms", "lammps_2d.dump", _cut(0.02), None,
     r"frame 0 has no 'ITEM: ATOMS' line \(truncated file\?\)"),
    ("dump: no diameter or radius", "lammps_2d.dump", _replace("id type diameter mass", "id type size mass"), None,
     r"the ATOMS columns \(id type size mass x y z\) lack diameter or radius; "
     r"a packing dump needs id, diameter or radius, and x y z"),
    ("dump: no positions", "lammps_3d.dump", _replace("mass x y z", "mass x y q"), None,
     r"lack x y z"),
    ("dump: non-numeric value", "lammps_3d.dump", _set_atom_value(12, 4, "x1.5"), None,
     r"line 13 of the file, in frame 0's atom lines, 'x1\.5' is not a number; "
     r"each row must hold the 7 columns id type radius mass x y z"),
    ("dump: fewer values than names", "lammps_2d.dump", lambda t: re.sub(r" 0\n", "\n", t), None,
     r"atom lines have 6 columns but 'ITEM: ATOMS' names 7"),
    ("dump: negative radius", "lammps_3d.dump", _set_atom_value(9, 2, "-0.4"), None,
     r"frame 0's atom lines: 1 particle\(s\) have a non-positive diameter \(first: id 1, diameter -0.8\)"),
    ("dump: boundary flags not LAMMPS's", "liggghts_3d.dump", _replace("BOX BOUNDS pp pp pp", "BOX BOUNDS pp fp pp"),
     None, r"the boundary flags \('ITEM: BOX BOUNDS pp fp pp'\) must be three LAMMPS boundary styles: pp \(periodic\) "
           r"or two of f, s, m"),
    ("dump: atom count not a number", "lammps_2d.dump", _replace("ATOMS\n128", "ATOMS\n12a"), None,
     r"'ITEM: NUMBER OF ATOMS' must be followed by one positive whole number"),
    ("yade: unknown #format", "yade_3d.txt", _replace("#format x_y_z_r", "#format x_y_z_r_vel"), None,
     r"YADE text format 'x_y_z_r_vel' is not read; the formats read are x_y_z_r, x_y_z_r_matId"),
    ("yade: truncated mid-line", "yade_3d.txt", lambda t: t.rstrip().rsplit("\t", 1)[0], None,
     r"line 131 of the file, in the sphere lines, has 3 values where the other lines have 4; "
     r"each row must hold the columns of format x_y_z_r"),
    ("yade: radius missing", "yade_3d.spheres",
     lambda t: re.sub(r" -1\n", "\n", t).replace(" 0.599225\n", "\n", 1), None,
     r"line 2 of the file, in the sphere lines, has 3 values where the other lines have 4"),
    ("yade: non-numeric", "yade_3d.spheres", _replace("\n2.20953 ", "\n2,20953 "), None,
     r"line 2 of the file, in the sphere lines, '2,20953' is not a number; each row must hold x y z r \(and clumpId\)"),
    ("yade: zero radius", "yade_3d.txt", _replace("\t0.599225\n", "\t0\n"), None,
     r"the sphere lines: 1 particle\(s\) have a non-positive diameter \(first: id 0, diameter 0\)"),
    ("yade: bad cell line", "yade_3d.spheres",
     _replace("##PERIODIC:: 5.37505 4.77783 4.1806", "##PERIODIC:: 5.37505 4.77783"), None,
     r"the line '##PERIODIC:: 5.37505 4.77783' must give the periodic cell's three positive side lengths"),
    ("yade: comments only", "yade_3d.txt", lambda t: "\n".join(t.split("\n")[:3]), None,
     r"no sphere lines, only comments"),
    ("unknown text format", "lammps_2d.data", lambda t: "hello, world\nthis is no packing\n", None,
     r"unknown format; the formats read are rotsound \(HDF5\), lammps-data"),
    ("empty file", "lammps_2d.data", lambda t: "\n  \n", None, r"the file is empty"),
    ("empty file, reader named", "lammps_2d.dump", lambda t: "", dem_formats.read_lammps_dump, r"the file is empty"),
    ("a data file read as a dump", "lammps_2d.data", lambda t: t, dem_formats.read_lammps_dump,
     r"does not start with 'ITEM: TIMESTEP'"),
]


@pytest.mark.parametrize("case, name, damage, reader, message", DAMAGED, ids=[c[0] for c in DAMAGED])
def test_damaged_files_are_refused_with_one_clear_message(tmp_path, case, name, damage, reader, message):
    path = tmp_path / name
    path.write_text(damage((DATA / name).read_text()))
    with pytest.raises(InputError) as caught:
        (reader or dem_formats.read)(path)
    text = str(caught.value)
    assert text.startswith(f"packing file {path}: "), text
    assert re.search(message, text), text
    assert "\n" not in text, "one message, one line"


def test_missing_binary_and_unknown_format_names(tmp_path):
    with pytest.raises(InputError, match=re.escape(f"packing file {tmp_path / 'nope.data'}: not found")):
        dem_formats.read(tmp_path / "nope.data")
    garbage = tmp_path / "garbage.bin"
    garbage.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(InputError, match="unknown format: neither HDF5 nor text"):
        dem_formats.read(garbage)
    with pytest.raises(InputError, match=r"packing.format = 'xyz': not a known format; allowed: rotsound, "
                                         r"lammps-data, lammps-dump, yade"):
        dem_formats.read(DATA / "lammps_2d.data", fmt="xyz")


def test_a_yade_export_without_its_cell_has_no_box(tmp_path):
    path = tmp_path / "plain.txt"
    lines = (DATA / "yade_3d.txt").read_text().split("\n")
    path.write_text("\n".join([lines[0]] + lines[3:]))  # as export.text writes: no comment
    p = dem_formats.read(path)
    assert p.box_lo is None and p.box_hi is None and p.positions.shape == (128, 3)


def test_a_2d_dump_not_periodic_in_z_and_a_word_column_read_as_the_plain_dump(tmp_path):
    """A 2D dump as rotsound's export writes it ('pp pp ff', disks at z = 0) and with a column of
    words (LAMMPS's dump_modify element) reads as the committed plain dump does."""
    text = (DATA / "lammps_2d.dump").read_text().replace("BOX BOUNDS pp pp pp", "BOX BOUNDS pp pp ff")
    head, atoms = text.split("ITEM: ATOMS id type diameter mass x y z\n")
    rows = [line.split() for line in atoms.strip().split("\n")]
    named = "\n".join(" ".join([w[0], w[1], "large" if w[1] == "2" else "small", *w[2:]]) for w in rows)
    path = tmp_path / "named.dump"
    path.write_text(head + "ITEM: ATOMS id type element diameter mass x y z\n" + named + "\n")
    plain, named_read = dem_formats.read_lammps_dump(DATA / "lammps_2d.dump"), dem_formats.read_lammps_dump(path)
    assert named_read.positions.shape == (128, 2)
    for field in ("positions", "diameters", "masses", "box_lo", "box_hi", "ids"):
        assert np.array_equal(getattr(named_read, field), getattr(plain, field)), field
    assert named_read.boundary == ("pp", "pp") and plain.boundary == ("pp", "pp")


def test_a_3d_dump_with_f_bounds_keeps_its_boundary_flags(tmp_path):
    """'pp pp fm' (a wall at the lower z bound, docs/walls.md): read, with the flags kept per axis."""
    path = tmp_path / "walled.dump"
    path.write_text((DATA / "lammps_3d.dump").read_text().replace("BOX BOUNDS pp pp pp", "BOX BOUNDS pp pp fm"))
    walled, plain = dem_formats.read_lammps_dump(path), dem_formats.read_lammps_dump(DATA / "lammps_3d.dump")
    assert walled.boundary == ("pp", "pp", "fm") and plain.boundary == ("pp", "pp", "pp")
    assert np.array_equal(walled.positions, plain.positions)


@pytest.mark.parametrize("name", ["lammps_triclinic.dump", "liggghts_triclinic.data", "liggghts_triclinic.dump"])
def test_a_triclinic_packing_reads_at_rest_in_its_tilted_cell(name):
    """read_packings of LAMMPS's tilted packing: its cell (the file's tilt over the mean diameter), at
    rest under its harmonic forces in the tilted cell (the rest check passes; LAMMPS's FIRE left
    7.5e-14), the 472 contacts LAMMPS counted; the dump and LIGGGHTS's files of the same state give
    the same packing; the same positions in the orthogonal box of the same sides are far from rest."""
    import dataclasses

    from solver.io import hdf5
    from solver.packing import mechanics

    data = hdf5.read_packings(str(DATA / "lammps_triclinic.data"))[0]
    unit = dem_formats.read(DATA / "lammps_triclinic.data").diameters.mean()
    assert_close(data.tilt, TRICLINIC["tilt"] / unit, rtol=1e-15, what="tilt in d0")
    assert_close(data.box, (TRICLINIC["hi"] - TRICLINIC["lo"]) / unit, rtol=1e-15, what="sides in d0")
    assert data.periodic is None and data.cell.tilted
    fractional = data.cell.fractional(data.positions)
    assert np.all((fractional >= 0.0) & (fractional < 1.0)), "wrapped into the tilted cell"
    assert len(geometry.find_contacts(data.positions, data.diameters, data.cell)) == 472
    other = hdf5.read_packings(str(DATA / name))[0]
    # %.17g dump: write_data's remap, a few ulp; LIGGGHTS's %g dump: six digits of O(5) file lengths
    atol = 2e-5 if name == "liggghts_triclinic.dump" else 1e-14
    assert_close(other.tilt, data.tilt, rtol=1e-5 if name == "liggghts_triclinic.dump" else 1e-15, what="tilt")
    assert_close(other.positions, data.positions, rtol=0.0, atol=atol, what=f"{name} positions")
    assert np.array_equal(other.rattler, data.rattler)
    orthogonal = dataclasses.replace(data, tilt=None)
    with pytest.raises(InputError, match="not in mechanical equilibrium"):
        mechanics.require_equilibrium(orthogonal, "the positions in the orthogonal box")


def test_a_tilt_across_walls_is_refused(tmp_path):
    """A tilt shears only along periodic axes: a tilted dump with walls (f bounds) along z and a
    tilt xz, and the tilted data file with the scene's walls along z (packing.walls), are refused
    naming the file; the same dump with walls along z and a tilt xy alone is read."""
    from solver.io import hdf5

    path = _edit(tmp_path, "lammps_triclinic.dump", "BOX BOUNDS xy xz yz pp pp pp", "BOX BOUNDS xy xz yz pp pp ff")
    with pytest.raises(InputError, match=re.escape(f"packing file {path}: the triclinic box's tilt xz = 0.9 shears "
                                                   f"across axis z, which has walls")):
        dem_formats.read(path)
    data = DATA / "lammps_triclinic.data"
    with pytest.raises(InputError, match=re.escape(f"packing file {data}: the triclinic box's tilt xz = 0.902532 "
                                                   f"shears across axis z, which has walls")):
        hdf5.read_packings(str(data), walls=[{"axis": "z", "position": -50.0}])
    text = path.read_text().replace("2.5000000000000000e-01 4.2999999999999998e+00 -8.0000000000000004e-01",
                                    "2.5000000000000000e-01 4.2999999999999998e+00 0")
    lines = text.splitlines()
    lines[6] = lines[6].rsplit(" ", 1)[0] + " 0"  # xz = yz = 0: xy alone, across y, which is periodic
    path.write_text("\n".join(lines) + "\n")
    sheared = dem_formats.read(path)
    assert sheared.boundary == ("pp", "pp", "ff") and np.array_equal(sheared.tilt, [-1.3, 0.0, 0.0])
