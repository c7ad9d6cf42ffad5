"""Capillary bridges: the pull of a liquid bridge between two particles, its energy and its
stiffness, as a function of the gap s = r_ij - (R_i + R_j) (docs/capillary_bridges.md).

Two closed forms, as the codes that implement them define them:

``willett``  Willett, Adams, Johnson & Seville, Langmuir 16, 9396 (2000), in MercuryDPM's
             ``LiquidBridgeWilletInteraction`` form: F0 = 2 pi a' gamma cos(theta) while the
             particles touch (s <= 0), F0 / (1 + 1.05 S + 2.5 S^2) with S = s sqrt(a' / V) across
             the gap, a' = R_i R_j / (R_i + R_j).
``soulie``   Soulie et al., Int. J. Numer. Anal. Meth. Geomech. 30, 213 (2006), eqs. 13-14, as
             LIGGGHTS 3.8.0's ``cohesion easo/capillary/viscous`` evaluates it: pi gamma
             sqrt(R_i R_j) (exp(A s / R2 + B) + C), R2 = max(R_i, R_j), with A, B, C from
             V* = V / R2^3 and the angle theta_e = theta^2 / 2 (LIGGGHTS takes 0.5 theta_i theta_j
             for Soulie's theta: a quirk kept so that LIGGGHTS referees it; at theta = 0 it is moot).

A bridge forms when the particles touch and breaks at the rupture distance s_c = (1 + theta_e/2)
V^(1/3) (Lian, Thornton & Adams 1993; theta_e = theta for willett): beyond it the pull is zero.
The bridge volume V is either given (``Cohesion.volume``, d0^3, every bridge alike) or, as in
LIGGGHTS, made of the liquid each particle carries (``Cohesion.liquid_content`` c, a fraction of
the particle's volume 4/3 pi R^3, in 2D as in 3D): each particle gives its share
c (4/3) pi R_i^3 (1 - sqrt(1 - R_j^2 / (R_i + R_j)^2)) / 2 to the bridge.

Units m = d0 = kn = 1: the surface tension gamma is in kn (harmonic law: force per length over
kn, dimensionless; docs/capillary_bridges.md converts from SI).  The pull F >= 0 acts along the
line of centres, towards the other particle.  Every function is vectorised over C pairs (arrays
(C,)) and not collective.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

COHESION_LAWS = ("willett", "soulie")

# Willett's closed form F0 / (1 + b S + a S^2) (MercuryDPM's coefficients) and the discriminant
# 4 a - b^2 > 0 of its denominator, which makes the energy an arctangent.
_WILLETT_B, _WILLETT_A = 1.05, 2.5
_WILLETT_ROOT = np.sqrt(4.0 * _WILLETT_A - _WILLETT_B**2)


@dataclass(frozen=True)
class Cohesion:
    """The liquid bridges of a wet packing (docs/capillary_bridges.md).

    law : ``willett`` or ``soulie`` (module docstring);  surface_tension : gamma > 0 (kn);
    contact_angle : theta in [0, pi/2) (radians);  volume : V > 0 of every bridge (d0^3), or 0 when
    ``liquid_content`` gives it;  liquid_content : c > 0, LIGGGHTS's surface liquid content (a
    fraction of each particle's volume), or 0 when ``volume`` gives it.  Exactly one of the two.
    """

    law: str = "willett"
    surface_tension: float = 0.0
    contact_angle: float = 0.0
    volume: float = 0.0
    liquid_content: float = 0.0

    def __post_init__(self):
        if self.law not in COHESION_LAWS:
            raise ValueError(f"cohesion law {self.law!r}: allowed are {', '.join(COHESION_LAWS)}")
        for name in ("surface_tension", "contact_angle", "volume", "liquid_content"):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"cohesion {name} = {value}: must be finite and >= 0")
        if self.surface_tension <= 0:
            raise ValueError(f"cohesion surface_tension = {self.surface_tension}: must be > 0")
        if not self.contact_angle < 0.5 * np.pi:
            raise ValueError(f"cohesion contact_angle = {self.contact_angle}: must be in [0, pi/2) (radians)")
        if (self.volume > 0) == (self.liquid_content > 0):
            raise ValueError("cohesion: give exactly one of volume (of every bridge, d0^3) and liquid_content "
                             f"(a fraction of each particle's volume); got volume = {self.volume}, "
                             f"liquid_content = {self.liquid_content}")

    @property
    def effective_angle(self) -> float:
        """theta_e (rad): theta for willett; theta^2 / 2 for soulie, as LIGGGHTS computes it."""
        return self.contact_angle if self.law == "willett" else 0.5 * self.contact_angle**2


def bridge_volume(radius_i: np.ndarray, radius_j: np.ndarray, cohesion: Cohesion) -> np.ndarray:
    """V (C,) of the bridges between particles of radii R_i, R_j (d0^3): ``cohesion.volume``, or
    the two particles' shares of their liquid (module docstring)."""
    if cohesion.volume > 0:
        return np.full(np.shape(radius_i), cohesion.volume)
    total = radius_i + radius_j

    def share(own, other):
        return 0.5 * cohesion.liquid_content * (4.0 / 3.0) * np.pi * own**3 * (1.0 - np.sqrt(1.0 - (other / total) ** 2))

    return share(radius_i, radius_j) + share(radius_j, radius_i)


def rupture_distance(radius_i: np.ndarray, radius_j: np.ndarray, cohesion: Cohesion) -> np.ndarray:
    """s_c = (1 + theta_e / 2) V^(1/3) (C,) (d0): the gap at which a bridge breaks."""
    return (1.0 + 0.5 * cohesion.effective_angle) * np.cbrt(bridge_volume(radius_i, radius_j, cohesion))


def _law_terms(radius_i, radius_j, cohesion):
    """What each law needs per pair: willett (F0, 1/length S = s k: k), soulie (F_scale, A/R2, B, C)."""
    volume = bridge_volume(radius_i, radius_j, cohesion)
    gamma, theta = cohesion.surface_tension, cohesion.contact_angle
    if cohesion.law == "willett":
        reduced = radius_i * radius_j / (radius_i + radius_j)
        return 2.0 * np.pi * reduced * gamma * np.cos(theta), np.sqrt(reduced / volume)
    big = np.maximum(radius_i, radius_j)
    log_v = np.log(volume / big**3)
    theta_e = cohesion.effective_angle
    a = -1.1 * (volume / big**3) ** -0.53
    b = (-0.148 * log_v - 0.96) * theta_e**2 - 0.0082 * log_v + 0.48
    c = 0.0018 * log_v + 0.078
    return np.pi * gamma * np.sqrt(radius_i * radius_j), a / big, b, c


def bridge_force(gap: np.ndarray, radius_i: np.ndarray, radius_j: np.ndarray, cohesion: Cohesion) -> np.ndarray:
    """The pull F >= 0 (C,) of bridges at gaps s (C,) (d0; s <= 0: touching): constant while the
    particles touch, falling across the gap, 0 from the rupture distance on."""
    s = np.maximum(gap, 0.0)
    if cohesion.law == "willett":
        f0, k = _law_terms(radius_i, radius_j, cohesion)
        pull = f0 / (1.0 + (_WILLETT_B + _WILLETT_A * k * s) * k * s)
    else:
        scale, slope, b, c = _law_terms(radius_i, radius_j, cohesion)
        pull = scale * (np.exp(slope * s + b) + c)
    return np.where(gap < rupture_distance(radius_i, radius_j, cohesion), pull, 0.0)


def bridge_stiffness(gap: np.ndarray, radius_i: np.ndarray, radius_j: np.ndarray, cohesion: Cohesion) -> np.ndarray:
    """dF/ds (C,) (kn): 0 while touching and beyond rupture, negative across the gap (the pull
    weakens as the gap opens)."""
    s = np.maximum(gap, 0.0)
    if cohesion.law == "willett":
        f0, k = _law_terms(radius_i, radius_j, cohesion)
        x = k * s
        slope = -f0 * k * (_WILLETT_B + 2.0 * _WILLETT_A * x) / (1.0 + (_WILLETT_B + _WILLETT_A * x) * x) ** 2
    else:
        scale, rate, b, _ = _law_terms(radius_i, radius_j, cohesion)
        slope = scale * rate * np.exp(rate * s + b)
    return np.where((gap > 0) & (gap < rupture_distance(radius_i, radius_j, cohesion)), slope, 0.0)


def bridge_energy(gap: np.ndarray, radius_i: np.ndarray, radius_j: np.ndarray, cohesion: Cohesion) -> np.ndarray:
    """W(s) = integral of F from 0 to s (C,) (kn d0^2): the work done against the pull in opening
    the gap from touching to s; F0 s while touching (s < 0), W(s_c) beyond rupture (the bridge's
    energy is lost when it breaks)."""
    s_c = rupture_distance(radius_i, radius_j, cohesion)
    s = np.clip(gap, 0.0, s_c)
    if cohesion.law == "willett":
        f0, k = _law_terms(radius_i, radius_j, cohesion)
        angle = np.arctan((2.0 * _WILLETT_A * k * s + _WILLETT_B) / _WILLETT_ROOT) - np.arctan(_WILLETT_B / _WILLETT_ROOT)
        opened = f0 / k * 2.0 / _WILLETT_ROOT * angle
    else:
        scale, rate, b, c = _law_terms(radius_i, radius_j, cohesion)
        f0 = scale * (np.exp(b) + c)
        opened = scale * (np.exp(b) * np.expm1(rate * s) / rate + c * s)
    return np.where(gap < 0, f0 * np.minimum(gap, 0.0), opened)
