"""``waves.engine: lammps`` in a scene (issue 46): the scene's waves integrated by LAMMPS with its
full contact law, in the same results groups as the linear paths, with their contacts' series;
at small amplitude they are the scene's linear Verlet waves.  2D and 3D, on 1 and 2 ranks."""

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close, scene_of

from solver import pipeline
from solver.io import results

CONTACTS = ("contacts_sliding", "contacts_opened", "contacts_formed", "contacts_opening", "contacts_coulomb",
            "contacts_energy")


def _run(shared_tmp, name, dim, packing=None, **waves):
    packing = packing or {"n": 64, "phi": 0.9 if dim == 2 else 0.7, "dim": dim}
    if waves.get("engine") == "lammps":
        packing = {"friction": 1.0, **packing}
    scene = scene_of(shared_tmp / f"{name}.h5", cache=str(shared_tmp / "cache"), seed=1, packing=packing,
                     model={"rho": [1.0]},
                     waves={"n": [1], "modes": ["TR"], "t_end": 10.0, "dt": 0.02, "amplitude": 1e-5, **waves})
    pipeline.run(scene, COMM, [])
    with results.open_results(scene.output) as f:
        group = f["waves/r00_TR_p0000"]
        return {name: group[name][()] for name in group}, dict(group.attrs)


# LAMMPS on 2 ranks is the 2D case's in the MPI pass; 3D varies the dimension, not the layout (as in test_frictional)
@pytest.mark.parametrize("dim", [2, pytest.param(3, marks=pytest.mark.serial_only)])
def test_small_amplitude_scene_is_the_linear_verlet_scene(lammps_present, shared_tmp, dim):
    """A = 1e-5, mu = 1: every run's z_fixed equals rotsound's own Verlet waves of the same scene
    (waves.engine: rotsound, method ts) to 1e-5 of its largest value (measured 7e-7 in the library
    test: the O(A) nonlinearity), C to 1e-5 of C(0); no contact slides, opens or forms, and each
    contact series has the unit's (R, K, S_c) shape at the times contacts_t (contacts_every 1: a
    record every sample).  energy_drift, from LAMMPS's state (kinetic energy and the contacts'
    springs), equals that of the linear Verlet waves, from (v^T M v + u^T D u) / 2 of rotsound's
    matrix: both are velocity Verlet at the same dt, whose energy wanders by O((omega dt)^2)
    (6e-5 in 2D, 3e-4 in 3D here), sampled at the same times; to 2e-6 absolute (the energies are
    quadratic in fields that agree to 7e-7; measured 4e-8).  The LAMMPS scene's plot and report read it."""
    lammps, attrs = _run(shared_tmp, f"lammps{dim}", dim, engine="lammps", contacts_every=1)
    linear, _ = _run(shared_tmp, f"linear{dim}", dim)
    scale = np.abs(linear["z_fixed"]).max()
    assert_close(lammps["z_fixed"], linear["z_fixed"], rtol=0.0, atol=1e-5 * scale, what="z_fixed against Verlet")
    assert_close(lammps["C"], linear["C"], rtol=0.0, atol=1e-5 * np.abs(linear["C"]).max(), what="C against Verlet")
    assert_close(lammps["energy_drift"], linear["energy_drift"], rtol=0.0, atol=2e-6,
                 what="energy drift against the linear Verlet waves'")
    shape = lammps["z_fixed"].shape[:2] + lammps["contacts_t"].shape
    assert_all(np.array_equal(lammps["contacts_t"], lammps["t"]), f"{lammps['contacts_t']}")
    assert_all(all(lammps[name].shape == shape for name in CONTACTS), {n: lammps[n].shape for n in CONTACTS})
    assert_all(lammps["contacts_sliding"].max() == 0 and lammps["contacts_opened"].max() == 0
               and lammps["contacts_formed"].max() == 0, "nothing slides, opens or forms at A = 1e-5")
    assert_all(attrs["integrator"].startswith("lammps") and '"friction": 1.0' in attrs["solver_settings"],
               f"{attrs['integrator']}, {attrs['solver_settings']}")
    if COMM.size == 1:  # drawing is rank 0's alone, from a file the same on 1 or 2 ranks: once, in the 1-rank pass
        from solver import plots

        assert plots.plot_results(str(shared_tmp / f"lammps{dim}.h5"))


# LAMMPS on 2 ranks is the 2D case's in the MPI pass; 3D varies the dimension, not the layout (as in test_frictional)
@pytest.mark.parametrize("dim", [2, pytest.param(3, marks=pytest.mark.serial_only)])
def test_lammps_frictional_packing_waves_from_its_stored_forces(lammps_present, shared_tmp, dim):
    """A frictional packing made by LAMMPS (packing.engine: lammps, mu = 1: stored tangential
    forces, none at the Coulomb limit) waved by LAMMPS from its own stored forces (loaded into its
    contact history) at A = 1e-5: every run's z_fixed equals the same scene's Verlet waves on the
    stressed matrix (waves.engine: rotsound) to 1e-5 of its largest value, and nothing slides."""
    packing = {"n": 64, "phi": 0.82 if dim == 2 else 0.62, "dim": dim, "engine": "lammps", "friction": 1.0,
               "force_tol": 1e-10}
    lammps, _ = _run(shared_tmp, f"stored_lammps{dim}", dim, packing, engine="lammps")
    linear, _ = _run(shared_tmp, f"stored_linear{dim}", dim, packing)
    scale = np.abs(linear["z_fixed"]).max()
    assert_close(lammps["z_fixed"], linear["z_fixed"], rtol=0.0, atol=1e-5 * scale, what="z_fixed against Verlet")
    assert_all(lammps["contacts_sliding"].max() == 0 and lammps["contacts_opened"].max() == 0, "nothing slides")


def test_sliding_scene_records_its_contacts(lammps_present, shared_tmp):
    """2D, A = 1e-2, mu = 1 -> 0.1 by packing.friction: contacts slide and open and the wave loses
    more than half its energy by t = 20 (energy_drift, the largest |E - E(0)| / E(0); its value is
    checked against the linear waves' where E is conserved, test above)."""
    scene = scene_of(shared_tmp / "slide.h5", cache="off", seed=1, packing={"n": 64, "phi": 0.9, "friction": 0.1},
                     model={"rho": [1.0]}, waves={"engine": "lammps", "n": [1], "modes": ["TR"], "t_end": 20.0,
                                                  "dt": 0.02, "amplitude": 1e-2})
    pipeline.run(scene, COMM, [])
    with results.open_results(scene.output) as f:
        group = f["waves/r00_TR_p0000"]
        sliding, opened, drift = group["contacts_sliding"][()], group["contacts_opened"][()], group["energy_drift"][()]
    assert_all(sliding.max() > 5 and opened.max() > 0, f"sliding {sliding.max()}, opened {opened.max()}")
    assert_all(np.all(drift > 0.5), f"share of the wave's energy lost by t = 20: {drift}")


def test_an_amplitude_sweep_is_one_unit_per_amplitude_read_back_in_order(lammps_present, shared_tmp):
    """waves.amplitude [1e-2, 1e-5] with the LAMMPS engine: one unit per amplitude
    (``waves/..._a00``, ``_a01``), each the unit a scene of that one amplitude makes (equal z), fitted
    on its own (``analysis/..._a<LL>``); ``results.sweeps`` reads them in ascending amplitude, with
    the contacts that slid (none at 1e-5, some at 1e-2) and the fits of the single-amplitude scene;
    ``results.waves`` and ``results.fits`` leave the sweep out; the plots draw the sweep.  A scene
    of that one amplitude taking the sweep's unit from the cache reads it as its own (not a sweep).
    The findings tool reads both files: A* against the single amplitude's fits, its figures."""
    sweep = {"engine": "lammps", "n": [1, 2], "modes": ["TR"], "t_end": 20.0, "dt": 0.02}
    cache, packing = str(shared_tmp / "cache"), {"n": 64, "phi": 0.9, "friction": 0.1}
    swept = scene_of(shared_tmp / "sweep.h5", cache=cache, seed=1, packing=packing,
                     model={"rho": [1.0]}, waves={**sweep, "amplitude": [1e-2, 1e-5]})
    alone, reused = (scene_of(shared_tmp / f"{name}.h5", cache=where, seed=1, packing=packing, model={"rho": [1.0]},
                              waves={**sweep, "amplitude": 1e-5}) for name, where in (("alone", "off"), ("reused", cache)))
    for scene in (swept, alone, reused):  # reused: the sweep's cached 1e-5 unit, in a scene of that one amplitude
        pipeline.run(scene, COMM, [])
    with results.open_results(reused.output) as f:
        reused_fit = results.fits(f)[(1.0, "TR")]
    with results.open_results(swept.output) as f, results.open_results(alone.output) as g:
        got = results.sweeps(f)[(1.0, "TR")]
        small = f["waves/r00_TR_p0000_a01"]["z"][()]
        records, samples = (f["waves/r00_TR_p0000_a01"][name][()] for name in ("contacts_t", "t"))
        assert_all(f["waves/r00_TR_p0000_a01"].attrs["amplitude"] == 1e-5 and "waves/r00_TR_p0000" not in f,
                   "the second amplitude's unit")
        reference, fitted = g["waves/r00_TR_p0000"]["z"][()], results.fits(g)[(1.0, "TR")]
        assert_all(results.waves(f) == {} and results.fits(f) == {}, "the linear readers leave the sweep out")
    assert_close(small, reference, rtol=0.0, atol=1e-14 * np.abs(reference).max(), what="the 1e-5 unit")
    assert_all(np.array_equal(records, samples[::10]), f"contacts_t {records}: every 10th sample (the default)")
    assert_close(got.amplitude, np.array([1e-5, 1e-2]), rtol=0.0, what="ascending amplitudes")
    assert_close(got.omega[0], fitted["omega"], rtol=1e-12, what="the small amplitude's fits")
    assert_close(reused_fit["omega"], fitted["omega"], rtol=1e-12, what="a cached sweep unit read as a single amplitude")
    assert_all(got.omega.shape == (2, 2) and got.sliding[0].max() == 0 and got.sliding[1].min() > 0,
               f"sliding {got.sliding}")
    assert_all(np.all(got.energy_change[1] > 10 * got.energy_change[0]), f"{got.energy_change}")
    assert_all(got.coulomb[0].max() < 1.0 and abs(got.coulomb[1].max() - 1.0) < 1e-9 and got.opening[1].max() == 1.0,
               f"largest Coulomb ratios {got.coulomb}, openings {got.opening}")
    if COMM.size == 1:  # drawing is rank 0's alone, from a file the same on 1 or 2 ranks: once, in the 1-rank pass
        from solver import plots

        written = plots.plot_results(swept.output)
        assert any(path.endswith("_sweep_TR_rho1.png") for path in written), written
        from scripts.tools import finite_amplitude_findings as findings

        found = findings.case(swept.output, findings.linear_fits([swept.output, alone.output]))
        table = findings.rows([found])  # A* against the single-amplitude scene's fits: between 1e-5 and 1e-2
        assert found["linear"] is not None and len(table) == 2, table
        assert all(1e-5 < row["A*_omega"] < 1e-2 for row in table), table
        assert len(findings.figures([found], str(shared_tmp))) == 8


@pytest.mark.serial_only  # LAMMPS on 2 ranks: the 2D scene tests above
def test_rolling_and_twisting_scene_runs_pair_granular_as_its_verlet_waves(lammps_present, shared_tmp):
    """3D, rho = 1, rho_roll = 0.5, rho_twist = 0.3 under model.history: granular, lever: contact
    (LAMMPS's pair granular, docs/finite_amplitude.md section 7; mu_roll = 0.1, mu_twist = 0.05 d0
    by waves.rolling_friction, twisting_friction), the twist wave R at A = 1e-5:
    z_fixed equals the same scene's Verlet waves on its (non-symmetric) matrix to 1e-5 of its
    largest value; the rolling records are there and nothing reaches a limit (the largest
    |f_r| / (mu_roll |f_n|) is 0.020 at mu_roll = 0.1: 1e4 would leave 2e-7); the energy record is
    NaN (LAMMPS reports no twisting torque per contact), and the scene's plot reads it."""
    model = {"rho": [1.0], "rho_roll": 0.5, "rho_twist": 0.3, "lever": "contact", "history": "granular"}
    groups = []
    lammps = {"engine": "lammps", "contacts_every": 1, "rolling_friction": 0.1, "twisting_friction": 0.05}
    for name, extra in (("granular_lammps", lammps), ("granular_linear", {})):
        packing = {"n": 64, "phi": 0.7, "dim": 3, **({"friction": 1.0} if extra else {})}
        scene = scene_of(shared_tmp / f"{name}.h5", cache=str(shared_tmp / "cache"), seed=1, packing=packing,
                         model=model, waves={"n": [1], "modes": ["R"], "t_end": 10.0, "dt": 0.02, "amplitude": 1e-5,
                                             **extra})
        pipeline.run(scene, COMM, [])
        with results.open_results(scene.output) as f:
            group = f["waves/r00_R_p0000"]
            groups.append({key: group[key][()] for key in group})
    lammps, linear = groups
    scale = np.abs(linear["z_fixed"]).max()
    assert_close(lammps["z_fixed"], linear["z_fixed"], rtol=0.0, atol=1e-5 * scale, what="z_fixed against Verlet")
    assert_all(lammps["contacts_rolling"].shape == lammps["contacts_sliding"].shape
               and lammps["contacts_rolling"].max() == 0 and 1e-3 < lammps["contacts_rolling_coulomb"].max() < 0.1 and lammps["contacts_sliding"].max() == 0
               and np.isnan(lammps["contacts_energy"]).all(),
               f"{lammps['contacts_rolling'].max()}, {lammps['contacts_rolling_coulomb'].max()}")
    from solver import plots

    assert plots.plot_results(str(shared_tmp / "granular_lammps.h5"))  # draws a NaN energy record
