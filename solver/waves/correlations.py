"""Normalised velocity autocorrelations and power spectra from sampled Fourier components.

The waves stage's own observables, computed when a waves unit is made (``waves.unit``) and read
again by the analysis and the figures.  numpy only (no PETSc).  For runs r (directions x
configurations) of one (rho, mode, k):
    C(k, t) = Re sum_r z_r(t) conj(z_r(0)) / sum_r |z_r(0)|^2          (paper's C_l, C_t, C_r)
    S(k, w) = sum_r |T_w[z_r](w)|^2 / sum_r |z_r(0)|^2,   T_w[z](w) = int_0^T z(t) e^{i w t} dt
The transform is a rectangle-rule sum over the samples (no window, as the paper defines S),
zero-padded to ``pad`` times the record so the omega grid is 2 pi / (pad T); the resolution is
still 2 pi / T.  S is normalised by <|z(0)|^2>, so it has units of t0^2 and comparable scale
across k.  Only omega >= 0 is kept.

A record cut at T while z still rings leaks: S of a tone is the sinc^2 of the cut, whose zeros,
2 pi / T apart, stripe a map of log S.  With ``taper`` (the figures' choice; the stored S and the
fits keep the paper's S) z is first multiplied by the falling half of a Hann window,
cos^2(pi t / 2T): 1 at t = 0, where the one-sided transform starts, and 0 with a zero slope at T.
Then a tone's S has no zeros: |T_w[e^{-i w0 t}]| lies between 1/|dw| and |dw|/(dw^2 - b^2) for
|dw| = |w - w0| > b = pi / T, the smooth 1/dw^2 tail of its start at t = 0.
"""

from __future__ import annotations

import numpy as np


def vaf(z: np.ndarray) -> np.ndarray:
    """C(t) (S,) from runs z (R, S) complex, averaged over the runs (numerator and denominator)."""
    z = np.atleast_2d(z)
    return np.real(np.sum(z * np.conj(z[:, :1]), axis=0)) / np.sum(np.abs(z[:, 0]) ** 2)


def power_spectrum(z: np.ndarray, dt_sample: float, pad: int = 4, taper: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(omega (W,), S (W,)) from runs z (R, S) sampled every ``dt_sample``; omega >= 0; ``taper``:
    z times cos^2(pi t / 2T) first (module docstring)."""
    z = np.atleast_2d(z)
    n = z.shape[1]
    if taper:
        z = z * np.cos(0.5 * np.pi * np.arange(n) / max(n - 1, 1)) ** 2
    size = pad * n
    # int z(t) e^{+i w t} dt  ->  size * ifft  (numpy's ifft has e^{+i...}/size)
    transform = np.fft.ifft(z, n=size, axis=1) * size * dt_sample
    omega = 2 * np.pi * np.fft.fftfreq(size, d=dt_sample)
    keep = omega >= 0
    power = np.sum(np.abs(transform[:, keep]) ** 2, axis=0) / np.sum(np.abs(z[:, 0]) ** 2)
    return omega[keep], power


def pooled(z: np.ndarray, dt_sample: float, pad: int = 4, taper: bool = False
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """C (K, S), omega (W,) and S (K, W) of runs z (R, K, S) pooled per wave number.

    The one place where a set of runs (directions x configurations) of one (rho, mode) becomes
    the paper's C_alpha(k, t) and S_alpha(k, omega); the units, the analysis and the figures
    (these with ``taper``, :func:`power_spectrum`) all call it.
    """
    z = np.asarray(z)
    c = np.array([vaf(z[:, i]) for i in range(z.shape[1])])
    spectra = [power_spectrum(z[:, i], dt_sample, pad, taper) for i in range(z.shape[1])]
    return c, spectra[0][0], np.array([s for _, s in spectra])
