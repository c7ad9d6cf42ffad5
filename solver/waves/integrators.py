"""Standing waves integrated in time with PETSc TS on eq:motion, M u'' = -D u.

Integrators (``waves.integrator``, or ``-waves_ts_type``; the TS has the options prefix ``waves_``):
  verlet : velocity Verlet as a TS of type ``python`` on the state X = (U, V) of a block of R
           waves (one MatMatMult per step for all of them; symplectic, 2nd order; Debian's
           petsc4py 3.18 cannot set up TSBASICSYMPLECTIC, which needs setRHSSplitIS).
           [default: see README]
  rk, theta, cn, beuler, ssp, ... : any first-order PETSc TS type on X' = J X,
           J = [[0, I], [-M^-1 D, 0]] assembled (``model.operators.first_order_matrix``), so
           implicit types get a real matrix to factor or precondition.  rk is classical RK4 unless
           ``-waves_ts_rk_type`` says otherwise.
  alpha2 : generalized-alpha on the second-order form M a + D u = 0 (implicit, CG solves).

Schedule (one source of truth): :func:`resolve_schedule` builds a TS with the scene's values as
defaults (type, dt, t_end), lets ``-waves_ts_*`` options act on it, and reads back type, dt,
final time, step limit and adaptivity; :func:`check_schedule` refuses, before any integration,
a step at or above the scheme's stability limit, a variable step, or too few samples, naming
where the value came from (``waves.dt = 0.6`` or ``-waves_ts_dt 0.6``); the runs then use
exactly those values, and a unit records them.  A run whose energy stops being finite or grows
tenfold raises :class:`StabilityError` on every rank.  Samples: ``sampling``.
Collective on the matrix's communicator.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import profiling
from ..errors import InputError, NumericalFailure
from ..model.operators import first_order_matrix
from ..options import ts_adapt_type, ts_settings
from . import excitation
from .excitation import start_velocity
from .sampling import FourierSampler, Recorder, WaveSeries

PREFIX = "waves_"

STABILITY = {("verlet", None): 2.0, ("rk", "4"): 2.0 * math.sqrt(2.0), ("rk", "3"): math.sqrt(3.0),
             ("rk", "3bs"): math.sqrt(3.0), ("rk", "1fe"): 0.0, ("euler", None): 0.0}
"""(integrator, RK variant) -> omega_max dt at the edge of stability on the imaginary axis (where
the spectrum of J lies): 2 for Verlet, 2 sqrt(2) for any 4-stage RK4, sqrt(3) for 3-stage RK3, 0
for forward Euler (never stable).  Implicit schemes are unconditionally stable; 2nd-order explicit
RK (``ssp``, ``rk 2a``) grows every mode by ~(omega dt)^4 per step, and other RK variants are not
tabulated: for those only the blow-up check applies."""


class StabilityError(NumericalFailure):
    """A run whose energy stopped being finite or grew tenfold (raised on every rank)."""


def stability_limit(integrator: str, omega_max: float, variant: str | None = None) -> float | None:
    """Largest stable dt (t0) of a tabulated explicit scheme (``STABILITY``), else None."""
    ratio = STABILITY.get((integrator, variant if integrator == "rk" else None))
    return None if ratio is None else ratio / omega_max


@dataclass(frozen=True)
class Schedule:
    """A resolved time-stepping plan: what the TS uses after the scene's values and the
    ``-waves_ts_*`` options, and where each value came from.

    integrator : ``verlet`` (TS type python) or the PETSc TS type;  variant : the RK type of rk;
    dt : step (t0);  steps : steps to take;  sample_every : steps between samples;
    adapt : TSAdapt type (``none`` is required);  sources : {"dt", "t_end", "integrator"} ->
    the scene key or option that set it.
    """

    integrator: str
    variant: str | None
    dt: float
    steps: int
    sample_every: int
    adapt: str
    sources: dict

    @property
    def t_end(self) -> float:
        return self.steps * self.dt

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


def _defaults(ts, ts_type: str, dt: float, max_time: float, max_steps: int | None = None) -> None:
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
            _defaults(ts, ts_type, dt, t_end)
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
        steps=steps, sample_every=sample_every, adapt=adapt,
        sources={"dt": _source("ts_dt", f"waves.dt = {dt:g}"), "t_end": t_source,
                 "integrator": _source("ts_type", f"waves.integrator = {integrator}")})


def check_schedule(schedule: Schedule, omega_max: float, rho: float) -> float | None:
    """Refuse (InputError) a variable step, fewer than 4 samples, or a dt at or above the
    scheme's stability limit for this matrix, naming where each value came from; return the
    limit (None if not tabulated).  Not collective (same verdict on every rank)."""
    src = schedule.sources
    if schedule.adapt != "none":
        raise InputError(f"{src['integrator']}: the TS adapts its step (TSAdapt {schedule.adapt}), but the "
                         f"waves are sampled every waves.sample_every steps and need a fixed step: add "
                         f"-{PREFIX}ts_adapt_type none")
    if schedule.steps < 4 * schedule.sample_every:
        raise InputError(f"waves.sample_every = {schedule.sample_every}: with dt = {schedule.dt:g} "
                         f"({src['dt']}) that leaves fewer than 4 samples in t_end = {schedule.t_end:g} "
                         f"({src['t_end']})")
    limit = stability_limit(schedule.integrator, omega_max, schedule.variant)
    if limit is not None and schedule.dt >= limit:
        raise InputError(f"{src['dt']}: above the stability limit {limit:.4f} t0 of {schedule.label} for "
                         f"this packing (omega_max = {omega_max:.4f}/t0, rho = {rho:g})")
    return limit


def _configure(ts, schedule: Schedule, monitor) -> dict:
    """Schedule on a run TS whose type and problem are set: defaults, prefix, monitor,
    setFromOptions (for the solver options: -waves_ts_theta_*, -waves_ksp_*, ...), then the
    schedule's step and step count again (the values the options gave when it was resolved);
    returns what the TS uses. Collective."""
    _defaults(ts, schedule.ts_type, schedule.dt, schedule.t_end * (1 + 1e-12), schedule.steps)
    ts.setMonitor(monitor)
    ts.setFromOptions()
    used = ts_settings(ts)
    if used["ts_type"] != schedule.ts_type or used.get("rk_type") != schedule.variant:
        raise RuntimeError(f"waves: the run TS is {used['ts_type']} {used.get('rk_type') or ''}, the "
                           f"schedule says {schedule.ts_type} {schedule.variant or ''}")
    ts.setTimeStep(schedule.dt)
    ts.setMaxTime(schedule.t_end * (1 + 1e-12))
    ts.setMaxSteps(schedule.steps)
    return {**used, "dt": schedule.dt, "max_steps": schedule.steps, "adapt_type": schedule.adapt}


class BlockVerlet:
    """TS ``python`` context: velocity Verlet for R waves at once, state X = (U, V) with U, V dense
    (local rows x R, column-major) viewing X's local array; one MatMatMult D U per step."""

    def __init__(self, D, minv_local, nloc, n, runs, comm):
        from petsc4py import PETSc

        self.D, self.minv, self.nloc, self.runs = D, minv_local[:, None], nloc, runs
        size = ((nloc, n), (PETSc.DECIDE, runs))
        self.U = PETSc.Mat().createDense(size, array=np.zeros((nloc, runs), order="F"), comm=comm)
        self.DU = PETSc.Mat().createDense(size, array=np.zeros((nloc, runs), order="F"), comm=comm)
        for m in (self.U, self.DU):
            m.assemble()
        self.acc = np.zeros((nloc, runs), order="F")
        # a block of one uses MatMult on Vecs (measured: MatMatMult with one column costs ~1.5x more)
        self.u1 = PETSc.Vec().createWithArray(np.zeros(nloc), size=(nloc, n), comm=comm)
        self.du1 = PETSc.Vec().createWithArray(np.zeros(nloc), size=(nloc, n), comm=comm)

    def views(self, X):
        arr = X.getArray()
        half = self.nloc * self.runs
        u = arr[:half].reshape((self.nloc, self.runs), order="F")
        v = arr[half:].reshape((self.nloc, self.runs), order="F")
        return u, v

    def _accelerate(self, u):
        if self.runs == 1:
            self.u1.getArray()[:] = u[:, 0]
            self.D.mult(self.u1, self.du1)
            np.multiply(self.du1.getArray()[:, None], -self.minv, out=self.acc)
            return
        self.U.getDenseArray()[:] = u
        self.D.matMult(self.U, self.DU)
        np.multiply(self.DU.getDenseArray(), -self.minv, out=self.acc)

    def setUp(self, ts):
        self._accelerate(self.views(ts.getSolution())[0])

    @profiling.logged("rsVerletStep")
    def step(self, ts):
        dt = ts.getTimeStep()
        u, v = self.views(ts.getSolution())
        v += 0.5 * dt * self.acc
        u += dt * v
        self._accelerate(u)
        v += 0.5 * dt * self.acc
        ts.setTime(ts.getTime() + dt)

    def destroy(self, ts=None):
        """Called by TS when it is destroyed."""
        for m in (self.U, self.DU, self.u1, self.du1):
            m.destroy()


def _blown(recorder: Recorder, what: str, schedule: Schedule) -> StabilityError:
    e = np.array(recorder.e)
    return StabilityError(f"{what}: energy grew from {np.max(e[0]):.3e} to {np.max(e[-1]):.3e} (or stopped "
                          f"being finite) by t = {recorder.t[-1]:.2f}: unstable ({schedule.label}, dt = "
                          f"{schedule.dt:g} from {schedule.sources['dt']})")


def integrate_block(dm, positions, waves_: list[tuple[str, int, float]], *, amplitude: float,
                    schedule: Schedule) -> list[WaveSeries]:
    """Integrate several (mode, run, k) waves together with block velocity Verlet; ``run`` indexes
    ``excitation.runs(mode, dm.dim)``.

    Same samples as :func:`integrate` for each wave with ``schedule.integrator == 'verlet'``
    (tested), one MatMatMult per step for all of them.  Raises StabilityError on every rank on
    blow-up.  Collective.
    """
    from petsc4py import PETSc

    comm = dm.D.getComm()
    mpi = comm.tompi4py()
    nloc, runs = dm.D.getLocalSize()[0], len(waves_)
    mass = dm.M.getArray().copy()
    excited = [(*excitation.runs(m, dm.dim)[r], k) for m, r, k in waves_]
    v0 = np.stack([start_velocity(dm, positions, c, a, k, amplitude, mpi) for c, a, k in excited], axis=1)
    context = BlockVerlet(dm.D, 1.0 / mass, nloc, dm.size, runs, comm)
    X = PETSc.Vec().createMPI((2 * nloc * runs, 2 * dm.size * runs), comm=comm)
    X.setArray(np.concatenate((np.zeros(nloc * runs), v0.ravel(order="F"))))
    recorder = Recorder(FourierSampler(dm, positions, excited, mpi), schedule.sample_every)

    def monitor(ts, step, t, X_):
        if recorder.due(step):
            u, v = context.views(X_)
            recorder.record(ts, step, t, u, v, -mass[:, None] * context.acc)  # D u from the cached acceleration

    ts = PETSc.TS().create(comm)
    try:
        ts.setType(PETSc.TS.Type.PYTHON)
        ts.setPythonContext(context)
        ts.setSolution(X)
        used = _configure(ts, schedule, monitor)
        ts.solve(X)
        taken = ts.getStepNumber()
    finally:
        ts.destroy()  # also destroys the context's dense blocks
        X.destroy()
    if recorder.blown:
        raise _blown(recorder, f"block of {runs} waves", schedule)
    return recorder.series(taken, used)


def integrate(dm, positions, mode: str, run: int, k: float, *, amplitude: float,
              schedule: Schedule) -> WaveSeries:
    """Integrate one standing wave, run ``run`` of ``excitation.runs(mode, dm.dim)``, with
    ``schedule`` (see :func:`resolve_schedule`); return its samples. Collective.

    Raises StabilityError on every rank if the energy stops being finite or grows 10x.
    Verlet runs go through :func:`integrate_block` with a block of one.
    """
    from petsc4py import PETSc

    if schedule.integrator == "verlet":
        return integrate_block(dm, positions, [(mode, run, k)], amplitude=amplitude, schedule=schedule)[0]
    comm = dm.D.getComm()
    mpi = comm.tompi4py()
    component, axis = excitation.runs(mode, dm.dim)[run]
    minv = dm.M.copy()
    minv.reciprocal()
    v0 = start_velocity(dm, positions, component, axis, k, amplitude, mpi)
    work = dm.M.duplicate()
    recorder = Recorder(FourierSampler(dm, positions, [(component, axis, k)], mpi), schedule.sample_every)

    def record(ts_, step, t, uvec, v_arr):
        dm.D.mult(uvec, work)
        recorder.record(ts_, step, t, uvec.getArray()[:, None], v_arr[:, None], work.getArray()[:, None])

    ts = PETSc.TS().create(comm)
    owned = [minv, work]
    try:
        if schedule.integrator == "alpha2":
            U, V = dm.M.duplicate(), dm.M.duplicate()
            U.set(0.0)
            V.setArray(v0)
            jac = dm.D.duplicate(copy=True)
            diag = dm.D.getDiagonal()
            owned += [U, V, jac, diag]

            def residual(ts_, t, u, v, a, F):
                dm.D.mult(u, F)
                ma = a.copy()
                ma.pointwiseMult(ma, dm.M)
                F.axpy(1.0, ma)
                ma.destroy()

            def jacobian(ts_, t, u, v, a, shift_v, shift_a, J, P):
                dm.D.copy(J, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
                d = diag.copy()
                d.axpy(shift_a, dm.M)
                J.setDiagonal(d)
                d.destroy()

            ts.setType(PETSc.TS.Type.ALPHA2)
            ts.setProblemType(PETSc.TS.ProblemType.NONLINEAR)
            owned.append(dm.M.duplicate())
            ts.setI2Function(residual, owned[-1])
            ts.setI2Jacobian(jacobian, jac, jac)
            ts.setSolution2(U, V)
            state = U
            ts.getSNES().getKSP().setType(PETSc.KSP.Type.CG)  # -waves_ksp_type wins

            def monitor(ts_, step, t, X):
                if recorder.due(step):
                    u, v = ts_.getSolution2()
                    record(ts_, step, t, u, v.getArray())
        else:
            ts.setType(schedule.ts_type)
            ts.setProblemType(PETSc.TS.ProblemType.LINEAR)
            jacobian = first_order_matrix(dm, minv)
            X = jacobian.createVecRight()
            X.setArray(np.concatenate((np.zeros(len(v0)), v0)))
            owned += [jacobian, X, X.duplicate()]
            ts.setRHSFunction(PETSc.TS.computeRHSFunctionLinear, owned[-1])
            ts.setRHSJacobian(PETSc.TS.computeRHSJacobianConstant, jacobian, jacobian)
            ts.setSolution(X)
            state = X
            u_view = PETSc.Vec().createWithArray(np.zeros(len(v0)), size=(len(v0), dm.size), comm=comm)
            owned.append(u_view)

            def monitor(ts_, step, t, X_):
                if recorder.due(step):
                    arr = X_.getArray()
                    u_view.placeArray(arr[: len(v0)])
                    record(ts_, step, t, u_view, arr[len(v0):])
                    u_view.resetArray()
        used = _configure(ts, schedule, monitor)
        ts.solve(state)
        taken = ts.getStepNumber()
    finally:
        ts.destroy()
        for obj in owned:
            obj.destroy()
    if recorder.blown:
        raise _blown(recorder, f"wave {mode} k = {k:.4f}", schedule)
    return recorder.series(taken, used)[0]
