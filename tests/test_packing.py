"""Packings: FIRE convergence, reproducibility, rattler rule, file round trip, bad files."""

import h5py
import numpy as np
import pytest
from conftest import COMM, assert_all

from solver import parallel
from solver.packing import geometry as contacts
from solver.packing import fire
from solver.io import hdf5 as h5io
from solver.packing import jammed as packing
from solver.errors import InputError


def test_fire_minimises_a_quadratic_monotonically_enough():
    rng = np.random.default_rng(0)
    stiffness = rng.uniform(0.1, 2.0, size=(50, 2))
    energies = []

    def forces(x):
        energies.append(0.5 * np.sum(stiffness * x * x))
        return -stiffness * x, energies[-1]

    result = fire.minimize(rng.normal(size=(50, 2)), forces, 1e-10, 10_000)
    assert result.converged and result.max_force < 1e-10
    assert np.abs(result.x).max() < 1e-9
    assert energies[-1] < 1e-18 * energies[0] + 1e-20


def test_generated_packing_is_jammed_and_converged(small_packing):
    p = small_packing
    assert p.info["max_force"] < 1e-6
    assert abs(p.phi - 0.9) < 1e-12
    assert 4.0 < p.info["z"] < 6.0            # PHYSICS.md: z ~ 4.9 at phi = 0.9
    assert 0.01 < p.info["mean_overlap"] < 0.04
    assert np.all((p.positions >= 0) & (p.positions < p.box_length))
    d = np.sort(np.unique(np.round(p.diameters, 12)))
    np.testing.assert_allclose(d, [1 / 1.2, 1.4 / 1.2])
    assert np.sum(p.diameters < 1) == 32


def test_force_balance_independently(small_packing):
    p = small_packing
    found = contacts.find_contacts(p.positions, p.diameters, p.box_length)
    f = found.overlap[:, None] * found.normal
    net = np.zeros((p.n, 2))
    np.add.at(net, found.i, f)
    np.add.at(net, found.j, -f)
    assert np.sqrt((net**2).sum(axis=1)).max() < 1e-6


def test_same_seed_same_packing_on_any_rank_count(comm):
    seeds = [parallel.seed_sequence(5, i) for i in range(3)]
    made = parallel.owner_compute(COMM, seeds, lambda s: packing.generate(32, 0.88, s))
    ref = packing.generate(32, 0.88, parallel.seed_sequence(5, 1))
    assert_all(np.array_equal(made[1].positions, ref.positions), "rank-dependent packing")
    assert_all(not np.array_equal(made[0].positions, made[1].positions), "configs identical")


def test_rattler_rule_is_a_fixed_point():
    """Near jamming rattlers are common; after removal every kept disk has >= 3 kept contacts."""
    p = packing.generate(256, 0.845, np.random.SeedSequence([11, 0]))
    found = contacts.find_contacts(p.positions, p.diameters, p.box_length, ~p.rattler)
    kept = found.count_per_particle(p.n)[~p.rattler]
    assert p.rattler.sum() >= 1
    assert kept.min() >= packing.MIN_CONTACTS
    # each rattler really is one under the rule applied to the packing without it
    everyone = contacts.find_contacts(p.positions, p.diameters, p.box_length).count_per_particle(p.n)
    one_pass = everyone < packing.MIN_CONTACTS
    assert np.all(p.rattler[one_pass]), "first-pass rattlers must be rattlers"


def test_packing_file_round_trip(shared_tmp, small_packing):
    path = shared_tmp / "round.h5"
    if COMM.rank == 0:
        h5io.save_packings(str(path), [small_packing, small_packing])
    COMM.Barrier()
    back = h5io.read_packings(str(path))
    assert_all(len(back) == 2 and np.array_equal(back[1].positions, small_packing.positions)
               and np.array_equal(back[0].rattler, small_packing.rattler), "round trip")
    assert_all(len(h5io.read_packings(str(path), count=1)) == 1, "count")
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
    (p,) = h5io.read_packings(str(path))
    assert_all(np.allclose(p.positions, small_packing.positions, atol=1e-9), "folding into box")
    assert_all(np.array_equal(p.rattler, small_packing.rattler), "rattlers recomputed")
    COMM.Barrier()


@pytest.mark.serial_only
@pytest.mark.parametrize("case, message", [
    ("missing", "not found"),
    ("garbage", "not a readable HDF5"),
    ("no_positions", "no 'positions' dataset"),
    ("no_box", "'box_length' is missing"),
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
        h5io.read_packings(str(path))
    assert str(path) in str(info.value)
