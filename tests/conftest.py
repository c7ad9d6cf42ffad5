"""Shared fixtures: the same suite runs on 1 rank and under ``mpirun -n 2``.

Every test is collective; asserts that depend on rank-local data go through ``assert_all``.
"""

from __future__ import annotations

import functools
import gc
import itertools
import json
import os
import pathlib
import subprocess
import sys

# One BLAS thread per process, set before numpy loads OpenBLAS (solver/__init__ comes too late
# once numpy is imported): two ranks x two threads on two cores made a 288-DOF spectrum take
# 18 s instead of 0.1 s (threads spinning in every small orthogonalisation).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import yaml  # noqa: E402

from solver import petscenv  # noqa: E402

PETSc = petscenv.init([])
from mpi4py import MPI  # noqa: E402  (after PETSc initialised MPI)

COMM = MPI.COMM_WORLD
REPO = pathlib.Path(__file__).resolve().parents[1]

# Tolerances in one place, tied to what each check can reach in float64.
TOL = {
    "roundoff": 1e-12,     # identities that hold to round-off (symmetry, zero modes)
    "fd_hessian": 1e-6,    # central differences, h = 1e-5, relative to max |D|
    "rank_invariance": 1e-12,
}


def pytest_collection_modifyitems(config, items):
    for item in items:
        if COMM.size > 1 and (item.get_closest_marker("serial_only") or item.get_closest_marker("spawns_ranks")):
            item.add_marker(pytest.mark.skip(reason="serial_only: runs in the 1-rank pass"))
        if COMM.size < 2 and item.get_closest_marker("mpi"):
            item.add_marker(pytest.mark.skip(reason="needs 2 ranks: runs in the mpirun -n 2 pass"))


@pytest.fixture(autouse=True)
def _collective_teardown():
    """After each test, on every rank at once: the test's cyclic garbage collected, its PETSc
    objects destroyed (``garbage_cleanup``), the ranks in step.  What survives the collection
    (modules, caches, module fixtures) is frozen out of later collections (``gc.freeze``): a
    full collection over the imported libraries' objects took 0.1-0.3 s a test, a quarter of
    the suite's time."""
    yield
    gc.collect()
    gc.freeze()
    PETSc.garbage_cleanup()
    COMM.Barrier()


@pytest.fixture(autouse=True, scope="module")
def _module_teardown():
    """After each module: everything frozen is collected once more, so that a module fixture's
    cyclic garbage (and any PETSc object in it) does not outlive its module."""
    yield
    gc.unfreeze()
    gc.collect()
    gc.freeze()
    PETSc.garbage_cleanup()
    COMM.Barrier()


@pytest.fixture
def comm():
    return PETSc.COMM_WORLD


@pytest.fixture
def shared_tmp(tmp_path):
    """Rank 0's tmp_path, the same directory on every rank."""
    return pathlib.Path(COMM.bcast(str(tmp_path), root=0))


def assert_close(actual, expected, rtol: float, atol: float = 0.0, what: str = "", equal_nan: bool = False) -> None:
    """Assert |actual - expected| <= atol + rtol |expected| elementwise, on every rank.

    Scale-aware: ``atol`` is 0 unless the caller passes one (with its reason written beside the
    call), so a tolerance never silently widens the way ``np.allclose``'s default atol = 1e-8
    does on quantities of order 1e-5.  ``atol`` may be an array (a bound per element).  A NaN on
    either side fails, unless the caller passes ``equal_nan=True`` (with the reason NaN is expected
    written beside the call): then NaN equals NaN where both are NaN, and only there.
    """
    actual, expected = np.asarray(actual), np.asarray(expected)
    ok = actual.shape == expected.shape
    worst, nans = np.inf, 0
    if ok:
        both_nan = _isnan(actual) & _isnan(expected) if equal_nan else np.zeros(actual.shape, dtype=bool)
        err = np.abs(actual - expected)
        bound = atol + rtol * np.abs(expected)
        bad = ~(err <= bound) & ~both_nan
        ok = not np.any(bad)
        nan = np.isnan(err) & ~both_nan
        nans = int(np.count_nonzero(nan))
        ratio = np.where(bound > 0, err / np.where(bound > 0, bound, 1.0), np.where(err > 0, np.inf, 0.0))
        worst = float(np.max(np.where(both_nan | nan, 0.0, ratio))) if err.size else 0.0
    atol_text = f"{np.max(atol):g} (largest of per-element values)" if np.ndim(atol) else f"{atol:g}"
    assert_all(ok, f"{what}: shapes {actual.shape} vs {expected.shape}, worst error / bound = {worst:.3g}, "
                   f"{nans} NaN (equal_nan={equal_nan}) (rtol={rtol:g}, atol={atol_text})")


def _isnan(values: np.ndarray) -> np.ndarray:
    """Elementwise NaN of an array of any dtype (False for integers, booleans and strings)."""
    return np.isnan(values) if np.issubdtype(values.dtype, np.inexact) else np.zeros(values.shape, dtype=bool)


def central_hessian(energy, count: int, size: int, h: float) -> np.ndarray:
    """(count, size, size) Hessian at w = 0 of ``energy(w (count, size)) -> (count,)`` (one value
    per contact) by central differences with step h; truncation error O(h^2)."""
    out = np.empty((count, size, size))
    for a in range(size):
        for b in range(size):
            e = []
            for sa, sb in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
                w = np.zeros((count, size))
                w[:, a] += sa * h
                w[:, b] += sb * h
                e.append(energy(w))
            out[:, a, b] = (e[0] - e[1] - e[2] + e[3]) / (4 * h * h)
    return out


def central_gradient(energy, w: np.ndarray, h: float) -> np.ndarray:
    """Gradient (count, size) of ``energy`` at w (count, size) by central differences, step h."""
    grad = np.empty_like(w)
    for a in range(w.shape[1]):
        step = np.zeros_like(w)
        step[:, a] = h
        grad[:, a] = (energy(w + step) - energy(w - step)) / (2 * h)
    return grad


def wave_frames(path, n: int) -> np.ndarray:
    """(S, N, C): the columns after the id of every frame of a DEM code's wave dump ``path`` (a text
    ``dump custom`` of id and C columns, sorted by id), each frame checked to list ids 1..N."""
    import re

    chunks = re.split(r"ITEM: ATOMS[^\n]*\n", pathlib.Path(path).read_text())[1:]
    frames = np.array([np.loadtxt(chunk.strip().splitlines()[:n]) for chunk in chunks])
    assert np.array_equal(frames[:, :, 0], np.broadcast_to(np.arange(1, n + 1), frames.shape[:2]))
    return frames[:, :, 1:]


def split_generalised(w: np.ndarray, dim: int):
    """(du, theta_i, theta_j) from generalised displacements w (C, 2m) = (u_i, theta_i, u_j, theta_j)
    of pairs in ``dim`` dimensions: du (C, D); theta (C,) in 2D, (C, 3) in 3D."""
    m = w.shape[1] // 2
    theta_i, theta_j = w[:, dim:m], w[:, m + dim:]
    if dim == 2:
        theta_i, theta_j = theta_i[:, 0], theta_j[:, 0]
    return w[:, :dim] - w[:, m:m + dim], theta_i, theta_j


def assert_all(condition: bool, message: str = "") -> None:
    """Assert on every rank that ``condition`` holds on every rank."""
    verdicts = COMM.allgather(bool(condition))
    failed = [r for r, ok in enumerate(verdicts) if not ok]
    assert not failed, f"failed on ranks {failed}: {message}"


def mpirun(n: int) -> list[str]:
    """``mpirun -n n`` with the flags Open MPI needs as root in a container."""
    cmd = ["mpirun", "-n", str(n)]
    if os.geteuid() == 0:
        cmd.append("--allow-run-as-root")
    if n > (os.cpu_count() or 1):
        cmd.append("--oversubscribe")
    return cmd


def child_env() -> dict[str, str]:
    """This process's environment without what its own MPI start put there (a rank's place in
    its job, and a singleton's: a pytest-xdist worker is one), so that a child mpirun or a
    child process starts a job of its own."""
    return {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_COMM", "PMIX_", "OMPI_MCA_ess"))}


def run_cli(args: list[str], ranks: int = 1, timeout: float = 120, cwd=None):
    """Run ``python -m solver ARGS`` (under mpirun when ranks > 1); return CompletedProcess."""
    env = child_env()
    cmd = [sys.executable, "-m", "solver", *args]
    if ranks > 1:
        cmd = mpirun(ranks) + cmd
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env,
                          cwd=cwd or REPO)


def main_here(args: list[str], capsys) -> tuple[int, str, str]:
    """``rotsound ARGS`` run in this process (``solver.__main__.main``): (exit code, stdout,
    stderr).  For the tests of what a command does, not of the process (a child process costs
    ~2 s of imports); the PETSc options it puts in the database (a scene's ``petsc:`` block, the
    command line's words) are taken out again.  Collective for ``run``."""
    from solver import __main__ as cli, options

    capsys.readouterr()
    before = options.snapshot()
    try:
        code = cli.main(args)
    finally:
        options.restore(before)  # a run's options must not reach the tests after it
    said = capsys.readouterr()
    return code, said.out, said.err


def run_stopped_after_windows(monkeypatch, scene, windows: int = 2, solver=None, name: str = "_solve_window") -> list:
    """Run ``scene`` in-process until ``windows`` spectrum windows are solved, then stop it as
    SIGTERM would (pipeline raises Interrupted on every rank); the windows stay on disk.  Returns
    the list that counts the calls of the window function ``name`` of module ``solver`` (default
    slicing's ``_solve_window``), which keeps counting on a later run. Collective."""
    from solver import pipeline
    from solver.errors import Interrupted
    from solver.spectrum import slicing

    solver = solver or slicing
    solve_window, calls = getattr(solver, name), []

    def counted(*args, **kwargs):
        calls.append(1)
        if len(calls) == windows:
            pipeline._TERMINATE[0] = True  # as the SIGTERM handler would
        return solve_window(*args, **kwargs)

    monkeypatch.setattr(solver, name, counted)
    try:
        with pytest.raises(Interrupted):
            pipeline.run(scene, COMM, [])
    finally:
        pipeline._TERMINATE[0] = False
    return calls


@pytest.fixture(scope="session")
def lammps_present():
    """Skip when LAMMPS's Python module or library is missing (the same verdict on every rank);
    in CI (CI=true, where scripts/tools/setup.sh installs LAMMPS) a missing LAMMPS fails instead."""
    from solver.errors import InputError
    from solver.packing import lammps_engine

    try:
        lammps_engine.open_lammps(COMM, screen=False).close()
    except InputError as exc:
        missing("LAMMPS", exc)


def missing(what: str, why) -> None:
    """Skip the test for want of ``what``; fail it instead in CI (CI=true), where the setup
    installs everything the tests use, so that a broken install cannot pass as skipped tests."""
    if os.environ.get("CI") == "true":
        pytest.fail(f"{what} is missing in CI, where scripts/tools/setup.sh installs it ({why})")
    pytest.skip(f"{what} is not installed ({why})")


OVITO_PYTHON = REPO / ".venv-ovito" / "bin" / "python"


def ovito_read(files: list[str], render: str | None = None) -> dict:
    """What OVITO itself reads in ``files`` (and, with ``render``, draws into that PNG):
    tests/io/ovito_check.py's report, run by OVITO's own Python in the venv scripts/tools/setup.sh makes
    for it.  Skips (fails in CI) where that venv is missing."""
    if not os.access(OVITO_PYTHON, os.X_OK):
        missing("OVITO's Python module", f"no {OVITO_PYTHON}: scripts/tools/setup.sh makes that venv")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}  # OVITO's venv sees nothing of ours
    words = ["--render", str(render)] if render else []
    done = subprocess.run([str(OVITO_PYTHON), str(REPO / "tests" / "io" / "ovito_check.py"), *words, *map(str, files)],
                          capture_output=True, text=True, timeout=180, env=env)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def scene_text(output, **sections) -> str:
    """The YAML text of a scene: ``output`` (a path), then ``sections`` in the order given, each a
    value (``seed=3``, ``cache="off"``) or a mapping (``packing={"n": 64, "phi": 0.9}``)."""
    return yaml.safe_dump({"output": str(output), **sections}, sort_keys=False)


def scene_of(output, **sections):
    """The validated :class:`~solver.io.schema.Scene` of :func:`scene_text`'s text."""
    from solver.io import coerce, schema

    return coerce.build(schema.Scene, yaml.safe_load(scene_text(output, **sections)))


@functools.lru_cache(maxsize=None)
def jammed_packing(n: int, phi: float, seed: int, dim: int = 2, law: str = "harmonic"):
    """The jammed packing of ``n`` particles at ``phi`` from SeedSequence([seed, 0]), made once per
    session and shared by every test that asks for it (the same on every rank: rotsound's FIRE on
    each).  Its arrays are read-only, so that no test can change another's packing."""
    from solver.packing import jammed

    p = jammed.generate(n, phi, np.random.SeedSequence([seed, 0]), dim=dim, law=law)
    for array in (p.positions, p.diameters, p.box, p.rattler):
        array.setflags(write=False)
    return p


@pytest.fixture(scope="session")
def small_packing():
    """A jammed 64-disk packing at phi = 0.9 (seed 7)."""
    return jammed_packing(64, 0.9, 7)


@pytest.fixture(scope="session")
def packing64():
    """Another jammed 64-disk packing at phi = 0.9 (seed 31: the waves tests' reference)."""
    return jammed_packing(64, 0.9, 31)


def all_pairs(p):
    """Overlap (N, N), separation r_i - r_j (N, N, D) and distance (N, N; inf on the diagonal) over
    every pair of packing ``p`` in its cubic box, minimum image, by brute force: not the
    package's neighbour search, Verlet list or contact code."""
    delta = p.positions[:, None, :] - p.positions[None, :, :]
    delta -= p.box_length * np.round(delta / p.box_length)
    distance = np.sqrt(np.sum(delta**2, axis=2))
    np.fill_diagonal(distance, np.inf)
    overlap = np.maximum(0.5 * (p.diameters[:, None] + p.diameters[None, :]) - distance, 0.0)
    return overlap, delta, distance


def brute_contacts(positions, diameters, cell):
    """(i, j, r_i - r_j) of every overlapping pair i < j of ``positions`` (N, D) in ``cell``: the
    shortest of the separations over the images n in {-1, 0, 1}^D (of fractional coordinates in
    [0, 1), enough for any pair closer than half the cell's height); no geometry search or reduction."""
    fractional = np.linalg.solve(cell.matrix, positions.T).T
    assert np.all((fractional >= 0) & (fractional < 1)), "positions are folded into the cell"
    shifts = np.array(list(itertools.product([-1, 0, 1], repeat=cell.dim)), dtype=float) @ cell.matrix.T
    i, j = np.triu_indices(len(positions), 1)
    images = (positions[i] - positions[j])[:, None, :] + shifts[None]  # (P, 3^D, D)
    distance = np.sqrt(np.sum(images**2, axis=2))
    touching = distance < 0.5 * (diameters[i] + diameters[j])[:, None]
    assert touching.sum(axis=1).max() <= 1, "a pair touches through one image only"
    pair, image = np.nonzero(touching)
    return i[pair], j[pair], images[pair, image]


def schedule(integrator, dt, t_end, every):
    """The scene's values as a TS schedule (no -waves_ts_* options are set in the tests)."""
    from solver.waves.schedule import resolve_schedule

    return resolve_schedule(integrator=integrator, dt=dt, t_end=t_end, sample_every=every)


def star_cluster(p) -> tuple[np.ndarray, int, int]:
    """(mask (N,), particles, contacts among them) of particle 0 and its contact neighbours: a
    star whose arms share few contacts, floppy in 2D and 3D (the rigidity-count tests)."""
    from solver.packing import geometry

    found = geometry.find_contacts(p.positions, p.diameters, p.box_length)
    cluster = np.zeros(p.n, dtype=bool)
    cluster[0] = True
    cluster[found.j[found.i == 0]] = True
    cluster[found.i[found.j == 0]] = True
    return cluster, int(cluster.sum()), int(np.sum(cluster[found.i] & cluster[found.j]))


def with_random_stored_forces(p, seed, ratio=0.5, zero=False):
    """``p`` with a stored tangential force on every contact among non-rattlers, |f_t| = ratio f_n
    in a random tangent direction (not in equilibrium: the matrix does not need it)."""
    import dataclasses

    from solver.packing import geometry, stressed

    found = geometry.find_contacts(p.positions, p.diameters, p.cell, ~p.rattler)
    rng = np.random.default_rng(seed)
    direction = rng.normal(size=found.normal.shape)
    direction -= np.einsum("cd,cd->c", direction, found.normal)[:, None] * found.normal
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    force = 0.0 * direction if zero else ratio * found.overlap[:, None] * direction
    stored = stressed.build(np.stack((found.i, found.j), 1), force, p.positions, p.diameters, p.cell,
                            "harmonic", None, "test")
    return dataclasses.replace(p, tangential=stored)


class FailingProducts:
    """A PETSc Mat stand-in for the deterministic-destruction tests: delegates to ``mat``, records
    every operand and product of its ``matMult`` in ``seen``, and raises RuntimeError at product
    number ``fail_at`` (on every rank alike).  After the error, every Mat in ``seen`` should have
    been destroyed (``handle == 0``) by the code under test, not left to the garbage collector."""

    def __init__(self, mat, fail_at: int):
        self.mat, self.fail_at, self.seen, self.calls = mat, fail_at, [], 0

    def __getattr__(self, name):
        return getattr(self.mat, name)

    def matMult(self, *operands):
        self.calls += 1
        self.seen += [m for m in operands if m is not None]
        if self.calls == self.fail_at:
            raise RuntimeError("injected failure")
        product = self.mat.matMult(*operands)
        self.seen.append(product)
        return product

    def live(self) -> int:
        """How many recorded Mats other than ``mat`` itself are still alive."""
        return sum(1 for m in {id(m): m for m in self.seen}.values() if m.handle != 0 and m is not self.mat)
