"""Contact files (``packing.contacts``, solver/io/contact_files.py): frictional packings written
by LAMMPS itself with their stored tangential forces (tests/data/dem/README.md) load as stressed
packings at rest, and damaged or inconsistent contact files get one clear error."""

import numpy as np
import pytest
from conftest import REPO, assert_close

from solver.contact_law import ContactModel
from solver.errors import InputError
from solver.io import contact_files, hdf5
from solver.packing import mechanics

pytestmark = pytest.mark.serial_only  # file reading: nothing to gain from a second rank

DATA = REPO / "tests" / "data" / "dem"
LEVER_CONTACT = ContactModel(lever="contact")  # LIGGGHTS's and YADE's lever (model.lever: contact)
STRESSED = [("lammps_2d_friction", "harmonic", 2), ("lammps_3d_hooke", "harmonic", 3),
            ("lammps_3d_hertz", "hertz", 3)]


@pytest.mark.parametrize("name, law, dim", STRESSED)
def test_lammps_frictional_packings_load_at_rest_with_their_contacts(name, law, dim):
    p = hdf5.read_packings(str(DATA / f"{name}.data"), model=ContactModel(law=law), contacts=str(DATA / f"{name}.contacts"))[0]
    assert p.dim == dim and p.stressed and p.info["n_stored"] > 0
    net, torque = mechanics.net_load(p)
    active = ~p.rattler
    # LAMMPS's own residuals at rest are below 1e-12 (README of tests/data/dem); the file's 17 digits keep them
    assert np.abs(net[active]).max() < 1e-10 and np.abs(torque[active]).max() < 1e-10
    with pytest.raises(InputError, match="packing.contacts"):  # without its contacts: refused, naming the key
        hdf5.read_packings(str(DATA / f"{name}.data"), model=ContactModel(law=law))


def test_reader_takes_the_first_six_columns_of_the_last_frame(tmp_path):
    text = (DATA / "lammps_2d_friction.contacts").read_text()
    raw = contact_files.read(DATA / "lammps_2d_friction.contacts")
    extra = tmp_path / "extra.contacts"  # two frames, the second with an extra column: the last is read
    lines = text.splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ENTRIES"))
    second = lines[:head] + [lines[head] + " c_more"] + [line + " 7.5" for line in lines[head + 1:]]
    first = lines[:head + 2]
    first[3] = "1"  # ITEM: NUMBER OF ENTRIES of a one-entry first frame
    extra.write_text("\n".join(first + second) + "\n")
    again = contact_files.read(extra)
    assert np.array_equal(raw.ids, again.ids) and np.array_equal(raw.force, again.force)


def _damaged(tmp_path, how):
    """The 2D contact file, damaged ``how``."""
    lines = (DATA / "lammps_2d_friction.contacts").read_text().splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ENTRIES"))
    row = lines[head + 1].split()
    if how == "truncated":
        lines = lines[:-3]
    elif how == "unknown id":
        row[1] = "99999"
        lines[head + 1] = " ".join(row)
    elif how == "normal part":
        row[3], row[4] = str(float(row[3]) + 0.01), str(float(row[4]) + 0.01)
        lines[head + 1] = " ".join(row)
    elif how == "columns":
        lines[head + 1:] = [" ".join(line.split()[:5]) for line in lines[head + 1:]]
    elif how == "not a dump local":
        lines[head] = lines[head].replace("ENTRIES", "ATOMS")
    path = tmp_path / f"{how.replace(' ', '_')}.contacts"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("how, match", [
    ("truncated", "entry lines where 'ITEM: NUMBER OF ENTRIES' says"),
    ("unknown id", "atom id 99999 is not in the packing file"),
    ("normal part", "is not tangential"),
    ("columns", "a contact file needs at least 6"),
    ("not a dump local", "unknown format"),
])
def test_damaged_contact_files_are_refused_naming_the_file(tmp_path, how, match):
    path = _damaged(tmp_path, how)
    with pytest.raises(InputError, match=match) as caught:
        hdf5.read_packings(str(DATA / "lammps_2d_friction.data"), contacts=str(path))
    assert str(path) in str(caught.value)


def test_a_listed_pair_that_does_not_touch_but_carries_a_force_is_refused(tmp_path):
    from solver.io import dem_formats
    from solver.packing import geometry

    raw = dem_formats.read(DATA / "lammps_2d_friction.data")
    found = geometry.find_contacts(raw.positions - raw.box_lo, raw.diameters, raw.box_hi - raw.box_lo)
    touching = set(zip(found.i.tolist(), found.j.tolist()))
    i, j = next((i, j) for i in range(raw.ids.size) for j in range(i + 1, raw.ids.size) if (i, j) not in touching)
    lines = (DATA / "lammps_2d_friction.contacts").read_text().splitlines()
    head = next(k for k, line in enumerate(lines) if line.startswith("ITEM: ENTRIES"))
    row = lines[head + 1].split()
    row[1], row[2] = str(raw.ids[i]), str(raw.ids[j])
    lines[head + 1] = " ".join(row)
    path = tmp_path / "apart.contacts"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match="carry a force but do not touch"):
        hdf5.read_packings(str(DATA / "lammps_2d_friction.data"), contacts=str(path))


def test_a_force_above_the_coulomb_limit_is_refused_when_mu_is_given():
    p = hdf5.read_packings(str(DATA / "lammps_2d_friction.data"), contacts=str(DATA / "lammps_2d_friction.contacts"))[0]
    from solver import contact_law
    from solver.packing import geometry

    found = geometry.find_contacts(p.positions, p.diameters, p.box)
    ratio = np.linalg.norm(p.tangential.on(found.i, found.j), axis=1) / contact_law.normal_force(found.overlap)
    below = 0.9 * ratio.max()  # a mu below the largest |f_t| / f_n the file holds
    with pytest.raises(InputError, match="above the Coulomb limit"):
        hdf5.read_packings(str(DATA / "lammps_2d_friction.data"), contacts=str(DATA / "lammps_2d_friction.contacts"),
                           friction=below)
    hdf5.read_packings(str(DATA / "lammps_2d_friction.data"), contacts=str(DATA / "lammps_2d_friction.contacts"),
                       friction=ratio.max() * 1.01)  # the true mu (1) and any mu above the largest ratio pass


def test_a_liggghts_frictional_packing_loads_with_the_contact_point_lever():
    """LIGGGHTS's packing (compute pair/gran/local pos id force force_tangential) balances its
    forces and torques with the lever R - xi/2 it integrates with (1e-14), not with LAMMPS's R
    (a torque of 5.8e-4 is left, refused naming model.lever); read as a LAMMPS file, its position
    columns are refused as ids."""
    data, contacts = str(DATA / "liggghts_3d_friction.data"), str(DATA / "liggghts_3d_friction.contacts")
    p = hdf5.read_packings(data, contacts=contacts, contacts_format="liggghts-local", model=LEVER_CONTACT,
                           friction=0.5)[0]
    net, torque = mechanics.net_load(p)
    active = ~p.rattler
    assert p.stressed and p.info["n_stored"] == 382
    assert np.abs(net[active]).max() < 1e-12 and np.abs(torque[active]).max() < 1e-12
    with pytest.raises(InputError, match="model.lever"):
        hdf5.read_packings(data, contacts=contacts, contacts_format="liggghts-local")
    with pytest.raises(InputError, match="id columns must hold whole numbers"):
        hdf5.read_packings(data, contacts=contacts)


def test_a_liggghts_contact_file_with_other_keywords_is_refused(tmp_path):
    lines = (DATA / "liggghts_3d_friction.contacts").read_text().splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ENTRIES")) + 1
    path = tmp_path / "narrow.contacts"
    path.write_text("\n".join(lines[:head] + [" ".join(line.split()[:13]) for line in lines[head:]]) + "\n")
    with pytest.raises(InputError, match="16 columns"):
        contact_files.read(path, "liggghts-local")


YADE = (str(DATA / "yade_3d_friction_uniform.spheres"), str(DATA / "yade_3d_friction_uniform.contacts"))


def test_a_yade_frictional_packing_loads_with_its_kn_from_the_file():
    """YADE's packing made with one kn (a FrictMat per sphere, E R the same) loads at rest: kn =
    5e4 is read from its normal forces, the shear forces (on id2 in YADE) turn to act on id1, and
    the torques balance with YADE's lever R - xi/2 to round-off. The net force keeps the normal
    part of YADE's shear forces (up to 1.3e-4 of them, README of tests/data/dem), projected away:
    below 1e-7 kn d0 where the mean |f_t| is 1.4e-3."""
    p = hdf5.read_packings(YADE[0], contacts=YADE[1], contacts_format="yade", model=LEVER_CONTACT, friction=0.5)[0]
    assert p.stressed and p.info["n_stored"] == 305 and int(p.rattler.sum()) == 6
    net, torque = mechanics.net_load(p)
    active = ~p.rattler
    assert np.abs(net[active]).max() < 1e-7 and np.abs(torque[active]).max() < 1e-12
    mean_ft = np.linalg.norm(p.tangential.force, axis=1).mean()
    raw = contact_files.read(YADE[1], "yade")
    # the file's mean |shearForce| over kn d0 (kn = 5e4 by construction, d0 = the mean diameter)
    expected = np.linalg.norm(raw.force, axis=1).mean() / (5e4 * p.info["length_unit"])
    assert abs(mean_ft / expected - 1) < 1e-6, (mean_ft, expected)
    with pytest.raises(InputError, match="packing.contacts"):
        hdf5.read_packings(YADE[0])


def test_a_yade_packing_with_many_kn_is_refused():
    """One material for all radii (YADE's usual) gives kn = 2 E R1 R2 / (R1 + R2), 4.2e4 to 6.0e4:
    refused, saying how to make one rotsound reads."""
    with pytest.raises(InputError, match=r"kn = \|normalForce\| / overlap differs between contacts \(42222.1 to 59534"):
        hdf5.read_packings(str(DATA / "yade_3d_friction.spheres"), contacts=str(DATA / "yade_3d_friction.contacts"),
                           contacts_format="yade", model=LEVER_CONTACT)


def _damaged_yade(tmp_path, how):
    lines = (DATA / "yade_3d_friction_uniform.contacts").read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    row = lines[first].split()
    if how == "columns":
        lines[first:] = [" ".join(line.split()[:7]) for line in lines[first:]]
    elif how == "negative id":
        row[0] = "-1"
    elif how == "tilted normal":
        row[5] = str(float(row[5]) + 1.0)
    elif how == "shear normal part":  # add 1 % of |f_n| along the normal to the shear force
        row[2:5] = [str(float(s) + 0.01 * float(n)) for s, n in zip(row[2:5], row[5:8])]
    if how in ("negative id", "tilted normal", "shear normal part"):
        lines[first] = " ".join(row)
    path = tmp_path / f"{how.replace(' ', '_')}.contacts"
    path.write_text("\n".join(lines) + "\n")
    return str(path)


@pytest.mark.parametrize("how, message", [
    ("columns", "interaction lines have 7 columns; packing.contacts_format yade reads 8"),
    ("negative id", "the id columns must hold whole numbers >= 0"),
    ("tilted normal", "is not along their centre line"),
    ("shear normal part", "has a part along the contact normal of"),
])
def test_damaged_yade_contact_files_are_refused(tmp_path, how, message):
    with pytest.raises(InputError, match=message):
        hdf5.read_packings(YADE[0], contacts=_damaged_yade(tmp_path, how), contacts_format="yade", model=LEVER_CONTACT)


def test_yade_contact_files_are_not_dump_locals_and_are_linear():
    with pytest.raises(InputError, match="is a LAMMPS/LIGGGHTS dump"):
        contact_files.read(DATA / "lammps_3d_hooke.contacts", "yade")
    with pytest.raises(InputError, match="no 'ITEM: ENTRIES' line"):
        contact_files.read(YADE[1], "lammps-local")
    with pytest.raises(InputError, match="model.law: harmonic"):
        hdf5.read_packings(YADE[0], contacts=YADE[1], contacts_format="yade", model=ContactModel(law="hertz", lever="contact"))


def test_the_coulomb_check_allows_the_noise_of_a_dem_code_at_rest():
    """LAMMPS caps |f_t| by mu times its normal force with damping, at the last step's positions:
    at rest that can exceed mu f_n (of the positions) by ~1e-12 kn d0, relatively large on a contact
    of tiny overlap. The check allows 1e-9 relative plus 1e-10 kn d0 (stressed.COULOMB_FLOOR), and no
    more."""
    from solver import contact_law
    from solver.packing import geometry, stressed

    p = hdf5.read_packings(str(DATA / "lammps_2d_friction.data"), contacts=str(DATA / "lammps_2d_friction.contacts"))[0]
    pairs, force = p.tangential.pairs, p.tangential.force.copy()
    _, _, overlap = geometry.pair_geometry(p.positions, p.diameters, p.box, pairs)
    fn = contact_law.normal_force(overlap)
    k = int(np.argmin(fn))  # the contact of smallest overlap, brought to mu f_n with mu = 0.5
    direction = force[k] / np.linalg.norm(force[k])
    for extra, refused in ((0.5e-10, False), (2e-10, True)):
        trial = force.copy()
        trial[k] = (0.5 * fn[k] + extra) * direction
        scaled = np.linalg.norm(trial, axis=1) > 0.5 * fn  # the others below the cone
        trial[scaled & (np.arange(len(fn)) != k)] *= 0.1
        if refused:
            with pytest.raises(InputError, match="above the Coulomb limit"):
                stressed.build(pairs, trial, p.positions, p.diameters, p.box, "harmonic", 0.5, "test")
        else:
            stressed.build(pairs, trial, p.positions, p.diameters, p.box, "harmonic", 0.5, "test")



def test_a_packing_engine_puts_forces_within_its_rest_tolerance_back_on_the_cone():
    """LAMMPS's own frictional packing at force_tol 1e-9 left |f_t| 1.1e-10 kn d0 above mu f_n (the
    finite-amplitude scene): the engine passes its rest tolerance as ``cap``, and a force that far
    above the cone is put back on it, exactly, so that the packing reads back under the file check
    and counts as mobilised; one further above is refused as before."""
    from solver import contact_law
    from solver.packing import geometry, stressed

    p = hdf5.read_packings(str(DATA / "lammps_2d_friction.data"), contacts=str(DATA / "lammps_2d_friction.contacts"))[0]
    pairs, force = p.tangential.pairs, p.tangential.force.copy()
    _, _, overlap = geometry.pair_geometry(p.positions, p.diameters, p.box, pairs)
    fn = contact_law.normal_force(overlap)
    k = int(np.argmin(fn))
    direction = force[k] / np.linalg.norm(force[k])
    trial = force.copy()
    trial[np.linalg.norm(trial, axis=1) > 0.5 * fn] *= 0.1  # every other contact below the cone of mu = 0.5
    trial[k] = (0.5 * fn[k] + 8e-10) * direction
    with pytest.raises(InputError, match="above the Coulomb limit"):
        stressed.build(pairs, trial, p.positions, p.diameters, p.box, "harmonic", 0.5, "test")
    capped = stressed.build(pairs, trial, p.positions, p.diameters, p.box, "harmonic", 0.5, "test", cap=1e-9)
    assert_close(np.linalg.norm(capped.force[k]), 0.5 * fn[k], rtol=1e-15, what="|f_t| put back on the cone")
    assert_close(capped.force[k] / np.linalg.norm(capped.force[k]), direction, rtol=1e-14, atol=1e-15,
                 what="its direction kept (atol: components of a unit vector)")
    on_cone = trial.copy()
    on_cone[k] = 0.5 * fn[k] * direction
    reference = stressed.build(pairs, on_cone, p.positions, p.diameters, p.box, "harmonic", 0.5, "test")
    others = np.arange(len(fn)) != k
    assert np.array_equal(capped.force[others], reference.force[others]), "forces below the cone changed"
    again = stressed.build(capped.pairs, capped.force, p.positions, p.diameters, p.box, "harmonic", 0.5, "re-read")
    assert stressed.at_limit(again.force, again.pairs, overlap, p.diameters, "harmonic", 0.5)[k]
    trial[k] = (0.5 * fn[k] + 3e-9) * direction
    with pytest.raises(InputError, match="above the Coulomb limit"):
        stressed.build(pairs, trial, p.positions, p.diameters, p.box, "harmonic", 0.5, "test", cap=1e-9)

def test_the_normal_part_check_allows_round_off_on_a_vanishing_force():
    """A stored force of 1e-13 kn d0 (LAMMPS left one on a contact of overlap 1e-12) may carry a
    normal part of 1e-6 of itself plus 1e-14 kn d0 (stressed.NORMAL_PART_FLOOR); a force of 1e-3
    with a normal part of 1e-5 of it is refused."""
    from solver.packing import geometry, stressed

    p = hdf5.read_packings(str(DATA / "lammps_2d_friction.data"), contacts=str(DATA / "lammps_2d_friction.contacts"))[0]
    pairs, force = p.tangential.pairs, p.tangential.force.copy()
    normal, _, _ = geometry.pair_geometry(p.positions, p.diameters, p.box, pairs)
    tangent = np.stack((-normal[:, 1], normal[:, 0]), axis=1)
    for size, part, refused in ((1e-13, 5e-15, False), (1e-3, 1e-8, True)):
        trial = force.copy()
        trial[0] = size * tangent[0] + part * normal[0]
        if refused:
            with pytest.raises(InputError, match="is not tangential"):
                stressed.build(pairs, trial, p.positions, p.diameters, p.box, "harmonic", None, "test")
        else:
            stressed.build(pairs, trial, p.positions, p.diameters, p.box, "harmonic", None, "test")


def test_a_yade_contact_file_whose_interactions_do_not_touch_is_refused(tmp_path):
    """kn comes from the touching interactions; a file of pairs apart (another step's, or another
    packing's) has none to give it: refused, naming both files' step."""
    from solver.packing import geometry

    p = hdf5.read_packings(YADE[0], contacts=YADE[1], contacts_format="yade", model=LEVER_CONTACT)[0]
    found = geometry.find_contacts(p.positions, p.diameters, p.box)
    touching = set(zip(found.i.tolist(), found.j.tolist()))
    apart = next((0, j) for j in range(1, p.n) if (0, j) not in touching)
    path = tmp_path / "apart.contacts"
    path.write_text(f"# one interaction\n{apart[0]} {apart[1]} 0 1 0 1 0 0\n")
    with pytest.raises(InputError, match="no listed interaction touches"):
        hdf5.read_packings(YADE[0], contacts=str(path), contacts_format="yade", model=LEVER_CONTACT)


def test_a_contact_file_of_a_tilted_packing_takes_its_pairs_in_the_tilted_cell(tmp_path):
    """The stored forces of a triclinic packing's contact file join it in its tilted cell: a LAMMPS
    dump local of LAMMPS's tilted packing (tests/data/dem/lammps_triclinic.data) listing its 472
    contacts, each with a tangential force of 1e-9 (file units) perpendicular to its centre line
    through the tilted cell's nearest image, reads as 472 stored forces, their forces the file's over
    the length unit; many of its pairs touch only across a tilted face (apart in the orthogonal box
    of the same sides, where the file would be refused)."""
    from solver.io import dem_formats
    from solver.packing import geometry

    raw = dem_formats.read(DATA / "lammps_triclinic.data")
    cell = geometry.Cell(raw.box_hi - raw.box_lo, raw.tilt, np.ones(3, dtype=bool))
    positions = raw.positions - raw.box_lo
    found = geometry.find_contacts(positions, raw.diameters, cell)
    pairs = np.column_stack((found.i, found.j))
    _, _, apart = geometry.pair_geometry(positions, raw.diameters, cell.sides, pairs)
    assert len(pairs) == 472 and np.sum(apart <= 0) > 20, np.sum(apart <= 0)  # across a tilted face
    tangent = np.cross(found.normal, [0.3, -0.5, 0.8])
    force = 1e-9 * tangent / np.linalg.norm(tangent, axis=1)[:, None]
    rows = "\n".join(f"{k + 1} {raw.ids[i]} {raw.ids[j]} {f[0]!r} {f[1]!r} {f[2]!r}"
                     for k, ((i, j), f) in enumerate(zip(pairs, force)))
    path = tmp_path / "tilted.contacts"
    path.write_text(f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ENTRIES\n{len(pairs)}\nITEM: BOX BOUNDS xy xz yz pp pp pp\n"
                    "0 1 0\n0 1 0\n0 1 0\nITEM: ENTRIES index c_pairs[1] c_pairs[2] c_shear[1] c_shear[2] c_shear[3]\n"
                    f"{rows}\n")
    p = hdf5.read_packings(str(DATA / "lammps_triclinic.data"), contacts=str(path))[0]
    unit = raw.diameters.mean()
    assert p.cell.tilted and len(p.tangential) == 472
    order = np.lexsort((p.tangential.pairs[:, 1], p.tangential.pairs[:, 0]))
    expected = np.lexsort((pairs[:, 1], pairs[:, 0]))
    np.testing.assert_array_equal(p.tangential.pairs[order], pairs[expected])
    # the file's force on i from j over the length unit (harmonic: kn = 1 in file units), i < j kept
    assert_close(p.tangential.force[order], force[expected] / unit, rtol=1e-12, atol=1e-24, what="stored forces")
