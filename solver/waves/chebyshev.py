"""Damped standing waves without time steps: the Chebyshev-Bessel series of exp(tJ) on the
first-order system, in blocks (``waves.method: spectral`` when the model has dashpots).  See
:func:`damped_spectral` and docs/damping.md section 8.  Collective on the matrix's communicator.
Units: d0 = m = kn = 1.

In mass-scaled coordinates q = M^1/2 u, p = M^1/2 v the damped motion (eq:motion with the
dashpots' C) is X' = J X, X = (q, p), J = [[0, I], [-A, -C^]], A = M^-1/2 D M^-1/2,
C^ = M^-1/2 C M^-1/2.  In the energy inner product <X, Y>_E = q.A q' + p.p' the numerical range
of J lies in the rectangle [-c_max, 0] x i[-omega_max, omega_max] (its E-skew part has the
undamped frequencies, its E-symmetric part is -C^), so for an ellipse around that rectangle with
foci c +- i f (c = -c_max/2, f = omega_max) and parameter rho,

    exp(t J) = e^(c t) sum_k eps_k J_k(f t) P_k(B),   B = (J - c) / f,   P_(k+1) = 2 B P_k + P_(k-1),

(eps_0 = 1, eps_k = 2, J_k Bessel functions of the first kind; P_k(B) = i^k T_k(-iB) has real
coefficients) and by Crouzeix and Palencia's theorem |P_k(B)|_E <= (1 + sqrt 2) rho^k: the tail of
the series bounds the truncation error in the energy norm, and exp(tJ) is a contraction in it,
so errors of successive blocks add without growing.  A block of length T costs about f T + a few
tens of products with J, one per term; z(t) at every sample of the block comes from the scalars
b.P_k X (no vector per sample).  The block length trades those few tens (shorter blocks pay them
more often) against cancellation: the terms grow like e^((alpha - c_max/2) T) over an answer of
size ~1 (alpha: the ellipse's real semi-axis), so long blocks lose digits.  :func:`plan` picks it.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from .. import profiling
from ..model.operators import largest_damping_rate, largest_omega, scaled_damping, scaled_operator
from .excitation import channel, runs, start_velocity
from .sampling import WaveSeries

CROUZEIX = 1.0 + math.sqrt(2.0)
ROUNDING = 2 * np.finfo(float).eps
"""Round-off of one term of the series, relative to its bound |coefficient| rho^k |X|_E (an
estimate; measured errors against dense exp(tJ) stay below it, tests/waves/test_damped_spectral.py)."""
MARGIN = 1e-3
"""omega_max and c_max come from Lanczos to 1e-8: the ellipse is drawn around a rectangle this
much (relative) larger."""


@dataclass(frozen=True)
class Plan:
    """How the series runs: ``samples`` sample spacings per block, ``terms`` + 1 terms (degree
    ``terms``), ellipse centre ``c`` (1/t0), focal half-distance ``f`` and parameter ``rho``;
    ``truncation`` and ``rounding``: the bounds of one block's error, relative to |X|_E at its
    start."""

    samples: int
    terms: int
    c: float
    f: float
    rho: float
    truncation: float
    rounding: float


def ellipse(omega_max: float, damping_max: float, stretch: float = 1.0) -> tuple[float, float, float]:
    """(c, f, rho): centre, focal half-distance and parameter of the ellipse with foci c +- i f,
    c = -c_max/2, f = ``stretch`` omega_max (>= omega_max), whose smallest real semi-axis alpha
    puts the corners of the rectangle [-c_max, 0] x i[-omega_max, omega_max] (the numerical range
    of J in the energy norm) on it: h^2/alpha^2 + omega^2/(f^2 + alpha^2) = 1, h = c_max/2, so
    alpha^2 = (h^2 + omega^2 - f^2 + sqrt((f^2 - h^2 - omega^2)^2 + 4 h^2 f^2)) / 2."""
    w = omega_max * (1 + MARGIN)
    h = 0.5 * damping_max * (1 + MARGIN)
    f = stretch * w
    alpha = math.sqrt(0.5 * (h * h + w * w - f * f + math.sqrt((f * f - h * h - w * w) ** 2 + 4 * h * h * f * f)))
    return -h, f, (alpha + math.hypot(alpha, f)) / f


def coefficients(terms: int, c: float, f: float, tau: np.ndarray) -> np.ndarray:
    """(terms + 1, len(tau)): eps_k e^(c tau) J_k(f tau), the series' coefficients at times tau."""
    from scipy.special import jv

    out = jv(np.arange(terms + 1)[:, None], f * tau[None, :]) * np.exp(c * tau)[None, :]
    out[1:] *= 2.0
    return out


def block_plan(samples: int, step: float, c: float, f: float, rho: float, tol: float,
               points: int | None = None) -> Plan:
    """The fewest terms whose tail bound (CROUZEIX sum over the dropped terms of |coefficient|
    rho^k, the worst sample of a block of ``samples`` spacings ``step``) is below ``tol``.
    ``points``: look at that many of the samples only, spread over the block, its end included
    (the search's estimate; a plan is made on every sample)."""
    tau = step * np.arange(1, samples + 1)
    if points is not None and samples > points:
        tau = tau[np.unique(np.linspace(samples - 1, 0, points).round().astype(int))]
    cap = int(math.ceil(1.5 * f * tau[-1] * rho)) + 80  # J_k(x) rho^k is negligible far beyond x rho
    with np.errstate(divide="ignore", over="ignore"):  # in logs: rho^k overflows long before J_k underflows
        bound = np.exp(np.log(np.abs(coefficients(cap, c, f, tau))) + np.arange(cap + 1)[:, None] * math.log(rho))
    if not np.all(np.isfinite(bound)):  # terms beyond double range: this block cannot be summed
        return Plan(samples, cap, c, f, rho, math.inf, math.inf)
    tail = CROUZEIX * np.cumsum(bound[::-1], axis=0)[::-1].max(axis=1)  # tail[k]: terms k.. dropped
    if tail[-1] > 1e-3 * tol:
        raise RuntimeError(f"waves (spectral, damped): the series' cap of {cap} terms is too small")
    terms = int(np.argmax(tail < tol))  # degree terms - 1 is kept when tail[terms] < tol
    return Plan(samples, max(terms, 1), c, f, rho, float(tail[terms]),
                float(ROUNDING * bound[:terms + 1].sum(axis=0).max()))


SEARCH_POINTS = 12
"""Samples per block the search of :func:`plan` bounds (the chosen block is then bounded on all)."""
STRETCHES = (1.0, 1.1, 1.2, 1.3, 1.5)
"""Focal half-distances tried, in omega_max: a longer one thins the ellipse (smaller rho, longer
blocks) but makes it taller (more terms per unit time); 1.2-1.3 measured best at c_max/omega_max
about 0.45, 15 % fewer products than 1."""


@functools.lru_cache(maxsize=64)
def plan(omega_max: float, damping_max: float, step: float, count: int, tol: float) -> Plan:
    """The ellipse (``STRETCHES``) and block (a number of sample spacings ``step``, of ``count`` in
    all) with the fewest products with J over the run whose errors, added over the run, stay below
    ``tol`` (relative to |X(0)|_E): truncation and rounding below tol / 2 each, in all.  ValueError
    if none can (``schedule.plan`` turns it into the scene's InputError before any wave runs)."""
    best, cost = None, math.inf
    for stretch in STRETCHES:
        c, f, rho = ellipse(omega_max, damping_max, stretch)
        samples, mine = 1, math.inf
        while samples <= count:
            blocks = math.ceil(count / samples)
            candidate = block_plan(samples, step, c, f, rho, 0.5 * tol / blocks, SEARCH_POINTS)
            if candidate.rounding * blocks > 0.5 * tol and samples > 1:
                break  # longer blocks only lose more digits (rounding is inf when the terms overflow)
            total = candidate.terms * blocks
            if candidate.rounding * blocks <= 0.5 * tol and total < cost:
                best, cost = candidate, total
            if total > 1.2 * mine:
                break  # past this ellipse's best block: longer ones only cost more
            mine = min(mine, total)
            samples = samples * 2 if samples < 8 else samples + max(samples // 4, 1)
    if best is not None:  # the search's choice, bounded on every sample of its block
        best = block_plan(best.samples, step, best.c, best.f, best.rho, 0.5 * tol / math.ceil(count / best.samples))
    if best is None or best.rounding * math.ceil(count / best.samples) > 0.5 * tol:
        raise ValueError(f"the damped spectral path cannot bound its error below {tol:g} over {count} samples "
                         f"spacing {step:g} (its rounding bound, with c_max = {damping_max:g}, is above it)")
    return best


@profiling.logged("rsChebyshevWave")
def damped_spectral(dm, positions, mode: str, run: int, k: float | np.ndarray, *, amplitude: float, times: np.ndarray,
                    tol: float = 1e-8, omega_max: float | None = None,
                    damping_max: float | None = None) -> WaveSeries:
    """A damped standing wave (dashpots ``dm.C``; symmetric D) without time stepping, for run
    ``run`` of ``excitation.runs(mode, dm.dim)``, sampled at ``times`` (S,), equally spaced from 0
    (t0).  Collective.

    X(0) = (0, M^1/2 v0) with v0 as on every path (eq:initial, zero modes projected out); z = z_fixed
    (phase of r_i(0): the model is linear).  The series (module docstring) runs in blocks of
    :func:`plan`'s length; z at each sample is b.P_k X summed with the Bessel coefficients, the
    state at a block's end is the sum of the P_k X.  Energy (v.M v + u.D u)/2 at block ends, NaN at
    the samples between.  Error estimate: the bounds of truncation and rounding added over the
    blocks, relative to |X(0)|_E (a bound on |z - exact| / (|M^-1/2 b| |X(0)|_E), b the channel).
    """
    from mpi4py import MPI

    mpi = dm.D.getComm().tompi4py()
    component, axis = runs(mode, dm.dim)[run]
    step = float(times[1] - times[0])
    count = len(times) - 1
    if omega_max is None:
        omega_max = largest_omega(dm)
    if damping_max is None:
        damping_max = largest_damping_rate(dm)
    chosen = plan(omega_max, damping_max, step, count, tol)
    if dm.scaled is None:
        dm.scaled = scaled_operator(dm)
    A, C = dm.scaled, scaled_damping(dm)
    root = np.sqrt(dm.M.getArray())
    b = channel(dm, positions, component, axis, k) / root  # z = b^H v = (M^-1/2 b)^H p
    b_local = np.ascontiguousarray(np.stack([b.real, b.imag]))
    base, _ = A.createVecs()
    vecs = [base] + [base.duplicate() for _ in range(9)]
    q, p, q_prev, p_prev, q_next, p_next, q_end, p_end, Aq, Cp = vecs
    q.zeroEntries()
    p.setArray(start_velocity(dm, positions, component, axis, k, amplitude, mpi) * root)

    def energy() -> float:
        A.mult(q, Aq)
        return 0.5 * (q.dot(Aq) + p.dot(p))

    def moment(vec) -> complex:
        local = vec.getArray(readonly=True)
        dots = np.empty(2)
        mpi.Allreduce(b_local @ local, dots, op=MPI.SUM)
        return complex(dots[0], -dots[1])

    def apply_b(q_in, p_in, q_out, p_out, factor):
        """(q_out, p_out) = factor B (q_in, p_in) + (q_out, p_out), B = (J - c) / f."""
        A.mult(q_in, Aq)
        C.mult(p_in, Cp)
        q_out.maxpy([factor / chosen.f, -factor * chosen.c / chosen.f], [p_in, q_in])
        p_out.maxpy([-factor / chosen.f, -factor / chosen.f, -factor * chosen.c / chosen.f], [Aq, Cp, p_in])

    z = [moment(p)]
    energies = [energy()]
    products, error = 0, 0.0
    try:
        start = 0
        while start < count:
            samples = min(chosen.samples, count - start)
            tau = step * np.arange(1, samples + 1)
            coef = coefficients(chosen.terms, chosen.c, chosen.f, tau)  # (terms + 1, samples)
            moments = np.empty(chosen.terms + 1, dtype=complex)
            # P_0 = X (held in q, p), P_1 = B X
            moments[0] = moment(p)
            q_end.set(0.0)
            p_end.set(0.0)
            q_end.axpy(coef[0, -1], q)
            p_end.axpy(coef[0, -1], p)
            q_next.set(0.0)
            p_next.set(0.0)
            apply_b(q, p, q_next, p_next, 1.0)
            q_prev, q, q_next = q, q_next, q_prev  # (prev, current) = (P_0, P_1); q_next is free
            p_prev, p, p_next = p, p_next, p_prev
            for index in range(1, chosen.terms + 1):
                moments[index] = moment(p)
                q_end.axpy(coef[index, -1], q)
                p_end.axpy(coef[index, -1], p)
                if index == chosen.terms:
                    break
                apply_b(q, p, q_prev, p_prev, 2.0)  # P_(k+1) = 2 B P_k + P_(k-1), in P_(k-1)'s place
                q_prev, q = q, q_prev
                p_prev, p = p, p_prev
            products += chosen.terms
            z.extend(moments @ coef)
            q_end.copy(q)
            p_end.copy(p)
            energies.extend([math.nan] * (samples - 1) + [energy()])
            error += chosen.truncation + chosen.rounding
            start += samples
    finally:
        for vec in vecs:
            vec.destroy()
        C.destroy()
    z = np.array(z)
    settings = {"method": "chebyshev", "tol": tol, "block_samples": chosen.samples, "terms": chosen.terms,
                "products": products, "omega_max": omega_max, "damping_max": damping_max, "rho": chosen.rho}
    return WaveSeries(np.asarray(times), z, z, np.array(energies), products, error, settings)
