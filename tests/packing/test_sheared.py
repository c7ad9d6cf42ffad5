"""Packings in a tilted (sheared) periodic cell: the quasi-statically sheared packings of
``packing.shear`` at rest (forces by brute force over the cell's images), their rattlers and
pressure, their start (the square packing) and their shear stress, the cell kept by
``from_arrays``, the packing file and the unit store, and the cell and the shear in the content keys."""

import dataclasses

import h5py
import numpy as np
import pytest
from conftest import assert_all, assert_close, brute_contacts, jammed_packing, scene_of, with_random_stored_forces

from solver import contact_law
from solver.errors import InputError
from solver.io import hdf5, unit_keys, unit_store
from solver.packing import geometry, jammed, mechanics, shear

pytestmark = pytest.mark.serial_only  # FIRE and files on one process: no communicator

FORCE_TOL = 1e-6


def sheared(dim, shear):
    n, phi = (64, 0.9) if dim == 2 else (64, 0.7)
    return jammed.generate(n, phi, np.random.SeedSequence([11, 0]), force_tol=FORCE_TOL, dim=dim, shear=shear)


def brute_net_forces(p):
    """Net harmonic contact force (N, D) on every particle, over the contacts brute_contacts finds
    among all of them (no Verlet list, no neighbour search)."""
    i, j, delta = brute_contacts(p.positions, p.diameters, p.cell)
    distance = np.linalg.norm(delta, axis=1)
    along = contact_law.normal_force(0.5 * (p.diameters[i] + p.diameters[j]) - distance, "harmonic",
                                     contact_law.reduced_radius(p.diameters[i], p.diameters[j]))
    force = (along / distance)[:, None] * delta  # on i from j
    net = np.zeros_like(p.positions)
    np.add.at(net, i, force)
    np.add.at(net, j, -force)
    return net, (i, j, delta, along)


@pytest.mark.parametrize("dim, strain", [(2, 0.3), (2, -0.5), (3, 0.45)])
def test_a_sheared_packing_is_at_rest_in_the_tilted_cell(dim, strain):
    p = sheared(dim, strain)
    assert_close(p.tilt, np.eye(len(geometry.TILTS[dim]))[0] * strain * p.box[0], rtol=0, atol=0, what="xy = shear L")
    assert_all(p.cell.tilt_problem() is None and p.info["shear"] == strain, "a valid tilt, recorded")
    assert_all(p.info["shear_steps"] == round(abs(strain) / 0.01) and p.info["shear_fire_steps"] > 0,
               "sheared in steps of 0.01, each relaxed by FIRE")
    net, (i, j, delta, along) = brute_net_forces(p)
    assert_all(np.linalg.norm(net, axis=1).max() < FORCE_TOL, "every particle at rest in the tilted cell")
    assert_all(i.size > dim * p.n and along.max() > 1e-3, "a jammed packing: contacts carry load")
    # the same particles in the orthogonal box are not at rest: the tilt is what holds them
    square = dataclasses.replace(p, positions=np.mod(p.positions, p.box), tilt=None)
    assert_all(np.linalg.norm(brute_net_forces(square)[0], axis=1).max() > 1e3 * FORCE_TOL, "the tilt matters")
    # rattlers (fewer than D + 1 contacts, repeated) and the virial pressure over the cell's volume
    rattler = np.zeros(p.n, dtype=bool)
    while True:
        keep = ~rattler[i] & ~rattler[j]
        count = np.bincount(i[keep], minlength=p.n) + np.bincount(j[keep], minlength=p.n)
        new = ~rattler & (count < dim + 1)
        if not new.any():
            break
        rattler |= new
    assert_all(np.array_equal(p.rattler, rattler), "rattlers as brute force finds them")
    pressure = np.sum(along * np.linalg.norm(delta, axis=1)) / (dim * abs(np.linalg.det(p.cell.matrix)))
    assert_close(p.info["pressure"], pressure, rtol=1e-12, atol=0, what="virial pressure")
    assert_all(mechanics.jamming_failure(p) is None, "rigid")


def test_fire_refreshes_its_verlet_list_in_a_tilted_cell():
    """The 3D sheared packing's FIREs re-listed movers (``geometry.pairs_with`` in the tilted cells)
    and still ended at rest (the test above): the partial refreshes found every new contact."""
    p = sheared(3, 0.45)
    assert_all(p.info["shear_neighbour_refreshes"] > 0, "the partial refresh ran while shearing")


def test_a_sheared_packing_starts_from_the_square_packing_of_its_seed():
    """packing.shear shears the packing packing.shear: 0 makes (not a new random start): the same
    particles, and the same bits as shearing that packing by hand; at the first step it has moved
    with the cell (affinely, plus a small relaxation), not to a new packing."""
    square = sheared(2, 0.0)
    p = sheared(2, 0.3)
    by_hand = shear.quasistatic(square, 0.3, 0.01, FORCE_TOL)
    assert_all(np.array_equal(p.positions, by_hand.positions) and np.array_equal(p.diameters, square.diameters),
               "generate shears the square packing")
    first = sheared(2, 0.01)
    affine = square.positions + 0.01 * square.positions[:, 1:2] * np.eye(2)[0]
    moved = np.linalg.norm(geometry.minimum_image(first.positions - affine, first.cell), axis=1)
    assert_all(moved.max() < 0.1, f"one step from the square packing: off the affine shear by {moved.max():.3g} d0")


def test_quasistatic_shear_of_a_square_packing_is_at_rest_in_its_tilted_cell():
    """shear.quasistatic to 0.05 in steps of 0.02 (0.02, 0.04, then 0.01 to 0.05): at rest in the
    cell tilted by 0.05 L (FIRE's forces recomputed), and moved (not the square packing back)."""
    square = jammed_packing(64, 0.88, 5)
    p = shear.quasistatic(square, 0.05, step=0.02)
    assert_close(p.cell.tilt, np.array([0.05 * square.box[0]]), rtol=1e-12, atol=0.0, what="tilt")
    assert_close(shear.strains(0.05, 0.02), np.array([0.02, 0.04, 0.05]), rtol=1e-12, atol=0.0, what="strains")
    assert_all(p.info["shear_steps"] == 3 and p.info["shear_step"] == 0.02, "three steps recorded")
    force, _ = mechanics.FrictionlessForces(p.diameters, p.cell)(p.positions)
    assert_all(np.abs(force).max() < FORCE_TOL, "at rest")
    moved = geometry.minimum_image(p.positions - square.positions, p.cell)
    assert_all(np.abs(moved).max() > 1e-3, "it did shear (not the square packing back)")


SEEDS = (1, 2, 3)


@pytest.fixture(scope="module")
def stress_ratios():
    """sigma_xy / p (R, 3) of 256 disks at phi = 0.9 for each of ``SEEDS``: the square packing, and it
    sheared to gamma = +0.2 and -0.2."""
    ratios = []
    for seed in SEEDS:
        row = []
        for strain in (0.0, 0.2, -0.2):
            p = jammed.generate(256, 0.9, np.random.SeedSequence([seed, 0]), force_tol=FORCE_TOL, shear=strain)
            sigma = mechanics.stress(p)["stress"]
            if strain:
                assert_close(p.info["sigma_xy"], sigma[0, 1], rtol=1e-12, atol=0, what="sigma_xy recorded")
            row.append(sigma[0, 1] / p.info["pressure"])
        ratios.append(row)
    return np.array(ratios)


def test_a_sheared_packing_carries_the_shear_stress_of_its_sign(stress_ratios):
    """Sheared by +gamma every packing has a smaller sigma_xy (compressive positive: it resists a
    positive shear) than sheared by -gamma; on average the +gamma packings lie below their square
    packings (the negative control: a finite packing's residual sigma_xy, noise of either sign,
    a few % of p at N = 256) and the -gamma ones above, by well over 2 % of p.  FIRE from a random
    start in the tilted cell (the method before) had no such order: its sigma_xy was noise of
    either sign (docs/boxes.md; on these seeds +0.2 gave the larger sigma_xy in two of three)."""
    square, plus, minus = stress_ratios.T
    assert_all(np.all(plus < minus), f"sigma_xy / p per seed (square, +0.2, -0.2): {stress_ratios}")
    assert_all(plus.mean() < square.mean() < minus.mean(), f"the square packings between: {stress_ratios}")
    assert_all(np.mean(minus - plus) / 2 > 0.02, f"a shear stress over the noise: {stress_ratios}")


def test_shear_zero_is_the_square_packing():
    plain = jammed.generate(64, 0.9, np.random.SeedSequence([11, 0]))
    zero = sheared(2, 0.0)
    assert_all(zero.tilt is None and "shear" not in zero.info, "no tilt")
    assert_all(np.array_equal(plain.positions, zero.positions), "the same packing")


def test_a_sheared_packing_is_written_and_read_back_bit_for_bit(tmp_path):
    p = sheared(2, 0.3)
    path = str(tmp_path / "sheared.h5")
    hdf5.save_packings(path, [p])
    with h5py.File(path) as f:
        assert_all(np.array_equal(f["packings/0000"].attrs["tilt"], p.tilt), "attribute tilt")
        assert_all("periodic" not in f["packings/0000"].attrs, "all periodic: no attribute")
    (read,) = hdf5.read_packings(path)
    for name in ("positions", "diameters", "box", "rattler", "tilt"):
        assert_all(np.array_equal(getattr(read, name), getattr(p, name)), f"{name} read back")
    assert_all(read.periodic is None and read.info["pressure"] == p.info["pressure"], "the same packing")
    walled = dataclasses.replace(p, tilt=None, periodic=np.array([True, False]))  # walls along y: no images
    hdf5.save_packings(path, [walled])
    (read,) = hdf5.read_packings(path, check_equilibrium=False)  # without its images it is not at rest
    assert_all(np.array_equal(read.periodic, walled.periodic) and read.tilt is None, "periodic read back")


def test_the_unit_store_keeps_the_cell_and_the_content_key_sees_it():
    p = sheared(2, 0.3)
    back = unit_store.packing_from_unit(unit_store.packing_unit(p))
    assert_all(np.array_equal(back.tilt, p.tilt) and back.periodic is None, "tilt kept")
    walled = dataclasses.replace(p, periodic=np.array([True, False]), tilt=None)
    back = unit_store.packing_from_unit(unit_store.packing_unit(walled))
    assert_all(np.array_equal(back.periodic, walled.periodic) and back.tilt is None, "periodic kept")
    scene = scene_of("out.h5", packing={"n": 64, "phi": 0.9})
    square = dataclasses.replace(p, tilt=None)
    keys = [unit_keys.scene_keys(scene, [q], [])["matrices/r00_p0000"].digest for q in (p, square, walled)]
    assert_all(len(set(keys)) == 3, "the tilt and the walls change the matrix's key")


def test_from_arrays_keeps_a_cells_tilt_and_periodic_axes():
    p = sheared(2, 0.3)
    cell = geometry.Cell(p.box, np.array([-0.2 * p.box[0]]), np.array([True, True]))
    q = jammed.from_arrays(p.positions + 0.5, p.diameters, cell)
    assert_all(np.array_equal(q.tilt, cell.tilt) and q.periodic is None, "tilt kept, all periodic")
    s = np.linalg.solve(cell.matrix, q.positions.T)
    assert_all(np.all((s >= 0) & (s < 1)), "positions folded into the tilted cell")
    orthogonal = jammed.from_arrays(p.positions, p.diameters, geometry.Cell.of(p.box, 2))
    assert_all(orthogonal.tilt is None and orthogonal.periodic is None, "an orthogonal periodic cell: as sides")


@pytest.mark.parametrize("attrs, fragment", [({"tilt": [0.6]}, "beyond half the side L_x"),
                                             ({"tilt": [0.1, 0.0]}, "need 1 finite number, the cell's tilt factor xy"),
                                             ({"tilt": [np.nan]}, "need 1 finite number"),
                                             ({"periodic": [1, 1]}, "attribute 'periodic' = [1, 1]: need 2 booleans")])
def test_a_bad_cell_in_a_packing_file_is_named(tmp_path, attrs, fragment):
    p = sheared(2, 0.0)
    path = str(tmp_path / "bad.h5")
    hdf5.save_packings(path, [p])
    with h5py.File(path, "r+") as f:
        for key, value in attrs.items():
            f["packings/0000"].attrs[key] = np.asarray(value) * (p.box[0] if key == "tilt" else 1)
    with pytest.raises(InputError, match="packing file .*bad.h5") as raised:
        hdf5.read_packings(path)
    assert_all(fragment in str(raised.value), str(raised.value))


def test_a_wet_sheared_packing_is_at_rest_with_its_bridges_through_the_cells_images(tmp_path):
    """A wet packing sheared with its capillary bridges carried from step to step: every bridged
    pair apart is within its rupture distance through the tilted cell's nearest image (brute
    force), and the packing is at rest with them."""
    from solver import capillary
    from solver.capillary import Cohesion

    cohesion = Cohesion("willett", surface_tension=0.002, volume=1e-3)
    p = jammed.generate(128, 0.86, np.random.SeedSequence(5), cohesion=cohesion, shear=0.4, shear_step=0.05)
    assert_all(p.tilt is not None and len(p.bridges) > 0, "tilted, with bridges apart")
    i, j = p.bridges[:, 0], p.bridges[:, 1]
    images = np.stack(np.meshgrid(*[[-1, 0, 1]] * 2, indexing="ij"), -1).reshape(-1, 2) @ p.cell.matrix.T
    gap = (np.linalg.norm((p.positions[i] - p.positions[j])[:, None, :] + images[None], axis=2).min(axis=1)
           - 0.5 * (p.diameters[i] + p.diameters[j]))
    assert_all(np.all((gap > 0) & (gap < capillary.rupture_distance(0.5 * p.diameters[i], 0.5 * p.diameters[j],
                                                                      cohesion))), "bridges apart, not broken")
    mechanics.require_equilibrium(p, "the wet sheared packing")
    path = str(tmp_path / "wet.h5")
    hdf5.save_packings(path, [p])
    (read,) = hdf5.read_packings(path, model=p.model)  # its bridges checked in the tilted cell, and its rest
    assert_all(np.array_equal(read.bridges, p.bridges) and np.array_equal(read.positions, p.positions), "read back")
    cached = unit_store.packing_from_unit(unit_store.packing_unit(p))  # the cache rebuilds the model from the info
    assert_all(cached.model.cohesion == cohesion and np.array_equal(cached.bridges, p.bridges), "wet in the cache")


def test_a_tilted_packings_stored_tangential_forces_are_read_through_the_cells_images(tmp_path):
    """Stored forces on contacts across the tilted faces pass the file's checks (each pair touches,
    each force is tangential) only in the tilted cell."""
    p = with_random_stored_forces(sheared(2, 0.3), 11)
    path = str(tmp_path / "stressed.h5")
    hdf5.save_packings(path, [p])
    (read,) = hdf5.read_packings(path, check_equilibrium=False)  # random forces: not at rest
    assert_all(np.array_equal(read.tangential.pairs, p.tangential.pairs), "every stored pair kept")
    # the reader projects the normal part out again: round-off, as for an orthogonal packing
    assert_close(read.tangential.force, p.tangential.force, rtol=0, atol=1e-14 * np.abs(p.tangential.force).max(),
                 what="and its force")
    i, j, _ = brute_contacts(p.positions, p.diameters, p.cell)
    assert_all(set(zip(i, j)) == set(map(tuple, read.tangential.pairs)), "the stored pairs are the contacts")


def test_the_recipe_key_of_a_generated_packing_holds_its_shear():
    keys = [unit_keys.packing_key(scene_of("out.h5", packing={"n": 64, "phi": 0.9, **strain}), 0)
            for strain in ({}, {"shear": 0.0}, {"shear": 0.3}, {"shear": -0.3}, {"shear": 0.3, "shear_step": 0.02},
                           {"shear_step": 0.02})]
    digests = [key.digest for key in keys]
    assert_all(digests[0] == digests[1] == digests[5] and len(set(digests)) == 4,
               "shear 0 keeps the key of before whatever the step; the shear and its step change it")
    before = keys[0].parts  # the key FIRE in the tilted cell had: the square's settings and the shear
    before["settings"]["shear"] = 0.3
    assert_all(unit_keys.UnitKey.of(**before).digest != digests[2], "the packings made before are not found again")


def test_a_tilted_cell_narrower_than_two_diameters_is_refused(tmp_path):
    """Sides 2.2 > 2 d, but tilted by half a side the cell is 2.2 / sqrt(1.25) = 1.97 across: a pair
    could touch through two images."""
    path = str(tmp_path / "narrow.h5")
    with h5py.File(path, "w") as f:
        f["positions"] = np.array([[0.3, 0.4], [1.4, 1.5]])
        f["diameters"] = np.ones(2)
        f.attrs["box"] = [2.2, 2.2]
        f.attrs["tilt"] = [1.1]
    with pytest.raises(InputError, match=r"narrow.h5: the cell of box = \[2.2, 2.2\] tilted by tilt = \[1.1\] is "
                                         r"1.968 across at its narrowest: every height must be > 2 max\(diameters\)"):
        hdf5.read_packings(path)
