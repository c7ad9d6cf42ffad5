"""Standing waves integrated in time with PETSc TS on eq:motion, M u'' = -D u.

Integrators (``waves.integrator``, or ``-waves_ts_type``; the TS has the options prefix ``waves_``):
  verlet : velocity Verlet as a TS of type ``python`` on the state X = (U, V) of a block of R
           waves (one MatMatMult per step for all of them; symplectic, 2nd order; Debian's
           petsc4py 3.18 cannot set up TSBASICSYMPLECTIC, which needs setRHSSplitIS).
           [the default]
  rk, theta, cn, beuler, ssp, ... : any first-order PETSc TS type on X' = J X,
           J = [[0, I], [-M^-1 D, 0]] assembled (``model.operators.first_order_matrix``), so
           implicit types get a real matrix to factor or precondition.  rk is classical RK4 unless
           ``-waves_ts_rk_type`` says otherwise.
  alpha2 : generalized-alpha on the second-order form M a + D u = 0 (implicit, CG solves).

Every run follows a :class:`~solver.waves.schedule.Schedule` (``schedule.resolve_schedule``: the
scene's values and the ``-waves_ts_*`` options, read back from a TS; checked against the
stability limit before any run).  Each non-Verlet TS is built by a problem object that owns its
TS and the PETSc objects the TS needs and destroys them all (:class:`FirstOrderProblem`,
:class:`SecondOrderProblem`, in the manner of dolfinx's ``LinearProblem``).  A run whose energy
stops being finite or grows tenfold raises :class:`StabilityError` on every rank.  Samples:
``sampling``.
Collective on the matrix's communicator.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import numpy as np

from .. import profiling
from ..errors import NumericalFailure
from ..model.operators import first_order_matrix
from ..options import ts_settings
from ..wording import counted
from . import excitation
from .excitation import start_velocity
from .sampling import FourierSampler, Recorder, WaveSeries
from .schedule import Schedule, apply_defaults


class StabilityError(NumericalFailure):
    """A run whose energy stopped being finite or grew tenfold (raised on every rank)."""


def _configure(ts, schedule: Schedule, monitor) -> dict:
    """Schedule on a run TS whose type and problem are set: defaults, prefix, monitor,
    setFromOptions (for the solver options: -waves_ts_theta_*, -waves_ksp_*, ...), then the
    schedule's step and step count again (the values the options gave when it was resolved);
    returns what the TS uses. Collective."""
    apply_defaults(ts, schedule.ts_type, schedule.dt, schedule.t_end * (1 + 1e-12), schedule.steps)
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
        raise _blown(recorder, f"block of {counted(runs, 'wave')}", schedule)
    return recorder.series(taken, used)


def integrate_all(dm, positions, waves_: list[tuple[str, int, float]], *, amplitude: float,
                  schedule: Schedule) -> list[WaveSeries]:
    """Integrate every (mode, run, k) of ``waves_`` with ``schedule``: all at once by block
    Verlet (:func:`integrate_block`), or one by one with the schedule's PETSc TS
    (:func:`integrate`). Collective."""
    if schedule.integrator == "verlet":
        return integrate_block(dm, positions, waves_, amplitude=amplitude, schedule=schedule)
    return [integrate(dm, positions, mode, run, k, amplitude=amplitude, schedule=schedule) for mode, run, k in waves_]


class _Problem:
    """A TS on ``dm``'s communicator and the PETSc objects it needs (``self.objects``), destroyed
    together by :meth:`destroy` (or on leaving a ``with`` block). Collective."""

    def __init__(self, dm):
        from petsc4py import PETSc

        self.dm = dm
        self.ts = PETSc.TS().create(dm.D.getComm())
        self.objects: list = []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.destroy()

    def destroy(self) -> None:
        self.ts.destroy()
        for obj in self.objects:
            obj.destroy()

    def release(self) -> None:
        """Undo what :meth:`state` set up, after the monitor has used it (nothing by default)."""


class SecondOrderProblem(_Problem):
    """eq:motion as M a + D u = 0 for TS ``alpha2`` (generalized-alpha; implicit, CG solves; GMRES
    for a non-symmetric D), from
    u = 0 and v = ``v0`` (nloc,).  :meth:`state` gives (u, v) views for the monitor."""

    def __init__(self, dm, v0: np.ndarray):
        from petsc4py import PETSc

        super().__init__(dm)
        ts = self.ts
        U, V = dm.M.duplicate(), dm.M.duplicate()
        U.set(0.0)
        V.setArray(v0)
        jac = dm.D.duplicate(copy=True)
        diag = dm.D.getDiagonal()
        self.objects += [U, V, jac, diag]

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
        self.objects.append(dm.M.duplicate())
        ts.setI2Function(residual, self.objects[-1])
        ts.setI2Jacobian(jacobian, jac, jac)
        ts.setSolution2(U, V)
        self.solution = U
        # CG needs a symmetric D; a stressed packing's is not (docs/stressed_contacts.md). -waves_ksp_type wins
        ts.getSNES().getKSP().setType(PETSc.KSP.Type.CG if dm.symmetric else PETSc.KSP.Type.GMRES)

    def state(self, ts, X):
        """(u Vec, v local array) of the TS's current solution."""
        u, v = ts.getSolution2()
        return u, v.getArray()


class FirstOrderProblem(_Problem):
    """eq:motion as X' = J X, X = (u, v), J = [[0, I], [-M^-1 D, 0]] assembled, for any
    first-order PETSc TS type ``ts_type`` (linear, constant Jacobian), from u = 0, v = ``v0``.
    :meth:`state` gives (u, v) views of X for the monitor."""

    def __init__(self, dm, v0: np.ndarray, ts_type: str):
        from petsc4py import PETSc

        super().__init__(dm)
        ts = self.ts
        minv = dm.M.copy()
        minv.reciprocal()
        self.objects.append(minv)
        ts.setType(ts_type)
        ts.setProblemType(PETSc.TS.ProblemType.LINEAR)
        jacobian = first_order_matrix(dm, minv)
        X = jacobian.createVecRight()
        X.setArray(np.concatenate((np.zeros(len(v0)), v0)))
        self.objects += [jacobian, X, X.duplicate()]
        ts.setRHSFunction(PETSc.TS.computeRHSFunctionLinear, self.objects[-1])
        ts.setRHSJacobian(PETSc.TS.computeRHSJacobianConstant, jacobian, jacobian)
        ts.setSolution(X)
        self.solution = X
        self.n = len(v0)
        self.u_view = PETSc.Vec().createWithArray(np.zeros(self.n), size=(self.n, dm.size), comm=dm.D.getComm())
        self.objects.append(self.u_view)

    def state(self, ts, X):
        """(u Vec viewing X's first half, v local array); call :meth:`release` after use."""
        arr = X.getArray()
        self.u_view.placeArray(arr[: self.n])
        return self.u_view, arr[self.n:]

    def release(self) -> None:
        self.u_view.resetArray()


def integrate(dm, positions, mode: str, run: int, k: float | np.ndarray, *, amplitude: float,
              schedule: Schedule) -> WaveSeries:
    """Integrate one standing wave, run ``run`` of ``excitation.runs(mode, dm.dim)``, with
    ``schedule`` (see ``schedule.resolve_schedule``); return its samples. Collective.

    Raises StabilityError on every rank if the energy stops being finite or grows 10x.
    Verlet runs go through :func:`integrate_block` with a block of one.
    """
    if schedule.integrator == "verlet":
        return integrate_block(dm, positions, [(mode, run, k)], amplitude=amplitude, schedule=schedule)[0]
    comm = dm.D.getComm()
    mpi = comm.tompi4py()
    component, axis = excitation.runs(mode, dm.dim)[run]
    v0 = start_velocity(dm, positions, component, axis, k, amplitude, mpi)
    recorder = Recorder(FourierSampler(dm, positions, [(component, axis, k)], mpi), schedule.sample_every)
    work = dm.M.duplicate()
    if schedule.integrator == "alpha2":
        problem = SecondOrderProblem(dm, v0)
    else:
        problem = FirstOrderProblem(dm, v0, schedule.ts_type)
    problem.objects.append(work)

    def monitor(ts_, step, t, X):
        if recorder.due(step):
            uvec, v_arr = problem.state(ts_, X)
            dm.D.mult(uvec, work)
            recorder.record(ts_, step, t, uvec.getArray()[:, None], v_arr[:, None], work.getArray()[:, None])
            problem.release()

    with problem:
        used = _configure(problem.ts, schedule, monitor)
        problem.ts.solve(problem.solution)
        taken = problem.ts.getStepNumber()
    if recorder.blown:
        raise _blown(recorder, f"wave {mode} k = {float(np.linalg.norm(k)):.4f}", schedule)
    return recorder.series(taken, used)[0]
