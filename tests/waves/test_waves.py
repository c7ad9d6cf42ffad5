"""Standing waves: TS vs the exact spectral solution, order of accuracy, energy, phases, ranks."""

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close, schedule
from mpi4py import MPI

from solver.contact_law import ContactModel
from solver.waves import correlations
from solver.model import dynmat, operators
from solver.packing import jammed
from solver.waves import excitation
from solver.waves import integrators
from solver.waves.schedule import stability_limit
from solver.waves.spectral import spectral
from solver.references import dense_eigen, exact_z_fixed


def run(dm, p, mode, k, dt, integrator="verlet", t_end=20.0, every=None, amplitude=1e-3, direction=0):
    return integrators.integrate(dm, p.positions, mode, direction, k, amplitude=amplitude,
                                 schedule=schedule(integrator, dt, t_end, every or int(round(0.5 / dt))))


@pytest.mark.parametrize("mode", ["L", "TR", "RT"])
def test_verlet_matches_exact_reference_at_second_order(comm, packing64, mode):
    dm = dynmat.assemble(packing64, ContactModel(1.0), comm)
    k = 2 * np.pi / packing64.box_length
    errors = []
    for dt in (0.02, 0.01, 0.005):  # asymptotic regime: omega_max dt <= 0.1
        series = run(dm, packing64, mode, k, dt, t_end=10.0)
        exact = exact_z_fixed(packing64, dm, dense_eigen(dm), excitation.runs(mode, 2)[0], k, series.t, 1e-3)
        errors.append(np.abs(series.z_fixed - exact).max() / np.abs(exact).max())
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert_all(errors[-1] < 1e-3, f"error {errors}")
    assert_all(np.all(np.abs(orders - 2) < 0.15), f"observed orders {orders}")
    dm.destroy()


@pytest.mark.parametrize("integrator, order", [("alpha2", 2), ("rk", 4), ("cn", 2)])
def test_other_integrators_converge(comm, packing64, integrator, order):
    dm = dynmat.assemble(packing64, ContactModel(1.0), comm)
    k = 2 * np.pi / packing64.box_length
    errors = []
    # RK4 reaches the reference's round-off floor early: compare it at larger (stable) steps
    for dt in ((0.04, 0.02) if order == 2 else (0.16, 0.08)):
        series = run(dm, packing64, "L", k, dt, integrator, t_end=10.0, every=int(round(0.32 / dt)))
        exact = exact_z_fixed(packing64, dm, dense_eigen(dm), excitation.runs("L", 2)[0], k, series.t, 1e-3)
        errors.append(np.abs(series.z_fixed - exact).max() / np.abs(exact).max())
    observed = np.log2(errors[0] / errors[1])
    assert_all(abs(observed - order) < 0.3, f"{integrator}: errors {errors}, order {observed}")
    dm.destroy()


def test_energy_bounded_over_long_run(comm, packing64):
    dm = dynmat.assemble(packing64, ContactModel(1.0), comm)
    series = run(dm, packing64, "RT", 2 * np.pi / packing64.box_length, 0.05, t_end=400.0, every=20)
    drift = np.abs(series.energy - series.energy[0]) / series.energy[0]
    omega_max = operators.largest_omega(dm)
    bound = (omega_max * 0.05) ** 2 / 4  # Verlet's shadow-energy oscillation, no secular growth
    assert_all(drift.max() < bound, f"drift {drift.max()} > {bound}")
    half = len(drift) // 2
    assert_all(drift[half:].max() < 1.5 * drift[:half].max() + 1e-12, "secular energy growth")
    dm.destroy()


def test_phase_with_current_positions_differs_by_order_amplitude(comm, packing64):
    dm = dynmat.assemble(packing64, ContactModel(1.0), comm)
    k = 2 * np.pi * 3 / packing64.box_length
    diffs = []
    for amplitude in (1e-3, 1e-2):
        s = run(dm, packing64, "L", k, 0.02, t_end=20.0, amplitude=amplitude)
        diffs.append(np.abs(correlations.vaf(s.z) - correlations.vaf(s.z_fixed)).max())
    assert_all(diffs[0] < 1e-3 and 5 < diffs[1] / diffs[0] < 20, f"phase difference {diffs}")
    dm.destroy()


def test_excitation_has_no_momentum_and_expected_channel(comm, packing64):
    dm = dynmat.assemble(packing64, ContactModel(1.0), comm)
    k = 2 * np.pi * 2 / packing64.box_length
    mpi = COMM
    for mode in ("L", "TR", "RT"):
        for direction in (0, 1):
            component, axis = excitation.runs(mode, 2)[direction]
            v0 = excitation.start_velocity(dm, packing64.positions, component, axis, k, 1e-3, mpi).reshape(-1, 3)
            momentum = mpi.allreduce(v0[:, :2].sum(axis=0))
            others = mpi.allreduce(np.abs(np.delete(v0, component, axis=1)).max())
            # the mean is removed: a sum of N terms of size <= max |v| cancels to N eps max |v|
            largest = mpi.allreduce(np.abs(v0).max(), op=MPI.MAX)
            assert_close(momentum, np.zeros(2), rtol=0, atol=packing64.n * np.finfo(float).eps * largest,
                         what=f"{mode} {direction} momentum")
            assert_all(others == 0, f"{mode} {direction}: other channels excited")
            if mode == "L":
                assert_all(component == axis, "L: velocity along k")
            if mode == "TR":
                assert_all(component != axis and component < 2, "TR: velocity across k")
    dm.destroy()


@pytest.mark.mpi
def test_two_ranks_equal_one(comm, packing64):
    from petsc4py import PETSc

    k = 2 * np.pi * 2 / packing64.box_length
    par = run(dynmat.assemble(packing64, ContactModel(0.5), comm), packing64, "TR", k, 0.02)
    ser = run(dynmat.assemble(packing64, ContactModel(0.5), PETSc.COMM_SELF), packing64, "TR", k, 0.02)
    # z crosses zero: the error is held relative to its amplitude; round-off of the MatMult sums
    # over 1000 steps (measured 1e-15; the rank-count table of docs/scale.md)
    assert_close(par.z, ser.z, rtol=0, atol=1e-12 * np.abs(ser.z).max(), what="1 vs 2 ranks")


def test_vaf_and_spectrum_of_damped_cosine():
    t = np.arange(0, 400, 0.1)
    omega0, gamma = 2.3, 0.05
    z = np.exp(-gamma * t) * np.cos(omega0 * t) * (1 + 0.5j)
    c = correlations.vaf(np.stack([z, 2 * z]))
    # C crosses zero: held relative to C(0) = 1, the normalisation's round-off (measured 3e-16)
    assert_close(c, np.exp(-gamma * t) * np.cos(omega0 * t), rtol=0, atol=1e-14, what="VAF")
    omega, power = correlations.power_spectrum(z[None], 0.1)
    assert abs(omega[np.argmax(power)] - omega0) < 2 * np.pi / (4 * 400)
    half = power > power.max() / 2
    width = omega[half].max() - omega[half].min()
    assert abs(width - 2 * gamma) < 0.2 * 2 * gamma  # Lorentzian full width 2 gamma


def test_tapered_spectrum_of_a_tone_has_no_side_band_zeros():
    """z = exp(-i w0 t) on [0, T]: cut, S is sinc^2 with zeros 2 pi / T apart (the stripes of the
    S(k, omega) maps); tapered by cos^2(pi t / 2T), S peaks at w0 and, beyond the main lobe
    (|dw| >= 3 pi / T), lies between its closed-form bounds 1/dw^2 and (dw / (dw^2 - b^2))^2,
    b = pi / T (correlations' docstring), to the rectangle rule's (dw dt)^2 / 12 <= 1e-3 where
    dw dt <= 0.1 (measured 8e-4)."""
    dt, w0 = 0.05, 1.7
    t = np.arange(0.0, 60.0 + dt / 2, dt)
    z = np.exp(-1j * w0 * t)[None]
    b = np.pi / t[-1]
    for taper in (False, True):
        omega, power = correlations.power_spectrum(z, dt, taper=taper)
        dw = np.abs(omega - w0)
        far = (dw >= 3 * b) & (dw <= 0.1 / dt)
        scaled = power[far] * dw[far] ** 2
        if not taper:
            assert scaled.min() < 1e-2, "the cut record's zeros should show"
            continue
        assert abs(omega[np.argmax(power)] - w0) <= np.pi / (4 * t[-1]), "peak off w0 by more than half the grid"
        assert scaled.min() >= 1 - 1e-3, f"S dw^2 = {scaled.min()} dips below the lower bound 1"
        upper = (dw[far] ** 2 / (dw[far] ** 2 - b**2)) ** 2
        assert np.max(scaled / upper) <= 1 + 1e-3, f"S above its upper bound by {np.max(scaled / upper) - 1:.1e}"


@pytest.mark.serial_only  # one figure of arrays, no communicator
def test_spectrum_maps_draw_the_tapered_records(tmp_path, monkeypatch):
    """plot_spectra of a tone at one k: the drawn column of log10 S has no zero of the cut record:
    beyond the main lobe S dw^2 stays within a factor 2 of 1 (the bounds above)."""
    from figures import capture
    from solver.io.results import Waves
    from solver.plots.waves import plot_spectra

    dt, w0 = 0.05, 1.7
    t = np.arange(0.0, 60.0 + dt / 2, dt)
    figures = capture(monkeypatch)
    plot_spectra({(1.0, "L"): Waves(np.array([0.5]), t, np.exp(-1j * w0 * t)[None, None], 4.0)}, str(tmp_path / "tone"))
    mesh = figures["tone_rho1.png"].axes[0].collections[0]
    omega = mesh.get_coordinates()[:, 0, 1]  # the nearest-shading grid's row edges
    omega = 0.5 * (omega[1:] + omega[:-1])
    drawn = 10.0 ** np.asarray(mesh.get_array()).reshape(omega.size, -1)[:, 0]
    dw, b = np.abs(omega - w0), np.pi / t[-1]
    far = (dw >= 3 * b) & (dw <= 0.1 / dt)
    scaled = drawn[far] * dw[far] ** 2
    assert 0.5 < scaled.min() and scaled.max() < 2.0, (scaled.min(), scaled.max())


def test_block_verlet_equals_blocks_of_one(comm, packing64):
    dm = dynmat.assemble(packing64, ContactModel(1.0), comm)
    L = packing64.box_length
    batch = [(mode, d, 2 * np.pi * n / L) for mode in ("L", "RT") for d in (0, 1) for n in (1, 3)]
    block = integrators.integrate_block(dm, packing64.positions, batch, amplitude=1e-3,
                                        schedule=schedule("verlet", 0.02, 10.0, 25))
    for (mode, d, k), got in zip(batch, block):
        ref = run(dm, packing64, mode, k, 0.02, t_end=10.0, every=25, direction=d)
        scale = np.abs(ref.z).max()
        assert_all(np.abs(got.z - ref.z).max() < 1e-12 * scale and
                   np.abs(got.z_fixed - ref.z_fixed).max() < 1e-12 * scale, f"{mode} {d} {k}")
        # energies ~1e-5 and 2e-6 (the old default atol = 1e-8 hid any error); measured 1e-15
        assert_close(got.energy, ref.energy, rtol=1e-12, what="energy from cached acceleration")
    dm.destroy()


@pytest.mark.parametrize("block", [False, True])
def test_blow_up_stops_with_error_not_nan(comm, packing64, block):
    dm = dynmat.assemble(packing64, ContactModel(1.0), comm)
    dt = 1.05 * stability_limit("verlet", operators.largest_omega(dm))
    k = 2 * np.pi / packing64.box_length
    with pytest.raises(integrators.StabilityError, match="unstable"):
        if block:
            integrators.integrate_block(dm, packing64.positions, [("RT", 0, k)], amplitude=1e-3,
                                        schedule=schedule("verlet", dt, 2000 * dt, 1))
        else:
            run(dm, packing64, "RT", k, dt, t_end=2000 * dt, every=1)
    dm.destroy()


@pytest.mark.parametrize("mode", ["TR", "RT"])
def test_unequal_masses_match_exact_reference_on_both_paths(comm, packing64, mode):
    """model.masses: density (m ~ d^2: large disks 1.96x the small ones): Verlet at second order
    and the spectral path to 1e-8 against the exact modal solution (which reads M only through
    A = M^-1/2 D M^-1/2); a start velocity, an energy or a channel that assumed unit masses
    would leave them apart."""
    dm = dynmat.assemble(packing64, ContactModel(1.0), comm, mass_rule="density")
    eig = dense_eigen(dm)
    k = 2 * np.pi * 2 / packing64.box_length
    errors = []
    for dt in (0.01, 0.005):  # asymptotic regime, as in the equal-mass test above
        series = run(dm, packing64, mode, k, dt, t_end=10.0)
        exact = exact_z_fixed(packing64, dm, eig, excitation.runs(mode, 2)[0], k, series.t, 1e-3)
        errors.append(np.abs(series.z_fixed - exact).max() / np.abs(exact).max())
    assert_all(errors[-1] < 1e-3 and abs(np.log2(errors[0] / errors[1]) - 2) < 0.15, f"Verlet errors {errors}")
    times = np.arange(0, 40.0 + 1e-9, 0.25)
    s = spectral(dm, packing64.positions, mode, 0, k, amplitude=1e-3, times=times, tol=1e-10)
    exact = exact_z_fixed(packing64, dm, eig, excitation.runs(mode, 2)[0], k, times, 1e-3)
    error = np.abs(s.z_fixed - exact).max() / np.abs(exact).max()
    assert_all(error < 1e-8, f"spectral error {error}")
    dm.destroy()


@pytest.mark.parametrize("mode", ["L", "TR", "RT"])
def test_spectral_path_matches_exact_reference(comm, packing64, mode):
    dm = dynmat.assemble(packing64, ContactModel(1.0), comm)
    k = 2 * np.pi * 2 / packing64.box_length
    times = np.arange(0, 80.0 + 1e-9, 0.25)  # same sample times as the TS run below
    s = spectral(dm, packing64.positions, mode, 1, k, amplitude=1e-3, times=times, tol=1e-10)
    exact = exact_z_fixed(packing64, dm, dense_eigen(dm), excitation.runs(mode, 2)[1], k, times, 1e-3)
    error = np.abs(s.z_fixed - exact).max() / np.abs(exact).max()
    assert_all(error < 1e-8 and s.error_estimate < 1e-10, f"spectral error {error}, estimate {s.error_estimate}")
    # and it agrees with the TS path within the TS error (Verlet, dt = 0.005: ~1e-4 here)
    ts = run(dm, packing64, mode, k, 0.005, t_end=80.0, every=50, direction=1)
    ts_error = np.abs(ts.z_fixed - exact).max() / np.abs(exact).max()
    assert_all(np.abs(ts.z_fixed - s.z_fixed).max() / np.abs(exact).max() <= 1.01 * ts_error + 1e-8, "vs TS")
    dm.destroy()


@pytest.mark.parametrize("mode", ["L", "RT"])
def test_a_packing_tiled_along_x_has_the_same_standing_waves_in_its_rectangular_box(comm, small_packing, mode):
    """Two copies side by side in a (2L, L) box: k d0 = 2 pi / L is allowed along x (n = 2 on 2L)
    and along y (n = 1), the two runs are pooled, and each run's z is twice the original's (two
    copies in phase), so C(k, t) is the original's.  A run given the other axis' n or side, or
    pooled with another k, differs at O(1)."""
    from solver.io import coerce, schema
    from solver.waves.schedule import plan
    from solver.waves.unit import mode_unit

    p = small_packing
    tiled = jammed.from_arrays(np.concatenate([p.positions, p.positions + [p.box_length, 0.0]]),
                               np.tile(p.diameters, 2), [2 * p.box_length, p.box_length])
    spec = coerce.build(schema.WavesSpec, {"kd0": [2 * np.pi / p.box_length], "t_end": 5.0, "dt": 0.02,
                                           "sample_every": 25})
    got = {}
    for name, q in (("original", p), ("tiled", tiled)):
        dm = dynmat.assemble(q, ContactModel(1.0), comm)
        ns, ks = excitation.wave_vectors(spec, q.box, [0, 1])
        got[name] = mode_unit(dm, q.positions, spec, mode, ns, ks, [0, 1],
                              plan(spec, operators.largest_omega(dm), dm.model.rho))[0]
        dm.destroy()
    assert_all(got["tiled"]["n_axes"].tolist() == [[2, 1]] and "n_axes" not in got["original"], "allowed n")
    # the same sums over twice the particles: round-off only
    assert_close(got["tiled"]["z"], 2 * got["original"]["z"], rtol=0.0,
                 atol=1e-12 * np.abs(got["original"]["z"]).max(), what=f"{mode} z")
    assert_close(got["tiled"]["C"], got["original"]["C"], rtol=0.0, atol=1e-12, what=f"{mode} C")


def test_each_run_uses_the_k_of_its_own_axis(comm, small_packing):
    """A box stretched 0.4 % along x: k d0 = 2 pi / L gives n = 1 on both sides, k_x = 2 pi / 1.004 L
    and k_y = 2 pi / L (0.4 % apart: pooled), and each run's z is that run integrated alone at
    its own axis' k; 'k' is their mean, 'k_axes' each."""
    from solver.io import coerce, schema
    from solver.waves.schedule import plan
    from solver.waves.unit import mode_unit

    p = small_packing
    stretched = jammed.from_arrays(p.positions * [1.004, 1.0], p.diameters, [1.004 * p.box_length, p.box_length])
    spec = coerce.build(schema.WavesSpec, {"kd0": [2 * np.pi / p.box_length], "t_end": 5.0, "dt": 0.02,
                                           "sample_every": 25})
    every = schedule("verlet", 0.02, 5.0, 25)
    dm = dynmat.assemble(stretched, ContactModel(1.0), comm)
    ns, ks = excitation.wave_vectors(spec, stretched.box, [0, 1])
    data = mode_unit(dm, stretched.positions, spec, "TR", ns, ks, [0, 1],
                     plan(spec, operators.largest_omega(dm), dm.model.rho))[0]
    assert_close(data["k_axes"][0], 2 * np.pi / stretched.box, rtol=1e-15, what="k per axis")
    for r, (_, axis) in enumerate(excitation.runs("TR", 2)):
        alone = integrators.integrate(dm, stretched.positions, "TR", r, 2 * np.pi / stretched.box[axis],
                                      amplitude=spec.amplitude, schedule=every)
        # block (MatMatMult) against one run (MatMult): round-off
        assert_close(data["z"][r, 0], alone.z, rtol=0.0, atol=1e-12 * np.abs(alone.z).max(), what=f"run {r}")
    dm.destroy()


def test_waves_axes_keeps_the_runs_along_those_axes(comm, small_packing):
    """waves.axes: [y] keeps only the runs with k along y (TR: v_x with k || y) and the k of y."""
    from solver.io import coerce, schema
    from solver.waves.schedule import plan
    from solver.waves.unit import mode_unit

    spec = coerce.build(schema.WavesSpec, {"n": [1], "axes": ["y"], "t_end": 5.0, "dt": 0.02, "sample_every": 25})
    dm = dynmat.assemble(small_packing, ContactModel(1.0), comm)
    axes = excitation.wave_axes(spec, 2)
    ns, ks = excitation.wave_vectors(spec, small_packing.box, axes)
    data, attrs, _ = mode_unit(dm, small_packing.positions, spec, "TR", ns, ks, axes,
                               plan(spec, operators.largest_omega(dm), dm.model.rho))
    dm.destroy()
    assert_all(axes == [1] and data["runs"].tolist() == [[0, 1]] and data["z"].shape[0] == 1
               and attrs["run_labels"] == '["v_x, k || y"]', f"{data['runs']}, {attrs['run_labels']}")
