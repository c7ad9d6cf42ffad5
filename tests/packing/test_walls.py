"""Walls and gravity in a packing's mechanics (docs/walls.md): a packing settled under gravity
between walls reads at rest, and not without its gravity or its walls (negative controls); the
stress tensor against the virial identity of a packing at rest; the walls' checks; the wall
contact file."""

import dataclasses

import numpy as np
import pytest
from walled import GRAVITY, settled

from solver.errors import InputError
from solver.io import results, wall_files
from solver.packing import mechanics, walls

pytestmark = pytest.mark.serial_only  # no communicator


@pytest.mark.parametrize("dim", [2, 3])
def test_a_packing_settled_under_gravity_between_walls_is_at_rest(dim):
    p = settled(dim)
    assert not p.rattler.any() and list(p.periodic) == [True] * (dim - 1) + [False]
    floor = walls.touching(p.positions, p.diameters, p.walls)
    assert set(floor.wall.tolist()) == {0, 1}, "both walls should touch the packing"
    mechanics.require_equilibrium(p, "settled")  # no raise
    net, torque = mechanics.net_load(p)
    assert np.abs(net).max() < 1e-9 and np.abs(torque).max() == 0.0
    weightless = dataclasses.replace(p, gravity=None)
    assert np.abs(mechanics.net_load(weightless)[0]).max() > 0.5 * GRAVITY, "the rest does not need gravity"
    with pytest.raises(InputError, match="not at rest between its walls under gravity none"):
        mechanics.require_equilibrium(weightless, "weightless")
    wall_free = dataclasses.replace(p, walls=None)
    with pytest.raises(InputError, match="not at rest between its walls"):
        mechanics.require_equilibrium(wall_free, "wall-free")


@pytest.mark.parametrize("dim", [2, 3])
def test_the_stress_along_the_walls_normal_is_the_virial_of_walls_and_weight(dim):
    """At rest sum_i x_i F_i = 0 along the walled axis z (no images): sigma_zz V = -sum_i m g_z z_i
    - sum_w p_w F_w,z, with F_w the force wall w exerts in total: the stress tensor's wall share
    (r_c = h n) is the one that makes this hold, and the particles' share alone misses it."""
    p = settled(dim)
    touch, push, _ = walls.loads(p.positions, p.diameters, p.walls, None, "harmonic")
    volume = walls.volume_between(p.box, p.walls)
    on_walls = np.array([push[touch.wall == w, -1].sum() for w in range(len(p.walls))])
    virial = -np.sum(p.gravity[-1] * p.positions[:, -1]) - np.sum(p.walls.position * on_walls)
    stress = np.asarray(p.info["stress"])
    assert np.isclose(stress[-1, -1] * volume, virial, rtol=1e-8, atol=0.0), (stress[-1, -1] * volume, virial)
    inner = stress - np.asarray(p.info["stress_walls"])
    assert not np.isclose(inner[-1, -1] * volume, virial, rtol=1e-2, atol=0.0)
    assert np.isclose(p.info["pressure"], np.trace(stress) / dim, rtol=1e-14, atol=0.0)


def test_walls_are_refused_through_the_packing_and_on_periodic_axes():
    positions = np.array([[0.5, 0.6], [1.5, 0.7], [2.5, 1.6]])
    diameters = np.ones(3)
    with pytest.raises(InputError, match=r"the wall y = 1 goes through the packing: particle 2 \(0-based\) has its "
                                         r"centre at y = 1.6, 1 centre\(s\) above the wall and 2 on it or below"):
        walls.build([1], [1.0], positions, diameters, np.array([True, False]), "scene")
    with pytest.raises(InputError, match=r"wall 0 \(y = 0\) stands on the periodic axis y"):
        walls.build([1], [0.0], positions, diameters, np.array([True, True]), "scene")
    with pytest.raises(InputError, match="a 2D packing has axes x, y"):
        walls.build([2], [0.0], positions, diameters, np.array([True, False]), "scene")
    built = walls.build([1, 1], [0.2, 2.2], positions, diameters, np.array([True, False]), "scene")
    assert built.facing.tolist() == [1.0, -1.0]


def test_gravity_needs_a_wall_against_it():
    periodic = np.array([True, False])
    floor = walls.Walls(np.array([1]), np.array([0.0]), np.array([1.0]))
    assert walls.gravity_problem(np.array([0.0, -1.0]), floor, periodic) is None
    assert "no wall on that side" in walls.gravity_problem(np.array([0.0, 1.0]), floor, periodic)
    assert "along the periodic axis x" in walls.gravity_problem(np.array([0.1, -1.0]), floor, periodic)


def test_wall_contact_file_round_trip_and_checks(tmp_path):
    path = tmp_path / "walls.txt"
    wall_files.write(path, np.array([3, 1]), np.array([0, 1]), np.array([[1.0, -2.0, 0.5], [0.0, 1e-3, -4.0]]))
    raw = wall_files.read(path)
    assert raw.ids.tolist() == [3, 1] and raw.wall.tolist() == [0, 1]
    assert np.array_equal(raw.force, [[1.0, -2.0, 0.5], [0.0, 1e-3, -4.0]])
    (tmp_path / "bad.txt").write_text("# id wall fx fy fz\n3 0 1.0 2.0\n")
    with pytest.raises(InputError, match=r"wall contact file .*bad.txt: contact lines have 4 columns; each line holds 5"):
        wall_files.read(tmp_path / "bad.txt")
    (tmp_path / "half.txt").write_text("3 0.5 1.0 2.0 0\n")
    with pytest.raises(InputError, match=r"line 1: the id and wall columns must hold whole numbers >= 0"):
        wall_files.read(tmp_path / "half.txt")
    (tmp_path / "none.txt").write_text("# no contact\n")
    assert len(wall_files.read(tmp_path / "none.txt").ids) == 0


def test_wall_contacts_keep_the_tangential_part_and_are_checked():
    positions = np.array([[0.5, 0.45], [1.5, 0.8]])
    diameters = np.ones(2)
    floor = walls.Walls(np.array([1]), np.array([0.0]), np.array([1.0]))
    stored = walls.build_contacts([0], [0], [[0.2, 0.05]], positions, diameters, floor, "file")
    assert np.array_equal(stored.force, [[0.2, 0.0]]) and stored.particle.tolist() == [0]
    with pytest.raises(InputError, match=r"names wall 1, but the packing has 1 wall"):
        walls.build_contacts([0], [1], [[0.2, 0.0]], positions, diameters, floor, "file")
    with pytest.raises(InputError, match=r"names particle index 5, not among the packing's 2 particles"):
        walls.build_contacts([5], [0], [[0.2, 0.0]], positions, diameters, floor, "file")
    with pytest.raises(InputError, match=r"carry a force but do not touch their wall \(first: particle 1 and wall 0"):
        walls.build_contacts([1], [0], [[0.2, 0.0]], positions, diameters, floor, "file")


def _write_dump(path, p, unit, lo, flags):
    """``p`` as a LAMMPS text dump in a file's units: lengths times ``unit``, origin ``lo``, masses 1."""
    dim = p.dim
    x = np.zeros((p.n, 3))
    x[:, :dim] = p.positions * unit + lo[:dim]
    hi = lo + np.append(p.box, np.ones(3 - dim)) * unit
    rows = "\n".join(f"{i + 1} 1 {p.diameters[i] * unit:.17g} 1 {x[i, 0]:.17g} {x[i, 1]:.17g} {x[i, 2]:.17g}"
                     for i in range(p.n))
    bounds = "\n".join(f"{lo[a]:.17g} {hi[a]:.17g}" for a in range(3))
    path.write_text(f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n{p.n}\nITEM: BOX BOUNDS {flags}\n{bounds}\n"
                    f"ITEM: ATOMS id type diameter mass x y z\n{rows}\n")


def test_a_lammps_dump_with_f_bounds_reads_between_walls_at_rest(tmp_path):
    """'pp pp ff': walls at the z bounds; gravity and the wall contact file in the file's units
    (lengths x 2, kn = 1 there, harmonic: forces and g divided by 2); at rest, as made; the same file
    read without its gravity is not (negative control); rotsound's packing file keeps it all."""
    from solver.io import hdf5

    p = settled(3)
    unit, lo = 2.0, np.array([-1.0, 3.0, 5.0])
    dump = tmp_path / "walled.dump"
    _write_dump(dump, p, unit, lo, "pp pp ff")
    touch, push, _ = walls.loads(p.positions, p.diameters, p.walls, None, "harmonic")
    tangential = 1e-3 * np.roll(touch.normal, 1, axis=1)  # a stored force the rest check must see
    contacts = tmp_path / "walls.txt"
    wall_files.write(contacts, touch.particle + 1, touch.wall, (push + tangential) * unit)
    with pytest.raises(InputError, match="not at rest between its walls"):  # the stored forces' torques
        hdf5.read_packings(str(dump), gravity=list(p.gravity * unit), wall_contacts=str(contacts))
    wall_files.write(contacts, touch.particle + 1, touch.wall, push * unit)
    read = hdf5.read_packings(str(dump), gravity=list(p.gravity * unit), wall_contacts=str(contacts))[0]
    assert read.walls.axis.tolist() == [2, 2] and np.allclose(read.walls.position, [0.0, p.box[2]], rtol=0, atol=1e-12)
    assert list(read.periodic) == [True, True, False] and np.allclose(read.gravity, p.gravity, rtol=1e-15, atol=0)
    assert len(read.wall_contacts) == len(touch) and not read.wall_contacts.nonzero()
    with pytest.raises(InputError, match="not at rest between its walls under gravity none"):
        hdf5.read_packings(str(dump), wall_contacts=str(contacts))
    _write_dump(dump, p, unit, lo, "pp pp pp")
    with pytest.raises(InputError, match="stands on the periodic axis z"):
        hdf5.read_packings(str(dump), walls=[{"axis": "z", "position": 5.0}])
    saved = tmp_path / "walled.h5"
    hdf5.save_packings(str(saved), [read])
    again = hdf5.read_packings(str(saved))[0]
    assert np.array_equal(again.walls.position, read.walls.position) and np.array_equal(again.gravity, read.gravity)
    assert np.array_equal(again.info["stress"], read.info["stress"]) and len(again.wall_contacts) == len(touch)
    out = tmp_path / "results.h5"  # the results file and the notebook API carry them
    hdf5.write_results(str(out), {}, [read], {})
    with results.open_results(str(out)) as f:
        seen = results.packing(f, 0)
    assert seen["walls"]["axis"].tolist() == [2, 2] and np.array_equal(seen["gravity"], read.gravity)
    assert np.array_equal(seen["stress_walls"], read.info["stress_walls"])


def test_gravity_along_a_periodic_axis_is_refused(tmp_path):
    from solver.io import hdf5

    p = settled(2)
    dump = tmp_path / "walled.dump"
    _write_dump(dump, p, 1.0, np.zeros(3), "pp ff pp")
    with pytest.raises(InputError, match="packing.gravity has the component 0.01 along the periodic axis x"):
        hdf5.read_packings(str(dump), gravity=[0.01, -0.01])
    with pytest.raises(InputError, match="packing.gravity pulls along y \\(0.01\\) but no wall on that side"):
        hdf5.read_packings(str(dump), gravity=[0.0, 0.01], walls=[{"axis": "y", "position": 0.0}])


def test_walls_and_their_stored_forces_key_the_units(tmp_path):
    """A matrix unit of a packing between walls is not the same packing's without them (nor with
    other stored wall forces); gravity, which adds no stiffness, leaves the key alone."""
    from conftest import scene_of
    from solver.io import unit_keys

    p = settled(2)
    scene = scene_of(tmp_path / "out.h5", packing={"file": "walled.h5"}, model={"rho": [0.5]})
    touch = walls.touching(p.positions, p.diameters, p.walls)
    loaded = dataclasses.replace(p, wall_contacts=walls.WallContacts(touch.particle, touch.wall,
                                                                     1e-3 * np.roll(touch.normal, 1, axis=1)))
    variants = [p, dataclasses.replace(p, walls=None), loaded, dataclasses.replace(p, gravity=None)]
    keys = [unit_keys.scene_keys(scene, [v], [])["matrices/r00_p0000"].digest for v in variants]
    assert len(set(keys[:3])) == 3 and keys[3] == keys[0], keys


def test_a_lammps_data_file_takes_its_walls_from_the_scene(tmp_path):
    """A data file records no boundary: packing.walls (file coordinates) makes their axis walled;
    the 2D settled packing, shifted by lo and scaled by 1.5, reads at rest with its gravity."""
    from solver.io import hdf5

    p = settled(2)
    unit, lo = 1.5, np.array([2.0, -1.0])
    x = p.positions * unit + lo
    density = 6.0 / (np.pi * (p.diameters * unit) ** 3)  # mass 1 each, LAMMPS's rule
    atoms = "\n".join(f"{i + 1} 1 {p.diameters[i] * unit:.17g} {density[i]:.17g} {x[i, 0]:.17g} {x[i, 1]:.17g} 0"
                      for i in range(p.n))
    hi = lo + p.box * unit
    path = tmp_path / "walled.data"
    path.write_text(f"LAMMPS data file\n\n{p.n} atoms\n1 atom types\n\n{lo[0]:.17g} {hi[0]:.17g} xlo xhi\n"
                    f"{lo[1]:.17g} {hi[1]:.17g} ylo yhi\n-0.5 0.5 zlo zhi\n\nAtoms # sphere\n\n{atoms}\n")
    scene_walls = [{"axis": "y", "position": float(lo[1])}, {"axis": "y", "position": float(hi[1])}]
    read = hdf5.read_packings(str(path), walls=scene_walls, gravity=list(p.gravity * unit))[0]
    assert list(read.periodic) == [True, False]
    assert np.allclose(read.walls.position, [0.0, p.box[1]], rtol=0, atol=1e-12)
    assert np.allclose(read.positions, p.positions, rtol=0, atol=1e-12)
    with pytest.raises(InputError, match="not at rest between its walls"):
        hdf5.read_packings(str(path), walls=scene_walls)


def test_walls_refuse_capillary_bridges():
    from solver.capillary import Cohesion
    from solver.contact_law import ContactModel

    p = settled(2)
    wet = dataclasses.replace(p, model=ContactModel(cohesion=Cohesion("willett", 0.01, 0.0, 0.001, 0.0)))
    with pytest.raises(InputError, match="capillary bridges to a wall are not modelled"):
        mechanics.with_walls(wet, p.walls)


def test_the_log_line_names_the_walls_their_share_and_gravity():
    from solver.pipeline import _walls_line

    p = settled(3)
    share = np.trace(p.info["stress_walls"]) / 3
    assert _walls_line(p) == (f", walls z = 0, z = {p.walls.position[1]:g} ({p.info['n_wall_contacts']} wall contacts, "
                              f"their share of the pressure {share:.3e}), g = [0.0, 0.0, -0.01]")
    assert p.info["n_wall_contacts"] == 18  # 9 on the floor, 9 under the ceiling
