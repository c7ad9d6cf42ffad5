"""One unit of standing waves: every direction and wave number of one (rho, mode, packing),
integrated (``integrators``, or ``spectral``) and reduced to the datasets and attributes of the
results file's ``waves/r<i>_<mode>_p<j>`` group (README, "Results file").

C (K, S) and S (K, W) pool the two directions of tab:modes (``analysis.correlations.pooled``).
Collective on the matrix's communicator.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import json

import numpy as np

from ..analysis import correlations
from . import integrators, spectral


def mode_unit(dm, positions, spec, mode: str, ns: np.ndarray, ks: np.ndarray, *, omega_max: float,
              schedule: integrators.Schedule | None = None, limit: float | None = None
              ) -> tuple[dict, dict, str]:
    """(datasets, attrs, summary) of one mode on ``dm`` for the wave numbers ``ks`` (``ns``).

    ``spec``: the scene's waves section; ``schedule``: the resolved TS schedule (``method: ts``;
    None for ``spectral``, which samples every ``dt * sample_every`` to ``t_end``);
    ``limit``: its stability limit (None: none tabulated).  ``summary``: one line for the log.
    Raises StabilityError on every rank if a run blows up (nothing is returned then).
    """
    if schedule is None:
        times = np.arange(0.0, spec.t_end * (1 + 1e-12), spec.dt * spec.sample_every)
        runs = [[spectral.spectral(dm, positions, mode, d, k, amplitude=spec.amplitude, times=times,
                                   tol=spec.tol, omega_max=omega_max) for k in ks] for d in range(2)]
    elif schedule.integrator == "verlet":  # all directions and k at once: one MatMatMult per step
        flat = integrators.integrate_block(dm, positions, [(mode, d, k) for d in range(2) for k in ks],
                                           amplitude=spec.amplitude, schedule=schedule)
        runs = [flat[d * len(ks):(d + 1) * len(ks)] for d in range(2)]
    else:
        runs = [[integrators.integrate(dm, positions, mode, d, k, amplitude=spec.amplitude, schedule=schedule)
                 for k in ks] for d in range(2)]
    z = np.array([[r.z for r in row] for row in runs])            # (2, K, S)
    z_fixed = np.array([[r.z_fixed for r in row] for row in runs])
    energy = np.array([[r.energy for r in row] for row in runs])
    t = runs[0][0].t
    vaf, omega, power = correlations.pooled(z, t[1] - t[0])
    drift = np.abs(energy - energy[..., :1]).max(axis=2) / energy[..., 0]
    datasets = {"k": ks, "n": ns, "t": t, "C": vaf, "omega": omega, "S": power, "z": z, "z_fixed": z_fixed,
                "energy_drift": drift}
    settings = {"wmax": dm.wmax_settings}
    if schedule is None:
        datasets["error_estimate"] = np.array([[r.error_estimate for r in row] for row in runs])
        settings["lanczos"] = {"tol": spec.tol, "max_steps": max(r.steps for row in runs for r in row)}
        summary = (f"spectral, up to {settings['lanczos']['max_steps']} Lanczos steps, error estimate "
                   f"{np.nanmax(datasets['error_estimate']):.1e}")
        dt, integrator = spec.dt, "spectral (Lanczos)"
    else:
        settings["ts"] = runs[0][0].settings
        summary = (f"{runs[0][0].steps} steps each ({schedule.label}, dt = {schedule.dt:g}), max energy "
                   f"drift {drift.max():.1e}")
        dt, integrator = schedule.dt, schedule.integrator
    attrs = {"rho": dm.rho, "mode": mode, "dt": dt, "integrator": integrator, "omega_max": omega_max,
             "dt_limit": limit if limit is not None else np.inf, "amplitude": spec.amplitude,
             "sample_dt": t[1] - t[0], "solver_settings": json.dumps(settings)}
    return datasets, attrs, summary
