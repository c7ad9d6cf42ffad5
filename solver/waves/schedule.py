"""How the standing waves of one matrix are run, decided once for every path (``waves.method``):
the time grid, and for time stepping the TS type, step and stability limit.

:func:`plan` is the one place the method, and the path the runs take (``PATHS``), are chosen:
``spectral`` and ``exponential`` sample every ``dt * sample_every`` to ``t_end`` with no time
stepping (``spectral``, ``exponential``, ``SAMPLED``; with dashpots ``spectral`` is the
Chebyshev-Bessel series, ``chebyshev``); ``ts`` resolves the TS schedule and refuses one that
cannot work (``integrators`` then follows it).  Either way the :class:`Schedule` carries the
path, the matrix's omega_max and the stability limit into the unit (``unit``).

TS schedule (one source of truth): :func:`resolve_schedule` builds a TS with the scene's values
as defaults (type, dt, t_end), lets ``-waves_ts_*`` options act on it, and reads back type, dt,
final time, step limit and adaptivity; :func:`check_schedule` refuses, before any integration,
a step at or above the scheme's stability limit, a variable step, or too few samples, naming
where the value came from (``waves.dt = 0.6`` or ``-waves_ts_dt 0.6``); the runs then use
exactly those values, and a unit records them.  Not collective.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..options import ts_adapt_type, ts_settings

PREFIX = "waves_"
METHODS = ("ts", "spectral", "exponential")
"""waves.method values: time steps, or the paths without (``SAMPLED``); :func:`plan` decides the path."""
ENGINES = ("rotsound", "lammps")
"""waves.engine values: the linear waves of the matrix (by ``METHODS``), or LAMMPS's nonlinear ones."""
INTEGRATORS = ("verlet", "alpha2", "rk", "theta", "cn", "beuler", "ssp")
"""waves.integrator values of a scene (``-waves_ts_type`` takes any PETSc TS type; python is verlet)."""
SECOND_ORDER = ("verlet", "alpha2")
"""waves.integrator values that integrate M u'' = -D u without a velocity-dependent force (no
dashpots: ``plan`` and the scene's rule ``rules.check_damping`` refuse them with ``model.damping`` or ``model.restitution``)."""
MIN_SAMPLES = 4
"""Fewest samples of a run (t_end / (dt * sample_every)): the waves' scene rule and :func:`check_schedule`
refuse fewer."""
SAMPLED = {"spectral": "spectral (Lanczos)", "exponential": "exponential (SLEPc MFN)"}
"""The methods without time steps (waves.method -> integrator label): samples every dt * sample_every.
With dashpots, ``spectral`` is the Chebyshev-Bessel series (``DAMPED_SPECTRAL``)."""
DAMPED_SPECTRAL = "spectral (Chebyshev-Bessel series)"
PATHS = ("ts", "spectral", "damped_spectral", "exponential")
"""How the runs of a unit go (``Schedule.path``): time steps (``integrators``), Lanczos on the
matrix (``spectral``), the Chebyshev-Bessel series of exp(tJ) (``chebyshev``: waves.method
spectral with dashpots), exp(h J) by SLEPc MFN (``exponential``)."""

STABILITY = {("verlet", None): 2.0, ("rk", "4"): 2.0 * math.sqrt(2.0), ("rk", "3"): math.sqrt(3.0),
             ("rk", "3bs"): math.sqrt(3.0), ("rk", "1fe"): 0.0, ("euler", None): 0.0}
"""(integrator, RK variant) -> omega_max dt at the edge of stability on the imaginary axis (where
the spectrum of J lies): 2 for Verlet, 2 sqrt(2) for any 4-stage RK4, sqrt(3) for 3-stage RK3, 0
for forward Euler (never stable).  Implicit schemes are unconditionally stable; 2nd-order explicit
RK (``ssp``, ``rk 2a``) grows every mode by ~(omega dt)^4 per step, and other RK variants are not
tabulated: for those only the blow-up check applies."""


STABILITY_DAMPED = {("rk", "4"): 2.6155876920, ("rk", "3"): math.sqrt(3.0), ("rk", "3bs"): math.sqrt(3.0),
                    ("rk", "1fe"): 0.0, ("euler", None): 0.0}
"""(integrator, RK variant) -> radius of the largest left half-disk inside the scheme's stability
region, where a damped packing's eigenvalues lie (``operators.largest_damping_rate``): 2.6156 for
RK4 (less than its 2.83 on the imaginary axis; tests/waves/test_damped_waves.py checks the
number), sqrt(3) for RK3.  Verlet and alpha2 take no damping (``SECOND_ORDER``)."""


def stability_limit(integrator: str, omega_max: float, variant: str | None = None,
                    damping_max: float = 0.0) -> float | None:
    """Largest stable dt (t0) of a tabulated explicit scheme (``STABILITY``; with dashpots whose
    fastest rate is ``damping_max`` > 0, ``STABILITY_DAMPED`` over max(omega_max, damping_max)),
    else None."""
    key = (integrator, variant if integrator == "rk" else None)
    if damping_max > 0.0:
        ratio = STABILITY_DAMPED.get(key)
        return None if ratio is None else ratio / max(omega_max, damping_max)
    ratio = STABILITY.get(key)
    return None if ratio is None else ratio / omega_max


@dataclass(frozen=True)
class Schedule:
    """How the waves of one matrix run: for time stepping what the TS uses after the scene's
    values and the ``-waves_ts_*`` options, and where each value came from; for the paths without
    time steps the sample grid alone.

    method : ``ts``, ``spectral`` or ``exponential``;  path : one of ``PATHS``, the method's path
    on this matrix (``spectral`` with dashpots: ``damped_spectral``);  integrator : ``verlet`` (TS type python),
    the PETSc TS type, or a ``SAMPLED`` label;  variant : the RK type of rk;  dt : step (t0;
    without time steps: the scene's, for the sample spacing);  steps : steps to take (without: 0);  t_end : last time
    (t0);  sample_every : steps between samples;  adapt : TSAdapt type (``none`` is required);
    sources : {"dt", "t_end", "integrator"} -> the scene key or option that set it;
    omega_max : largest eigenfrequency of the matrix (1/t0), None until :func:`plan`;
    limit : the scheme's stability limit on dt for it, None if none is tabulated;
    damping_max : the dashpots' fastest rate c_max (1/t0; 0 without dashpots).
    """

    integrator: str
    variant: str | None
    dt: float
    steps: int
    t_end: float
    sample_every: int
    adapt: str
    sources: dict
    method: str = "ts"
    path: str = "ts"
    omega_max: float | None = None
    limit: float | None = None
    damping_max: float = 0.0

    def sample_times(self) -> np.ndarray:
        """The sample times (S,) of the paths without time steps: every dt * sample_every from 0 to t_end."""
        return np.arange(0.0, self.t_end * (1 + 1e-12), self.dt * self.sample_every)

    @property
    def ts_type(self) -> str:
        return "python" if self.integrator == "verlet" else self.integrator

    @property
    def label(self) -> str:
        """e.g. ``verlet`` or ``rk (-waves_ts_type rk, RK type 4)`` for messages."""
        notes = [self.sources["integrator"]] if self.sources["integrator"].startswith("-") else []
        notes += [f"RK type {self.variant}"] if self.variant else []
        return self.integrator + (f" ({', '.join(notes)})" if notes else "")


def _source(option: str, scene: str) -> str:
    """``-waves_<option> <value>`` if the user set that option, else the scene's ``scene`` text."""
    from petsc4py import PETSc

    options = PETSc.Options()
    name = PREFIX + option
    if not options.hasName(name):
        return scene
    value = options.getString(name, "")
    return f"-{name} {value}".rstrip()


def apply_defaults(ts, ts_type: str, dt: float, max_time: float, max_steps: int | None = None) -> None:
    """The scene's values on a TS, before setFromOptions (so that ``-waves_ts_*`` win)."""
    from petsc4py import PETSc

    ts.setType(ts_type)
    if ts_type == "rk":
        ts.setRKType("4")  # classical RK4
    ts.setTime(0.0)
    ts.setTimeStep(dt)
    ts.setMaxTime(max_time)
    if max_steps is not None:
        ts.setMaxSteps(max_steps)
    ts.setExactFinalTime(PETSc.TS.ExactFinalTime.MATCHSTEP)
    ts.setOptionsPrefix(PREFIX)


def resolve_schedule(*, integrator: str, dt: float, t_end: float, sample_every: int) -> Schedule:
    """The schedule the TS will follow: scene values (``waves.integrator``, ``waves.dt``,
    ``waves.t_end``) as defaults on a probe TS, then the ``-waves_ts_*`` options, read back.

    Probes live on ``PETSc.COMM_SELF`` (they only read the options database, the same on every
    rank) and are destroyed.  A second probe starts from the type the first one ended with, so
    that the defaults of that type (RK4 for rk) are in place before the options act, as on the
    run's TS.  steps = min(max steps, floor(max time / dt)).  Raises InputError (the same on
    every rank) if PETSc refuses the options.  Not collective.
    """
    from petsc4py import PETSc

    def probe(ts_type):
        ts = PETSc.TS().create(PETSc.COMM_SELF)
        try:
            apply_defaults(ts, ts_type, dt, t_end)
            ts.setFromOptions()
            return ts_settings(ts), ts_adapt_type(ts)
        except PETSc.Error as exc:  # e.g. -waves_ts_type verlet: not a PETSc type
            given = " ".join(f"-{k} {v}" for k, v in PETSc.Options().getAll().items() if k.startswith(PREFIX))
            reason = str(exc).strip().splitlines()[-1].lstrip("[0123456789] ")
            raise InputError(f"{given}: PETSc's TS refused it ({reason}); -{PREFIX}ts_type takes a PETSc TS "
                             f"type (python is Verlet)") from None
        finally:
            ts.destroy()

    settings, adapt = probe("python" if integrator == "verlet" else integrator)
    if settings["ts_type"] != ("python" if integrator == "verlet" else integrator):  # -waves_ts_type
        settings, adapt = probe(settings["ts_type"])
    kind = settings["ts_type"]
    used_dt, max_time, max_steps = settings["dt"], settings["max_time"], settings["max_steps"]
    steps = int(min(max_steps, math.floor(max_time / used_dt * (1 + 1e-12))))
    t_source = _source("ts_max_time", f"waves.t_end = {t_end:g}")
    if _source("ts_max_steps", "").startswith("-"):
        t_source += f", {_source('ts_max_steps', '')}"
    return Schedule(
        integrator="verlet" if kind == "python" else kind, variant=settings.get("rk_type"), dt=used_dt,
        steps=steps, t_end=steps * used_dt, sample_every=sample_every, adapt=adapt,
        sources={"dt": _source("ts_dt", f"waves.dt = {dt:g}"), "t_end": t_source,
                 "integrator": _source("ts_type", f"waves.integrator = {integrator}")})


def check_schedule(schedule: Schedule, omega_max: float, rho: float, damping_max: float = 0.0) -> float | None:
    """Refuse (InputError) a variable step, fewer than ``MIN_SAMPLES`` samples, a dt at or above the scheme's
    stability limit for this matrix (its dashpots' fastest rate ``damping_max``, 0 without), or,
    with dashpots, a second-order integrator (the scene key is refused by ``rules.check_damping``;
    this catches ``-waves_ts_type``), naming where each value came from; return the limit (None if
    not tabulated).  Not collective (same verdict on every rank)."""
    src = schedule.sources
    if damping_max > 0.0 and schedule.integrator in SECOND_ORDER:
        raise InputError(f"{src['integrator']}: {schedule.integrator} has no velocity-dependent force, but the "
                         f"model has dashpots (model.damping or model.restitution); use waves.method: exponential, or a first-order "
                         f"integrator (rk, theta, cn, beuler)")
    if schedule.adapt != "none":
        raise InputError(f"{src['integrator']}: the TS adapts its step (TSAdapt {schedule.adapt}), but the "
                         f"waves are sampled every waves.sample_every steps and need a fixed step: add "
                         f"-{PREFIX}ts_adapt_type none")
    if schedule.steps < MIN_SAMPLES * schedule.sample_every:
        raise InputError(f"waves.sample_every = {schedule.sample_every}: with dt = {schedule.dt:g} "
                         f"({src['dt']}) that leaves fewer than {MIN_SAMPLES} samples in t_end = {schedule.t_end:g} "
                         f"({src['t_end']})")
    limit = stability_limit(schedule.integrator, omega_max, schedule.variant, damping_max)
    if limit is not None and schedule.dt >= limit:
        damped = f", fastest damping rate {damping_max:.4f}/t0" if damping_max > 0.0 else ""
        raise InputError(f"{src['dt']}: above the stability limit {limit:.4f} t0 of {schedule.label} for "
                         f"this packing (omega_max = {omega_max:.4f}/t0{damped}, rho = {rho:g})")
    return limit


def plan(spec, omega_max: float, rho: float, damping_max: float = 0.0) -> Schedule:
    """The schedule of the waves section ``spec`` on a matrix whose largest eigenfrequency is
    ``omega_max`` and whose dashpots' fastest rate is ``damping_max`` (0: none; rho = kt/kn, for
    messages): the one place ``waves.engine``, ``waves.method`` and the runs' path (``PATHS``) are
    decided; ``engine: lammps`` runs on the TS schedule's dt, samples and stability limit (path
    ``lammps``).
    ``spectral``, ``exponential``: the sample grid (with dashpots, a ``waves.tol`` the damped spectral
    path cannot bound is refused here); ``ts``: :func:`resolve_schedule`, refused by
    :func:`check_schedule` (InputError, the same on every rank) if it cannot work.  Not collective.
    """
    if spec.engine == "lammps":  # LAMMPS's velocity Verlet (fix nve/sphere) at the TS schedule's dt and samples
        resolved = resolve_schedule(integrator="verlet", dt=spec.dt, t_end=spec.t_end, sample_every=spec.sample_every)
        limit = check_schedule(resolved, omega_max, rho)  # the undamped Verlet limit; LAMMPS's dashpots are first order
        return dataclasses.replace(resolved, integrator="lammps (velocity Verlet)", method="ts", path="lammps",
                                   omega_max=omega_max, damping_max=damping_max, limit=limit)
    if spec.method in SAMPLED:
        path = "damped_spectral" if spec.method == "spectral" and damping_max > 0.0 else spec.method
        label = DAMPED_SPECTRAL if path == "damped_spectral" else SAMPLED[spec.method]
        if path == "damped_spectral":
            from . import chebyshev

            try:
                chebyshev.plan(omega_max, damping_max, spec.dt * spec.sample_every,
                               int(round(spec.t_end / (spec.dt * spec.sample_every))), spec.tol)
            except ValueError as err:
                raise InputError(f"waves.tol = {spec.tol:g}: {err}; raise waves.tol, or use waves.method: "
                                 f"exponential") from None
        return Schedule(integrator=label, variant=None, dt=spec.dt, steps=0, t_end=spec.t_end,
                        sample_every=spec.sample_every, adapt="none", sources={}, method=spec.method,
                        path=path, omega_max=omega_max, damping_max=damping_max)
    resolved = resolve_schedule(integrator=spec.integrator, dt=spec.dt, t_end=spec.t_end,
                                sample_every=spec.sample_every)
    return dataclasses.replace(resolved, omega_max=omega_max, damping_max=damping_max,
                               limit=check_schedule(resolved, omega_max, rho, damping_max))
