"""The waves' time schedule has one source of truth: the TS with prefix ``waves_`` read back after
the scene's values and the ``-waves_ts_*`` options; it is checked before any integration, used
for the runs and recorded.  Also: a blow-up in flight ends cleanly, a run writes nothing into
the options database, the theta, beuler and ssp integrators converge at their order, and what
each solver object used is recorded per unit; ``schedule.plan`` is the one place the waves'
method is decided."""

import contextlib
import json

import numpy as np
import pytest
import yaml
from conftest import COMM, assert_all, assert_close, run_cli, schedule

from solver.contact_law import ContactModel
from solver import options
from solver.errors import InputError
from solver.model import dynmat, operators
from solver.waves import excitation
from solver.waves import integrators
from solver.io.schema import WavesSpec
from solver.waves.schedule import check_schedule, plan, stability_limit
from solver.references import dense_eigen, exact_z_fixed


@contextlib.contextmanager
def user_options(**values):
    """Options as a user's command line would put them into the database (removed afterwards)."""
    from petsc4py import PETSc

    database = PETSc.Options()
    for name, value in values.items():
        database.setValue(name, value)
    try:
        yield [word for name, value in values.items() for word in (f"-{name}", value)]
    finally:
        for name in values:
            database.delValue(name)


def resolve(integrator="verlet", dt=0.05, t_end=2.0, every=5):
    return schedule(integrator, dt, t_end, every)


def test_schedule_comes_from_the_scene_or_the_waves_ts_options():
    plain = resolve()
    assert_all((plain.integrator, plain.variant, plain.dt, plain.steps, plain.adapt) == ("verlet", None, 0.05, 40, "none")
               and plain.sources["dt"] == "waves.dt = 0.05" and plain.sources["integrator"] == "waves.integrator = verlet",
               f"{plain}")
    with user_options(waves_ts_type="rk", waves_ts_dt="0.01", waves_ts_max_time="1.5"):
        chosen = resolve()
    assert_all((chosen.integrator, chosen.variant, chosen.dt, chosen.steps) == ("rk", "4", 0.01, 150)
               and chosen.sources == {"dt": "-waves_ts_dt 0.01", "integrator": "-waves_ts_type rk",
                                      "t_end": "-waves_ts_max_time 1.5"}, f"{chosen}")
    with user_options(waves_ts_rk_type="3"):
        rk3 = resolve("rk")
    assert_all(rk3.variant == "3" and stability_limit("rk", 1.0, rk3.variant) == np.sqrt(3.0), f"{rk3}")


def test_a_variable_step_or_too_few_samples_is_refused_naming_the_option():
    with user_options(waves_ts_adapt_type="basic"):
        adaptive = resolve("rk")
    with pytest.raises(InputError, match="TSAdapt basic.*-waves_ts_adapt_type none"):
        check_schedule(adaptive, 1.0, 1.0)
    with user_options(waves_ts_max_steps="10"):
        short = resolve()
    with pytest.raises(InputError, match=r"fewer than 4 samples in t_end = 0.5 \(waves.t_end = 2, -waves_ts_max_steps 10\)"):
        check_schedule(short, 1.0, 1.0)


def test_a_ts_type_petsc_does_not_know_is_bad_input():
    with user_options(waves_ts_type="verlet"):
        with pytest.raises(InputError, match=r"^-waves_ts_type verlet: PETSc's TS refused it \(Unknown TS type"):
            resolve()


def test_dt_from_the_option_is_checked_like_the_scene_key(comm, packing64):
    """The stability check reads the schedule, whichever source set dt (the issue: -ts_dt 0.6
    bypassed the check that refuses waves.dt = 0.6)."""
    dm = dynmat.assemble(packing64, ContactModel(1.0), comm)
    omega_max = operators.largest_omega(dm)
    dm.destroy()
    limit = 2.0 / omega_max
    with pytest.raises(InputError, match=r"^waves.dt = 0.6: above the stability limit"):
        check_schedule(resolve(dt=0.6, t_end=20.0), omega_max, 1.0)
    with user_options(waves_ts_dt="0.6"):
        with pytest.raises(InputError, match=rf"^-waves_ts_dt 0.6: above the stability limit {limit:.4f} t0 of verlet"):
            check_schedule(resolve(dt=0.02, t_end=20.0), omega_max, 1.0)
    assert_all(check_schedule(resolve(dt=0.02, t_end=20.0), omega_max, 1.0) == limit, "limit returned")


SCENE = """\
output: {out}
cache: off
seed: 4
packing: {{n: 64, phi: 0.9}}
model: {{rho: 1}}
spectrum: {{method: slicing}}
waves: {{n: [1], modes: [L], dt: 0.05, t_end: 4, sample_every: 5}}
"""


def test_run_uses_and_records_the_options_and_writes_nothing_into_the_database(shared_tmp):
    """-waves_ts_type rk -waves_ts_dt 0.01 are what the unit was integrated with (its z equals a
    direct RK4 run at dt = 0.01) and what it records; the spectrum unit records its EPS (MUMPS
    with ICNTL 13, 24), the inertia factorisation and the partitions; and the run leaves the
    options database as it found it (slicing and the waves once wrote their defaults there)."""
    from petsc4py import PETSc

    from solver import pipeline
    from solver.io import coerce, schema

    scene = coerce.build(schema.Scene, yaml.safe_load(SCENE.format(out=shared_tmp / "r.h5")))
    with user_options(waves_ts_type="rk", waves_ts_dt="0.01") as argv:
        before = PETSc.Options().getAll()
        result = pipeline.run(scene, COMM, argv, fresh=True)
        after = PETSc.Options().getAll()
    assert_all(after == before, f"options written by the run: {set(after.items()) ^ set(before.items())}")
    units, made = result["units"], result["packings"][0]
    datasets, attrs = units["waves/r00_L_p0000"]
    used = json.loads(attrs["solver_settings"])
    assert_all(attrs["integrator"] == "rk" and attrs["dt"] == 0.01 and datasets["t"].size == 81
               and abs(attrs["sample_dt"] - 0.05) < 1e-15, f"{attrs}")
    assert_all({k: used["ts"][k] for k in ("prefix", "ts_type", "rk_type", "dt", "max_steps", "adapt_type")}
               == {"prefix": "waves_", "ts_type": "rk", "rk_type": "4", "dt": 0.01, "max_steps": 400,
                   "adapt_type": "none"} and used["wmax"]["prefix"] == "wmax_", f"{used}")
    dm = dynmat.assemble(made, ContactModel(1.0), PETSc.COMM_WORLD)
    direct = integrators.integrate(dm, made.positions, "L", 0, float(datasets["k"][0]), amplitude=1e-3,
                                   schedule=resolve("rk", dt=0.01, t_end=4.0))
    dm.destroy()
    assert_close(datasets["z"][0, 0], direct.z, rtol=0, atol=1e-14 * np.abs(direct.z).max(),
                 what="unit z against a direct RK4 run at dt = 0.01")  # same code, same numbers
    spectrum = json.loads(units["spectra/r00_p0000"][1]["solver_settings"])
    eps = spectrum["spectrum"]
    assert_all(eps["prefix"] == "spectrum_" and eps["eps_type"] == "krylovschur" and eps["st_type"] == "sinvert"
               and eps["factor_package"] == "mumps" and eps["tol"] == scene.spectrum.tol
               and eps["partitions"] == [COMM.size], f"{eps}")
    if COMM.size == 1:  # with one partition per rank SLEPc may re-create a (sequential) factor, which
        assert_all(eps["mumps_icntl"] == {"13": 1, "24": 1}, f"{eps}")  # then has MUMPS's own ICNTL
    assert_all(spectrum["inertia"]["prefix"] == "inertia_" and spectrum["inertia"]["factor_package"] == "mumps",
               f"{spectrum['inertia']}")


CLI_SCENE = """\
output: {out}
cache: off
packing: {{n: 64, phi: 0.9}}
model: {{rho: 1}}
waves: {{n: [1], modes: [L], t_end: 20}}
"""


def run_scene(tmp_path, words):
    out = tmp_path / "never.h5"
    path = tmp_path / "scene.yaml"
    path.write_text(CLI_SCENE.format(out=out))
    return run_cli(["run", str(path), *words], ranks=2, timeout=120, cwd=tmp_path), out


@pytest.mark.spawns_ranks
@pytest.mark.serial_only  # launches its own mpirun
def test_dt_option_above_the_limit_is_refused_before_integrating(tmp_path):
    """N = 64, rho = 1: limit ~0.43.  -waves_ts_dt 0.6 stops every rank with exit code 2 and one
    message naming the option, before any integration; nothing is written for the waves."""
    proc, out = run_scene(tmp_path, ["-waves_ts_dt", "0.6"])
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    assert proc.stderr.count("rotsound: error: -waves_ts_dt 0.6: above the stability limit") == 1, proc.stderr
    assert proc.stderr.count("rotsound: error:") == 1 and "Traceback" not in proc.stderr + proc.stdout
    assert "waves rho" not in proc.stdout, "integrated before refusing"
    assert not out.exists() and not list(tmp_path.glob("never.h5.units/waves*"))


@pytest.mark.spawns_ranks
@pytest.mark.serial_only  # launches its own mpirun
def test_blow_up_in_flight_ends_with_one_error_line_and_exit_code_3(tmp_path):
    """ssp has no tabulated stability limit (it passes the check) and diverges at dt = 0.6: every
    rank stops with exit code 3 and one message naming the dt and where it came from; no
    traceback, no results file, no unit for that wave."""
    proc, out = run_scene(tmp_path, ["-waves_ts_type", "ssp", "-waves_ts_dt", "0.6"])
    assert proc.returncode == 3, (proc.returncode, proc.stdout, proc.stderr)
    assert proc.stderr.count("rotsound: error:") == 1, proc.stderr
    assert "unstable (ssp (-waves_ts_type ssp), dt = 0.6 from -waves_ts_dt 0.6)" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr + proc.stdout
    assert not out.exists() and not list(tmp_path.glob("never.h5.units/waves*"))


@pytest.mark.parametrize("integrator, order, dts", [("theta", 2, (0.08, 0.04, 0.02)),
                                                    ("beuler", 1, (0.04, 0.02, 0.01)),
                                                    ("ssp", 2, (0.08, 0.04, 0.02))])
def test_theta_beuler_ssp_converge_at_their_order(comm, packing64, integrator, order, dts):
    """Against the exact modal solution (references.exact_z_fixed): each halving of dt divides the
    error by 2^order to within 0.1 in the observed order (measured: theta 2.00, 2.00; beuler 0.97,
    0.99; ssp 2.00, 2.00)."""
    dm = dynmat.assemble(packing64, ContactModel(1.0), comm)
    k = 2 * np.pi / packing64.box_length
    errors = []
    for dt in dts:
        series = integrators.integrate(dm, packing64.positions, "L", 0, k, amplitude=1e-3,
                                       schedule=resolve(integrator, dt=dt, t_end=10.0, every=int(round(0.32 / dt))))
        assert_all(series.settings["ts_type"] == integrator and series.settings["dt"] == dt, f"{series.settings}")
        exact = exact_z_fixed(packing64, dm, dense_eigen(dm), excitation.runs("L", 2)[0], k, series.t, 1e-3)
        errors.append(np.abs(series.z_fixed - exact).max() / np.abs(exact).max())
    dm.destroy()
    observed = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert_all(np.all(np.abs(observed - order) < 0.1), f"{integrator}: errors {errors}, orders {observed}")


def test_unused_options_are_judged_by_prefix():
    names = ["spectrum_eps_tol", "log_view", "waves_ts_dt", "inertia_mat_mumps_icntl_14", "not_an_option"]
    assert options.unused(names, [("spectra", "slicing")]) == ["waves_ts_dt", "not_an_option"]
    assert options.unused(names, [("waves", "ts")]) == ["spectrum_eps_tol", "inertia_mat_mumps_icntl_14",
                                                        "not_an_option"]


def test_bare_solver_options_are_refused_with_the_prefixed_name():
    from solver.errors import InputError

    for name, hint in (("eps_tol", "-spectrum_eps_tol or -wmax_eps_tol"), ("ts_dt", "-waves_ts_dt"),
                       ("mat_mumps_icntl_14", "-spectrum_st_mat_mumps_icntl_14 or -inertia_mat_mumps_icntl_14")):
        with pytest.raises(InputError, match=f"did you mean {hint}"):
            options.refuse_bare_solver_options(["log_view", name])
    options.refuse_bare_solver_options(["log_view", "spectrum_eps_tol", "waves_ts_dt"])


@pytest.mark.serial_only  # the plan's arithmetic, no communicator
def test_plan_decides_the_method_once():
    """plan: spectral gives the sample grid alone (no step, no limit); ts gives the TS schedule with
    the Verlet limit 2 / omega_max, and refuses a step above it; both carry omega_max."""
    spectral = plan(WavesSpec(method="spectral", dt=0.05, t_end=1.0, sample_every=2), 3.0, 1.0)
    assert_all(spectral.method == "spectral" and spectral.limit is None and spectral.omega_max == 3.0
               and spectral.steps == 0, f"{spectral}")
    assert_close(spectral.sample_times(), 0.1 * np.arange(11), rtol=0.0, atol=1e-15, what="spectral grid")
    ts = plan(WavesSpec(dt=0.05, t_end=1.0, sample_every=2), 3.0, 1.0)
    assert_all(ts.method == "ts" and ts.integrator == "verlet" and ts.steps == 20 and ts.omega_max == 3.0,
               f"{ts}")
    assert_close(ts.limit, 2.0 / 3.0, rtol=1e-15, what="Verlet limit")
    with pytest.raises(InputError, match="above the stability limit 0.6667 t0 of verlet"):
        plan(WavesSpec(dt=0.7, t_end=10.0, sample_every=1), 3.0, 1.0)
