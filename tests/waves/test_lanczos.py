"""The spectral (Lanczos) path of standing waves, waves/spectral.py: its breakdown on an invariant
subspace (exact closed-form answer on the perfect crystal of test_crystal.py) and its Chebyshev-moment
evaluation when scipy's tridiagonal eigensolver fails."""

import numpy as np
import pytest
import scipy.linalg
from conftest import assert_all, assert_close, jammed_packing
from lattices import DIAMETER, L, N_X, N_Y, bloch_matrix, crystal

from solver.contact_law import ContactModel
from solver.model import dynmat
from solver.packing import jammed
from solver.waves import quadrature, spectral
from solver.waves.excitation import runs

AMPLITUDE = 1e-3
TIMES = np.arange(0.0, 60.0 + 1e-9, 0.25)


@pytest.fixture(scope="module")
def crystal_packing():
    return jammed.from_arrays(crystal(), np.full(N_X * N_Y, DIAMETER), L)


def crystal_wave(comm, packing, mode, p):
    """Lanczos z(t) of ``mode`` at k = 2 pi p / L along x on the crystal, and its closed form.

    u_x alone (L) is a Bloch eigenvector there (the mirror y -> -y decouples it from u_y and
    theta); u_y (TR) and theta (RT) span, with the other one, a 2-dimensional invariant subspace.
    So z(t) = z(0) sum_j |e_j[c]|^2 cos(omega_j t) over the eigenpairs (omega_j^2, e_j) of the (u_x)
    or (u_y, theta) block of the Bloch matrix, c the excited component, and
    z(0) = sum_i A sin(k x_i) exp(-i k x_i) = -i A N / 2 (x: a sum over whole periods).
    Returns (WaveSeries, expected z (S,), |z(0)|).
    """
    direction = [axis for _, axis in runs(mode, 2)].index(0)  # the direction with k along x
    component = runs(mode, 2)[direction][0]
    k = 2 * np.pi * p / L
    dm = dynmat.assemble(packing, ContactModel(1.0), comm)
    series = spectral.spectral(dm, packing.positions, mode, direction, k, amplitude=AMPLITUDE,
                               times=TIMES, tol=1e-10)
    dm.destroy()
    block = [0] if mode == "L" else [1, 2]
    matrix = bloch_matrix(np.array([k, 0.0]), 1.0)
    assert_all(np.abs(matrix[np.ix_(block, [c for c in range(3) if c not in block])]).max() < 1e-15,
               "the block is decoupled (the premise)")
    lam, vectors = np.linalg.eigh(matrix[np.ix_(block, block)])
    weights = np.abs(vectors[block.index(component)]) ** 2
    z0 = -0.5j * AMPLITUDE * N_X * N_Y
    return series, z0 * (weights @ np.cos(np.outer(np.sqrt(lam), TIMES))), abs(z0)


WAVES = [("L", 1, 1), ("L", 3, 1), ("TR", 2, 2), ("RT", 1, 2)]  # mode, p, invariant subspace dimension


@pytest.mark.parametrize("mode, p, invariant", WAVES)
def test_lanczos_on_an_invariant_subspace_gives_the_exact_cosines(comm, crystal_packing, mode, p, invariant):
    series, expected, z0 = crystal_wave(comm, crystal_packing, mode, p)
    # round-off of the start vector (the translation projected out, sin summed) and of the steps
    assert_close(series.z, expected, rtol=0.0, atol=1e-12 * z0, what=f"{mode}, p = {p}")


@pytest.mark.parametrize("mode, p, invariant", WAVES)
def test_lanczos_stops_at_the_invariant_subspace(comm, crystal_packing, mode, p, invariant):
    """RT, p = 1: |v| = 1.06e-14 after step 2 with alpha_2 = 1.13 and ||A|| = omega_max^2 = 24: a
    threshold relative to the last alpha (1e-14 max(|alpha|, 1), before) missed the breakdown on
    1 rank (187 steps) and caught it on 2; relative to ||A|| it is caught on any rank count."""
    series, _, _ = crystal_wave(comm, crystal_packing, mode, p)
    assert_all(series.steps == invariant and series.error_estimate == 0.0,
               f"{series.steps} Lanczos steps (invariant subspace of dimension {invariant}), "
               f"estimate {series.error_estimate}")


def test_chebyshev_moments_give_the_same_z_when_mrrr_fails(comm, monkeypatch):
    """eigh_tridiagonal (MRRR) can raise LinAlgError on the clustered Ritz values that loss of
    orthogonality makes; an open run's z then comes from Chebyshev moments of T (no eigenvectors).
    Forced to fail everywhere, the run must reach the same z to its tolerance (each run is within
    tol = 1e-10 of the converged z: 1e-9 of max |z| apart at most) and report its own estimate."""
    p = jammed_packing(64, 0.9, 31)
    k = 2 * np.pi * 2 / p.box_length
    dm = dynmat.assemble(p, ContactModel(1.0), comm)
    times = np.arange(0.0, 300.0 + 1e-9, 0.5)  # long enough for Ritz values to repeat
    reference = spectral.spectral(dm, p.positions, "RT", 0, k, amplitude=AMPLITUDE, times=times, tol=1e-10)
    calls = []

    original = scipy.linalg.eigh_tridiagonal

    def failing(*args, **kwargs):  # MRRR's eigenpairs fail; the bisection for T's ends does not
        if kwargs.get("eigvals_only"):
            return original(*args, **kwargs)
        calls.append(1)
        raise np.linalg.LinAlgError("forced by the test")

    monkeypatch.setattr(scipy.linalg, "eigh_tridiagonal", failing)
    fallback = spectral.spectral(dm, p.positions, "RT", 0, k, amplitude=AMPLITUDE, times=times, tol=1e-10)
    dm.destroy()
    # rank 0 evaluates z (and broadcasts it): only there is the solver called
    assert_all(comm.getRank() != 0 or len(calls) >= 2, f"the failing solver was called {len(calls)} times")
    assert_all(fallback.error_estimate < 1e-10, f"estimate {fallback.error_estimate}")
    scale = np.abs(reference.z).max()
    assert_close(fallback.z, reference.z, rtol=0.0, atol=1e-9 * scale, what="z from Chebyshev moments")


def test_chebyshev_moments_of_a_diagonal_t_are_its_cosines():
    """T diagonal (beta = 0): z = norm_a sum_j w_j [j = 0] cos(sqrt(alpha_0) t) = norm_a w_0
    cos(sqrt(alpha_0) t) exactly; with a coupled 2 x 2 T, the closed form over its two eigenpairs."""
    times = np.linspace(0.0, 50.0, 201)
    lam_max = 4.0
    alpha = np.array([2.5] + [1.0] * 149)  # degree 149: the series of cos(2 t) to t = 50 needs ~50
    z = spectral._z_chebyshev(alpha, np.zeros(149), np.r_[0.7 - 0.2j, np.ones(149)], 1.3, times, lam_max)
    assert_close(z, 1.3 * (0.7 - 0.2j) * np.cos(np.sqrt(2.5) * times), rtol=0.0, atol=1e-12, what="diagonal T")
    a, b = np.array([1.0, 2.0]), np.array([0.6])
    theta, S = np.linalg.eigh(np.diag(a) + np.diag(b, 1) + np.diag(b, -1))
    w = np.array([0.3, -1.1])
    expected = ((w @ S) * S[0]) @ np.cos(np.outer(np.sqrt(theta), times))
    # degree m - 1 = 1 is not enough for cos on [0, 4] to t = 50: pad T with uncoupled rows far
    # enough that the series converges (the moments of the padding are zero: w is zero there)
    pad = 120
    alpha2 = np.r_[a, np.full(pad, 3.0)]
    beta2 = np.r_[b, np.zeros(pad)]
    z2 = spectral._z_chebyshev(alpha2, beta2, np.r_[w, np.zeros(pad)], 1.0, times, lam_max)
    assert_close(z2, expected, rtol=0.0, atol=1e-12, what="2 x 2 T")
    # an omega_max^2 below T's top Ritz value (3.0) widens the interval to it: the same z
    z3 = spectral._z_chebyshev(alpha2, beta2, np.r_[w, np.zeros(pad)], 1.0, times, 2.0)
    assert_close(z3, expected, rtol=0.0, atol=1e-12, what="2 x 2 T, lam_max below its spectrum")


def test_chebyshev_moments_follow_a_negative_ritz_value_as_cosh():
    """A T with a negative eigenvalue (-2e-4: a marginal packing's negative curvature; m = 150,
    its spectrum in [-2e-4, 4.2]): z from the Chebyshev path equals the dense eigenpairs' sum with
    cos(sqrt(theta) t) continued as cosh(sqrt(-theta) t), to 1e-10 of max |z| (rtol 0), where the
    interval [0, lam_max] alone made the moments grow; the MRRR path (``_z_and_estimate``) gives the
    same function.  To t = 100 (growth e^1.41) it is refused: the packing is not at a minimum."""
    rng = np.random.default_rng(5)
    m = 150
    alpha, beta = rng.uniform(1.0, 3.0, m), rng.uniform(0.1, 0.5, m - 1)
    theta, S = np.linalg.eigh(np.diag(alpha) + np.diag(beta, 1) + np.diag(beta, -1))
    alpha = alpha - theta[0] - 2e-4  # shift: the lowest eigenvalue is now -2e-4
    theta = theta - theta[0] - 2e-4
    w = rng.standard_normal(m) + 1j * rng.standard_normal(m)
    times = np.linspace(0.0, 30.0, 121)  # sqrt(4.2) 30 / 2 = 31 << m: the series has converged
    expected = ((w @ S) * S[0]) @ (np.where(theta[:, None] >= 0, np.cos(np.outer(np.sqrt(np.abs(theta)), times)),
                                            np.cosh(np.outer(np.sqrt(np.abs(theta)), times))))
    scale = np.abs(expected).max()
    z = spectral._z_chebyshev(alpha, beta, w, 1.0, times, theta[-1])
    assert_close(z, expected, rtol=0.0, atol=1e-10 * scale, what="Chebyshev z with a negative Ritz value")
    mrrr, _ = spectral._z_and_estimate(alpha, beta, w, 1.0, times, m, False, theta[-1])
    assert_close(mrrr, expected, rtol=0.0, atol=1e-10 * scale, what="MRRR z with a negative Ritz value")
    # the same T to t = 100: sqrt(2e-4) 100 = 1.41 > 1, refused on both paths, naming the remedy
    for call in (lambda t: spectral._z_and_estimate(alpha, beta, w, 1.0, t, m, False, theta[-1]),
                 lambda t: quadrature.gauss_correlation(alpha, beta, t)):
        with pytest.raises(RuntimeError, match="negative curvature.*force_tol"):
            call(np.linspace(0.0, 100.0, 11))


def test_a_batch_of_waves_closing_at_different_steps_gives_each_its_exact_cosines(comm, crystal_packing):
    """The four crystal waves in one spectral_all: their Krylov spaces close after 1 or 2 steps
    while the others go on, so a closed wave must stay closed (zero vector, exact z, estimate 0)."""
    closed_forms = [crystal_wave(comm, crystal_packing, mode, p)[1:] for mode, p, _ in WAVES]
    dm = dynmat.assemble(crystal_packing, ContactModel(1.0), comm)
    waves = [(mode, [axis for _, axis in runs(mode, 2)].index(0), 2 * np.pi * p / L) for mode, p, _ in WAVES]
    batch = spectral.spectral_all(dm, crystal_packing.positions, waves, amplitude=AMPLITUDE, times=TIMES, tol=1e-10)
    dm.destroy()
    for series, (expected, z0), (mode, p, invariant) in zip(batch, closed_forms, WAVES):
        assert_close(series.z, expected, rtol=0.0, atol=1e-12 * z0, what=f"{mode}, p = {p} in the batch")
        assert_all(series.steps == invariant and series.error_estimate == 0.0, f"{mode}, p = {p}: {series.steps}")


def test_a_batch_of_waves_is_each_wave_alone(comm):
    """spectral_all over mixed modes, runs and k (more than one chunk of spectral.BATCH) against
    spectral of each wave alone on a jammed packing (no invariant subspace): a chunk takes as many
    steps as its slowest wave, so each
    agrees with its lone run to the tolerance both reach, not to round-off."""
    p = jammed_packing(256, 0.9, 12)
    dm = dynmat.assemble(p, ContactModel(1.0), comm)
    k = 2 * np.pi / p.box_length
    waves = [("L", 0, k), ("TR", 1, 3 * k), ("RT", 0, 2 * k), ("RT", 1, 5 * k), ("L", 1, 4 * k), ("TR", 0, k)]
    assert len(waves) > spectral.BATCH, "the waves must span more than one chunk"
    tol = 1e-9
    batch = spectral.spectral_all(dm, p.positions, waves, amplitude=AMPLITUDE, times=TIMES, tol=tol)
    alone = [spectral.spectral(dm, p.positions, *wave, amplitude=AMPLITUDE, times=TIMES, tol=tol) for wave in waves]
    dm.destroy()
    for wave, one, single in zip(waves, batch, alone):
        scale = np.abs(single.z).max()
        assert_all(one.error_estimate < tol and one.steps >= single.steps, f"{wave}: {one.steps} vs {single.steps}")
        # both within their estimate (< tol relative) of the same exact z
        assert_close(one.z, single.z, rtol=0.0, atol=2 * tol * scale, what=f"{wave} batch vs alone")
        assert_close(one.energy, single.energy, rtol=1e-14, what=f"{wave} energy")
