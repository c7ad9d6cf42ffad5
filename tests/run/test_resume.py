"""Resume after a kill: finished units are kept, the rerun's file equals an uninterrupted run's."""

import os
import random
import shutil
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest
from conftest import COMM, REPO, child_env, main_here, mpirun, run_cli, run_stopped_after_windows, scene_of, scene_text

pytestmark = pytest.mark.serial_only  # these tests launch and kill their own mpirun jobs

SCENE = """\
output: {out}
cache: off
seed: 5
packing: {{n: 64, phi: 0.9, count: 2}}
model: {{rho: [0.5, 1.0]}}
spectrum: {{energies: true}}
waves: {{n: [1, 2], t_end: 60, dt: 0.02}}  # about 6 s of waves after the third unit: the kill lands in them
"""
TIMING = {"seconds", "assembly_seconds"}

WINDOWED = dict(cache="off", seed=5, packing={"n": 64, "phi": 0.9, "count": 1}, model={"rho": [1.0]},
                spectrum={"energies": True, "max_window_modes": 40})
"""A spectrum of several windows (scene_of's sections), for the window-checkpoint tests."""


@pytest.fixture(scope="module")
def windowed(tmp_path_factory):
    """(datasets, attrs) of WINDOWED's spectrum run uninterrupted in this process, shared by the
    window-checkpoint tests."""
    from solver import pipeline

    out = tmp_path_factory.mktemp("windowed") / "ref.h5"
    return pipeline.run(scene_of(out, **WINDOWED), COMM, [])["units"]["spectra/r00_p0000"]


def scene(tmp_path, name):
    path = tmp_path / f"{name}.yaml"
    path.write_text(SCENE.format(out=tmp_path / f"{name}.h5"))
    return str(path), tmp_path / f"{name}.h5"


def contents(path):
    """{object path: (datasets or attrs without timings)} of a results file."""
    out = {}

    def visit(name, obj):
        attrs = {k: v for k, v in obj.attrs.items() if k not in TIMING}
        out[name + "@attrs"] = attrs
        if isinstance(obj, h5py.Dataset):
            out[name] = obj[()]
    with h5py.File(path) as f:
        f.visititems(visit)
    return out


def equal(a, b) -> bool:
    """Bitwise-equal arrays, NaN equal to NaN (an undetected k_c is NaN)."""
    a, b = np.asarray(a), np.asarray(b)
    return np.array_equal(a, b, equal_nan=a.dtype.kind in "fc" and b.dtype.kind in "fc")


def assert_same(a, b):
    ca, cb = contents(a), contents(b)
    assert sorted(ca) == sorted(cb)
    for key, value in ca.items():
        if key.endswith("@attrs"):
            assert value.keys() == cb[key].keys(), key
            for k in value:
                assert equal(value[k], cb[key][k]), (key, k)
        else:
            assert equal(value, cb[key]), key


def start(scene_path):
    env = child_env()
    return subprocess.Popen(mpirun(2) + [sys.executable, "-m", "solver", "run", scene_path], cwd=REPO,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            start_new_session=True)


def wait_for_units(out, count, proc, timeout=120):
    folder = str(out) + ".units"
    deadline = time.time() + timeout
    while time.time() < deadline and proc.poll() is None:
        if os.path.isdir(folder) and sum(f.endswith(".h5") for f in os.listdir(folder)) >= count:
            return
        time.sleep(0.05)
    if proc.poll() is not None:
        raise AssertionError(f"the run ended (exit code {proc.returncode}) before the kill: {proc.communicate()[1]}")
    raise AssertionError(f"the run stalled before the kill: fewer than {count} units after {timeout} s")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    path, out = scene(tmp_path_factory.mktemp("ref"), "ref")
    proc = run_cli(["run", path], ranks=2, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.mark.spawns_ranks
def test_kill_9_then_resume_equals_uninterrupted(tmp_path, reference):
    path, out = scene(tmp_path, "killed")
    proc = start(path)
    wait_for_units(out, 3, proc)
    time.sleep(random.uniform(0.0, 1.0))  # a random moment
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    assert not out.exists()
    rerun = run_cli(["run", path], ranks=2, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    assert " resumed" in rerun.stdout
    assert_same(out, reference)


@pytest.mark.spawns_ranks
def test_sigterm_stops_cleanly_and_resumes(tmp_path, reference):
    path, out = scene(tmp_path, "termed")
    proc = start(path)
    wait_for_units(out, 3, proc)
    # to the ranks, as the manual says (docs/scale.md; a SIGTERM to Open MPI's mpirun tears the job down)
    ranks = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True).stdout.split()
    assert len(ranks) == 2, ranks
    for pid in ranks:
        os.kill(int(pid), signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode != 0
    assert "stopped by SIGTERM" in err and "Traceback" not in err
    rerun = run_cli(["run", path], ranks=2, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    assert_same(out, reference)


@pytest.mark.spawns_ranks
def test_damaged_unit_is_recomputed(tmp_path, reference):
    """The reference run's units (the same scene: its digest leaves the output out), one of them
    cut short: the rerun recomputes it and equals the uninterrupted run."""
    path, out = scene(tmp_path, "damaged")
    shutil.copytree(str(reference) + ".units", str(out) + ".units")
    unit = sorted(p for p in os.listdir(str(out) + ".units") if p.startswith("spectra"))[0]
    with open(os.path.join(str(out) + ".units", unit), "r+b") as f:
        f.truncate(100)
    rerun = run_cli(["run", path], ranks=2, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    assert f"{unit} is damaged or incomplete: recomputing it" in rerun.stdout
    assert_same(out, reference)


def test_different_scene_same_output_is_refused(tmp_path, capsys):
    small = "output: {out}\ncache: off\nseed: 5\npacking: {{n: 64, phi: 0.9}}\nmodel: {{rho: [0.5]}}\nspectrum: {{}}\n"
    out = tmp_path / "first.h5"
    path = tmp_path / "first.yaml"
    path.write_text(small.format(out=out))
    assert main_here(["run", str(path)], capsys)[0] == 0  # the first results, made in this process
    other = tmp_path / "other.yaml"
    other.write_text(small.format(out=out).replace("seed: 5", "seed: 6"))
    proc = run_cli(["run", str(other)], ranks=2)
    assert proc.returncode == 2 and "different scene" in proc.stderr and "--fresh" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr
    fresh = run_cli(["run", str(other), "--fresh"], ranks=2)
    assert fresh.returncode == 0 and "resumed" not in fresh.stdout, fresh.stderr


def test_sigterm_mid_spectrum_keeps_finished_windows(tmp_path, monkeypatch, capsys, windowed):
    """SIGTERM during a many-window spectrum stops after the window in flight; the rerun takes
    the plan and the finished windows from the units folder and equals an uninterrupted run."""

    from solver import pipeline

    make = lambda name: scene_of(tmp_path / name, **WINDOWED)  # noqa: E731
    reference = windowed[0]
    calls = run_stopped_after_windows(monkeypatch, make("cut.h5"))
    assert len(calls) == 2
    capsys.readouterr()
    resumed = pipeline.run(make("cut.h5"), COMM, [])["units"]["spectra/r00_p0000"][0]
    log = capsys.readouterr().out
    # 5 windows: the plan and windows 0, 1 resumed; windows 2, 3, 4 computed
    assert "spectrum_windows 3 computed, 3 resumed" in log, log
    assert len(calls) == 5
    assert not list((tmp_path / "cut.h5.units").glob("spectrum_windows*")), "window files removed"
    for key, value in reference.items():  # the same windows solved the same way: bitwise equal
        assert equal(resumed[key], value), key


STOP_AFTER_ONE_WINDOW = """\
import sys

from solver import pipeline
from solver.__main__ import main
from solver.spectrum import slicing

solve_window = slicing._solve_window


def then_stop(*args, **kwargs):
    result = solve_window(*args, **kwargs)
    pipeline._TERMINATE[0] = True  # as the SIGTERM handler would, during the first window
    return result


slicing._solve_window = then_stop
sys.exit(main())
"""


@pytest.mark.spawns_ranks
@pytest.mark.parametrize("first, then", [(2, 1), (1, 2)])
def test_spectrum_stopped_after_one_window_resumes_on_another_rank_count(tmp_path, first, then, windowed):
    """`rotsound run` of a many-window spectrum stopped after its first window (as by SIGTERM)
    on 2 ranks resumes on 1, and 1 -> 2: the plan and the first window come from the units
    folder (the plan once held one sub-interval per rank of the first run, and Krylov-Schur
    refused more partitions than ranks), the result equals an uninterrupted run."""
    from conftest import assert_close

    reference = windowed
    path, out, driver = tmp_path / "cut.yaml", tmp_path / "cut.h5", tmp_path / "stop_after_one_window.py"
    path.write_text(scene_text(out, **WINDOWED))
    driver.write_text(STOP_AFTER_ONE_WINDOW)
    env = child_env()
    env["PYTHONPATH"] = str(REPO)
    stopped = subprocess.run((mpirun(first) if first > 1 else []) + [sys.executable, str(driver), "run", str(path)],
                             cwd=REPO, env=env, capture_output=True, text=True, timeout=300)
    assert stopped.returncode != 0 and "stopped by SIGTERM" in stopped.stderr, stopped.stderr
    assert "spectrum window 1/" in stopped.stdout and "spectrum window 2/" not in stopped.stdout, stopped.stdout
    resumed = run_cli(["run", str(path)], ranks=then, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    windows = int(reference[1]["windows"])
    assert windows >= 4
    assert f"spectrum_windows {windows - 1} computed, 2 resumed" in resumed.stdout, resumed.stdout
    with h5py.File(out) as f:
        got = {k: v[()] for k, v in f["spectra/r00_p0000"].items()}
        residual = max(f["spectra/r00_p0000"].attrs["max_relative_residual"], reference[1]["max_relative_residual"])
    datasets = reference[0]
    assert_close(got["omega"], datasets["omega"], rtol=1e-12, what="omega")
    # The first window was sliced on another rank count (other sub-intervals, other Krylov
    # paths): its eigenvectors agree to r lambda / gap (Davis-Kahan), so K_x, K_y, K, Q are held
    # to that bound per mode, as in test_spectrum's resume test.
    lam = datasets["omega"] ** 2
    gap = np.minimum(np.diff(lam, prepend=-np.inf), np.diff(lam, append=np.inf))
    bound = 2 * (2 * residual * lam / gap) / (2 * int(reference[1]["n_disks"])) + 1e-14  # + round-off
    for key in ("Kx", "Ky", "K", "Q"):
        assert np.all(np.abs(got[key] - datasets[key]) <= bound), key
