"""MercuryDPM's files (tests/data/dem/mercury_3d_friction.*, written by MercuryDPM itself from
the driver mercury_3d_friction.cpp; tests/data/dem/README.md): the ``.data`` file as a packing
(``packing.format: mercury``, detected from its content), the ``.fstat`` as its stored tangential
forces (``packing.contacts_format: mercury-fstat``).  The frictional packing is at rest with them
(MercuryDPM's own balance) and not without them; damaged files are refused naming the file."""

import dataclasses

import numpy as np
import pytest
from conftest import REPO

from solver.contact_law import ContactModel
from solver.errors import InputError
from solver.io import contact_files, dem_formats, hdf5
from solver.packing import configuration, mechanics

pytestmark = pytest.mark.serial_only  # file reading: nothing to gain from a second rank

DATA = REPO / "tests" / "data" / "dem"
PACKING, CONTACTS = DATA / "mercury_3d_friction.data", DATA / "mercury_3d_friction.fstat"
LEVER_CONTACT = ContactModel(lever="contact")  # MercuryDPM's contact point: the middle of the overlap
MU = 0.5  # the driver's Coulomb coefficient


def _read(data=PACKING, contacts=CONTACTS, model=LEVER_CONTACT, friction=MU):
    return hdf5.read_packings(str(data), contacts=str(contacts), contacts_format="mercury-fstat", model=model,
                              friction=friction)[0]


def _fstat_rows():
    """The .fstat's contact lines as a (2C, 16) table, parsed here with numpy alone."""
    return np.loadtxt(CONTACTS, comments="#")


def test_the_data_file_is_detected_and_holds_the_drivers_packing():
    """The driver's recipe (mercury_3d_friction.cpp): 200 spheres, 100 of diameter 0.8 and 100 of
    1.2 (mean 1), in a periodic cube of packing fraction 0.62, from the origin; MercuryDPM writes
    the domain as the header's box and the particles in index order."""
    assert dem_formats.detect_format(PACKING) == "mercury"
    raw = dem_formats.read(PACKING)
    header = np.array(PACKING.read_text().splitlines()[0].split(), dtype=float)
    assert raw.source == "mercury" and raw.dim == 3 and raw.masses is None
    assert np.array_equal(raw.ids, np.arange(200)) and header[0] == 200
    assert np.array_equal(np.sort(raw.diameters), np.repeat([0.8, 1.2], 100))
    assert np.array_equal(raw.box_lo, np.zeros(3)) and np.all(raw.box_hi == raw.box_hi[0])
    phi = configuration.solid_volume(raw.diameters, 3) / np.prod(raw.box_hi - raw.box_lo)
    assert abs(phi - 0.62) < 1e-14, phi


def test_the_fstat_lists_each_contact_twice_and_the_reader_keeps_one_row_each():
    rows = _fstat_rows()
    i, j = rows[:, 1].astype(int), rows[:, 2].astype(int)
    raw = contact_files.read(CONTACTS, "mercury-fstat")
    assert len(rows) == 2 * len(raw.ids) and np.all(raw.ids[:, 0] < raw.ids[:, 1])
    assert set(map(tuple, raw.ids)) == set(zip(np.minimum(i, j), np.maximum(i, j)))
    # the second line of a pair (j i) holds the opposite forces: one sign convention, on the first
    forward = {(a, b): k for k, (a, b) in enumerate(zip(i, j))}
    back = np.array([forward[(b, a)] for a, b in raw.ids])
    assert np.array_equal(raw.force, -rows[back, 9:10] * rows[back, 13:16])
    assert np.array_equal(raw.normal_force, -rows[back, 8:9] * rows[back, 10:13])


def test_the_frictional_packing_is_at_rest_on_its_stored_forces():
    """With its 551 stored tangential forces and MercuryDPM's lever (R - xi/2) the forces and
    torques balance as MercuryDPM left them (it stopped below 1e-13 kn d0); the normal forces alone
    leave a net force of the order of the mean tangential force, and rotsound refuses the packing
    without its .fstat (naming packing.contacts) and with LAMMPS's lever R (naming model.lever)."""
    p = _read()
    rows = _fstat_rows()
    assert p.stressed and p.info["n_stored"] == len(rows) // 2
    net, torque = mechanics.net_load(p)
    active = ~p.rattler
    assert np.abs(net[active]).max() < 1e-12 and np.abs(torque[active]).max() < 1e-12
    mean_ft = np.linalg.norm(p.tangential.force, axis=1).mean()
    bare, _ = mechanics.net_load(dataclasses.replace(p, tangential=None))
    assert np.abs(bare[active]).max() > 0.5 * mean_ft
    with pytest.raises(InputError, match="packing.contacts"):
        hdf5.read_packings(str(PACKING))
    with pytest.raises(InputError, match="lever of model.lever"):
        _read(model=ContactModel())


def test_kn_is_read_from_the_fstats_normal_forces(tmp_path):
    """Every force of the .fstat times 1e3 (kn = 1e3 where the driver had 1): the same stored
    forces in kn d0."""
    lines = CONTACTS.read_text().splitlines()
    scaled = []
    for line in lines:
        words = line.split()
        if not line.startswith("#"):
            words[8], words[9] = repr(float(words[8]) * 1e3), repr(float(words[9]) * 1e3)
        scaled.append(" ".join(words))
    path = tmp_path / "stiff.fstat"
    path.write_text("\n".join(scaled) + "\n")
    a, b = _read(), _read(contacts=path)
    assert np.array_equal(a.tangential.pairs, b.tangential.pairs)
    assert np.allclose(b.tangential.force, a.tangential.force, rtol=1e-12, atol=1e-18)


def _damaged_data(tmp_path, how):
    lines = PACKING.read_text().splitlines()
    if how == "extra line":
        lines.insert(5, lines[5])
    elif how == "missing line":
        del lines[5]
    elif how == "truncated":
        lines = lines[:len(lines) // 2]
    elif how == "non-number":
        words = lines[7].split()
        words[3] = "abc"
        lines[7] = " ".join(words)
    elif how == "2D header":
        lines[0] = " ".join(lines[0].split()[:4] + lines[0].split()[5:7])
    path = tmp_path / f"{how.replace(' ', '_')}.data"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("how, match", [
    ("extra line", "line 202 is not a frame header .* that frame has more particle lines than its header says"),
    ("missing line", "frame 0 .header at line 1. has 199 particle lines where its header says N = 200"),
    ("truncated", "has 99 particle lines where its header says N = 200"),
    ("non-number", "line 8 of the file, in frame 0's particle lines, 'abc' is not a number"),
    ("2D header", "the header of a 2D MercuryDPM data file"),
])
def test_damaged_data_files_are_refused_naming_the_file(tmp_path, how, match):
    path = _damaged_data(tmp_path, how)
    with pytest.raises(InputError, match=match) as caught:
        hdf5.read_packings(str(path), fmt="mercury", contacts=str(CONTACTS), contacts_format="mercury-fstat",
                           model=LEVER_CONTACT)
    assert str(path) in str(caught.value)


def _damaged_fstat(tmp_path, how):
    lines = CONTACTS.read_text().splitlines()
    first = 3  # after the three '#' lines
    row = lines[first].split()
    if how == "one side":
        del lines[first + 1]
    elif how == "twice from one side":
        lines.insert(first, lines[first])
    elif how == "wall":
        row[2] = "-1"
    elif how == "columns":
        lines[first:] = [" ".join(line.split()[:15]) for line in lines[first:]]
    elif how == "non-number":
        row[6] = "x"
    elif how == "other kn":  # both lines of the first contact: its fn 1 % larger
        for k in (first, first + 1):
            words = lines[k].split()
            words[8] = repr(1.01 * float(words[8]))
            lines[k] = " ".join(words)
    elif how == "apart":
        for k in (first, first + 1):
            words = lines[k].split()
            words[6] = "0"
            lines[k] = " ".join(words)
    elif how == "other step":
        for k in (first, first + 1):
            words = lines[k].split()
            words[6] = repr(float(words[6]) + 1e-6)
            lines[k] = " ".join(words)
    if how in ("wall", "non-number"):
        lines[first] = " ".join(row)
    path = tmp_path / f"{how.replace(' ', '_')}.fstat"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("how, match", [
    ("one side", r"the contact of particles \[\d+, \d+\] is not listed once from each side"),
    ("twice from one side", "a contact is listed more than twice"),
    ("wall", "line 4 is a contact with a wall"),
    ("columns", "contact lines have 15 columns; packing.contacts_format mercury-fstat reads 16"),
    ("non-number", "line 4 of the file, in the last frame's contact lines, 'x' is not a number"),
    ("other kn", r"kn = fn / overlap differs between contacts"),
    ("other step", "the .data and .fstat files must be written at the same step"),
    ("apart", r"has overlap 0 <= 0; MercuryDPM lists touching pairs only"),
])
def test_damaged_fstat_files_are_refused_naming_the_file(tmp_path, how, match):
    path = _damaged_fstat(tmp_path, how)
    with pytest.raises(InputError, match=match) as caught:
        _read(contacts=path)
    assert str(path) in str(caught.value)


def test_a_scene_on_the_mercury_files_makes_the_stressed_packing(tmp_path):
    """packing.file, packing.format: mercury (and detected), contacts_format: mercury-fstat through
    the scene's keys and rules to the stressed packing; under LAMMPS's lever the scene is refused
    before any compute, naming the keys MercuryDPM's convention needs."""
    from conftest import COMM

    from solver import pipeline
    from solver.io import coerce, schema

    from solver.io import scene_rules

    rows = _fstat_rows()
    at_limit = int(np.sum(rows[:, 9] >= (1 - 1e-9) * MU * rows[:, 8])) // 2  # MercuryDPM's sliding contacts
    packing = {"file": str(PACKING), "contacts": str(CONTACTS), "contacts_format": "mercury-fstat", "friction": MU}
    for extra in ({}, {"format": "mercury"}):
        scene = {"packing": {**packing, **extra}, "model": {"lever": "contact", "rho": 2 / 7},
                 "output": str(tmp_path / "out.h5")}
        p, = pipeline.make_packings(coerce.build(schema.Scene, scene), COMM)
        assert p.stressed and p.info["n_stored"] == len(rows) // 2 and p.info["n_mobilised"] == at_limit > 0
    with pytest.raises(InputError, match="set model.lever: contact and model.history: lammps"):
        scene_rules.check_scene(coerce.build(schema.Scene, {"packing": packing, "output": str(tmp_path / "out.h5")}))


def test_the_fstat_under_hertz_or_read_as_a_dump_local_is_refused():
    with pytest.raises(InputError, match="MercuryDPM's linear species .* model.law: harmonic"):
        _read(model=ContactModel(law="hertz", lever="contact"))
    with pytest.raises(InputError, match="unknown format: not a text 'dump local'"):
        hdf5.read_packings(str(PACKING), contacts=str(CONTACTS), model=LEVER_CONTACT)
