"""The lattice model of the TR and RT branches and its band edges, written once.

numpy only.  Units: omega in 1/t0, k in 1/d0, l in d0; a_t, a_r in 1/t0.

Paper's eq:omega_t(k) and eq:omega_r(k) with eq:f(k) and eq:g(k) (PHYSICS.md section 6):
    omega_t = a_t sqrt(f - sqrt(g)),   omega_r = a_r sqrt(f + sqrt(g)),
    f = 2 sin^2(kl) + 9 rho cos^2(kl) + 11 rho,
    g = 4 sin^4(kl) + rho (399 rho - 4) cos^2(kl) - rho (121 rho / 4 + 21) sin^2(2 kl) + rho (rho + 4).
The paper's eq:g(k) prints 300 for the coefficient 399: only 399 gives the limits the paper itself
states, omega_t(0) = 0 and omega_r(0) = a_r sqrt(40 rho) (at k = 0, f^2 - g = (399 - X) rho^2).

Band edges (the paper's section "Frequency-band of the RT mode", fig:band_RT), with the first
Brillouin zone |kl| <= pi/2, so k_max = pi / (2 l):
    omega_r(0)     = a_r sqrt(40 rho),
    omega_r(k_max) = 2 a_r sqrt(3 rho + 1),
    omega_t(k_max) = a_t sqrt(10 rho);
omega_r(0) = omega_r(k_max) at rho = 1/7.  The zone-edge values do not involve the coefficient 399.
"""

from __future__ import annotations

import numpy as np

G_COEFFICIENT = 399.0  # the paper's eq:g(k) prints 300: a misprint (see module docstring)
RHO_CROSSING = 1.0 / 7.0  # omega_r(0) = omega_r(k_max) here


def lattice_fg(k, rho, l):
    """f(k, rho) and g(k, rho) of eq:f(k) and eq:g(k) (arrays broadcast). Not collective."""
    s, c = np.sin(k * l), np.cos(k * l)
    f = 2 * s**2 + 9 * rho * c**2 + 11 * rho
    g = (4 * s**4 + rho * (G_COEFFICIENT * rho - 4) * c**2
         - rho * (121 * rho / 4 + 21) * np.sin(2 * k * l) ** 2 + rho * (rho + 4))
    return f, g


def lattice_omega(k, rho, l, a_t, a_r):
    """(omega_t, omega_r) of eq:omega_t(k) and eq:omega_r(k) at wave numbers k (1/d0)."""
    f, g = lattice_fg(k, rho, l)
    root = np.sqrt(np.clip(g, 0.0, None))
    return a_t * np.sqrt(np.clip(f - root, 0.0, None)), a_r * np.sqrt(f + root)


def k_max(l):
    """Edge of the first Brillouin zone, pi / (2 l) (1/d0)."""
    return np.pi / (2 * l)


def omega_r_zero(rho, a_r):
    """omega_r(0) = a_r sqrt(40 rho): the RT branch at k = 0 (fig:band_RT, solid line)."""
    return a_r * np.sqrt(40 * np.asarray(rho, float))


def omega_r_kmax(rho, a_r):
    """omega_r(k_max) = 2 a_r sqrt(3 rho + 1): the RT branch at the zone edge (fig:band_RT, dotted)."""
    return 2 * a_r * np.sqrt(3 * np.asarray(rho, float) + 1)


def omega_t_kmax(rho, a_t):
    """omega_t(k_max) = a_t sqrt(10 rho): the TR branch at the zone edge (fig:band_RT, dashed)."""
    return a_t * np.sqrt(10 * np.asarray(rho, float))


def edge_a_t(params: dict) -> float:
    """The a_t to draw the acoustic branch with at short waves: ``a_t_edge`` (fitted to the RT
    frequencies beyond k_c) when the run found one, else the long-wave TR value ``a_t``
    (PHYSICS.md section 6: one a_t cannot fit both).  ``params``: the ``analysis/lattice`` attributes."""
    edge = float(params.get("a_t_edge", np.nan))
    return edge if np.isfinite(edge) else float(params["a_t"])
