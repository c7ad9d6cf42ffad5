"""Standing waves in 3D (issue 18): the runs of each mode (L, TR, RT, R), what a start velocity
excites, the zero modes projected out of it, and every run on the TS paths (block Verlet, PETSc's
RK4) and the spectral path against the exact reference of a full eigendecomposition, on a small
jammed sphere packing with every spring on and with rolling/twisting springs only (rho = 0).
The 2D waves are covered by test_waves.py, unchanged."""

import json

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close, jammed_packing, schedule
from mpi4py import MPI

from solver.contact_law import ContactModel
from solver.analysis import dispersion
from solver.io.schema import AnalysisSpec, WavesSpec
from solver.model import dynmat, operators
from solver.waves import excitation
from solver.waves import integrators
from solver.waves.spectral import spectral
from solver.waves.schedule import plan
from solver.waves.unit import mode_unit
from solver.references import dense_eigen, exact_z_fixed

AMPLITUDE = 1e-3
MODES = ["L", "TR", "RT", "R"]
SPRINGS = {"all": (1.0, 0.2, 0.3), "no_tangential": (0.0, 0.5, 0.2)}
"""(rho, rho_roll, rho_twist): every spring on; and rho = 0 with rolling and twisting springs, where
the uniform spins are exact zero modes (rolling != twisting, so RT and R differ)."""


@pytest.fixture(scope="module")
def spheres():
    """32 jammed spheres at phi = 0.7 (192 DOF with rotations; L = 2.96 d0)."""
    return jammed_packing(32, 0.7, 31, dim=3)


@pytest.fixture(scope="module", params=list(SPRINGS))
def matrix(request, spheres):
    """(springs name, DynamicalMatrix on COMM_WORLD, its dense eigendecomposition (lam, vec) of
    A = M^-1/2 D M^-1/2)."""
    from petsc4py import PETSc

    rho, rho_roll, rho_twist = SPRINGS[request.param]
    dm = dynmat.assemble(spheres, ContactModel(rho, rho_roll=rho_roll, rho_twist=rho_twist), PETSc.COMM_WORLD)
    yield request.param, dm, dense_eigen(dm)
    dm.destroy()


def relative_errors(p, dm, eig, mode, k, series):
    """max |z_fixed - exact| / max |exact| of each run of ``mode`` (R,)."""
    errors = []
    for run, s in zip(excitation.runs(mode, 3), series):
        exact = exact_z_fixed(p, dm, eig, run, k, s.t, AMPLITUDE)
        errors.append(np.abs(s.z_fixed - exact).max() / np.abs(exact).max())
    return np.array(errors)


def test_runs_of_each_mode():
    """2D: tab:modes as before.  3D: L 3 runs (velocity along k), TR 6 (velocity across k, both
    polarisations), RT 6 (angular velocity across k), R 3 (angular velocity along k): every
    (component, axis) once."""
    assert_all(excitation.runs("L", 2) == [(0, 0), (1, 1)] and excitation.runs("TR", 2) == [(0, 1), (1, 0)]
               and excitation.runs("RT", 2) == [(2, 0), (2, 1)], "2D table changed")
    assert_all("R" not in excitation.RUNS[2], "R in 2D")
    counts = {mode: len(excitation.runs(mode, 3)) for mode in MODES}
    assert_all(counts == {"L": 3, "TR": 6, "RT": 6, "R": 3}, f"runs per mode {counts}")
    every = [run for mode in MODES for run in excitation.runs(mode, 3)]
    assert_all(sorted(every) == [(c, a) for c in range(6) for a in range(3)], f"not each pair once: {every}")
    for mode, rule in (("L", lambda c, a: c == a), ("TR", lambda c, a: c < 3 and c != a),
                       ("RT", lambda c, a: c >= 3 and c - 3 != a), ("R", lambda c, a: c - 3 == a)):
        assert_all(all(rule(c, a) for c, a in excitation.runs(mode, 3)), f"{mode}: {excitation.runs(mode, 3)}")


def test_start_velocity_excites_only_its_channel_without_zero_modes(spheres, matrix):
    """L/TR excite one translation, RT/R one rotation, nothing else.  In a slot with an exact zero
    mode (translations; the spins at rho = 0) the mass-weighted sum (momentum, spin angular
    momentum) vanishes; in a slot without one (the spins at rho > 0) the start is the raw sine
    (projecting there would change the wave)."""
    name, dm, _ = matrix
    k = 2 * np.pi / spheres.box_length
    rigid = {slot for slot, _ in dm.rigid_modes()}
    assert_all(rigid == ({0, 1, 2} if name == "all" else {0, 1, 2, 3, 4, 5}), f"{name}: rigid modes {rigid}")
    start, stop = dm.disk_range
    r0 = spheres.positions[dm.active][start:stop]
    mass = dm.M.getArray().reshape(-1, 6)  # m, m, m, I, I, I per sphere
    for mode in MODES:
        for component, axis in excitation.runs(mode, 3):
            v0 = excitation.start_velocity(dm, spheres.positions, component, axis, k, AMPLITUDE, COMM).reshape(-1, 6)
            label = f"{name} {mode} ({component}, {axis})"
            others = COMM.allreduce(np.abs(np.delete(v0, component, axis=1)).max(), op=MPI.MAX)
            assert_all(others == 0.0, f"{label}: other slots excited")
            assert_all((component >= 3) == (mode in ("RT", "R")), f"{label}: rotation iff RT or R")
            raw = AMPLITUDE * np.sin(k * r0[:, axis])
            if component in rigid:
                weighted = COMM.allreduce(np.sum(mass[:, component] * v0[:, component]))
                # a sum of N terms of size <= I max |v| cancelling: N eps I max |v|
                largest = COMM.allreduce(np.abs(v0).max() * mass[:, component].max(), op=MPI.MAX)
                assert_close(weighted, 0.0, rtol=0.0, atol=spheres.n * np.finfo(float).eps * largest,
                             what=f"{label}: zero-mode content")
                shift = COMM.allreduce(np.abs(v0[:, component] - raw).max(), op=MPI.MAX)
                assert_all(shift > 1e-3 * AMPLITUDE, f"{label}: premise, sum of sin(k r) is not 0 here")
            else:
                assert_all(np.array_equal(v0[:, component], raw), f"{label}: the start was changed")


def assert_converges(errors, bound, order, slack, what):
    """errors = [per-run errors at dt, at dt / 2]: the finer ones below ``bound`` and the observed
    orders log2(e(dt) / e(dt/2)) within ``slack`` of ``order``, on every rank."""
    orders = np.log2(errors[0] / errors[1])
    assert_all(errors[1].max() < bound, f"{what}: errors {errors[1]} above {bound:.2e}")
    assert_all(np.all(np.abs(orders - order) < slack), f"{what}: observed orders {orders}")


@pytest.mark.parametrize("mode", MODES)
def test_block_verlet_matches_exact_reference_at_second_order(spheres, matrix, mode):
    """Every run of the mode in one block, at dt and dt / 2: each within Verlet's phase-error bound
    (omega_max dt)^2 / 24 * omega_max t_end of the exact z, and converging at order 2 (a wrong
    start vector -- a zero mode left in -- gives an error that does not shrink with dt).
    omega_max dt = 0.11 and 0.056 here."""
    name, dm, eig = matrix
    k = 2 * np.pi / spheres.box_length
    count = len(excitation.runs(mode, 3))
    errors = []
    for dt in (0.02, 0.01):
        every = schedule("verlet", dt, 5.0, int(round(0.5 / dt)))
        block = integrators.integrate_block(dm, spheres.positions, [(mode, r, k) for r in range(count)],
                                            amplitude=AMPLITUDE, schedule=every)
        errors.append(relative_errors(spheres, dm, eig, mode, k, block))
    omega_max = operators.largest_omega(dm)
    bound = (omega_max * 0.01) ** 2 / 24 * omega_max * 5.0  # measured: at most 0.35 of it (all, R)
    assert_converges(errors, bound, 2, 0.15, f"{name} {mode}")


@pytest.mark.parametrize("mode", MODES)
def test_petsc_rk4_matches_exact_reference_at_fourth_order(spheres, matrix, mode):
    """Each run through PETSc's TS (type rk, classical RK4, first-order form): within RK4's
    phase-error bound (omega_max dt)^4 / 120 * omega_max t_end and converging at order 4
    (observed 3.93 to 4.18)."""
    name, dm, eig = matrix
    k = 2 * np.pi / spheres.box_length
    count = len(excitation.runs(mode, 3))
    errors = []
    for dt in (0.12, 0.06):
        series = [integrators.integrate(dm, spheres.positions, mode, r, k, amplitude=AMPLITUDE,
                                        schedule=schedule("rk", dt, 5.0, int(round(0.48 / dt)))) for r in range(count)]
        errors.append(relative_errors(spheres, dm, eig, mode, k, series))
    omega_max = operators.largest_omega(dm)
    bound = (omega_max * 0.06) ** 4 / 120 * omega_max * 5.0  # measured: at most 0.26 of it (all, R)
    assert_converges(errors, bound, 4, 0.3, f"{name} {mode}")


@pytest.mark.parametrize("mode", MODES)
def test_spectral_path_matches_exact_reference_for_every_3d_run(spheres, matrix, mode):
    """Every run by Lanczos to tol 1e-10: within 1e-8 of the exact z (measured <= 1e-13), 1e-8
    as in test_waves (a few times the tolerance of the Lanczos error estimate)."""
    name, dm, eig = matrix
    k = 2 * np.pi * 2 / spheres.box_length
    times = np.arange(0, 40.0 + 1e-9, 0.25)
    series = [spectral(dm, spheres.positions, mode, r, k, amplitude=AMPLITUDE, times=times, tol=1e-10)
              for r in range(len(excitation.runs(mode, 3)))]
    errors = relative_errors(spheres, dm, eig, mode, k, series)
    estimates = np.array([s.error_estimate for s in series])
    assert_all(errors.max() < 1e-8 and estimates.max() < 1e-10, f"{name} {mode}: errors {errors}, "
               f"estimates {estimates}")


@pytest.mark.parametrize("mode", ["TR", "R"])
def test_unit_stores_every_run_in_order(spheres, mode):
    """mode_unit in 3D: z, z_fixed, energy_drift have one row per run, in the order of the
    datasets ``runs`` / ``run_labels``, each row equal to that run alone (Verlet block of one; every
    run at the last k, the first run also at the first k)."""
    from petsc4py import PETSc

    dm = dynmat.assemble(spheres, ContactModel(1.0, rho_roll=0.2, rho_twist=0.3), PETSc.COMM_WORLD)
    spec = WavesSpec(n=[1, 2], t_end=5.0, dt=0.02, sample_every=25)
    ns, ks = excitation.wave_vectors(spec, spheres.box, [0, 1, 2])  # the cube: one column three times
    every = schedule("verlet", 0.02, 5.0, 25)
    data, attrs, _ = mode_unit(dm, spheres.positions, spec, mode, ns, ks, [0, 1, 2],
                               plan(spec, operators.largest_omega(dm), dm.model.rho))
    count = len(excitation.runs(mode, 3))
    assert_all(data["z"].shape == (count, 2, 11) and data["z_fixed"].shape == (count, 2, 11)
               and data["energy_drift"].shape == (count, 2), f"shapes {data['z'].shape}")
    assert_all([tuple(r) for r in data["runs"]] == excitation.runs(mode, 3), f"runs {data['runs']}")
    labels = json.loads(attrs["run_labels"])
    assert_all(labels[0] == ("v_y, k || x" if mode == "TR" else "w_x, k || x") and len(labels) == count, str(labels))
    for r, i in [(0, 0)] + [(r, 1) for r in range(count)]:
        alone = integrators.integrate(dm, spheres.positions, mode, r, ks[i, 0], amplitude=spec.amplitude,
                                      schedule=every)
        # the same arithmetic in a block of R K columns or of one: MatMatMult vs MatMult round-off
        assert_close(data["z"][r, i], alone.z, rtol=0.0, atol=1e-12 * np.abs(alone.z).max(),
                     what=f"{mode} run {r} k {i}")
    dm.destroy()


def test_analysis_fits_every_mode_including_r(spheres, matrix):
    """The dispersion analysis takes 3D units of L, TR, RT and R (spectral path): one fitted group
    per mode, each C pooled over that mode's runs; R, like RT, is optical (no gamma ~ k^p fit) and
    its fitted frequencies lie inside the band of non-zero eigenfrequencies."""
    name, dm, (lam, _) = matrix
    spec = WavesSpec(n=[1, 2], t_end=60.0, dt=0.05, sample_every=5, method="spectral", tol=1e-8)
    ns, ks = excitation.wave_vectors(spec, spheres.box, [0, 1, 2])
    units = {}
    for mode in MODES:
        data, attrs, _ = mode_unit(dm, spheres.positions, spec, mode, ns, ks, [0, 1, 2],
                                   plan(spec, operators.largest_omega(dm), dm.model.rho))
        units[f"waves/r00_{mode}_p0000"] = (data, {**attrs, "packing": 0})
    out = dispersion.analyse(units, AnalysisSpec(power_law_kd0_max=2 * np.pi))  # every k: L and TR count points
    groups = sorted(g for g in out if g.startswith("analysis/rho"))
    assert_all(groups == sorted(f"analysis/rho{dm.model.rho:g}_{m}" for m in MODES), f"{name}: groups {groups}")
    table, attrs = out[f"analysis/rho{dm.model.rho:g}_R"]
    assert_all(attrs["mode"] == "R" and attrs["configurations"] == 1 and attrs["power_law_points"] == 0,
               f"{name}: R attributes {attrs}")
    band = np.sqrt(lam[lam > 1e-10 * lam.max()])
    omega = table["omega"]
    assert_all(np.all(np.isfinite(omega)) and np.all((omega > band.min()) & (omega < band.max())),
               f"{name}: R frequencies {omega} outside [{band.min():.3f}, {band.max():.3f}]")


@pytest.mark.mpi
@pytest.mark.parametrize("mode", MODES)
def test_two_ranks_equal_one_for_every_3d_run_on_both_paths(spheres, mode):
    """Every run of the mode on 2 ranks against 1 rank (COMM_SELF): Verlet to 1e-12 of max |z|
    (round-off of the MatMult sums), Lanczos within 2 tol of max |z| (each within tol of exact)."""
    from petsc4py import PETSc

    k = 2 * np.pi / spheres.box_length
    count = len(excitation.runs(mode, 3))
    times = np.arange(0, 20.0 + 1e-9, 0.25)
    out = []
    for comm in (PETSc.COMM_WORLD, PETSc.COMM_SELF):
        dm = dynmat.assemble(spheres, ContactModel(1.0, rho_roll=0.2, rho_twist=0.3), comm)
        ts = integrators.integrate_block(dm, spheres.positions, [(mode, r, k) for r in range(count)],
                                         amplitude=AMPLITUDE, schedule=schedule("verlet", 0.02, 10.0, 25))
        lanczos = [spectral(dm, spheres.positions, mode, r, k, amplitude=AMPLITUDE, times=times, tol=1e-10)
                   for r in range(count)]
        out.append((np.array([s.z for s in ts]), np.array([s.z for s in lanczos])))
        dm.destroy()
    (par_ts, par_sp), (ser_ts, ser_sp) = out
    assert_close(par_ts, ser_ts, rtol=0.0, atol=1e-12 * np.abs(ser_ts).max(), what=f"{mode} Verlet")
    assert_close(par_sp, ser_sp, rtol=0.0, atol=2e-10 * np.abs(ser_sp).max(), what=f"{mode} Lanczos")


SCENE_3D = """\
output: {out}
cache: off
seed: 4
packing: {{n: 32, phi: 0.7, dim: 3}}
model: {{rho: [1.0], rho_roll: 0.2, rho_twist: 0.3}}
waves: {{modes: [L, TR, RT, R], n: [1, 2], t_end: 20, dt: 0.02, sample_every: 10}}
"""


@pytest.mark.spawns_ranks
@pytest.mark.serial_only  # launches its own (mpirun) processes
def test_cli_runs_a_3d_scene_with_every_mode_on_1_and_2_ranks(tmp_path, capsys):
    """``rotsound run`` end to end on 32 spheres with L, TR, RT and R (1 rank in this process, 2 as a
    job of its own): each waves group has one row per run (3, 6, 6, 3) labelled in the file, the
    analysis fits all four modes, and 2 ranks give the 1-rank z to 1e-12 of max |z| (round-off of
    the MatMult sums, as in 2D)."""
    import h5py
    from conftest import main_here, run_cli

    files = []
    for ranks in (1, 2):
        scene = tmp_path / f"s{ranks}.yaml"
        scene.write_text(SCENE_3D.format(out=tmp_path / f"s{ranks}.h5"))
        if ranks == 1:  # in this process (a process of 1 rank: test_cli); the 2-rank job is the process checked
            code, said, err = main_here(["run", str(scene)], capsys)
        else:
            proc = run_cli(["run", str(scene)], ranks)
            code, said, err = proc.returncode, proc.stdout, proc.stderr
        assert code == 0, err
        for mode, count in (("L", 3), ("TR", 6), ("RT", 6), ("R", 3)):
            assert f"waves rho = 1, {mode}, packing 0: 2 k x {count} runs" in said, said
        files.append(tmp_path / f"s{ranks}.h5")
    with h5py.File(files[0]) as one, h5py.File(files[1]) as two:
        assert one["packings/0000/positions"].shape == (32, 3)
        for mode in MODES:
            group = one[f"waves/r00_{mode}_p0000"]
            runs = excitation.runs(mode, 3)
            assert group["z"].shape == (len(runs), 2, 101) and group["energy_drift"].shape == (len(runs), 2)
            assert [tuple(r) for r in group["runs"][()]] == runs
            assert json.loads(group.attrs["run_labels"]) == [excitation.run_label(c, a, 3) for c, a in runs]
            z, z2 = group["z"][()], two[f"waves/r00_{mode}_p0000/z"][()]
            assert_close(z2, z, rtol=0.0, atol=1e-12 * np.abs(z).max(), what=f"{mode}: 2 ranks vs 1")
        assert sorted(name for name in one["analysis"] if name.startswith("rho")) == \
            sorted(f"rho1_{mode}" for mode in MODES)
    code, out, err = main_here(["plot", str(files[0])], capsys)  # the four-mode figures of a 3D file
    assert code == 0, err
    for figure in ("packing", "vaf", "spectrum_rho1", "dispersion"):
        assert (tmp_path / f"s1_{figure}.png").exists(), (figure, out)
