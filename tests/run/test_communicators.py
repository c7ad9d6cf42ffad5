"""Every stage runs on the communicator it is given, and an error on one rank raises on every rank.

Under ``mpirun -n 2``: two scenes run at the same time on two 1-rank sub-communicators and each
equals its plain run; failures injected on rank 0 only (writing the results file, inside
``owner_compute``, an exception that cannot be pickled) raise on both ranks and leave nobody
waiting (pytest-timeout would end a hang; the marker below shortens it).
"""

import errno
import threading

import h5py
import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close, run_cli, scene_of, scene_text

from solver import parallel, pipeline
from solver.errors import InputError
from solver.io import hdf5

# Scene A: slicing spectrum with per-mode energies (several windows, checkpointed) and TS waves
# (block Verlet); scene B: KPM with K and Q and spectral (Lanczos) waves.  Small: seconds each.
SCENES = (
    dict(cache="off", seed=4, packing={"n": 64, "phi": 0.9}, model={"rho": [1.0]},
         spectrum={"energies": True, "max_window_modes": 100}, waves={"n": [1, 2], "t_end": 20, "dt": 0.05}),
    dict(cache="off", seed=9, packing={"n": 96, "phi": 0.88}, model={"rho": [0.5]},
         spectrum={"method": "kpm", "energies": True, "probes": 8},
         waves={"n": [1, 2], "method": "spectral", "t_end": 20, "tol": 1e-10}),
)
WAVES_TOL = 1e-10  # scene B's waves.tol
SKIPPED_ATTRS = {"seconds", "assembly_seconds", "max_relative_residual", "solver_settings"}  # compare()


def scene(index, path):
    return scene_of(path, **SCENES[index])


def compare(got, ref, what):
    """Each unit of the sub-communicator run ``got`` against the plain 2-rank run ``ref``.

    The plain run is on 2 ranks, the sub-communicator run on 1, so each dataset is held to the
    agreement the rank count allows (the manual's table of rank-count tolerances, docs/scale.md; reductions and
    MatMults sum in another order):
      packings, matrices, bin edges, the waves' k, n, t and omega grids: exact (rank-free);
      slicing omega: 1e-11 relative (Rayleigh quotients: error ~ residual^2 / gap);
      slicing K_x, K_y, K, Q: the Davis-Kahan bound of the eigenvectors, 2 sin(theta) / 2N per
        mode with sin(theta) <= 2 r lambda / gap (r the larger relative residual), as in
        test_resume; the participation ratio comes from the same vectors and is not compared again;
      vDOS and KPM density, KPM K and Q: 1e-11 of their largest value (a bin's mass is a
        difference of the expansion's primitive at its edges, so round-off is relative to the
        total, not to the bin);
      Verlet z, z_fixed, C, S: 1e-12 of their largest magnitude (they oscillate through zero, so
        an elementwise relative bound means nothing at the crossings); energy_drift: 1e-11
        absolute (a difference of energies that agree to 1e-12);
      spectral z, z_fixed, C, S: 2 waves.tol of the largest magnitude (each run is within its
        Lanczos error estimate, below waves.tol, of the exact z, should the step counts differ);
        error_estimate is not compared (a round-off-level difference of two approximations);
      analysis fits: 1e-6 relative, their error bars (*_err) 1e-5 (least squares stop at scipy's
        xtol ~1.5e-8, so inputs that differ at round-off move the parameters by up to that).
    Attributes: timings, max_relative_residual and solver_settings skipped (the solver's path:
    slicing partitions per rank, Lanczos iterations); the rest equal, floats to 1e-12 relative
    (omega_max, omega_c: the same Lanczos solve).
    """
    assert_all(sorted(got) == sorted(ref), f"{what}: groups {sorted(got)} vs {sorted(ref)}")
    for name, (data, attrs) in ref.items():
        mine, mine_attrs = got[name]
        assert_all(sorted(mine) == sorted(data), f"{what} {name}: datasets")
        spectral = name.startswith("waves/") and "error_estimate" in data
        for key, value in data.items():
            value, other = np.asarray(value), np.asarray(mine[key])
            label = f"{what} {name}/{key}"
            grid = key == "edges" or name.startswith("waves/") and key in ("k", "n", "t", "omega")
            if value.dtype.kind not in "fc" or name.startswith(("packings/", "matrices/")) or grid:
                assert_all(np.array_equal(value, other), f"{label}: not identical")
            elif name.startswith("spectra/") and key == "omega":
                assert_close(other, value, rtol=1e-11, what=label)
            elif name.startswith("spectra/") and "omega" in data:  # slicing K_x, K_y, K, Q, P
                if key == "participation":
                    continue
                lam = data["omega"] ** 2
                gap = np.minimum(np.diff(lam, prepend=-np.inf), np.diff(lam, append=np.inf))
                r = max(attrs["max_relative_residual"], mine_attrs["max_relative_residual"])
                bound = 2 * (2 * r * lam / gap) / (2 * attrs["n_disks"])
                assert_all(np.all(np.abs(other - value) <= bound), f"{label}: beyond the Davis-Kahan bound")
            elif name.startswith(("spectra/", "vdos/")):  # vDOS and KPM density, KPM K, Q
                # atol: bin masses are differences of a primitive (see the docstring); equal_nan: KPM's
                # K and Q are NaN in the bins without spectral weight (spectrum/kpm.py), in both runs
                assert_close(other, value, rtol=0.0, atol=1e-11 * np.nanmax(np.abs(value)), what=label,
                             equal_nan=key in ("K", "Q"))
            elif name.startswith("waves/") and key == "error_estimate":
                continue
            elif name.startswith("waves/") and key == "energy_drift":
                assert_close(other, value, rtol=0.0, atol=1e-11, what=label)  # atol: see the docstring
            elif name.startswith("waves/"):
                # atol: oscillating through zero; spectral: within its Lanczos estimate (docstring)
                scale = (2 * WAVES_TOL if spectral else 1e-12) * np.abs(value).max()
                assert_close(other, value, rtol=0.0, atol=scale, what=label)
            else:  # analysis fits and their error bars
                assert_close(other, value, rtol=1e-5 if key.endswith("_err") else 1e-6, what=label)
        for key, value in attrs.items():
            if key in SKIPPED_ATTRS:
                continue
            other = mine_attrs[key]
            if isinstance(value, (float, np.floating)) and np.isfinite(value):
                assert_close(other, value, rtol=1e-12, what=f"{what} {name}@{key}")
            else:  # integers, strings, inf and NaN: identical
                nan = isinstance(value, (float, np.floating)) and np.isnan(value) and np.isnan(other)
                assert_all(np.array_equal(other, value) or nan, f"{what} {name}@{key}: {other!r} vs {value!r}")


@pytest.mark.mpi
@pytest.mark.timeout(240)
def test_two_scenes_on_split_communicators_equal_their_plain_runs(shared_tmp):
    """Rank 0 runs scene A and rank 1 scene B at the same time, each on its own 1-rank
    sub-communicator (COMM_WORLD.Split), through the whole pipeline: packings, assembly, slicing
    and KPM spectra, Verlet and spectral waves, analysis, unit store and results file.  Each
    result equals the plain run of its scene on COMM_WORLD (tolerances: :func:`compare`).
    Before the fix, assembly used COMM_WORLD whatever the communicator: the two ranks met in one
    collective with different matrices and the run failed or hung."""
    plain = [pipeline.run(scene(i, shared_tmp / f"plain{i}.h5"), COMM, [])["units"] for i in range(2)]
    sub = COMM.Split(COMM.rank, 0)
    error, got = None, None
    try:
        got = pipeline.run(scene(COMM.rank, shared_tmp / f"split{COMM.rank}.h5"), sub, [])["units"]
    except Exception as exc:  # noqa: BLE001 - raised on both ranks below, so nobody waits
        error = exc
    finally:
        sub.Free()
    parallel.agree(COMM, error)
    for index, units in enumerate(COMM.allgather(got)):  # every rank checks both: same collectives
        compare(units, plain[index], f"scene {'AB'[index]} (on rank {index}'s sub-communicator)")
    with h5py.File(shared_tmp / f"split{COMM.rank}.h5") as f:
        assert_all(f.attrs["ranks"] == 1, "the sub-communicator run records 1 rank")


def matrices_only(path):
    """The cheapest scene that writes a results file: two packings and their matrix summaries."""
    return scene_of(path, cache="off", seed=1, packing={"n": 32, "phi": 0.9, "count": 2}, model={"rho": 1})


@pytest.mark.mpi
@pytest.mark.timeout(60)
@pytest.mark.parametrize("failure", [OSError(errno.ENOSPC, "No space left on device"),
                                     ValueError("injected: not an OSError")], ids=["ENOSPC", "ValueError"])
def test_results_file_failure_on_rank_0_raises_on_every_rank(shared_tmp, monkeypatch, failure):
    """Rank 0 fails while writing the results file (inside the writer, after the temporary file
    is open).  Every rank raises -- a full disk as one InputError naming the output, anything
    else as itself -- and nothing is left behind.  Before the fix only an OSError reached rank 1:
    a ValueError left it waiting in the broadcast for ever."""
    out = shared_tmp / f"full_{type(failure).__name__}.h5"
    write_packing = hdf5.write_packing

    def failing(group, packing):
        if COMM.rank == 0:
            raise failure
        write_packing(group, packing)

    monkeypatch.setattr(hdf5, "write_packing", failing)
    with pytest.raises(Exception) as caught:
        pipeline.run(matrices_only(out), COMM, [])
    if isinstance(failure, OSError):
        assert_all(caught.type is InputError and "No space left on device" in str(caught.value)
                   and f"output = {out}" in str(caught.value), f"raised {caught.value!r}")
    else:
        assert_all(caught.type is ValueError and "injected" in str(caught.value), f"raised {caught.value!r}")
    assert_all(not out.exists() and not (shared_tmp / (out.name + ".partial")).exists(), "nothing written")


@pytest.mark.mpi
@pytest.mark.timeout(60)
def test_base_exception_on_rank_0_raises_on_every_rank():
    """A KeyboardInterrupt in rank 0's task of owner_compute is raised on every rank (the decision
    in its docstring); before, it left rank 1 waiting in the exchange of errors."""
    def task(index):
        if index == 0:
            raise KeyboardInterrupt
        return index

    caught = None
    try:
        parallel.owner_compute(COMM, [0, 1], task)
    except KeyboardInterrupt as exc:
        caught = exc
    assert_all(isinstance(caught, KeyboardInterrupt), f"rank {COMM.rank} raised {caught!r}")


class _Unpicklable(Exception):
    def __init__(self, message):
        super().__init__(message)
        self.lock = threading.Lock()  # cannot be pickled


@pytest.mark.mpi
@pytest.mark.timeout(60)
def test_unpicklable_error_on_rank_0_raises_on_every_rank():
    """An exception that cannot be pickled still reaches every rank (as a RuntimeError naming it);
    before, pickling it failed on rank 0 alone, before the exchange, and rank 1 waited."""
    caught = None
    try:
        parallel.agree(COMM, _Unpicklable("holds a lock") if COMM.rank == 0 else None)
    except Exception as exc:  # noqa: BLE001 - checked below
        caught = exc
    expected = (_Unpicklable, "holds a lock") if COMM.rank == 0 else (RuntimeError, "_Unpicklable: holds a lock")
    assert_all(type(caught) is expected[0] and expected[1] in str(caught), f"rank {COMM.rank} raised {caught!r}")


@pytest.mark.spawns_ranks
@pytest.mark.serial_only  # launches its own mpirun
def test_unwritable_output_stops_every_rank_with_one_message(tmp_path):
    """On 2 ranks: an output whose folder is a regular file, and an output whose temporary file
    cannot be created (a folder already holds its name) after every unit was computed: exit code
    2, one message naming the path, no traceback, no results file, no rank left waiting (timeout).
    Before the fix the second gave an OSError traceback and an MPI abort (exit 1)."""
    blocker = tmp_path / "a_file"
    blocker.write_text("a regular file, not a folder")
    cases = [(blocker / "r.h5", str(blocker)), (tmp_path / "r.h5", "cannot write the results file")]
    (tmp_path / "r.h5.partial").mkdir()
    for out, message in cases:
        scene = tmp_path / "scene.yaml"
        scene.write_text(scene_text(out, cache="off", packing={"n": 32, "phi": 0.9}))
        proc = run_cli(["run", str(scene)], ranks=2, timeout=120)
        assert proc.returncode == 2, (proc.returncode, proc.stderr)
        assert proc.stderr.count("rotsound: error:") == 1 and message in proc.stderr, proc.stderr
        assert "Traceback" not in proc.stderr + proc.stdout and not out.exists()
