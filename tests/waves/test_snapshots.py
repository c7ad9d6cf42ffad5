"""Snapshots of standing waves (``waves.snapshots``): the whole velocity field by Lanczos in two
passes (``spectral.velocity_field``) against the dense modal solution M^-1/2 U cos(Omega t) U^T
M^1/2 v(0), 2D and 3D (rolling, twisting, the twist mode R); through a scene, stored, drawn, and
without the key the waves units keep their content keys of before; 1 and 2 ranks."""

import os

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close, jammed_packing, scene_of

from solver import pipeline
from solver.contact_law import ContactModel
from solver.io import results, unit_keys
from solver.model import dynmat
from solver.waves import excitation, spectral
from solver.references import dense_eigen

TIMES = np.array([0.0, 3.0, 17.5, 40.0])


def _dense_field(dm, v0_local, lam, U, times, comm):
    """M^-1/2 U cos(sqrt(lam) t) U^T M^1/2 v(0), local rows (T, nloc): the exact modal solution."""
    mpi = comm.tompi4py()
    s = np.sqrt(np.concatenate(mpi.allgather(dm.M.getArray(readonly=True).copy())))
    v0 = np.concatenate(mpi.allgather(v0_local))
    start, stop = dm.disk_range[0] * dm.dof, dm.disk_range[1] * dm.dof
    omega = np.sqrt(np.clip(lam, 0.0, None))
    return np.array([(U @ (np.cos(omega * t) * (U.T @ (s * v0))) / s)[start:stop] for t in times])


@pytest.mark.parametrize("dim, mode", [(2, "L"), (2, "TR"), (2, "RT"), (3, "TR"), (3, "R")])
def test_velocity_field_equals_the_modal_solution(comm, dim, mode):
    p = jammed_packing(64, 0.9, 31) if dim == 2 else jammed_packing(32, 0.68, 5, dim=3)
    model = ContactModel(0.5) if dim == 2 else ContactModel(0.5, rho_roll=0.2, rho_twist=0.1)
    dm = dynmat.assemble(p, model, comm)
    lam, U = dense_eigen(dm)
    k = 2 * np.pi / p.box[0]
    for run in range(len(excitation.runs(mode, dim))):
        field, estimate = spectral.velocity_field(dm, p.positions, mode, run, k, amplitude=1e-3, times=TIMES,
                                                  tol=1e-10)
        component, axis = excitation.runs(mode, dim)[run]
        v0 = excitation.start_velocity(dm, p.positions, component, axis, k, 1e-3, comm.tompi4py())
        exact = _dense_field(dm, v0, lam, U, TIMES, comm)
        # relative to max |v(0)| = 1e-3; measured ~1e-13
        assert_close(field, exact, rtol=0.0, atol=1e-10 * 1e-3, what=f"{mode} run {run} field")
        assert_all(estimate < 1e-10, f"estimate {estimate:.1e}")
        assert_close(field[0], v0, rtol=0.0, atol=1e-12 * 1e-3, what="t = 0 is the start")
    dm.destroy()


def test_a_matrix_with_negative_curvature_is_refused_on_every_path(comm):
    """D shifted by -0.01 I: A = M^-1/2 D M^-1/2 gains eigenvalues near -0.01 / m, along which a wave
    grows by about e^4 within t = 40.  The snapshot pass, the spectral z and the unshifted matrix's
    control: the first two refuse it on every rank, naming the remedy; the control runs."""
    p = jammed_packing(64, 0.9, 31)
    k = 2 * np.pi / p.box[0]
    dm = dynmat.assemble(p, ContactModel(0.5), comm)
    spectral.velocity_field(dm, p.positions, "L", 0, k, amplitude=1e-3, times=TIMES, tol=1e-10)  # control
    dm.destroy()
    dm = dynmat.assemble(p, ContactModel(0.5), comm)
    dm.D.shift(-0.01)
    with pytest.raises(RuntimeError, match="negative curvature.*force_tol"):
        spectral.velocity_field(dm, p.positions, "L", 0, k, amplitude=1e-3, times=TIMES, tol=1e-10)
    with pytest.raises(RuntimeError, match="negative curvature.*force_tol"):
        spectral.spectral(dm, p.positions, "L", 0, k, amplitude=1e-3, times=TIMES, tol=1e-10)
    dm.destroy()


def test_snapshots_through_a_scene(comm, shared_tmp, monkeypatch):
    waves = {"n": [2, 1], "method": "spectral", "t_end": 20, "modes": ["L", "RT"], "snapshots": [0.0, 5.0]}
    scene = scene_of(shared_tmp / "snap.h5", cache="off", seed=7, packing={"n": 64, "phi": 0.9},
                     model={"rho": [0.5]}, waves=waves)
    pipeline.run(scene, COMM, [])
    with results.open_results(scene.output) as f:
        snapshots = results.wave_snapshots(f)
        packing = results.packing(f, 0)
    assert_all([w.mode for w in snapshots] == ["L", "RT"], f"{[w.mode for w in snapshots]}")
    k = 2 * np.pi / packing["box"][0]  # the smallest k of n = [2, 1]
    for w in snapshots:
        assert_close(np.array([w.k]), np.array([k]), rtol=1e-12, what="the smallest k")
        assert_all(w.velocity.shape == (2, 64, 2) and w.spin.shape == (2, 64, 1), "fields of every particle")
    first = snapshots[0]  # L, run 0: v_x = A sin(k x) at t = 0, less its mean (the zero mode)
    start = 1e-3 * np.sin(k * packing["positions"][:, 0])
    assert_close(first.velocity[0][:, 0], start - start.mean(), rtol=0.0, atol=1e-15, what="L at t = 0")
    if COMM.size == 1:  # drawing is rank 0's alone, from a file the same on 1 or 2 ranks: once, in the 1-rank pass
        from figures import assert_readable, capture
        from solver import plots

        figures = capture(monkeypatch)
        written = plots.plot_results(scene.output)
        pictures = [w for w in written if "_wave_" in os.path.basename(w) and w.endswith(".png")]
        assert len(pictures) == 4, written
        assert_readable(figures)


def test_without_snapshots_the_waves_keys_are_those_of_before(shared_tmp):
    scene = scene_of(shared_tmp / "k.h5", packing={"n": 64, "phi": 0.9}, waves={"n": [1]})
    p = jammed_packing(64, 0.9, 7)
    keys = unit_keys.scene_keys(scene, [p], [])
    waves = [key for name, key in keys.items() if name.startswith("waves/")]
    assert waves and all("snapshots" not in key.parts["settings"] for key in waves), sorted(keys)
