"""Damped standing waves (model.damping, docs/damping.md): the exact path exp(hJ) with
J = [[0, I], [-M^-1 D, -M^-1 C]] against a dense expm built here, the energy the dashpots take
(dE/dt = -v^T C v <= 0), RK4 on the damped first-order system at its order, the step limits with
dashpots (RK4's half-disk), and the scene: keys, refusals, a damped scene's waves on 1 and 2 ranks."""

import json
import math
import re

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close, jammed_packing, scene_of, schedule

from solver import pipeline
from solver.contact_law import ContactModel
from solver.errors import InputError
from solver.model import damping, dynmat, operators
from solver.waves import excitation, exponential, integrators
from solver.waves.schedule import STABILITY_DAMPED, check_schedule, resolve_schedule
from solver.references import first_order_flow

AMPLITUDE = 1e-3
TIMES = np.arange(0.0, 20.0 + 1e-9, 0.1)


def _damped(dim, comm, gamma_n=0.5, gamma_t=0.2):
    p = jammed_packing(48 if dim == 2 else 40, 0.86 if dim == 2 else 0.68, 9, dim)
    dm = dynmat.assemble(p, ContactModel(0.6, gamma_n=gamma_n, gamma_t=gamma_t), comm, "density")
    dm.C = damping.assemble(p, dm, "density")
    return p, dm


@pytest.mark.parametrize("dim, mode", [(2, "L"), (2, "RT"), (3, "TR")])
def test_exponential_damped_waves_equal_dense_expm(comm, dim, mode):
    """z and z_fixed against dense exp(tJ) of the damped system to 1e-12 of max |z| (measured
    9e-16); the premise: the dashpots take more than half of the energy by t = 20 (97 % in 2D L)."""
    p, dm = _damped(dim, comm)
    component, axis = excitation.runs(mode, dim)[0]
    k = 2 * np.pi / float(p.box[axis])
    (series,) = exponential.exponential_all(dm, p.positions, [(mode, 0, k)], amplitude=AMPLITUDE, times=TIMES,
                                            tol=1e-8)
    start = excitation.start_velocity(dm, p.positions, component, axis, k, AMPLITUDE, comm.tompi4py())
    whole = np.concatenate(comm.tompi4py().allgather(start))  # every rank's part, the matrix's order
    flow = first_order_flow(dm, whole, TIMES[1] - TIMES[0], len(TIMES), order="matrix")
    dm.destroy()
    r0 = p.positions[~p.rattler]
    u, v = flow[:, 0], flow[:, 1]
    z_fixed = v[:, :, component] @ np.exp(-1j * k * r0[:, axis])
    z = np.sum(v[:, :, component] * np.exp(-1j * k * (r0[None, :, axis] + u[:, :, axis])), axis=1)
    scale = np.abs(z_fixed).max()
    assert_all(series.energy[-1] < 0.5 * series.energy[0], f"energy {series.energy[0]} -> {series.energy[-1]}")
    assert_close(series.z_fixed, z_fixed, rtol=0.0, atol=1e-12 * scale, what=f"z_fixed, {dim}D {mode}")
    assert_close(series.z, z, rtol=0.0, atol=1e-12 * scale, what=f"z, {dim}D {mode}")


def test_dashpots_only_take_energy(comm):
    """E(t) = (v^T M v + u^T D u)/2 never grows (dE/dt = -v^T C v <= 0; to 1e-13 of E(0) per
    sample) and falls; with the tangential dashpot alone too."""
    for gammas in ((0.5, 0.2), (0.0, 0.4)):
        p, dm = _damped(2, comm, *gammas)
        k = 2 * np.pi * 2 / float(p.box[0])
        (series,) = exponential.exponential_all(dm, p.positions, [("TR", 0, k)], amplitude=AMPLITUDE,
                                                times=TIMES, tol=1e-8)
        dm.destroy()
        steps = np.diff(series.energy)
        assert_all(steps.max() < 1e-13 * series.energy[0] and series.energy[-1] < 0.9 * series.energy[0],
                   f"gammas {gammas}: largest increase {steps.max()}, E {series.energy[0]} -> {series.energy[-1]}")


def test_rk4_on_the_damped_system_converges_at_fourth_order(comm):
    """PETSc's RK4 on the assembled damped J (waves.integrator: rk) against the exact path: the
    error ratio between dt = 0.05 and 0.025 within 25 % of 16 (measured 7.3e-7 / 4.5e-8 = 16.2)."""
    p, dm = _damped(2, comm)
    k = 2 * np.pi * 2 / float(p.box[0])
    (exact,) = exponential.exponential_all(dm, p.positions, [("L", 0, k)], amplitude=AMPLITUDE, times=TIMES,
                                           tol=1e-10)
    errors = []
    for dt in (0.05, 0.025):
        series = integrators.integrate(dm, p.positions, "L", 0, k, amplitude=AMPLITUDE,
                                       schedule=schedule("rk", dt, TIMES[-1], int(round(0.1 / dt))))
        errors.append(np.abs(series.z_fixed - exact.z_fixed).max() / np.abs(exact.z_fixed).max())
    dm.destroy()
    assert_all(abs(errors[0] / errors[1] / 16.0 - 1) < 0.25, f"errors {errors}")


def test_rk4_half_disk_radius():
    """STABILITY_DAMPED's RK4 entry: |R(z)| <= 1 on the left half-disk of that radius (its boundary
    checked: the arc and the imaginary axis) and > 1 on the arc 1 % further out."""
    r = STABILITY_DAMPED[("rk", "4")]

    def amplification(z):
        return np.abs(sum(z**n / math.factorial(n) for n in range(5)))

    theta = np.linspace(np.pi / 2, np.pi, 4001)
    edge = np.concatenate((r * np.exp(1j * theta), 1j * np.linspace(0, r, 200)))
    assert_all(amplification(edge).max() <= 1 + 1e-9 and amplification(1.01 * r * np.exp(1j * theta)).max() > 1,
               f"{amplification(edge).max()}")


def test_damped_step_limits_and_second_order_integrators(comm):
    """With dashpots: the RK4 limit is 2.6156 / max(omega_max, c_max) (c_max from Lanczos equals the
    largest eigenvalue of the dense M^-1/2 C M^-1/2 to 1e-7), a dt above it and Verlet (which an
    option could choose) are refused."""
    p, dm = _damped(2, comm, gamma_n=6.0, gamma_t=3.0)
    omega_max, c_max = operators.largest_omega(dm), operators.largest_damping_rate(dm)
    m = dynmat.gather_vec(dm.M)
    dense = dynmat.gather_csr(dm.C).toarray() / np.sqrt(np.outer(m, m))
    dm.destroy()
    assert_close(c_max, np.linalg.eigvalsh(dense).max(), rtol=1e-7, atol=0.0, what="c_max")
    assert_all(c_max > omega_max, f"the premise: damping sets the limit ({c_max} vs {omega_max})")
    limit = STABILITY_DAMPED[("rk", "4")] / c_max
    ok = resolve_schedule(integrator="rk", dt=0.95 * limit, t_end=10.0, sample_every=1)
    assert_close(check_schedule(ok, omega_max, 0.6, c_max), limit, rtol=1e-15, atol=0.0, what="limit")
    with pytest.raises(InputError, match="fastest damping rate"):
        check_schedule(resolve_schedule(integrator="rk", dt=1.05 * limit, t_end=10.0, sample_every=1),
                       omega_max, 0.6, c_max)
    with pytest.raises(InputError, match="no velocity-dependent force"):
        check_schedule(resolve_schedule(integrator="verlet", dt=0.01, t_end=10.0, sample_every=1),
                       omega_max, 0.6, c_max)


@pytest.mark.parametrize("sections, match", [
    ({"model": {"damping": {"gamma_n": 0.3}}, "spectrum": {"method": "kpm"}}, "it solves the undamped problem"),
    ({"spectrum": {"method": "pep"}}, "the damped modes need dashpots"),
    ({"model": {"damping": {"gamma_t": 0.3}}, "waves": {"n": [1]}}, "waves.integrator = 'verlet' with model"),
    ({"model": {"damping": {"gamma_n": -0.3}}}, r"model.damping.gamma_n = -0.3: must be in \[0.0"),
    ({"model": {"restitution": 0.8, "damping": {"gamma_n": 0.3}}}, "which is given too: give one of them"),
    ({"model": {"restitution": 0.8, "law": "hertz"}}, "depends on the impact speed"),
    ({"model": {"restitution": 0.0}}, r"model.restitution = 0.0: must be in \(0.0, 1.0\]"),
])
def test_damped_scenes_refuse_what_cannot_take_damping(tmp_path, sections, match):
    with pytest.raises(InputError, match=match):
        scene_of(tmp_path / "x.h5", packing={"n": 64, "phi": 0.9}, **sections)


def test_restitution_is_gamma_n_by_another_name(tmp_path):
    """model.restitution e gives the contact model gamma_n = restitution_damping(e), and a scene
    given e has the unit keys of the same scene given that gamma_n."""
    from solver.contact_law import restitution_damping
    from solver.io import unit_keys

    waves = {"n": [1], "method": "exponential"}
    by_e = scene_of(tmp_path / "x.h5", packing={"n": 64, "phi": 0.9},
                    model={"restitution": 0.8, "damping": {"gamma_t": 0.1}}, waves=waves)
    gamma = restitution_damping(0.8)
    by_gamma = scene_of(tmp_path / "x.h5", packing={"n": 64, "phi": 0.9},
                        model={"damping": {"gamma_n": gamma, "gamma_t": 0.1}}, waves=waves)
    p = jammed_packing(64, 0.9, 0)
    assert_all(by_e.model.contact(1.0).gamma_n == gamma and 0 < gamma
               and unit_keys.scene_keys(by_e, [p], []) == unit_keys.scene_keys(by_gamma, [p], []), str(gamma))


def test_restitution_is_recorded_with_the_gamma_n_it_gives(shared_tmp, capsys):
    """A scene given model.restitution e says in its log and its results file (root attribute
    ``dashpots``) the gamma_n it used and how it came from e: docs/damping.md section 5's closed form,
    computed here, gamma_n = 2 omega_0 (-ln e) / sqrt(pi^2 + ln^2 e) with omega_0^2 = kn / m_eff,
    m_eff = 1/2 (two particles of mass 1), to 1e-15 relative (round-off: the same expression)."""
    import h5py

    e = 0.8
    closed = 2.0 * math.sqrt(1.0 / 0.5) * -math.log(e) / math.sqrt(math.pi ** 2 + math.log(e) ** 2)
    out = shared_tmp / "restitution.h5"
    scene = scene_of(out, cache="off", packing={"n": 64, "phi": 0.9}, model={"rho": 0.5, "restitution": e})
    capsys.readouterr()
    pipeline.run(scene, COMM, [])
    log = COMM.bcast(capsys.readouterr().out, root=0)
    with h5py.File(out, "r") as f:
        recorded = json.loads(f.attrs["dashpots"])
    assert_close(recorded["gamma_n"], closed, rtol=1e-15, atol=0.0, what="recorded gamma_n")
    assert_all(recorded["gamma_t"] == 0.0 and recorded["gamma_n_from"].startswith("model.restitution e = 0.8: ")
               and "m_eff = 0.5" in recorded["gamma_n_from"], str(recorded))
    assert_all(f"dashpots: gamma_n = {closed:.6g}, gamma_t = 0 (1/t0); gamma_n from model.restitution e = 0.8" in log,
               log)


def test_a_damped_scene_runs_its_waves(shared_tmp, capsys):
    """model.damping with exponential, spectral (the Chebyshev-Bessel series) and rk waves: the same
    C(k, t) to RK4's error (below 1e-7 of C(0) = 1 at dt = 0.02; measured 6e-9), and not the
    undamped twin's (its own unit keys; C(t_end) 0.24 against 0.30), on 1 and 2 ranks; the two
    exact paths give the same z_fixed (the r_i(0) phase: the spectral path's z) to 1e-9 of max |z|
    (measured 1e-15), and the spectral unit records its series and a finite energy loss.  The rk
    run's log names its energy change as what the dashpots took, the stored energy_drift's largest
    value (E decreases, so its drift is the loss at t_end) to the log's 3 digits."""
    base = dict(cache="off", packing={"n": 64, "phi": 0.9}, model={"rho": 0.5})
    waves = {"modes": ["TR"], "n": [1], "t_end": 10.0, "dt": 0.02, "sample_every": 5}
    damped = {"rho": 0.5, "damping": {"gamma_n": 0.4, "gamma_t": 0.1}}
    results = {}
    for name, model, extra in (("exact", damped, {"method": "exponential"}), ("rk", damped, {"integrator": "rk"}),
                               ("series", damped, {"method": "spectral"}),
                               ("undamped", base["model"], {"method": "exponential"})):
        scene = scene_of(shared_tmp / f"{name}.h5", **{**base, "model": model}, waves={**waves, **extra})
        capsys.readouterr()
        units = pipeline.run(scene, COMM, [])["units"]
        log = COMM.bcast(capsys.readouterr().out, root=0)
        datasets, attrs = units[next(n for n in units if n.startswith("waves/"))]
        if name == "rk":
            said = re.search(r"energy taken by the dashpots \(and the scheme's error\) by t = 10: lost \S+ to (\S+) %", log)
            assert_all(said is not None and "drift" not in log, log)
            assert_close(float(said.group(1)), 100 * datasets["energy_drift"].max(), rtol=5e-3, what="loss said")
        results[name] = datasets["C"]
        results[name + " z_fixed"] = datasets["z_fixed"]
        assert_all(("damping_max" in attrs) == (name != "undamped"), f"{name}: {sorted(attrs)}")
        if name == "series":
            settings = json.loads(attrs["solver_settings"])["chebyshev"]
            assert_all(np.all(np.isfinite(datasets["energy_drift"])) and settings["terms"] > 0, str(settings))
    assert_close(results["series z_fixed"], results["exact z_fixed"], rtol=0.0,
                 atol=1e-9 * np.abs(results["exact z_fixed"]).max(), what="spectral against exponential")
    difference = np.abs(results["rk"] - results["exact"]).max()
    decay = np.abs(results["exact"][:, -1]).max(), np.abs(results["undamped"][:, -1]).max()
    assert_all(difference < 1e-7 and not np.allclose(results["exact"], results["undamped"], rtol=0.0, atol=1e-3),
               f"rk vs exact {difference}, C(t_end) damped/undamped {decay}")
