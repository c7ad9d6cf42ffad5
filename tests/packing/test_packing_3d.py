"""3D sphere packings: the generated packing checked against independent all-pairs sums, the
rattler rule (fewer than 4 contacts) on a hand-made lattice, the rigidity count, packing files of
shape (N, 3), the box-size rule and the packing's unit key.  2D is covered by test_packing.py and
test_jamming.py, unchanged."""

import pathlib

import h5py
import numpy as np
import pytest
from conftest import COMM, all_pairs, assert_all, assert_close, jammed_packing, star_cluster

from solver.errors import InputError
from solver.io import hdf5
from solver.io import coerce, results, schema
from solver.io import unit_keys
from solver.packing import geometry
from solver.packing import configuration, jammed
from solver.packing import mechanics

PHI = 0.7  # above this mixture's 3D jamming point (~0.648)


@pytest.fixture(scope="module")
def spheres():
    """A jammed 128-sphere packing at phi = 0.7 (same on every rank; ~0.2 s)."""
    return jammed_packing(128, PHI, 3, dim=3)


def test_generated_spheres_fill_the_asked_volume_fraction(spheres):
    """The cube against the mixture's volume (64 spheres of d = 1/1.2 and 64 of 1.4/1.2), not
    p.phi (computed from the box that was computed from phi): a 2D box formula fails here."""
    p = spheres
    volume = np.pi / 6 * 64 * ((1 / 1.2) ** 3 + (1.4 / 1.2) ** 3)
    assert p.positions.shape == (128, 3) and p.dim == 3
    assert_close(p.box_length, np.cbrt(volume / PHI), rtol=1e-15, what="box length")
    assert_close(p.phi, PHI, rtol=1e-15, what="phi read back")
    assert np.all((p.positions >= 0) & (p.positions < p.box_length))
    assert_close(np.unique(p.diameters), [1 / 1.2, 1.4 / 1.2], rtol=np.finfo(float).eps, what="diameters")


def test_spheres_contacts_pressure_and_rattlers(spheres):
    """From the all-pairs overlaps: every non-rattler touches at least 4 = D + 1 non-rattlers;
    the mean contact number z of the non-rattlers is the packing's and lies above the isostatic
    2D = 6 (phi = 0.7 is above jamming; measured 7.8 to 8.0 over seeds); the pressure is the 3D
    virial sum_c f_c r_c / (3 L^3) (the 2D formula / (2 L^2) differs by a factor 1.5 L)."""
    p = spheres
    overlap, _, distance = all_pairs(p)
    touching = overlap > 0
    kept = touching[np.ix_(~p.rattler, ~p.rattler)].sum(axis=1)
    assert kept.min() >= 4, kept.min()
    z = kept.sum() / kept.size
    assert_close(p.info["z"], z, rtol=1e-15, what="z")
    assert 6.0 < z < 9.0, z
    pressure = np.sum(overlap[touching] * distance[touching]) / 2 / (3 * p.box_length**3)
    assert_close(p.info["pressure"], pressure, rtol=1e-12, what="virial pressure")
    assert mechanics.jamming_failure(p) is None


def test_rattler_rule_in_3d_on_a_hand_made_lattice():
    """A simple cubic lattice (4^3 sites, spacing 0.95, d = 1: 6 contacts each) with 5 sites
    removed so that sphere A keeps 3 contacts and its neighbour B keeps 4, one of them A.  The 3D
    rule (fewer than 4, repeated) flags exactly A, then B: the 2D threshold (3) flags nobody,
    and a single pass only A."""
    a = 0.95
    sites = np.stack(np.meshgrid(*[np.arange(4)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    removed = {(1, 0, 0), (0, 1, 0), (0, 0, 1), (3, 1, 0), (3, 0, 1)}  # A = (0,0,0), B = (3,0,0) = (-1,0,0)
    keep = np.array([tuple(s) not in removed for s in sites])
    sites = sites[keep]
    where = {tuple(s): index for index, s in enumerate(sites)}
    found = geometry.find_contacts(a * sites.astype(float), np.ones(len(sites)), 4 * a)
    count = found.count_per_particle(len(sites))
    assert count[where[(0, 0, 0)]] == 3 and count[where[(3, 0, 0)]] == 4  # the construction
    rattler = mechanics.find_rattlers(a * sites.astype(float), np.ones(len(sites)), 4 * a)
    assert sorted(np.flatnonzero(rattler)) == sorted([where[(0, 0, 0)], where[(3, 0, 0)]])


def test_rigidity_count_in_3d(spheres):
    """N' non-rattler spheres need 3(N' - 1) + 1 = 3N' - 2 contacts among them.  The jammed
    packing passes; sphere 0 and its contact neighbours alone (a star: k arms and the few
    contacts between them, fewer than 3k + 1) fail with the 3D count in the message, as does a
    packing of rattlers; require_jammed names packing.phi and the 3D jamming point."""
    p = spheres
    cluster, n_cluster, inside = star_cluster(p)
    assert inside < 3 * n_cluster - 2, (n_cluster, inside)  # the test's cluster is floppy in 3D
    floppy = configuration.Packing(p.positions, p.diameters, p.box, ~cluster, p.info)
    why = mechanics.jamming_failure(floppy)
    assert why is not None and why.startswith(f"only {n_cluster} of 128 spheres are not rattlers and they "
                                              f"share {inside} contacts, fewer than the 3N' - 2 = "
                                              f"{3 * n_cluster - 2}"), why
    loose = configuration.Packing(p.positions, p.diameters, p.box, np.ones(p.n, dtype=bool), p.info)
    assert mechanics.jamming_failure(loose).startswith("all 128 spheres are rattlers")
    with pytest.raises(InputError, match=r"packing.phi = 0.7: configuration 1 did not jam: all 128 spheres "
                                         r"are rattlers .*this 3D mixture jams near phi = 0.648"):
        jammed.require_jammed([p, loose], 0.7)


def test_box_of_two_large_diameters_is_refused_before_fire():
    """16 spheres at phi = 0.9 would fit a cube of side 2.160 < 2 d_L = 2.333: refused naming
    packing.n and packing.phi and the smallest N that fits (by hand: N > 2 phi (2 d_L)^3 / (pi/6
    (d_S^3 + d_L^3)) = 20.16, even: 22); smallest_n is the smallest even N whose box fits."""
    with pytest.raises(InputError, match=r"packing.n = 16, packing.phi = 0.9: the 3D box would have side "
                                         r"L = 2.16, .*choose packing.n >= 22 at this phi"):
        jammed.generate(16, 0.9, np.random.SeedSequence([0, 0]), dim=3)
    for phi in (0.6, 0.75, 0.9, 0.99):
        n = jammed.smallest_n(phi, 3)
        box = [jammed.box_length_for(jammed.bidisperse_diameters(m), phi, 3) for m in (n - 2, n)]
        assert box[1] > 2 * jammed.D_LARGE and (n == 16 or box[0] <= 2 * jammed.D_LARGE), (phi, n, box)
    assert jammed.smallest_n(0.99, 2) == 16  # every 2D box of 16 or more disks fits


def test_sphere_file_round_trip(shared_tmp, spheres):
    """A stand-alone packing file, a hand-made top-level file (no rattler flag, shifted by -3L)
    and a results file's first configuration all give back the (N, 3) positions."""
    p = spheres
    stored, external, out = (shared_tmp / name for name in ("spheres.h5", "external3d.h5", "results3d.h5"))
    if COMM.rank == 0:
        hdf5.save_packings(str(stored), [p])
        with h5py.File(external, "w") as f:
            f["positions"] = p.positions - 3.0 * p.box_length
            f["diameters"] = p.diameters
            f.attrs["box_length"] = p.box_length
        hdf5.write_results(str(out), {}, [p], {})
    COMM.Barrier()
    (back,) = hdf5.read_packings(str(stored))
    assert_all(back.positions.shape == (128, 3) and np.array_equal(back.positions, p.positions)
               and np.array_equal(back.rattler, p.rattler) and back.box_length == p.box_length, "round trip")
    (other,) = hdf5.read_packings(str(external))
    folding = 4 * np.finfo(float).eps * 3 * p.box_length  # subtracting 3L and folding: round-off
    assert_close(other.positions, p.positions, rtol=0, atol=folding, what="folding into the cube")
    assert_all(np.array_equal(other.rattler, p.rattler), "rattlers recomputed with the 3D rule")
    with results.open_results(str(out)) as f:
        first = results.first_packing(f)
    assert_all(np.array_equal(first["positions"], p.positions), "results file: first configuration (N, 3)")
    assert_close(first["phi"], PHI, rtol=1e-15, what="phi attribute")
    COMM.Barrier()


def test_packing_key_gets_dim_only_in_3d():
    """2D recipes carry no dim (as before packing.dim existed); 3D recipes differ from them."""
    keys = {dim: unit_keys.packing_key(coerce.build(schema.Scene, {"packing": {"n": 64, "phi": 0.9, "dim": dim}}), 0)
            for dim in (2, 3)}
    assert set(keys[2].parts["settings"]) == {"n", "phi", "seed", "index", "force_tol", "max_steps", "fire"}
    assert keys[3].parts["settings"]["dim"] == 3 and keys[2].digest != keys[3].digest


def test_net_force_of_a_sphere_file_counts_z(spheres):
    """The equilibrium check of packing files (mechanics.net_force) on spheres: one sphere moved by
    0.01 d0 along z gives the largest net force of the all-pairs sum, z component included."""
    p = spheres
    moved = p.positions.copy()
    moved[5, 2] += 0.01
    shaken = configuration.Packing(moved, p.diameters, p.box, p.rattler, p.info)
    overlap, delta, distance = all_pairs(shaken)
    net = np.sum((overlap / distance)[..., None] * delta, axis=1)
    expected = np.sqrt(np.sum(net[~p.rattler] ** 2, axis=1)).max()
    assert expected > 1e-3, expected  # well above EQUILIBRIUM_TOL = 1e-4: the file would be refused
    assert_close(mechanics.net_force(shaken), expected, rtol=1e-12, what="largest net force")


@pytest.mark.serial_only  # one figure of arrays, no communicator
def test_sphere_packing_figure_is_the_section_at_half_height(tmp_path, monkeypatch, spheres):
    """The packing figure of a 3D results file draws the spheres cut by z = L/2 (a (N, 3) array
    handed to matplotlib's 2D offsets raised ValueError), each as the disk of its section."""
    from matplotlib.collections import EllipseCollection

    from solver.plots.packing import plot_packing

    p = spheres
    drawn = []
    original = EllipseCollection.__init__

    def spy(self, widths, heights, angles, **kwargs):
        drawn.append((np.asarray(widths), np.asarray(kwargs["offsets"])))
        original(self, widths, heights, angles, **kwargs)

    monkeypatch.setattr(EllipseCollection, "__init__", spy)
    paths = plot_packing({"positions": p.positions, "diameters": p.diameters, "rattler": p.rattler,
                          "box": p.box, "phi": p.phi, "z": p.info["z"]}, str(tmp_path / "spheres"))
    (widths, offsets), = drawn
    dz = np.abs(p.positions[:, 2] - p.box_length / 2)
    crossing = dz < p.diameters / 2  # the box centre is far from its faces: no periodic image needed
    assert offsets.shape == (crossing.sum(), 2) and crossing.sum() > 5
    assert_close(np.sort(widths), np.sort(2 * np.sqrt(p.diameters[crossing] ** 2 / 4 - dz[crossing] ** 2)),
                 rtol=1e-14, what="section diameters")
    assert paths and all(pathlib.Path(path).exists() for path in paths), paths


@pytest.mark.parametrize("start, moves, gap, refreshes", [
    (1.12575, [(0.0, 0.07425), (-0.16, 0.0), (0.149, -0.07425 - 0.149)], 0.98775, 1),
    (1.10, [(0.0, 0.14), (-0.16, 0.0), (0.149, -0.14 - 0.149)], 0.962, 2),
])
def test_neighbour_list_refresh_keeps_every_pair_that_can_touch(start, moves, gap, refreshes):
    """FIRE's Verlet list (skin s = 0.3) on the worst cases of its partial refresh (a cell walled
    along z: a periodic box's list is made whole, cell_list); spheres a and b (d = 1) on a line, moves (a, b) along it.  First: b moves 0.07425 (just under s/4: not
    re-listed) away from a, a moves 0.16 (over s/2) away, which re-lists a at distance 1.36 =
    d + 1.2 s; then a moves 0.149 back and b 0.149 past its start, both under s/2, to 0.98775:
    touching.  A refresh reaching d + s, not d + 1.25 s, dropped that pair and its force.
    Second: b first moves 0.14 (over s/4), so it is re-listed with a at 1.40 and its reference
    reset; its later 0.289 towards a trips a second refresh.  Re-listing only particles past
    s/2 left b's old reference (0.149 from it in the end: no refresh) and missed the contact at
    0.962.  Six far spheres stand still (so that re-listing two is a refresh, not a rebuild).  At
    every stage the forces equal the two-sphere formula."""
    far = [[1, 1, 1], [1, 1, 8], [1, 8, 1], [8, 1, 1], [1, 8, 8], [8, 8, 8]]
    x = np.array([[5.0, 5.0, 5.0], [5.0 + start, 5.0, 5.0]] + far, dtype=float)
    walled = geometry.Cell(np.full(3, 10.0), np.zeros(3), np.array([True, True, False]))  # refreshes: not periodic
    forces = mechanics.FrictionlessForces(np.ones(len(x)), walled)
    assert forces.skin == 0.3
    for move in [(0.0, 0.0)] + moves:
        x[:2, 0] += move
        f, _ = forces(x)
        overlap = max(1.0 - (x[1, 0] - x[0, 0]), 0.0)
        expected = np.zeros_like(x)
        expected[:2, 0] = -overlap, overlap
        assert_close(f, expected, rtol=1e-12, what=f"gap {x[1, 0] - x[0, 0]}")
    assert_close(x[1, 0] - x[0, 0], gap, rtol=1e-12, what="final gap")
    assert forces.rebuilds == 1 and forces.refreshes == refreshes and f[1, 0] > 0.01
