"""One unit of standing waves: every run (``excitation.runs``: 2 in 2D; 3 or 6 in 3D) and wave
number of one (rho, mode, packing), run by the path its schedule chose (``PATHS``: time steps,
``integrators``; or without time steps, ``spectral``, ``chebyshev`` and ``exponential``) and
reduced to the datasets and attributes of the results file's ``waves/r<i>_<mode>_p<j>`` group
(docs/results_file.md).

C (K, S) and S (K, W) pool the mode's runs (``waves.correlations.pooled``): numerators and
denominators averaged over directions and polarisations.
Collective on the matrix's communicator.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import functools
import json

import numpy as np

from . import correlations
from ..model import dynmat
from . import chebyshev, excitation, exponential, integrators, lammps_dem, spectral
from .sampling import WaveSeries
from .schedule import Schedule
from ..wording import counted


def mode_unit(dm, positions, spec, mode: str, ns: np.ndarray, ks: np.ndarray, axes: list[int],
              schedule: Schedule, dem: lammps_dem.Setting | None = None, cell=None) -> tuple[dict, dict, str]:
    """(datasets, attrs, summary) of one mode on ``dm`` for the wave numbers ``ks`` (``ns``), both
    (K, A) over the A ``axes`` used (``excitation.wave_vectors``), every run of the mode in
    ``dm.dim`` dimensions along those axes (R runs: the first axis of z, z_fixed, energy_drift,
    error_estimate; which run is which: datasets ``runs`` (R, 2) and attribute ``run_labels``).
    A run along axis a uses the k of that axis; in a tilted ``cell`` (``geometry.Cell``; None: an
    orthogonal one) k runs along the reciprocal vector b_a (``excitation.wave_vector``).

    ``spec``: the scene's waves section; ``schedule``: how the runs go (``schedule.plan``: its
    ``path`` picks the function of ``PATHS``; the paths without time steps sample every
    ``dt * sample_every`` to ``t_end``, time stepping follows the TS schedule; it carries omega_max
    and the stability limit; path ``lammps``: LAMMPS integrates the packing ``dem`` describes,
    and the unit also keeps each run's contact series, datasets ``contacts_*`` (R, K, S_c) at the
    times ``contacts_t`` (S_c,), every ``dem.record_every``-th sample).
    ``summary``: one line for the log.
    Raises StabilityError on every rank if a run blows up (nothing is returned then).
    """
    chosen = [r for r, (_, axis) in enumerate(excitation.runs(mode, dm.dim)) if axis in axes]
    excited = [excitation.runs(mode, dm.dim)[r] for r in chosen]
    column = {r: axes.index(axis) for r, (_, axis) in zip(chosen, excited)}  # the k of the run's axis
    count = len(ks)
    waves = [(mode, r, excitation.wave_vector(k, axis, cell)) for r, (_, axis) in zip(chosen, excited)
             for k in ks[:, column[r]]]
    run_path = functools.partial(_lammps, dem) if schedule.path == "lammps" else PATHS[schedule.path]
    flat, estimated, path_settings, summary = run_path(dm, positions, spec, waves, schedule)
    series = [flat[i * count:(i + 1) * count] for i in range(len(chosen))]
    z = np.array([[r.z for r in row] for row in series])  # (R, K, S)
    z_fixed = np.array([[r.z_fixed for r in row] for row in series])
    energy = np.array([[r.energy for r in row] for row in series])
    t = series[0][0].t
    vaf, omega, power = correlations.pooled(z, t[1] - t[0])
    same = bool(np.all(ks == ks[:, :1]))  # one k for every axis (a square or cubic box, or sides n L)
    datasets = {"k": ks[:, 0] if same else ks.mean(axis=1), "n": ns[:, 0], "t": t, "C": vaf, "omega": omega,
                "S": power, "z": z, "z_fixed": z_fixed, "energy_drift": _drift(energy),
                "runs": np.array(excited, dtype=np.int64)}
    if not (same and np.all(ns == ns[:, :1])):  # sides that differ: each axis' own n and k (k: their mean)
        datasets.update(n_axes=ns, k_axes=ks)
    if flat[0].contacts is not None:  # the LAMMPS path's: their times, and each run's series (R, K, S_c)
        datasets["contacts_t"] = flat[0].contacts["contacts_t"]
        datasets.update({name: np.array([[r.contacts[name] for r in row] for row in series])
                         for name in flat[0].contacts if name != "contacts_t"})
    if estimated:
        datasets["error_estimate"] = np.array([[r.error_estimate for r in row] for row in series])
    settings = {"wmax": dm.wmax_settings, **path_settings}
    attrs = {"rho": dm.model.rho, "mode": mode, "dt": schedule.dt, "integrator": schedule.integrator,
             "omega_max": schedule.omega_max, "dt_limit": np.inf if schedule.limit is None else schedule.limit,
             "amplitude": spec.amplitude, "sample_dt": t[1] - t[0], "solver_settings": json.dumps(settings),
             "run_labels": json.dumps([excitation.run_label(c, a, dm.dim) for c, a in excited])}
    if schedule.damping_max > 0.0:  # dashpots: their fastest rate, which the step limit also used
        attrs["damping_max"] = schedule.damping_max
    if spec.snapshots:  # the schema allows them on the undamped spectral path only
        smallest = float(ks[:, column[chosen[0]]].min())
        datasets.update(_snapshots(dm, positions, spec, mode, chosen[0], excitation.wave_vector(smallest, excited[0][1], cell), schedule))
        attrs.update(snapshot_k=smallest, snapshot_run=excitation.run_label(*excited[0], dm.dim))
    return datasets, attrs, summary


def _drift(energy: np.ndarray) -> np.ndarray:
    """max |E - E(0)| / E(0) of each run's energy samples ``energy`` (..., S) (the damped spectral
    path leaves NaN between its blocks; NaN where every sample is: LAMMPS's waves with twisting
    springs, whose energy is not recorded)."""
    return np.fmax.reduce(np.abs(energy - energy[..., :1]), axis=-1) / energy[..., 0]


def _time_steps(dm, positions, spec, waves, schedule: Schedule):
    """Path ``ts``: every wave of ``waves`` ((mode, run, k)) integrated (``integrators``; Verlet:
    all at once, one MatMatMult per step).  Returns (series, False: no error estimates, settings,
    summary) as every path does.  Collective."""
    flat = integrators.integrate_all(dm, positions, waves, amplitude=spec.amplitude, schedule=schedule)
    energy = np.array([r.energy for r in flat])
    summary = (f"{flat[0].steps} steps each ({schedule.label}, dt = {schedule.dt:g}), "
               + _energy_words(dm, energy, _drift(energy), flat[0].t[-1]))
    return flat, False, {"ts": flat[0].settings}, summary


def _lanczos(dm, positions, spec, waves, schedule: Schedule):
    """Path ``spectral``: no time steps, Lanczos on the matrix (``spectral``).  Collective."""
    flat = spectral.spectral_all(dm, positions, waves, amplitude=spec.amplitude, times=schedule.sample_times(),
                                 tol=spec.tol, omega_max=schedule.omega_max)
    lanczos = {"tol": spec.tol, "max_steps": max(r.steps for r in flat)}
    summary = (f"spectral, up to {lanczos['max_steps']} Lanczos steps, error estimate "
               f"{np.nanmax([r.error_estimate for r in flat]):.1e}")
    return flat, True, {"lanczos": lanczos}, summary


def _series(dm, positions, spec, waves, schedule: Schedule):
    """Path ``damped_spectral``: no time steps, the Chebyshev-Bessel series of exp(tJ) with the
    dashpots (``chebyshev``), one wave after another.  Collective."""
    times = schedule.sample_times()
    flat = [chebyshev.damped_spectral(dm, positions, mode, r, k, amplitude=spec.amplitude, times=times, tol=spec.tol,
                                      omega_max=schedule.omega_max, damping_max=schedule.damping_max)
            for mode, r, k in waves]
    series = {**flat[0].settings, "products": max(r.steps for r in flat)}
    summary = (f"spectral (Chebyshev-Bessel series, blocks of {series['block_samples']} samples, "
               f"{series['terms']} terms), up to {series['products']} products "
               f"with J, error bound {np.nanmax([r.error_estimate for r in flat]):.1e}")
    return flat, True, {"chebyshev": series}, summary


def _mfn(dm, positions, spec, waves, schedule: Schedule):
    """Path ``exponential``: exp(h J) of the first-order system from sample to sample by SLEPc MFN
    (``exponential``).  Collective."""
    flat = exponential.exponential_all(dm, positions, waves, amplitude=spec.amplitude, times=schedule.sample_times(),
                                       tol=spec.tol, rate=max(schedule.omega_max, schedule.damping_max))
    mfn = {**flat[0].settings, "max_iterations": max(r.settings["max_iterations"] for r in flat)}
    summary = (f"exponential, {len(flat[0].t) - 1} MFN solves each (up to {mfn['max_iterations']} "
               f"iterations), error estimate {np.nanmax([r.error_estimate for r in flat]):.1e}")
    return flat, True, {"mfn": mfn}, summary


def _lammps(dem: lammps_dem.Setting, dm, positions, spec, waves, schedule: Schedule):
    """Path ``lammps``: every wave integrated by LAMMPS with its full contact law
    (``lammps_dem.run``), one after another, from rotsound's start at ``waves.amplitude``;
    z = z_fixed with the r_i(0) phase.  Collective."""
    mpi = dm.D.getComm().tompi4py()
    x = positions[dm.active]
    t = np.arange(schedule.steps // schedule.sample_every + 1) * (schedule.dt * schedule.sample_every)
    flat = []
    for mode, r, k in waves:
        component, axis = excitation.runs(mode, dm.dim)[r]
        start = excitation.whole_start(dm, positions, component, axis, k, spec.amplitude, mpi)
        z, contacts = lammps_dem.run(positions, dem.diameters, dem.box, dm.active, dm.model, dem.friction, start,
                                     schedule.dt, schedule.steps, schedule.sample_every, dem.rest_tol,
                                     (component, np.exp(-1j * k * x[:, axis])), mpi, dem.record_every,
                                     dem.tangential, dem.rolling_friction, dem.twisting_friction)
        flat.append(WaveSeries(t, z, z, contacts.energy, schedule.steps,
                               contacts={"contacts_t": t[::dem.record_every], **contacts.as_datasets()}))
    settings = {"dt": schedule.dt, "steps": schedule.steps, "sample_every": schedule.sample_every,
                "contacts_every": dem.record_every, "friction": dem.friction,
                "pair_style": lammps_dem.pair_style(dm.model)}
    energy = np.array([r.energy for r in flat])
    gain = "velocity Verlet's O(dt^2) error" + (", and the Mindlin springs' stiffness following the overlap"
                                               if dm.model.law == "hertz" else "") + \
        ": sliding, dashpots and opened contacts only take energy"
    sliding = max(int(r.contacts["contacts_sliding"].max()) for r in flat)
    opened = max(int(r.contacts["contacts_opened"].max()) for r in flat)
    summary = (f"LAMMPS, {schedule.steps} steps each (dt = {schedule.dt:g}, mu = {dem.friction:g}), "
               f"up to {counted(sliding, 'contact')} sliding and {opened} opened at once, energy by t = "
               f"{flat[0].contacts['contacts_t'][-1]:g}: {_loss_words(energy, gain)}")
    return flat, False, {"lammps": settings}, summary


PATHS = {"ts": _time_steps, "spectral": _lanczos, "damped_spectral": _series, "exponential": _mfn}
"""``Schedule.path`` -> the function that runs a unit's waves that way: (dm, positions, waves
section, [(mode, run, k)], schedule) -> (series in that order, whether they carry error
estimates, solver settings, summary for the log)."""


def _energy_words(dm, energy: np.ndarray, drift: np.ndarray, t_end: float) -> str:
    """What the log says of the energy E = (v^T M v + u^T D u)/2 of time-stepped runs (``energy``
    (W, S) of W runs, ``drift`` (W,) its max |E - E(0)|/E(0)): its drift where it is conserved; with dashpots
    on a symmetric matrix the share of E(0) gone by ``t_end`` (the dashpots' work, plus the
    scheme's error, which is not separated; a rise, which dashpots cannot give, is said as the
    scheme's error: :func:`_loss_words`); on a non-symmetric matrix (stored
    forces) E is not conserved, and only its largest change is said."""
    if not dm.symmetric:
        why = "dashpots and a non-symmetric matrix" if dm.C is not None else "the matrix is not symmetric"
        return f"largest change of E {drift.max():.1e} of E(0) (not conserved: {why})"
    if dm.C is not None:
        words = _loss_words(energy, "the scheme's error: dashpots only take energy")
        return f"energy taken by the dashpots (and the scheme's error) by t = {t_end:g}: {words}"
    return f"max energy drift {drift.max():.1e}"


def _loss_words(energy: np.ndarray, gain: str) -> str:
    """The share of E(0) gone by the last sample of each run (``energy`` (W, S) of W runs) as the
    log says it: "lost a to b %" (or "lost a %") where E fell, and where it rose "gained up to c % in n runs"
    followed by ``gain``, a clause saying what made it (the energy's takers cannot give).  Not
    collective."""
    lost = 100.0 * (1.0 - energy[..., -1] / energy[..., 0])
    if np.isnan(lost).all():  # LAMMPS's waves with twisting springs (lammps_dem.Contacts.energy)
        return "not recorded (LAMMPS reports no twisting torque per contact)"
    fell, rose = lost[lost >= 0.0], -lost[lost < 0.0]
    words = []
    if fell.size:
        low, high = f"{fell.min():.3g}", f"{fell.max():.3g}"
        words.append(f"lost {high} %" if low == high else f"lost {low} to {high} %")
    if rose.size:
        words.append(f"gained up to {rose.max():.3g} % in {counted(rose.size, 'run')} ({gain})")
    return ", ".join(words)


def _snapshots(dm, positions, spec, mode: str, run: int, k: float, schedule: Schedule) -> dict:
    """``snapshot_t`` (T,), ``snapshot_velocity`` (T, N, D) and, with rotations, ``snapshot_spin``
    (T, N, R): the whole velocity field of run ``run`` at ``k`` at the times ``spec.snapshots``
    (``spectral.velocity_field``), over every particle in packing order, zero on rattlers; and
    ``snapshot_error`` (its estimate relative to max |v(0)|).  Collective."""
    times = np.array(spec.snapshots, dtype=float)
    local, error = spectral.velocity_field(dm, positions, mode, run, k, amplitude=spec.amplitude, times=times,
                                           tol=spec.tol, omega_max=schedule.omega_max)
    full = dynmat.over_particles(dm, local)  # (T, N, dof)
    out = {"snapshot_t": times, "snapshot_velocity": full[:, :, :dm.dim], "snapshot_error": np.float64(error)}
    if dm.rotations:
        out["snapshot_spin"] = full[:, :, dm.dim:]
    return out
