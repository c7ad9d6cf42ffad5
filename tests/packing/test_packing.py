"""Packings: FIRE convergence, reproducibility, rattler rule, file round trip, bad files."""

import dataclasses

import h5py
import numpy as np
import pytest
from conftest import COMM, all_pairs, assert_all, assert_close, jammed_packing

from solver.contact_law import ContactModel
from solver import parallel
from solver.packing import geometry
from solver.packing import fire
from solver.io import hdf5
from solver.packing import jammed
from solver.packing import mechanics
from solver.errors import InputError


def test_fire_minimises_a_quadratic_monotonically_enough():
    """FIRE is not monotone step by step (an uphill step is undone by zeroing v and stepping
    back), but enough: the energy rises on at most 5 % of the steps (measured 2 %), and the
    largest energy of each block of 10 steps never exceeds that of the block before."""
    rng = np.random.default_rng(0)
    stiffness = rng.uniform(0.1, 2.0, size=(50, 2))
    energies = []

    def forces(x):
        energies.append(0.5 * np.sum(stiffness * x * x))
        return -stiffness * x, energies[-1]

    result = fire.minimize(rng.normal(size=(50, 2)), forces, 1e-10, 10_000)
    assert result.converged
    # the forces at the returned x, recomputed here (result.max_force < tol holds by construction)
    assert np.sqrt(np.sum((stiffness * result.x) ** 2, axis=1)).max() < 1e-10
    assert np.abs(result.x).max() < 1e-9  # |x| <= |F| / min(stiffness) = 1e-10 / 0.1
    e = np.array(energies)
    assert e[-1] < 1e-18 * e[0]  # E <= 100 (1e-10)^2 / (2 0.1) = 5e-18, E(0) ~ 50
    rises = int(np.sum(np.diff(e) > 0))
    assert rises <= 0.05 * e.size, f"energy rose on {rises} of {e.size} steps"
    block_max = e[: e.size // 10 * 10].reshape(-1, 10).max(axis=1)
    assert np.all(np.diff(block_max) <= 0), f"block maxima {block_max}"


def test_generated_packing_is_jammed_and_converged(small_packing):
    p = small_packing
    # the box against the mixture's area (32 disks of d = 1/1.2 and 32 of 1.4/1.2, the paper's
    # d0 = 1), not p.phi (computed from the box that was computed from phi)
    area = np.pi / 4 * 32 * ((1 / 1.2) ** 2 + (1.4 / 1.2) ** 2)
    assert_close(p.box_length, np.sqrt(area / 0.9), rtol=1e-15, what="box length")
    assert_close(np.pi / 4 * np.sum(p.diameters**2) / p.box_length**2, 0.9, rtol=1e-15, what="phi of the disks")
    assert 4.0 < p.info["z"] < 6.0            # PHYSICS.md: z ~ 4.9 at phi = 0.9
    assert 0.01 < p.info["mean_overlap"] < 0.04
    assert np.all((p.positions >= 0) & (p.positions < p.box_length))
    assert_close(np.unique(p.diameters), [1 / 1.2, 1.4 / 1.2], rtol=np.finfo(float).eps, what="diameters")
    assert np.sum(p.diameters < 1) == 32


@pytest.mark.parametrize("dim", [2, 3])
def test_force_balance_independently(small_packing, dim):
    """The net harmonic force on every particle, recomputed from the returned positions over all
    N^2 pairs with the minimum image (not FIRE's forces, its neighbour list or the package's
    contact search), is below FIRE's force_tol = 1e-6 (contact forces are ~0.025 in 2D, ~0.017
    in 3D): a force loop over x and y only, or a z column left out of the neighbour list, leaves
    net forces of order 1e-2."""
    p = small_packing if dim == 2 else jammed_packing(128, 0.7, 3, dim=3)  # test_packing_3d's spheres
    overlap, delta, distance = all_pairs(p)
    net = np.sum((overlap / distance)[..., None] * delta, axis=1)
    worst = np.sqrt(np.sum(net**2, axis=1)).max()
    assert worst < 1e-6, worst


def test_same_seed_same_packing_on_any_rank_count(comm):
    seeds = [parallel.seed_sequence(5, i) for i in range(3)]
    made = parallel.owner_compute(COMM, seeds, lambda s: jammed.generate(32, 0.88, s))
    ref = jammed.generate(32, 0.88, parallel.seed_sequence(5, 1))
    assert_all(np.array_equal(made[1].positions, ref.positions), "rank-dependent packing")
    assert_all(not np.array_equal(made[0].positions, made[1].positions), "configs identical")


def test_rattler_rule_is_a_fixed_point():
    """Near jamming rattlers are common; after removal every kept disk has >= 3 kept contacts."""
    p = jammed.generate(256, 0.845, np.random.SeedSequence([11, 0]))
    found = geometry.find_contacts(p.positions, p.diameters, p.box_length, ~p.rattler)
    kept = found.count_per_particle(p.n)[~p.rattler]
    assert p.rattler.sum() >= 1
    assert kept.min() >= mechanics.min_contacts(2)
    # each rattler really is one under the rule applied to the packing without it
    everyone = geometry.find_contacts(p.positions, p.diameters, p.box_length).count_per_particle(p.n)
    one_pass = everyone < mechanics.min_contacts(2)
    assert np.all(p.rattler[one_pass]), "first-pass rattlers must be rattlers"


def test_packing_file_round_trip(shared_tmp, small_packing):
    path = shared_tmp / "round.h5"
    if COMM.rank == 0:
        hdf5.save_packings(str(path), [small_packing, small_packing])
    COMM.Barrier()
    back = hdf5.read_packings(str(path))
    assert_all(len(back) == 2 and np.array_equal(back[1].positions, small_packing.positions)
               and np.array_equal(back[0].rattler, small_packing.rattler), "round trip")
    assert_all(len(hdf5.read_packings(str(path), count=1)) == 1, "count")
    COMM.Barrier()


def test_external_packing_single_group(shared_tmp, small_packing):
    """A hand-made file from 'another code': top-level datasets, no rattler flag, shifted box."""
    path = shared_tmp / "external.h5"
    if COMM.rank == 0:
        with h5py.File(path, "w") as f:
            f["positions"] = small_packing.positions - 3.0 * small_packing.box_length
            f["diameters"] = small_packing.diameters
            f.attrs["box_length"] = small_packing.box_length
    COMM.Barrier()
    (p,) = hdf5.read_packings(str(path))
    # folding subtracts multiples of L: round-off ~ eps 3L absolute (measured 2.7e-15)
    folding = 4 * np.finfo(float).eps * 3 * small_packing.box_length
    assert_close(p.positions, small_packing.positions, rtol=0, atol=folding, what="folding into box")
    assert_all(np.array_equal(p.rattler, small_packing.rattler), "rattlers recomputed")
    COMM.Barrier()


@pytest.mark.serial_only
@pytest.mark.parametrize("case, message", [
    ("missing", "not found"),
    ("garbage", "not a readable HDF5"),
    ("no_positions", "no 'positions' dataset"),
    ("no_box", "attribute 'box' .* or 'box_length' .* is missing"),
    ("shape", "'positions' has shape"),
    ("nan", "NaN"),
    ("negative", "> 0"),
    ("small_box", "box_length"),
    ("no_contacts", "all disks are rattlers"),
    ("empty", "no 'positions' dataset"),
])
def test_bad_packing_files(tmp_path, small_packing, case, message):
    path = tmp_path / f"{case}.h5"
    pos, diam, L = small_packing.positions, small_packing.diameters, small_packing.box_length
    if case == "garbage":
        path.write_bytes(b"\x89HDF\r\n\x1a\n truncated")
    elif case != "missing":
        with h5py.File(path, "w") as f:
            if case != "no_positions" and case != "empty":
                f["positions"] = {"shape": pos[:, :1], "nan": np.where(pos > 5, np.nan, pos),
                                  "no_contacts": pos * 3}.get(case, pos)
            if case != "empty":
                f["diameters"] = -diam if case == "negative" else diam
            if case not in ("no_box", "empty"):
                f.attrs["box_length"] = {"small_box": 1.0, "no_contacts": 3 * L}.get(case, L)
    with pytest.raises(InputError, match=message) as info:
        hdf5.read_packings(str(path))
    assert str(path) in str(info.value)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_packing_tiled_along_x_is_the_same_packing_in_a_rectangular_box(dim, small_packing, tmp_path, comm):
    """Two copies side by side in a (2L, L[, L]) box: the same contacts per particle, phi, z and
    pressure, still in equilibrium, the box round-trips through a packing file as 'box' (no
    'box_length': the sides differ), and every eigenvalue of the original's dynamical matrix is
    one of the tiled one's (its Bloch k = 0 sector).  A minimum image or a fold that used one side
    for every axis breaks all of these."""
    from solver.model import dynmat
    from solver.references import dense_eigen

    p = small_packing if dim == 2 else jammed_packing(64, 0.7, 3, dim=3)
    shift = np.zeros(dim)
    shift[0] = p.box_length
    box = np.full(dim, p.box_length)
    box[0] *= 2
    tiled = jammed.from_arrays(np.concatenate([p.positions, p.positions + shift]), np.tile(p.diameters, 2), box)
    assert_all(np.array_equal(tiled.rattler, np.tile(p.rattler, 2)), "rattlers differ from the copies'")
    for name in ("z", "pressure", "energy"):
        expected = 2 * p.info[name] if name == "energy" else p.info[name]
        assert_close(tiled.info[name], expected, rtol=1e-12, what=name)
    assert_close(tiled.phi, p.phi, rtol=1e-15, what="phi")
    path = tmp_path / f"tiled{dim}.h5"  # each rank its own file
    hdf5.save_packings(str(path), [tiled])
    with h5py.File(path, "r") as f:
        assert_all("box_length" not in f["packings/0000"].attrs, "box_length written for a non-cubic box")
    back = hdf5.read_packings(str(path))[0]  # also checks equilibrium (net force <= 1e-4)
    assert_all(np.array_equal(back.box, box) and np.array_equal(back.positions, tiled.positions), "round trip")
    with pytest.raises(ValueError, match="not one side length"):
        tiled.box_length
    lam = dense_eigen(dynmat.assemble(p, ContactModel(0.5), comm))[0]
    lam_tiled = dense_eigen(dynmat.assemble(tiled, ContactModel(0.5), comm))[0]
    nearest = np.abs(lam[:, None] - lam_tiled[None, :]).min(axis=1)
    # eigh on 192- and 384-DOF matrices of norm ~10: each eigenvalue to ~1e-13
    assert_close(nearest, np.zeros_like(nearest), rtol=0.0, atol=1e-11 * lam.max(),
                 what="original eigenvalues among the tiled ones")


def test_a_files_masses_round_trip(small_packing, tmp_path):
    """A packing file's optional 'masses' dataset is read, kept on the Packing and written back."""
    masses = np.linspace(0.5, 2.0, small_packing.n)
    path, again = tmp_path / "with_masses.h5", tmp_path / "again.h5"
    with h5py.File(path, "w") as f:
        f["positions"], f["diameters"] = small_packing.positions, small_packing.diameters
        f.attrs["box_length"] = small_packing.box_length
        f["masses"] = masses
    p = hdf5.read_packings(str(path))[0]
    hdf5.save_packings(str(again), [p])
    back = hdf5.read_packings(str(again))[0]
    assert_all(np.array_equal(p.masses, masses) and np.array_equal(back.masses, masses), "masses lost")


def test_an_unbalanced_file_is_refused_and_relax_re_minimises_it(small_packing, tmp_path):
    """A packing whose normal forces do not balance (here: a jammed one shaken by up to 0.02 d0, as
    a frictional DEM packing would look to the normal forces) is refused with the message that
    offers packing.relax; with relax: true, FIRE takes it back to a jammed minimum of the normal
    energy, in equilibrium to force_tol under the FIRE forces and to the file check."""
    from solver import pipeline
    from solver.io import coerce, schema

    rng = np.random.default_rng(4)
    path = str(tmp_path / "shaken.h5")  # each rank its own copy
    with h5py.File(path, "w") as f:
        f["positions"] = small_packing.positions + rng.uniform(-0.02, 0.02, small_packing.positions.shape)
        f["diameters"] = small_packing.diameters
        f.attrs["box_length"] = small_packing.box_length
    scene = {"packing": {"file": path}, "output": str(tmp_path / "out.h5")}
    with pytest.raises(InputError, match="packing.relax: true"):
        pipeline.make_packings(coerce.build(schema.Scene, scene), COMM)
    scene["packing"]["relax"] = True
    relaxed, = pipeline.make_packings(coerce.build(schema.Scene, scene), COMM)
    f, _ = mechanics.FrictionlessForces(relaxed.diameters, relaxed.box)(relaxed.positions)
    assert_all(np.sqrt((f ** 2).sum(axis=1)).max() < 1e-6 and mechanics.net_force(relaxed) < 1e-6,
               "relaxed packing not in equilibrium")
    assert_all(relaxed.info["relaxed"] and mechanics.jamming_failure(relaxed) is None, "not a jammed packing")


@pytest.mark.serial_only  # FIRE and forces on one process, no communicator
@pytest.mark.parametrize("dim", [2, 3])
def test_hertz_packings_balance_under_hertz_forces_only(dim):
    """model.law: hertz makes FIRE minimise the Hertz normal energy: the packing is jammed and in
    equilibrium under Hertz forces, and not under harmonic ones (the two laws weigh
    overlaps differently, so one law's minimum is off balance under the other)."""
    p = jammed_packing(64, 0.9 if dim == 2 else 0.7, 2, dim=dim, law="hertz")
    assert_all(p.info["law"] == "hertz" and mechanics.jamming_failure(p) is None, "not a jammed Hertz packing")
    assert p.model.law == "hertz", "the packing does not record the law it was made under"
    hertz, harmonic = mechanics.net_force(p), mechanics.net_force(dataclasses.replace(p, model=ContactModel()))
    # FIRE's criterion holds with the rattlers in; without their contacts ~1e-6 remain on others
    assert_all(hertz < 1e-5 and harmonic > mechanics.EQUILIBRIUM_TOL, f"Hertz {hertz}, harmonic {harmonic}")
