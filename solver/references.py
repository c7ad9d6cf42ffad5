"""Dense references: the exact answers that the tests, the cross-checks (crosschecks/) and the
benchmarks (benchmarks/) hold rotsound's solvers against, in one place.

Each is computed densely from the gathered matrix (scipy.linalg's ``eigh`` of
A = M^-1/2 D M^-1/2, scipy.sparse.linalg's ``expm`` of the first-order matrix), so a few
thousand DOF at most (N^2 memory, N^3 time), and independently of the solvers it checks: this
module imports the matrix (``model``) and nothing of ``spectrum`` or ``waves`` (its layer in
tests/run/test_imports.py sits right above ``model``).  Arrays are over the non-rattlers in the
packing's order (``dynmat.in_packing_order``) unless a function says otherwise.  The functions
that gather are collective and give the same result on every rank.

- :func:`dense_eigen`: the full eigendecomposition of A; :func:`dense_eigenvalues`, its eigenvalues
  alone;
- :func:`modal_weights`, :func:`exact_z_fixed`: one standing-wave run's z(t), exactly, as a sum
  of cosines over A's modes (PHYSICS.md section 4); :func:`exact_start_correlation`, the start's
  own autocorrelation C_a(t) (docs/waves_theory.md);
- :func:`verlet_eigen`: velocity Verlet's own frequencies, so that :func:`exact_z_fixed` gives
  Verlet's z at the steps exactly;
- :func:`first_order_flow`: displacements and velocities of M u'' = -D u - C u' from u = 0,
  v = v(0), by exp(tJ) (any D: stressed, non-symmetric; with or without dashpots C);
- :func:`l_wave_start`, :func:`exact_l_wave`: the benchmarks' L wave and its exact z(t);
- :func:`allen_feldman_dense`: every mode's Allen-Feldman diffusivity, the definition of
  docs/diffusivity.md evaluated literally (X^a built densely from the positions, the double sum
  over all pairs of modes), the reference of ``solver.transport.allen_feldman``;
- :func:`allen_feldman_binned_dense`: the Allen-Feldman diffusivity per omega bin in the trace form
  that ``solver.transport.kpm_diffusivity`` estimates (docs/diffusivity_trace.md), sharp or with
  the same Jackson-filtered bins, exactly: what the stochastic estimator converges to.

Units: d0 = m = kn = 1, t0 = 1.
"""

from __future__ import annotations

import numpy as np

from .model import dynmat
from .model.operators import scaled_operator
from .packing import geometry


def dense_eigenvalues(dm) -> np.ndarray:
    """Every eigenvalue (ascending) of A = M^-1/2 D M^-1/2 of ``dm`` (symmetric) by LAPACK,
    without eigenvectors, dense on every rank. Collective."""
    A = scaled_operator(dm)
    try:
        return np.linalg.eigvalsh(dynmat.gather_csr(A).toarray())
    finally:
        A.destroy()


def dense_eigen(dm) -> tuple[np.ndarray, np.ndarray]:
    """(lam, vec): the full eigendecomposition of A = M^-1/2 D M^-1/2 of ``dm`` (a symmetric
    :class:`~solver.model.dynmat.DynamicalMatrix`), dense on every rank, with its rows in the
    packing's order of the non-rattlers (``dynmat.in_packing_order``). Collective."""
    import scipy.linalg as sl

    A = scaled_operator(dm)
    dense = dynmat.in_packing_order(dm, dynmat.gather_csr(A).toarray())  # rows as the packing lists them
    A.destroy()
    return sl.eigh(dense)


def _weights(vec: np.ndarray, mass: np.ndarray, start: np.ndarray, phase: np.ndarray,
             drop: np.ndarray | None = None) -> np.ndarray:
    """w (n,): z(t) = sum_j w_j cos(omega_j t) of the start velocity ``start`` projected on
    ``phase`` (both (N', dof), packing order), from A's eigenvectors ``vec`` and the masses
    ``mass`` (n,); the modes ``drop`` (a mask) carry no part of the start."""
    a = vec.T @ (np.sqrt(mass) * start.ravel())
    if drop is not None:
        a[drop] = 0.0
    return ((phase.ravel() / np.sqrt(mass)) @ vec) * a


def modal_weights(p, dm, eig, run, k, amplitude, start: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(omega (n,), w (n,)): one standing-wave run's z(t) (r_i(0) in the phase) is exactly
    sum_j w_j cos(omega_j t) (with ``start``, the read-out is M v(0) instead of the channel:
    v(0)^T M v(t) = sum_j w_j cos(omega_j t)), from the full eigendecomposition ``eig`` = :func:`dense_eigen`
    (PHYSICS.md section 4), 2D or 3D.  ``run`` = (component, axis): the start is the raw amplitude
    sin(k r_a) in the component (a tilted cell's (D,) wave vector ``k``: sin(k . r) in the
    polarisation, ``_polarisation``) with its part in A's whole null space removed -- found from the
    eigenvalues (|lam| < 1e-10 max lam), not from ``dm.rigid_modes()``, and in A's
    (mass-weighted) metric, so the reference does not share the code's projection; RuntimeError
    (on every rank: the data are the same everywhere) when the two disagree on the number of zero
    modes.  Collective (gathers M)."""
    lam, vec = eig
    zero = np.abs(lam) < 1e-10 * lam.max()
    if zero.sum() != len(dm.rigid_modes()):
        raise RuntimeError(f"{zero.sum()} zero modes, rigid modes {dm.rigid_modes()}")
    omega = np.sqrt(np.where(zero, 0.0, lam))
    mass = dynmat.in_packing_order(dm, dynmat.gather_vec(dm.M))
    component, axis = run
    r0 = p.positions[~p.rattler]
    if np.ndim(k) == 0:
        v0 = np.zeros((len(r0), dm.dof))
        v0[:, component] = amplitude * np.sin(k * r0[:, axis])
        b = np.zeros((len(r0), dm.dof), complex)
        b[:, component] = np.exp(-1j * k * r0[:, axis])
    else:
        polarisation = _polarisation(component, axis, np.asarray(k, dtype=float), dm.dim, dm.dof)
        phase = r0 @ np.asarray(k, dtype=float)
        v0 = amplitude * np.sin(phase)[:, None] * polarisation
        b = np.exp(-1j * phase)[:, None] * polarisation
    return omega, _weights(vec, mass, v0, mass.reshape(v0.shape) * v0 if start else b, zero)


def exact_start_correlation(p, dm, eig, run, k, t) -> np.ndarray:
    """C_a(t) (S,) of one standing-wave run (component, axis) at times ``t``: the start's own
    autocorrelation <v(0), v(t)>_M / <v(0), v(0)>_M = sum_j w_j cos(omega_j t) / sum_j w_j with
    w_j = (e_j^T M^1/2 v(0))^2 (:func:`modal_weights` with ``start``: the read-out is M v(0)).
    Collective (gathers M)."""
    omega, w = modal_weights(p, dm, eig, run, k, 1.0, start=True)
    return w @ np.cos(np.outer(omega, t)) / w.sum()


def _polarisation(component: int, axis: int, k: np.ndarray, dim: int, dof: int) -> np.ndarray:
    """(dof,) run (``component``, ``axis``)'s polarisation for the wave vector ``k`` (D,) of a tilted
    cell, as docs/waves.md states it and not by ``waves.excitation``'s Gram-Schmidt: the column of
    Q (QR of [k, e_c for c != axis], signs made positive on the diagonal of R) of the component's
    place among them; 2D's angular velocity e_2."""
    p = np.zeros(dof)
    if component >= dim and dim == 2:
        p[component] = 1.0
        return p
    first = dim if component >= dim else 0
    order = [axis] + [c for c in range(dim) if c != axis]
    columns = np.column_stack([k] + [np.eye(dim)[c] for c in order[1:]])
    q, r = np.linalg.qr(columns)
    q = q * np.sign(np.diag(r))
    p[first:first + dim] = q[:, order.index(component - first)]
    return p


def exact_z_fixed(p, dm, eig, run, k, t, amplitude) -> np.ndarray:
    """The exact z(t) (S,) of one standing-wave run (component, axis) at times ``t`` (S,)
    (:func:`modal_weights`). Collective."""
    omega, w = modal_weights(p, dm, eig, run, k, amplitude)
    return w @ np.cos(np.outer(omega, t))


def verlet_eigen(eig, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``eig`` = (lam, vec) with each frequency replaced by velocity Verlet's, 2/dt arcsin(omega dt/2):
    Verlet's velocities at the steps of a linear system are exactly v(0) cos(omega~ t) per mode
    (u_n = B sin(omega~ n dt) solves the 3-term recurrence with cos(omega~ dt) = 1 - (omega dt)^2/2,
    and v_n = (u_{n+1} - u_{n-1}) / 2 dt), so :func:`exact_z_fixed` with these gives Verlet's z at
    the sample times.  Exact zero modes (|lam| < 1e-10 max lam, as :func:`modal_weights`) become 0.
    ValueError above Verlet's stability limit.  Not collective."""
    lam, vec = eig
    zero = np.abs(lam) < 1e-10 * lam.max()
    omega = np.sqrt(np.where(zero, 0.0, lam))
    if omega.max() * dt >= 2.0:
        raise ValueError(f"dt = {dt} is above Verlet's stability limit 2/omega_max = {2 / omega.max():.4f}")
    return np.where(zero, 0.0, (2.0 / dt * np.arcsin(0.5 * omega * dt)) ** 2), vec


def first_order_flow(dm, start: np.ndarray, sample: float, count: int, offset: float = 0.0,
                     order: str = "packing") -> np.ndarray:
    """X (count, 2, N', dof): displacements X[:, 0] and velocities X[:, 1] at t = offset,
    offset + sample, ... of M u'' = -D u - C u' from u = 0, v = ``start`` at t = 0:
    X(t) = exp(t J) X(0), J = [[0, I], [-M^-1 D, -M^-1 C]], dense (C = ``dm.C``, the dashpots,
    if any; D as assembled, symmetric or not), J built here from the gathered D, C and M (not by
    ``model.operators.first_order_matrix``, which the exact wave paths use).  Exact to round-off
    whatever D's symmetry.
    ``start`` is over the non-rattlers, (N', dof) or flat, in the packing's order (``order``
    "packing", as ``excitation.whole_start`` gives it) or in the matrix's (``order`` "matrix",
    as the gathered Vec of a solver's start is); the result is in the same order.  Collective
    (gathers D, C and M)."""
    # scipy.sparse.linalg's expm (Al-Mohy and Higham's algorithm, in Python; it takes a dense array),
    # not scipy.linalg.expm: Debian 12's scipy 1.10.1 reads uninitialised memory in the latter for
    # matrices of 400 rows or more (Pade order 9; scipy issue 18086, fixed in 1.13), so that one J
    # gave another exp(tJ) call after call (tests/waves/test_liggghts_waves.py).
    import scipy.sparse.linalg as spl

    if order not in ("packing", "matrix"):
        raise ValueError(f"order {order!r}: packing or matrix")

    def ordered(whole):
        return dynmat.in_packing_order(dm, whole) if order == "packing" else whole

    d = ordered(dynmat.gather_csr(dm.D).toarray())
    m = ordered(dynmat.gather_vec(dm.M))
    size = d.shape[0]
    j = np.zeros((2 * size, 2 * size))
    j[:size, size:] = np.eye(size)
    j[size:, :size] = -d / m[:, None]
    if dm.C is not None:
        j[size:, size:] = -ordered(dynmat.gather_csr(dm.C).toarray()) / m[:, None]
    step = spl.expm(sample * j)
    x = np.concatenate((np.zeros(size), np.ravel(start)))
    if offset:
        x = spl.expm(offset * j) @ x
    out = []
    for _ in range(count):
        out.append(x.reshape(2, -1, dm.dof))
        x = step @ x
    return np.array(out)


def l_wave_start(p, k: float, amplitude: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """(r0 (N', D), v0 (N', 3)): the benchmarks' L wave on the non-rattlers of the 2D packing
    ``p`` (scripts/benchmarks/bench_waves.py, bench_spectral.py): v_x = ``amplitude`` sin(k x), its plain
    mean removed (the uniform translation), v_y = w_z = 0.  Not collective."""
    r0 = p.positions[~p.rattler]
    v0 = np.zeros((len(r0), 3))
    v0[:, 0] = amplitude * np.sin(k * r0[:, 0])
    v0[:, 0] -= v0[:, 0].mean()
    return r0, v0


def exact_l_wave(p, dm, k: float, times: np.ndarray) -> np.ndarray:
    """z(t) (S,) of :func:`l_wave_start` (x velocities projected on exp(-i k x)) at ``times``, from
    the full eigendecomposition of ``dm`` (the 2D matrix of ``p`` with rotations).  Unlike
    :func:`exact_z_fixed` the start is not projected off the zero modes: its mass-weighted rigid
    part (the plain mean is removed, not the mass-weighted one) stays, as a constant.
    Collective."""
    lam, vec = dense_eigen(dm)
    omega = np.sqrt(np.clip(lam, 0, None))
    mass = dynmat.in_packing_order(dm, dynmat.gather_vec(dm.M))
    r0, v0 = l_wave_start(p, k)
    b = np.zeros((len(r0), 3), complex)
    b[:, 0] = np.exp(-1j * k * r0[:, 0])
    return _weights(vec, mass, v0, b) @ np.cos(np.outer(omega, times))


def allen_feldman_dense(dm, positions: np.ndarray, box, eta: float, zero_tol: float = 1e-4,
                        partners_to: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
    """(omega (M,) ascending in 1/t0, d (M,) in d0^2/t0): the Allen-Feldman diffusivity of every
    mode of ``dm`` (symmetric) with omega^2 > ``zero_tol``^2 (the spectrum's rule for zero modes),
    by the definition (docs/diffusivity.md): A = M^-1/2 D M^-1/2 gathered dense in the packing's
    order, ``eigh``; X^a = A times (r_i - r_j)_a per particle block, from ``positions`` (N, D,
    every particle in packing order) and the minimum image in ``box`` (a ``geometry.Cell``: tilted,
    or with walled axes, which have no images; or its (D,) sides, orthogonal periodic), built here densely;
    Y^a = V^T X^a V; d_n = pi / (4 D omega_n^2) sum_{m != n} sum_a |Y^a_nm|^2 (omega_n + omega_m)^2
    / (4 omega_n omega_m) (eta / pi) / ((omega_n - omega_m)^2 + eta^2), the partners m limited to
    omega_m <= ``partners_to`` (1/t0; the low-frequency window's sum).  n^2 memory, n^3 time.
    Collective (gathers A)."""
    import scipy.linalg as sl

    A = scaled_operator(dm)
    dense = dynmat.in_packing_order(dm, dynmat.gather_csr(A).toarray())
    A.destroy()
    lam, vec = sl.eigh(dense)
    keep = lam > zero_tol**2
    omega, vec = np.sqrt(lam[keep]), vec[:, keep]
    r = np.asarray(positions, dtype=float)[dm.active]  # the non-rattlers, in packing order
    delta = _pair_separations(r, box)
    dim = r.shape[1]
    square = np.zeros((omega.size, omega.size))
    for a in range(dim):
        x = dense * np.kron(delta[:, :, a], np.ones((dm.dof, dm.dof)))
        y = vec.T @ x @ vec
        square += y**2
    wn, wm = omega[:, None], omega[None, :]
    weight = (wn + wm) ** 2 / (4 * wn * wm) * (eta / np.pi) / ((wn - wm) ** 2 + eta**2)
    np.fill_diagonal(weight, 0.0)  # m != n
    weight[:, omega > partners_to] = 0.0
    return omega, np.pi / (4 * dim * omega**2) * (square * weight).sum(axis=1)


def _jackson(m: int) -> np.ndarray:
    """Jackson damping factors g_k, k = 0..m-1 (Weisse et al., Rev. Mod. Phys. 78, 275, eq. 71)."""
    k = np.arange(m)
    q = np.pi / (m + 1)
    return ((m - k + 1) * np.cos(q * k) + np.sin(q * k) / np.tan(q)) / (m + 1)


def _binned_filters(lam: np.ndarray, edges: np.ndarray, lam_max: float, moments: int | None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """(F (M, B), I (M, B)) at the eigenvalues ``lam`` (M,): F_b = 1_b lambda^-1/2 and the
    indicator 1_b of omega in [edges_b, edges_b+1), sharp (``moments`` None) or as their
    Jackson-damped Chebyshev series of ``moments`` terms in x = (lambda - c) / h, [c - h, c + h] =
    [-0.01, 1.01] ``lam_max``.  The coefficients by quadrature in theta = arccos x, substituted
    theta = theta_low - u^2 from each bin's low-lambda end so that lambda^-1/2 at lambda = 0 is
    integrable smoothly (not the estimator's omega quadrature); F's bins are cut at
    lambda = c + 0.999 h as the estimator's, the indicator's at c + h (``kpm.bin_masses``)."""
    nbins = edges.size - 1
    if moments is None:
        which = np.searchsorted(edges, np.sqrt(lam), side="right") - 1
        inside = (which >= 0) & (which < nbins)
        ind = np.zeros((lam.size, nbins))
        ind[np.flatnonzero(inside), which[inside]] = 1.0
        return ind / np.sqrt(lam)[:, None], ind
    from scipy.special import roots_legendre

    lo, hi = -0.01 * lam_max, 1.01 * lam_max
    c, h = (hi + lo) / 2, (hi - lo) / 2
    k = np.arange(moments)
    norm = (2.0 - (k == 0)) / np.pi * _jackson(moments)

    def theta(lam_):
        return np.arccos(np.clip((lam_ - c) / h, -1.0, 1.0))

    f_coef = np.zeros((moments, nbins))
    i_coef = np.zeros((moments, nbins))
    for b in range(nbins):  # a loop over bins, each vectorised
        # the indicator, in closed form: int cos(k theta) over [theta(high), theta(low)]
        t_low, t_high = theta(edges[b] ** 2), theta(edges[b + 1] ** 2)
        i_coef[:, b] = np.where(k == 0, t_low - t_high, (np.sin(k * t_low) - np.sin(k * t_high)) / np.maximum(k, 1))
        top = min(edges[b + 1] ** 2, c + 0.999 * h)
        if edges[b] ** 2 >= top:
            continue
        t_low, t_high = theta(edges[b] ** 2), theta(top)
        u_max = np.sqrt(t_low - t_high)
        nodes, weights = roots_legendre(int(4 * moments * (t_low - t_high)) + 400)
        u = u_max * (nodes + 1) / 2
        t = t_low - u**2
        lam_t = c + h * np.cos(t)  # > 0 at every node (u > 0)
        f_coef[:, b] = np.cos(np.outer(k, t)) @ (2 * u / np.sqrt(lam_t) * weights * u_max / 2)
    series = np.cos(np.outer(theta(lam), k))  # T_k(x_n)
    return series @ (norm[:, None] * f_coef), series @ (norm[:, None] * i_coef)


def _pair_separations(r: np.ndarray, box) -> np.ndarray:
    """(n, n, D) r_i - r_j of every pair of ``r`` (n, D), each its nearest image in ``box`` (a
    ``geometry.Cell`` or its (D,) sides; ``geometry.minimum_image``: exact for the contacts' separations)."""
    return geometry.minimum_image(r[:, None, :] - r[None, :, :], box)


def allen_feldman_binned_dense(dm, positions: np.ndarray, box, edges: np.ndarray, lam_max: float,
                               moments: int | None = None, weight: str = "trace", zero_tol: float = 1e-4,
                               min_count: float = 1.0) -> dict:
    """The Allen-Feldman diffusivity per omega bin of ``dm`` (symmetric) in the trace form of
    docs/diffusivity_trace.md, exactly: {"count", "total", "d"}, each (B,) over the bins ``edges``
    (B+1,) in 1/t0; ``box`` as :func:`allen_feldman_dense`'s.  Over the modes with omega >
    ``zero_tol`` (``eigh`` of the gathered A), Y^a = V^T X^a V (X^a dense, as :func:`allen_feldman_dense`):

        total_b = pi / (4 D Delta_b) sum_a sum_{n, m} |Y^a_nm|^2 w_nm f_b(lambda_n) f_b(lambda_m),
        count_b = sum_n i_b(lambda_n),   d_b = total_b / count_b (NaN where count_b < ``min_count``),

    ``weight`` "trace": w = 1 and f_b = 1_b lambda^-1/2 (the estimator's target); "allen_feldman":
    w_nm = (omega_n + omega_m)^2 / (4 omega_n^3 omega_m) (the definition's pair weight, m != n) and
    f_b = 1_b.  i_b = 1_b; with ``moments`` K, f_b and i_b are their Jackson-damped Chebyshev
    series of K terms on [-0.01, 1.01] ``lam_max`` (the estimator's at K moments, its
    ``omega_max``^2 as ``lam_max``); sharp bins without.  n^2 memory.  Collective (gathers A)."""
    import scipy.linalg as sl

    if weight not in ("trace", "allen_feldman"):
        raise ValueError(f"weight {weight!r}: trace or allen_feldman")
    edges = np.asarray(edges, dtype=float)
    A = scaled_operator(dm)
    dense = dynmat.in_packing_order(dm, dynmat.gather_csr(A).toarray())
    A.destroy()
    lam, vec = sl.eigh(dense)
    keep = lam > zero_tol**2
    lam, vec = lam[keep], vec[:, keep]
    omega = np.sqrt(lam)
    r = np.asarray(positions, dtype=float)[dm.active]
    delta = _pair_separations(r, box)
    dim = r.shape[1]
    square = np.zeros((lam.size, lam.size))
    for a in range(dim):
        y = vec.T @ (dense * np.kron(delta[:, :, a], np.ones((dm.dof, dm.dof)))) @ vec
        square += y**2
    f, ind = _binned_filters(lam, edges, lam_max, moments)
    if weight == "allen_feldman":
        wn, wm = omega[:, None], omega[None, :]
        square *= (wn + wm) ** 2 / (4 * wn**3 * wm)
        np.fill_diagonal(square, 0.0)
        f = ind
    total = np.pi / (4 * dim * np.diff(edges)) * np.einsum("nb,nm,mb->b", f, square, f)
    count = ind.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.where(count >= min_count, total / count, np.nan)
    return {"count": count, "total": total, "d": d}
