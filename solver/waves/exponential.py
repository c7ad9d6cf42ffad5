"""Standing waves by the exponential of the first-order system, without time steps:
X(t + h) = exp(h J) X(t), J = [[0, I], [-M^-1 D, 0]] (eq:motion), X = (u, v), applied from sample
to sample (h = ``waves.dt * sample_every``) by SLEPc's MFN, a restarted Krylov method for
f(A) b.  See :func:`exponential_all`.

It needs no symmetry: this is the exact path for a stressed packing, whose matrix has no
orthogonal eigendecomposition for ``spectral`` (docs/stressed_contacts.md section 4), and the
reference the time steppers are measured against.  The MFN has the options prefix ``waves_``
(``-waves_mfn_*``, ``-waves_fn_*``).  Collective on the matrix's communicator.
Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import math

import numpy as np

from .. import profiling
from ..errors import InputError, NumericalFailure
from ..model.operators import first_order_matrix
from ..options import mfn_settings
from . import excitation
from .excitation import start_velocity
from .sampling import FourierSampler, WaveSeries

PREFIX = "waves_"
TOL_FLOOR = 1e-14
"""Smallest tolerance asked of one MFN solve: round-off of exp(h J) b in double precision."""


def krylov_dimension(norm: float, tol: float) -> int:
    """Default Krylov dimension (MFN ncv) for exp(h J) b when |h J| <= ``norm``: the smallest m with
    norm^m e^norm / m! <= ``tol`` (the bound of the degree-m Taylor remainder, which the Krylov
    approximation beats), plus 2, between 6 and 60.  Too small a value costs restarts, not accuracy:
    the MFN still stops at its tolerance."""
    m, term = 1, norm * math.exp(norm)
    while term > tol and m < 58:
        m += 1
        term *= norm / m
    return min(max(m + 2, 6), 60)


@profiling.logged("rsExponentialWave")
def exponential_all(dm, positions, waves: list[tuple[str, int, float]], *, amplitude: float,
                    times: np.ndarray, tol: float, rate: float | None = None) -> list[WaveSeries]:
    """One WaveSeries per wave (mode, run of ``excitation.runs(mode, dm.dim)``, k) at ``times``
    (S,), equally spaced from 0 (t0).  Collective.

    v(0) as for time stepping (eq:initial, zero modes projected out), u(0) = 0; every sample is
    exp(h J) of the one before, by an MFN with tolerance max(``tol`` / S, TOL_FLOOR) unless
    ``-waves_mfn_tol`` says otherwise, and Krylov dimension :func:`krylov_dimension` of
    h ``rate`` (the spectral radius of J: max(omega_max, c_max); None: SLEPc's default 30) unless
    ``-waves_mfn_ncv`` says otherwise.  The errors of the S solves add, so each series carries
    S x that tolerance as its error estimate (relative to |X(0)|; measured against dense
    exp(t J) in tests/waves/test_exponential.py).  z has the phase of r_i(t), z_fixed of r_i(0),
    as on the TS path.  Settings are read back from the MFN after setFromOptions; a scale of
    the exponential other than h (``-waves_fn_scale``) is refused (InputError, every rank), and
    an MFN that does not converge raises NumericalFailure on every rank.
    """
    from petsc4py import PETSc
    from slepc4py import SLEPc

    comm = dm.D.getComm()
    mpi = comm.tompi4py()
    step = float(times[1] - times[0])
    minv = dm.M.copy()
    minv.reciprocal()
    J = first_order_matrix(dm, minv)
    mfn = SLEPc.MFN().create(comm)
    mfn.setOptionsPrefix(PREFIX)
    mfn.setOperator(J)
    fn = mfn.getFN()
    fn.setType(SLEPc.FN.Type.EXP)
    fn.setScale(step)
    step_tol = max(tol / len(times), TOL_FLOOR)
    mfn.setTolerances(tol=step_tol)
    if rate is not None:
        mfn.setDimensions(krylov_dimension(step * rate, step_tol))
    mfn.setFromOptions()
    X, Y = J.createVecs()
    n = dm.M.getLocalSize()
    u = PETSc.Vec().createMPI((n, dm.size), comm=comm)
    du = u.duplicate()
    try:
        mfn.setUp()
        settings = mfn_settings(mfn)
        if settings["fn_scale"] != (step, 1.0):
            raise InputError(f"-waves_fn_scale: the exponential's scale is the sample spacing h = waves.dt x "
                             f"sample_every = {step:g}; got {settings['fn_scale']} (set waves.dt instead)")
        series = []
        for mode, run, k in waves:
            component, axis = excitation.runs(mode, dm.dim)[run]
            sampler = FourierSampler(dm, positions, [(component, axis, k)], mpi)
            X.setArray(np.concatenate((np.zeros(n), start_velocity(dm, positions, component, axis, k, amplitude, mpi))))
            samples, iterations = [], 0
            for index in range(len(times)):
                if index:
                    mfn.solve(X, Y)
                    if mfn.getConvergedReason() <= 0:
                        raise NumericalFailure(f"waves (exponential): SLEPc MFN did not converge at t = "
                                               f"{times[index]:g} (reason {mfn.getConvergedReason()}, "
                                               f"{mfn.getIterationNumber()} iterations; raise -waves_mfn_ncv "
                                               f"or -waves_mfn_max_it)")
                    iterations = max(iterations, mfn.getIterationNumber())
                    X, Y = Y, X
                state = X.getArray(readonly=True)
                u.setArray(state[:n])
                dm.D.mult(u, du)
                samples.append(sampler(state[:n, None], state[n:, None], du.getArray(readonly=True)[:, None]))
            z, z_fixed, energy = (np.array(column)[:, 0] for column in zip(*samples))
            series.append(WaveSeries(np.asarray(times), z, z_fixed, energy, len(times) - 1,
                                     error_estimate=len(times) * settings["mfn_tol"],
                                     settings={**settings, "max_iterations": iterations}))
        return series
    finally:
        for obj in (mfn, J, minv, X, Y, u, du):
            obj.destroy()
