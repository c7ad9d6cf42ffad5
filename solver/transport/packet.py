"""The diffusivity measured directly, as a spreading energy packet (issue 45, point 3; derivation
and measurements in docs/diffusivity_packet.md).

Energy is put into a small region, filtered to a frequency band, propagated exactly, and its
energy-weighted mean square distance from the start's centre is followed:
<dr^2>(t) -> 2 D d t in the diffusive regime, d to be compared with route 1 (the Allen-Feldman
d_n of ``allen_feldman``, weighted by the packet's modal energies).

Coordinates: mass-weighted, q = M^1/2 u, pi = q' (the rows of A = M^-1/2 D M^-1/2, translations
and rotations, rattlers removed, on A's layout).  Particle energies (docs/diffusivity.md section 1)

    h_i = 1/2 sum_{alpha in i} pi_alpha^2 + 1/2 sum_{alpha in i} q_alpha (A q)_alpha,

placed at the particle centres r_i, rotations included; H = sum_i h_i is conserved.  With
f_i = |r_i - r_c|^2 (minimum image about the packet's centre r_c, fixed at the start)

    <dr^2>(t) = sum_i h_i f_i / H,    d<dr^2>/dt = sum_i h_i' f_i / H,
    h_i' = 1/2 sum_{alpha in i} (q_alpha (A pi)_alpha - pi_alpha (A q)_alpha)

(the rate is exact at every sample, not a finite difference; summed over i with f_i it is the
energy current's pair form 1/2 q^T F pi, F_{alpha beta} = A_{alpha beta} (f_i - f_j), Hardy's).

Decisions, and why:

- **Exact propagation by Chebyshev series in A** (MatMult only, no time steps).  Every quantity
  is f(A) applied to a start vector with f an entire function of lambda = omega^2: cos(t omega),
  sin(t omega)/omega, omega sin(t omega), lambda cos(t omega), lambda omega sin(t omega).  Their
  Chebyshev coefficients on [0, lambda_top] (lambda_top = (1.001 omega_max)^2, omega_max by
  Lanczos) come from interpolation at Chebyshev nodes (a DCT; cos(t sqrt(lambda)) has the exact
  coefficients (-1)^k eps_k J_2k(omega_top t), so about omega_top t_max / 2 terms), truncated where
  the sum of the dropped |c_k| is below ``tol`` times the function's largest value on the
  interval: with the spectrum inside the interval, |T_k(B)| <= 1, so that is a bound on the
  truncation error of every sample relative to |start|.  One recursion T_k(B) V (V the start
  vectors side by side, one MatMatMult per term) serves every time: the vectors are gathered in
  chunks and multiplied by the (chunk, families x times) coefficient block (one dgemm), so the
  cost is K MatMatMults plus 2 K n F T flops for F families at T times, K ~ omega_max t_max / 2.
  The Lanczos path (``waves.spectral``) gives scalars b^H f(A) a cheaply, but the packet needs the
  whole vector at every time (every particle's energy); the Chebyshev path keeps it in one
  recursion with a rigorous bound.

- **The start: two phases of one band-filtered random vector.**  s: independent normal numbers
  (SeedSequence([seed, 45, probe]), drawn over every particle of the packing in its order, then restricted:
  rank-free) on all DOF of the non-rattlers within ``radius`` of ``centre`` (minimum image), the
  exact zero modes (``dm.rigid_modes()``) projected out.  The band filter is a Gaussian in omega,
  centre omega_0 = (lo + hi)/2, sigma = (hi - lo)/4 (the band holds +-2 sigma), made even in
  omega so that it is an entire function of lambda:

      phase A (at rest):   q(0) = F_A(A) s,  pi(0) = 0,   F_A(w) = g(w - w_0) + g(w + w_0)
      phase B (a kick):    q(0) = 0,  pi(0) = F_B(A) s,   F_B(w) = w (g(w - w_0) - g(w + w_0))

  with g(x) = exp(-x^2 / 2 sigma^2).  For omega > 0, F_B = omega F_A up to a relative
  2 exp(-2 omega omega_0 / sigma^2) (at the band's centre at most 2 e^-8 = 7e-4, for a band
  from 0; e^-200 for the band 2-3), so phase B is phase A a quarter period on in every mode.
  Summing the two phases' particle energies then cancels the terms oscillating at
  omega_n + omega_m (kinetic against potential, the 2 omega breathing of a start at rest) and
  leaves the difference-frequency terms, the ones that carry the diffusion: the packet's energy
  density is that of the complex wave e^(-i t sqrt(A)) psi.  A start at rest alone has that
  breathing in <dr^2>; it averages out of a long fit but shows in the exact rate d<dr^2>/dt
  (measured, N = 512, band 2-3: an rms of 7 % of the mean rate for t < 3, 500 times more than
  with both phases; docs/diffusivity_packet.md section 2).  Needing sqrt(A) exactly
  (F_B = omega F_A exactly) is impossible with polynomials in A; the odd/even Gaussian pair is
  exact up to the bound above.  Both phases are exact solutions; the filters' own truncation only
  changes the start, not the exactness.  Both phases are scaled by one factor to H = 1 in all
  (each then holds about 1/2).  ``probes`` > 1 adds independent random vectors (each a pair of
  phases, each pair of energy 1/probes): an average over starts.

- **The fit.**  d = slope / (2 D) of a least-squares line through <dr^2>(t) over a window
  [t_a, t_b]; by default t_b is the last sample with <dr^2> below ``SATURATION_FRACTION`` of the
  box's uniform-spread value sum_a L_a^2 / 12 (a tilted cell's: its edges' sum_a |a|^2 / 12) and
  t_a = t_b / 2 (after the ballistic start; see the docs page for how these were chosen).  Error
  estimate: the larger distance of the two half-windows' slopes from the whole window's.  The
  exact local d(t) = (d<dr^2>/dt) / (2 D) is returned at every sample, so a user can see the
  plateau and choose the window.

Cost, n DOF, T times, P probes: K ~ omega_max t_max / 2 + (terms of the filter) MatMatMults on
2 P columns; 2 K n (2 P)(4 T) flops in the dgemms; memory (2 P)(4 T + 4 + chunk) n / p float64
per rank.  Collective on the matrix's communicator ``comm``; results equal on 1 and 2 ranks to
round-off.  Units: d0 = m = kn = 1, t0 = 1.
"""

from __future__ import annotations

import math

import numpy as np

from .. import profiling
from ..model.operators import largest_omega, scaled_operator
from ..packing.geometry import Cell, minimum_image
from ..spectrum import chebyshev, kpm

MARGIN = 1e-3
"""omega_max comes from Lanczos to 1e-8 (a lower bound): the interval's top is (1 + MARGIN) omega_max."""
SATURATION_FRACTION = 0.3
"""The default fit window ends where <dr^2> reaches this fraction of the uniform spread sum L_a^2/12."""
CHUNK = 32
"""Chebyshev vectors gathered before one dgemm with their coefficients."""
FAMILIES = ("C", "S", "W", "LC", "LW")
"""cos(t w), sin(t w)/w, w sin(t w), lambda cos(t w), lambda w sin(t w); w = sqrt(lambda)."""


def family_values(name: str, lam: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(len(lam), len(t)): the family ``name`` (:data:`FAMILIES`) at lambda ``lam`` >= 0 (1/t0^2)
    and times ``t`` (t0).  Not collective."""
    w = np.sqrt(np.clip(lam, 0.0, None))[:, None]
    t = np.asarray(t, dtype=float)[None, :]
    if name == "C":
        return np.cos(w * t)
    if name == "S":
        return t * np.sinc(w * t / math.pi)  # sin(t w)/w, = t at w = 0
    if name == "W":
        return w * np.sin(w * t)
    if name == "LC":
        return w**2 * np.cos(w * t)
    if name == "LW":
        return w**3 * np.sin(w * t)
    raise ValueError(f"unknown family {name!r}")


def band_centre_sigma(band: tuple[float, float]) -> tuple[float, float]:
    """(omega_0, sigma) in 1/t0 of the Gaussian band filter for ``band`` = (lo, hi), 0 <= lo < hi:
    centre (lo + hi)/2, sigma = (hi - lo)/4.  ValueError otherwise.  Not collective."""
    lo, hi = (float(x) for x in band)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 <= lo < hi):
        raise ValueError(f"band must be (lo, hi) with 0 <= lo < hi, not {band!r}")
    return 0.5 * (lo + hi), 0.25 * (hi - lo)


def filter_values(lam: np.ndarray, omega0: float, sigma: float) -> np.ndarray:
    """(len(lam), 2): F_A and F_B (module docstring) at lambda ``lam`` >= 0. Not collective."""
    w = np.sqrt(np.clip(lam, 0.0, None))
    plus, minus = np.exp(-0.5 * ((w - omega0) / sigma) ** 2), np.exp(-0.5 * ((w + omega0) / sigma) ** 2)
    return np.stack([plus + minus, w * (plus - minus)], axis=1)


def band_weight(omega: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    """(M,): the energy a unit random start puts, on average, in a mode of frequency ``omega``
    (1/t0) per unit of its weight on the start region, 1/2 (omega^2 F_A^2 + F_B^2) (both phases):
    the spectral weight of the packet, for averaging route 1's d_n over it.  Not collective."""
    omega0, sigma = band_centre_sigma(band)
    f = filter_values(np.asarray(omega, dtype=float) ** 2, omega0, sigma)
    return 0.5 * (omega**2 * f[:, 0] ** 2 + f[:, 1] ** 2)


def chebyshev_coefficients(func, lam_top: float, tol: float, start: int = 256) -> np.ndarray:
    """(K, F): Chebyshev coefficients in x = 2 lambda / lam_top - 1 of the F functions ``func``
    (lambda (P,) -> (P, F) values) on [0, lam_top], by interpolation at P Chebyshev nodes (a DCT;
    P doubled from ``start`` until the top eighth of the coefficients is below tol / 100 of each
    function's largest value), truncated to the fewest terms whose dropped |c_k| sum below ``tol``
    times that largest value, column by column (K the largest need).  Not collective."""
    from scipy.fft import dct

    points = start
    while True:
        x = np.cos(math.pi * (np.arange(points) + 0.5) / points)
        values = np.asarray(func(0.5 * lam_top * (1.0 + x)), dtype=float).reshape(points, -1)
        scale = np.maximum(np.abs(values).max(axis=0), np.finfo(float).tiny)
        coef = dct(values, type=2, axis=0) / points
        coef[0] *= 0.5
        top = np.abs(coef[-(points // 8):]).max(axis=0) / scale
        if np.all(top < 1e-2 * tol) or points >= 2**20:
            break
        points *= 2
    if np.any(top >= 1e-2 * tol):
        raise RuntimeError(f"packet: Chebyshev interpolation did not converge with {points} nodes")
    tail = np.cumsum(np.abs(coef[::-1]), axis=0)[::-1] / scale  # tail[k]: terms k.. dropped
    keep = int(np.max(np.argmax(tail < tol, axis=0)))
    return np.ascontiguousarray(coef[:max(keep, 1)])


@profiling.logged("rsAFPacketSeries")
def chebyshev_apply(A, vectors: np.ndarray, coef: list, lam_top: float) -> list:
    """[(nloc, F_r)] for r = 0 .. R-1: sum_k T_k(B) v_r c_r[k] with B = 2 A / lam_top - 1, v_r the
    column r of ``vectors`` (nloc, R; this rank's rows of A's layout) and ``coef`` [(K_r, F_r)].
    One recursion (``chebyshev.Recursion`` on A, the interval [0, lam_top]) on the (nloc, R) block,
    one MatMatMult per term; the vectors are multiplied by their coefficients in chunks of
    :data:`CHUNK` terms (one dgemm per column and chunk).  Collective on A's communicator."""
    nloc, columns = vectors.shape
    out = [np.zeros((nloc, c.shape[1])) for c in coef]

    def add(k0: int, block: np.ndarray) -> None:
        terms = block.reshape(nloc, columns, -1, order="F")  # T_k(B) v_r for the chunk's k
        for r, c in enumerate(coef):  # R start vectors: a handful, not particles
            stop = min(k0 + block.shape[1], c.shape[0])
            if stop > k0:
                out[r] += terms[:, r, :stop - k0] @ c[k0:stop]

    centre, half_width = chebyshev.interval_scale(0.0, lam_top)
    with chebyshev.Recursion(A, centre, half_width, columns) as recursion:
        recursion.chunked(np.asfortranarray(vectors, dtype=float), max(c.shape[0] for c in coef), CHUNK, add)
    return out


def _particle_range(A, dof: int) -> tuple[int, int]:
    """This rank's matrix particles [start, stop) from A's row ownership. Not collective."""
    start, stop = A.getOwnershipRange()
    return start // dof, stop // dof


def start_vector(dm, positions: np.ndarray, box: np.ndarray, centre, radius: float, seed: int, probe: int
                 ) -> tuple[np.ndarray, int]:
    """(s (nloc,), count): this rank's rows (A's layout) of the random start of probe ``probe``
    (module docstring: normal numbers of SeedSequence([seed, 45, probe]) drawn over every particle
    and DOF in the packing's order, kept on the non-rattlers within ``radius`` d0 of ``centre``
    (minimum image), the rigid zero modes projected out by ``kpm.project_rigid``) and how many
    particles carry it.  Collective on the matrix's communicator; rank-free."""
    positions = np.asarray(positions, dtype=float)
    rng = np.random.default_rng(np.random.SeedSequence([seed, 45, probe]))
    every = rng.standard_normal((positions.shape[0], dm.dof))
    inside = np.sum(minimum_image(positions - np.asarray(centre, dtype=float), box) ** 2, axis=1) <= radius**2
    every[~(inside & dm.active)] = 0.0
    start, stop = dm.D.getOwnershipRange()
    s = every[dm.order[start // dm.dof:stop // dm.dof]].ravel()
    kpm.project_rigid(dm, s[:, None])
    return s, int(np.count_nonzero(inside & dm.active))


@profiling.logged("rsAFPacketStart")
def band_starts(A, dm, positions: np.ndarray, box: np.ndarray, *, band: tuple[float, float], centre, radius: float,
                seed: int, probes: int, lam_top: float, comm, tol: float = 1e-10) -> tuple[list, int, int]:
    """(starts, count, terms): the packet's starts [(q0, None), (None, pi0)] per probe (this rank's
    rows of A's layout), phase A q0 = F_A(A) s and phase B pi0 = F_B(A) s of :func:`start_vector`'s
    s, scaled by one factor per probe to energy 1 / ``probes`` (module docstring); how many
    particles the region holds; the filters' Chebyshev terms.  ``A`` = M^-1/2 D M^-1/2 of ``dm``,
    spectrum in [0, ``lam_top``].  ValueError (every rank) for an empty region or a band without
    energy.  Collective on ``comm``."""
    mpi = comm.tompi4py()
    omega0, sigma = band_centre_sigma(band)
    raw, count = [], 0
    for probe in range(probes):  # a handful of probes
        s, count = start_vector(dm, positions, box, centre, radius, seed, probe)
        raw.append(s)
    if count == 0:
        raise ValueError(f"no particle lies within radius {radius} of centre {centre!r}")
    fcoef = chebyshev_coefficients(lambda lam: filter_values(lam, omega0, sigma), lam_top, tol)
    filtered = chebyshev_apply(A, np.stack(raw, axis=1), [fcoef] * probes, lam_top)
    starts = []
    image, vec = A.createVecLeft(), A.createVecRight()
    try:
        for f in filtered:
            qa, pb = f[:, 0].copy(), f[:, 1].copy()
            vec.setArray(qa)
            A.mult(vec, image)
            ea, eb = mpi.allreduce(np.array([0.5 * qa @ image.getArray(readonly=True), 0.5 * pb @ pb]))
            if not (ea > 0 and eb > 0):
                raise ValueError(f"the band {band!r} holds no energy of the start (no modes there?)")
            # ea and eb agree to the filters' 2 exp(-2 omega omega_0 / sigma^2)
            scale = 1.0 / math.sqrt(probes * (ea + eb))  # one factor for both: keeps F_B = omega F_A
            starts += [(qa * scale, None), (None, pb * scale)]
    finally:
        image.destroy()
        vec.destroy()
    return starts, count, int(fcoef.shape[0])


@profiling.logged("rsAFPacketSpread")
def energy_spread(A, dof: int, starts: list, times: np.ndarray, centre, positions: np.ndarray, box: np.ndarray,
                  lam_top: float, comm, tol: float = 1e-10) -> dict:
    """The exact spread of the energy of the starts ``starts`` = [(q0, pi0)] (this rank's rows of
    A's layout, (nloc,) each, either may be None) propagated together (energies added), at
    ``times`` (T,) in t0.  ``positions`` (n_loc_particles, D) of this rank's matrix particles, in
    d0; ``centre`` r_c (D,).  Returns arrays over the times: ``energy`` H(t), ``first`` (T, D) the
    energy-weighted mean minimum-image displacement from r_c, ``msd`` <|r - r_c|^2>, ``msd_rate``
    d<|r - r_c|^2>/dt exactly (module docstring), and ``terms`` (the largest Chebyshev series'
    length).  Collective on ``comm``."""
    from mpi4py import MPI

    times = np.asarray(times, dtype=float)
    fam = {name: i for i, name in enumerate(FAMILIES)}
    coef_all = chebyshev_coefficients(
        lambda lam: np.concatenate([family_values(name, lam, times) for name in FAMILIES], axis=1), lam_top, tol)
    T = times.size
    block = {name: coef_all[:, fam[name] * T:(fam[name] + 1) * T] for name in FAMILIES}
    # (q, pi, A q, A pi) of a start (q0, 0): (C, -W, LC, -LW) q0; of (0, pi0): (S, C, W, LC) pi0
    recipes = {"q": (("C", 1.0), ("W", -1.0), ("LC", 1.0), ("LW", -1.0)),
               "p": (("S", 1.0), ("C", 1.0), ("W", 1.0), ("LC", 1.0))}
    columns, coefs, kinds = [], [], []
    for q0, p0 in starts:
        for vec, kind in ((q0, "q"), (p0, "p")):
            if vec is not None:
                columns.append(vec)
                coefs.append(np.concatenate([sign * block[name] for name, sign in recipes[kind]], axis=1))
                kinds.append(kind)
    nloc = A.getLocalSize()[0]
    if not columns:
        raise ValueError("energy_spread needs at least one start vector")
    out = chebyshev_apply(A, np.stack(columns, axis=1).reshape(nloc, -1), coefs, lam_top)
    state = np.zeros((4, nloc, T))  # q, pi, A q, A pi of the sum of the columns of each start
    h = np.zeros((nloc, T))
    hdot = np.zeros((nloc, T))
    index = 0
    for q0, p0 in starts:  # a handful of starts
        state[...] = 0.0
        for vec in (q0, p0):
            if vec is not None:
                state += out[index].reshape(nloc, 4, T).transpose(1, 0, 2)
                index += 1
        q, p, aq, ap = state
        h += 0.5 * (p * p + q * aq)
        hdot += 0.5 * (q * ap - p * aq)
    count = nloc // dof
    h = h.reshape(count, dof, T).sum(axis=1)
    hdot = hdot.reshape(count, dof, T).sum(axis=1)
    delta = minimum_image(np.asarray(positions, dtype=float) - np.asarray(centre, dtype=float), box)  # (count, D)
    f = np.sum(delta**2, axis=1)
    dim = delta.shape[1]
    local = np.concatenate([h.sum(axis=0), (delta.T @ h).ravel(), f @ h, f @ hdot])
    sums = np.empty_like(local)
    comm.tompi4py().Allreduce(local, sums, op=MPI.SUM)
    energy = sums[:T]
    first = sums[T:T + dim * T].reshape(dim, T).T / energy[:, None]
    return {"energy": energy, "first": first, "msd": sums[T + dim * T:T + dim * T + T] / energy,
            "msd_rate": sums[T + dim * T + T:] / energy, "terms": coef_all.shape[0]}


def fit_diffusivity(times: np.ndarray, msd: np.ndarray, dim: int, window: tuple[float, float]
                    ) -> tuple[float, float, float, float]:
    """(d, error, d_first_half, d_second_half) in d0^2/t0: the slope / (2 ``dim``) of the least-squares
    line through ``msd`` (T,) over the samples with t in ``window``, and of the lines through its
    two halves; error the larger distance of the halves' from the whole's.  At least 4 samples in
    the window, else ValueError.  Not collective."""
    t_a, t_b = window
    inside = np.flatnonzero((times >= t_a) & (times <= t_b))
    if inside.size < 4:
        raise ValueError(f"the fit window {window} holds {inside.size} samples (at least 4 needed)")
    def slope(sel):
        return np.polyfit(times[sel], msd[sel], 1)[0] / (2 * dim)
    half = inside.size // 2
    d, d1, d2 = slope(inside), slope(inside[:half + 1]), slope(inside[half:])
    return float(d), float(max(abs(d1 - d), abs(d2 - d))), float(d1), float(d2)


def default_window(times: np.ndarray, msd: np.ndarray, saturation: float) -> tuple[float, float]:
    """[t_b / 2, t_b], t_b the last sample before <dr^2> first reaches SATURATION_FRACTION x
    ``saturation`` (the whole run if it never does).  Not collective."""
    over = np.flatnonzero(msd >= SATURATION_FRACTION * saturation)
    end = (over[0] - 1) if over.size else times.size - 1
    end = max(end, 0)
    return 0.5 * float(times[end]), float(times[end])


def spreading(dm, positions: np.ndarray, box: np.ndarray, *, band: tuple[float, float], centre, radius: float,
              times: np.ndarray, seed: int, comm, tol: float = 1e-10, probes: int = 1,
              window: tuple[float, float] | None = None) -> tuple[dict, dict]:
    """The spreading packet (module docstring): (datasets, attrs).  Collective on ``comm``, the
    matrix's communicator; every rank returns the same values, equal on 1 and 2 ranks to round-off.

    ``positions`` (N, D) d0 of every particle in the packing's order, ``box`` its periodic cell (a
    ``geometry.Cell``, or its (D,) sides);
    ``band`` = (lo, hi) 1/t0; ``centre`` (D,) and ``radius`` d0 the start region; ``times`` (T,)
    t0, ascending from >= 0; ``seed`` the start's random numbers; ``tol`` each Chebyshev series'
    truncation bound relative to its function's largest value; ``probes`` independent starts
    averaged; ``window`` (t_a, t_b) the fit window (default :func:`default_window`; d and its
    error are NaN when it holds fewer than 4 samples: no diffusive window).

    datasets: ``times`` (T,) t0; ``msd`` (T,) d0^2; ``msd_rate`` (T,) d0^2/t0 (exact derivative);
    ``local_d`` (T,) = msd_rate / (2 D), d0^2/t0; ``energy`` (T,) (1 at the start);
    ``centre_shift`` (T, D) d0, the packet's energy-weighted mean displacement from r_c.
    attrs: ``d``, ``d_error``, ``d_first_half``, ``d_second_half`` (d0^2/t0), ``window`` (t0),
    ``energy_drift`` (max |H(t) - H| / H, H = 1 exactly), ``terms`` (propagation series),
    ``filter_terms``, ``lam_top`` (1/t0^2), ``omega0``, ``sigma`` (1/t0), ``saturation``
    (sum L_a^2 / 12, or a tilted cell's edges' sum |a|^2 / 12, d0^2), ``r_c`` (d0; the start's
    energy-weighted centre, by the minimum image
    about ``centre``: the fixed centre of every <dr^2>), ``msd0`` (d0^2, the start's <dr^2> about
    r_c), ``start_particles`` (in the region), ``probes``,
    ``t_cross`` (the first sample where local_d reaches half of d: the end of the ballistic start)."""
    times = np.asarray(times, dtype=float)
    if times.ndim != 1 or times.size < 2 or np.any(np.diff(times) <= 0) or times[0] < 0:
        raise ValueError("times must be ascending, at least two, from >= 0")
    if not (radius > 0):
        raise ValueError(f"radius must be > 0, not {radius!r}")
    if int(probes) != probes or probes < 1:
        raise ValueError(f"probes must be a positive integer, not {probes!r}")
    if not dm.symmetric:
        raise ValueError("the spreading packet needs a symmetric dynamical matrix (not a stressed packing's)")
    omega0, sigma = band_centre_sigma(band)
    positions = np.asarray(positions, dtype=float)
    lam_top = (largest_omega(dm) * (1.0 + MARGIN)) ** 2
    A = scaled_operator(dm)
    try:
        pstart, pstop = _particle_range(A, dm.dof)
        mine = positions[dm.order[pstart:pstop]]
        starts, count, filter_terms = band_starts(A, dm, positions, box, band=band, centre=centre, radius=radius,
                                                  seed=seed, probes=probes, lam_top=lam_top, comm=comm, tol=tol)
        # r_c: the start's energy-weighted centre, from the start region's centre by the minimum image
        at0 = energy_spread(A, dm.dof, starts, np.zeros(1), np.asarray(centre, dtype=float), mine, box,
                            lam_top, comm, tol)
        r_c = np.asarray(centre, dtype=float) + at0["first"][0]
        spread = energy_spread(A, dm.dof, starts, np.concatenate([[0.0], times]), r_c, mine, box, lam_top, comm, tol)
        msd0 = float(spread["msd"][0])  # the start's, about r_c
        spread = {key: value[1:] if key != "terms" else value for key, value in spread.items()}
    finally:
        A.destroy()
    dim = dm.dim
    saturation = float(np.sum(Cell.of(box, dim).matrix ** 2) / 12.0)  # sum of the edges' |a|^2 / 12
    if window is None:
        window = default_window(times, spread["msd"], saturation)
    if np.count_nonzero((times >= window[0]) & (times <= window[1])) >= 4:
        d, error, d1, d2 = fit_diffusivity(times, spread["msd"], dim, window)
    else:  # no diffusive window (a box too small, or times too coarse): no fit, NaN
        d = error = d1 = d2 = math.nan
    local_d = spread["msd_rate"] / (2 * dim)
    reached = np.flatnonzero(local_d >= 0.5 * d)
    datasets = {"times": times, "msd": spread["msd"], "msd_rate": spread["msd_rate"], "local_d": local_d,
                "energy": spread["energy"], "centre_shift": spread["first"]}
    attrs = {"d": d, "d_error": error, "d_first_half": d1, "d_second_half": d2, "window": tuple(window),
             "energy_drift": float(np.max(np.abs(spread["energy"] - 1.0))), "terms": int(spread["terms"]),
             "filter_terms": filter_terms, "lam_top": lam_top, "omega0": omega0, "sigma": sigma,
             "saturation": saturation, "r_c": r_c,
             "msd0": msd0, "start_particles": count,
             "probes": probes, "t_cross": float(times[reached[0]]) if reached.size else math.nan}
    return datasets, attrs
