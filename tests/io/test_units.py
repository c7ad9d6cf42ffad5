"""The unit store: units keyed by content (settings, the PETSc options acting on the stage,
version), and file errors on rank 0 raised on every rank.  Runs on 1 and 2 ranks."""

import errno
import json

import h5py
import numpy as np
import pytest
import yaml
from conftest import COMM, assert_all, assert_close, run_stopped_after_windows, scene_of

from solver import pipeline
from solver.io import coerce, schema
from solver.io import unit_keys, unit_store

SCENE = """\
output: {out}
cache: {cache}
seed: 3
packing: {{n: 32, phi: 0.9, count: 1}}
model: {{rho: [1.0]}}
spectrum: {{method: slicing, max_window_modes: 20}}
waves: {{modes: [L], n: [1, 2], t_end: 40, dt: 0.05}}
"""


def make(folder, name, cache="off"):
    return coerce.build(schema.Scene, yaml.safe_load(SCENE.format(out=folder / f"{name}.h5", cache=cache)))


def run(scene, argv, capsys):
    """pipeline.run on COMM_WORLD; rank 0's log (the same string on every rank)."""
    capsys.readouterr()
    pipeline.run(scene, COMM, argv)
    return COMM.bcast(capsys.readouterr().out, root=0)


def counts(log) -> dict[str, str]:
    """{stage: '1 computed, 2 resumed'} from the log's closing 'units: ...' line."""
    line = [line for line in log.splitlines() if line.startswith("units: ")][0]
    stages = line[len("units: "):].split(" (folder ")[0].split("; ")
    return dict(stage.split(" ", 1) for stage in stages)


def group_options(path, group):
    with h5py.File(path, "r") as f:
        return json.loads(f[group].attrs["petsc_options"])


def test_options_acting_on_a_stage_key_its_units(shared_tmp, capsys):
    """A rerun with an option acting on spectra recomputes the spectra only, and says why;
    -log_view (acting on no unit) recomputes nothing; each unit records the options that
    produced it; dropping the option again takes the spectrum from the cache."""
    scene = make(shared_tmp, "keyed", cache=str(shared_tmp / "cache"))
    out = shared_tmp / "keyed.h5"
    run(scene, [], capsys)
    log = run(scene, ["-log_view"], capsys)
    assert_all(counts(log) == {"matrices": "1 resumed", "packings": "1 resumed", "spectra": "1 resumed",
                               "waves": "1 resumed"}, counts(log))
    assert_all("recomputing" not in log, log)

    log = run(scene, ["-spectrum_eps_tol", "1e-10", "-log_view"], capsys)
    assert_all("spectra/r00_p0000: recomputing: PETSc options acting on it changed "
               "(-spectrum_eps_tol 1e-10, was none)" in log.splitlines(), log)
    found = counts(log)
    assert_all(found.pop("spectrum_windows", "").endswith(" computed") and found == {
        "matrices": "1 resumed", "packings": "1 resumed", "spectra": "1 computed", "waves": "1 resumed"}, counts(log))
    assert_all(group_options(out, "spectra/r00_p0000") == {"spectrum_eps_tol": "1e-10"}, "spectrum's options")
    assert_all(group_options(out, "waves/r00_L_p0000") == {} and group_options(out, "matrices/r00_p0000") == {},
               "waves and matrix: no option acted on them")

    log = run(scene, [], capsys)
    assert_all("spectra/r00_p0000: taken from the cache: PETSc options acting on it changed "
               "(-spectrum_eps_tol not set, was 1e-10)" in log.splitlines(), log)
    assert_all(counts(log)["spectra"] == "1 from the cache", counts(log))
    assert_all(group_options(out, "spectra/r00_p0000") == {}, "the cached spectrum's options")


def test_stored_key_parts_say_what_changed():
    """The reason names the part that changed and its old and new values."""
    old = unit_keys.UnitKey.of(unit="spectrum", section="spectrum", rho=1.0, settings={"tol": 1e-12, "window": None},
                           options={"spectrum_eps_tol": "1e-6", "spectrum_eps_view": None}, version="0.1.0")
    new = unit_keys.UnitKey.of(unit="spectrum", section="spectrum", rho=1.0, settings={"tol": 1e-10, "window": None},
                           options={"spectrum_st_type": "sinvert"}, version="0.2.0")
    assert new.digest != old.digest
    assert new.changes(old.parts_json) == (
        "PETSc options acting on it changed (-spectrum_eps_tol not set, was 1e-6; -spectrum_eps_view not set, "
        "was set; -spectrum_st_type sinvert, was none); spectrum settings changed (tol 1e-12 -> 1e-10); "
        "version changed (0.1.0 -> 0.2.0)")
    assert new.changes(None) == "no content key stored (written by an older rotsound)"


def test_a_packing_of_an_earlier_fire_is_recomputed_not_resumed(shared_tmp, capsys, small_packing):
    """A packing stored under its recipe's key of before FIRE had a version (issue 60: FIRE on
    every core changed its steps, so its packings) is recomputed, not resumed, and the log says
    why; the same before the key had the version (it would have been resumed)."""
    from solver.packing import fire

    scene = make(shared_tmp, "fire_version")
    store = unit_store.UnitStore(scene.output, "scene: fire version\n", "d3", COMM)
    now = unit_keys.packing_key(scene, 0)
    before = unit_keys.UnitKey.of(**{**now.parts, "settings": {k: v for k, v in now.parts["settings"].items()
                                                               if k != "fire"}})
    store.save("packings/0000", *unit_store.packing_unit(small_packing), key=before)
    store.counts.clear()  # that save counted as computed
    capsys.readouterr()
    made = pipeline.make_packings(scene, COMM, store)
    log = COMM.bcast(capsys.readouterr().out, root=0)
    assert_all(f"packings/0000: recomputing: packing settings changed (fire none -> {fire.VERSION})"
               in log.splitlines(), log)
    assert_all(store.counts["packings"] == {"resumed": 0, "cache": 0, "computed": 1}, store.counts)
    assert_all(made[0].n == 32, "the stored 64-disk packing was taken")


def test_window_checkpoint_of_other_options_is_discarded(shared_tmp, capsys, monkeypatch):
    """A spectrum stopped after two windows, resumed with an option acting on spectra: the
    saved plan and windows are recomputed (never mixed in), and the log says why once."""
    windowed = dict(cache="off", seed=5, packing={"n": 32, "phi": 0.9, "count": 1}, model={"rho": [1.0]},
                    spectrum={"energies": True, "max_window_modes": 20})
    scene = scene_of(shared_tmp / "cut.h5", **windowed)
    reference = pipeline.run(scene_of(shared_tmp / "ref.h5", **windowed), COMM, [])["units"]["spectra/r00_p0000"][0]
    calls = run_stopped_after_windows(monkeypatch, scene)
    capsys.readouterr()
    resumed = pipeline.run(scene, COMM, ["-spectrum_eps_tol", "1e-12"])["units"]["spectra/r00_p0000"][0]
    log = COMM.bcast(capsys.readouterr().out, root=0)
    windows = len(calls) - 2
    assert_all(windows >= 3, f"{windows} windows")
    assert_all("spectrum_windows/r00_p0000_plan: recomputing: PETSc options acting on it changed "
               "(-spectrum_eps_tol 1e-12, was none)" in log.splitlines(), log)
    assert_all(log.count("recomputing") == 1, "said once")
    assert_all(counts(log)["spectrum_windows"] == f"{windows + 1} computed", counts(log))
    for key, value in reference.items():  # atol: K or Q of ~0 (as in test_spectrum's resume test)
        assert_close(resumed[key], value, rtol=1e-9, atol=1e-14, what=key)


# --- errors on rank 0 reach every rank --------------------------------------------------------

FAILURES = {"ENOSPC": lambda: OSError(errno.ENOSPC, "No space left on device (injected)"),
            "RuntimeError": lambda: RuntimeError("injected")}


def fail_on_rank0(monkeypatch, target, attribute, failure):
    """Make ``target.attribute`` raise ``failure()`` on rank 0 only."""
    def fail(*args, **kwargs):
        raise FAILURES[failure]()
    if COMM.rank == 0:
        monkeypatch.setattr(target, attribute, fail)


def outcome(action) -> str:
    """Name of the exception ``action()`` raised on this rank, or 'none'."""
    try:
        action()
    except Exception as exc:  # noqa: BLE001 - the test compares what every rank saw
        return type(exc).__name__
    return "none"


def assert_every_rank(got: str, expected: str) -> None:
    seen = COMM.allgather(got)
    assert_all(seen == [expected] * COMM.size, f"raised per rank {seen}, expected {expected} everywhere")


def key(n):
    return unit_keys.UnitKey.of(unit="test", n=n)


@pytest.fixture
def store(shared_tmp):
    made = unit_store.UnitStore(str(shared_tmp / "out.h5"), "scene: test\n", "d1", COMM,
                                cache=str(shared_tmp / "cache"))
    made.save("spectra/r00_p0000", {"omega": np.arange(3.0)}, {"rho": 1.0}, key(1))
    return made


@pytest.mark.mpi
@pytest.mark.timeout(60)
@pytest.mark.parametrize("failure", sorted(FAILURES))
@pytest.mark.parametrize("attribute", ["replace", "makedirs"])
def test_scene_claim_error_on_rank0_raises_everywhere(shared_tmp, monkeypatch, attribute, failure):
    fail_on_rank0(monkeypatch, unit_store.os, attribute, failure)
    got = outcome(lambda: unit_store.UnitStore(str(shared_tmp / "out.h5"), "scene: test\n", "d1", COMM))
    assert_every_rank(got, "InputError" if failure == "ENOSPC" else "RuntimeError")


@pytest.mark.mpi
@pytest.mark.timeout(60)
@pytest.mark.parametrize("failure", sorted(FAILURES))
@pytest.mark.parametrize("operation, target, attribute", [
    ("save", "h5py", "File"),          # writing the unit file
    ("save", "os", "replace"),         # renaming it into place
    ("save", "shutil", "copyfile"),    # entering it in the cache (after os.link fails below)
    ("load", "h5py", "File"),          # reading a unit file
    ("load_cache", "os", "replace"),   # linking a cache entry into the folder
    ("discard", "os", "remove"),
    ("window_save", "h5py", "File"),
    ("window_load", "h5py", "File"),
    ("window_clear", "os", "remove"),
])
def test_unit_store_error_on_rank0_raises_everywhere(store, shared_tmp, monkeypatch, operation, target, attribute,
                                                     failure):
    """Full disk (ENOSPC) or any other exception on rank 0: every rank raises it (an unreadable
    unit file is a damaged one: recomputed, on every rank alike), and no rank is left waiting."""
    import os
    import shutil

    checkpoint = unit_store.WindowCheckpoint(store, "r00_p0000", key(1))
    checkpoint.save("window0000", {"lam": np.arange(2.0)})
    other = unit_store.UnitStore(str(shared_tmp / "other.h5"), "scene: other\n", "d2", COMM, cache=store.cache)
    if target == "shutil":  # no hard links: the cache entry is a copy
        fail_on_rank0(monkeypatch, os, "link", "ENOSPC")
    fail_on_rank0(monkeypatch, {"h5py": h5py, "os": os, "shutil": shutil}[target], attribute, failure)
    action = {
        "save": lambda: store.save("spectra/r00_p0001", {"omega": np.arange(2.0)}, {}, key(2)),
        "load": lambda: store.load("spectra/r00_p0000", key(1)),
        "load_cache": lambda: other.load("spectra/r00_p0000", key(1)),
        "discard": lambda: store.discard("spectra/r00_p0000"),
        "window_save": lambda: checkpoint.save("window0001", {"lam": np.arange(2.0)}),
        "window_load": lambda: checkpoint.load("window0000"),
        "window_clear": checkpoint.clear,
    }[operation]
    expected = "RuntimeError" if failure == "RuntimeError" else "OSError"
    if operation in ("load", "window_load") and failure == "ENOSPC":
        expected = "none"  # an unreadable file counts as missing (h5py raises OSError for those)
    assert_every_rank(outcome(action), expected)
    monkeypatch.undo()
    assert_every_rank(outcome(lambda: store.save("spectra/r00_p0002", {}, {}, key(3))), "none")  # still in step
