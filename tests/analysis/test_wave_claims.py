"""The report's wave claims (analysis/claims.py) fed known analysis values: each claim PASSes just
inside its tolerance edge and FAILs just beyond it (or when what it asks for is absent)."""

import numpy as np
import pytest

from solver.analysis import claims
from solver.analysis import lattice

pytestmark = pytest.mark.serial_only  # pure numpy

EDGE = 1e-9     # relative step inside / beyond a tolerance edge
A_R, L_MODEL, A_T, A_T_EDGE = 0.73, 0.446, 0.55, 0.66
K = np.linspace(0.1, 3.4, 24)
KC = {0.2: 0.5 * (K[10] + K[11]), 0.5: 0.5 * (K[14] + K[15])}  # RT leaves the optical branch here
BAND_RHO = np.array([0.2, 0.5, 1.0, 2.0])


AT = int(np.argmin(np.abs(K - 0.38 * np.pi)))  # the paper's k d0 = 0.38 pi, where Fig. 2 compares


def wave_fit(omega, gamma, **attrs):
    omega = np.full(K.size, omega) if np.isscalar(omega) else np.asarray(omega, float)
    return {"k": K.copy(), "omega": omega, "gamma": np.full(K.size, gamma), "c": omega / K,
            "omega_lorentz": np.full(K.size, np.nan), **attrs}


def at_paper_k(value, elsewhere):
    """(K,) holding ``value`` at the paper's k and ``elsewhere`` at every other k."""
    out = np.full(K.size, elsewhere, dtype=float)
    out[AT] = value
    return out


def baseline() -> claims.Data:
    """Analysis values for which every wave claim passes with room to spare."""
    d = claims.Data()
    power = {"power_law_p_err": 0.1, "power_law_points": 6}
    d.fits = {
        (0.0, "L"): wave_fit(at_paper_k(0.8, 5.0), 0.05, power_law_p=2.0, **power),
        (0.0, "TR"): wave_fit(at_paper_k(0.5, 4.0), 0.06, power_law_p=2.0, **power),
        (1.0, "L"): wave_fit(at_paper_k(1.0, 0.1), 0.01, power_law_p=3.0, **power),
        (1.0, "TR"): wave_fit(at_paper_k(0.6, 0.01), 0.02, power_law_p=3.0, **power),
        (1.0, "RT"): wave_fit(at_paper_k(3.0, 0.1), 0.1, k_c=np.nan),
        (2.0, "RT"): wave_fit(lattice.lattice_omega(K, 2.0, L_MODEL, 1.0, A_R)[1], 0.1, k_c=np.nan),
        (0.5, "RT"): wave_fit(2.0, 0.1, k_c=KC[0.5]),
        (0.2, "RT"): wave_fit(1.0, 0.1, k_c=KC[0.2]),
    }
    d.fits[(0.2, "RT")]["omega_lorentz"] = np.where(K < KC[0.2], 1.5, 1.2)  # the gap 1.2-1.5 at k_c
    d.lattice = {"a_r": A_R, "a_r_err": 0.01, "l": L_MODEL, "l_err": 0.005, "a_t": A_T, "a_t_edge": A_T_EDGE}
    r0 = lattice.omega_r_zero(BAND_RHO, A_R)
    rk = np.where(BAND_RHO < 1, lattice.omega_t_kmax(BAND_RHO, A_T_EDGE), lattice.omega_r_kmax(BAND_RHO, A_R))
    rk[BAND_RHO == 1.0] = 2.6  # near the paper's 2.5; closer to the optical branch (2.92) than
    # to the acoustic one (2.09): the rho < 1 claims must leave rho = 1 out
    d.bands = {"rho": BAND_RHO.copy(), "omega_r0": r0, "omega_r_kmax": rk,
               "omega_t_kmax": lattice.omega_t_kmax(BAND_RHO, A_T), "omega_c": 1.1 * r0,
               "k_large": np.full(BAND_RHO.size, 3.4), "k_small": np.full(BAND_RHO.size, 0.1)}
    edges = np.linspace(0, 8, 161)
    d.vdos = {float(r): (edges, np.exp(-((edges[:-1] - 2.3) ** 2)), 1.1 * w, 0.01, 2)
              for r, w in zip(BAND_RHO, r0)}
    return d


def status(d, prefix):
    rows = [r for r in claims.claims(d) if r.claim.startswith(prefix)]
    assert len(rows) == 1, f"{len(rows)} claims start with {prefix!r}"
    return rows[0].status


def band(d, key, rho):
    return d.bands[key], int(np.flatnonzero(d.bands["rho"] == rho)[0])


def set_band(d, key, rho, value):
    values, i = band(d, key, rho)
    values[i] = value


def scale_fit(d, key, field, factor):
    d.fits[key][field] = d.fits[key][field] * factor


def beyond(limit, side):
    """A value just inside (side = -1) or just beyond (side = +1) ``limit`` > 0 from below."""
    return limit * (1 + side * EDGE)


def at_k(value):
    return at_paper_k(value, np.nan)  # only the paper's k may matter


# (claim prefix, change of the baseline as a function of side = -1 (inside) / +1 (beyond))
WAVE_CLAIMS = [
    ("RT oscillates much faster", lambda d, s: d.fits[(1.0, "RT")].update(
        omega=at_k(2 * 1.0 * (1 - s * EDGE)))),                          # omega_r > 2 max(omega_l, omega_t)
    ("RT decays faster", lambda d, s: d.fits[(1.0, "RT")].update(
        gamma=at_k(0.02 * (1 - s * EDGE)))),                             # gamma_r > max(gamma_l, gamma_t)
    ("L faster than TR", lambda d, s: d.fits[(1.0, "TR")].update(omega=at_k(beyond(1.0, s)))),
    ("Friction makes L and TR oscillate faster", lambda d, s: d.fits[(0.0, "TR")].update(
        omega=at_k(beyond(0.6, s)))),
    ("Friction makes L and TR decay more weakly", lambda d, s: d.fits[(0.0, "L")].update(
        gamma=at_k(0.01 * (1 - s * EDGE)))),
    ("RT band at rho = 1 (Fig. 3c)", lambda d, s: set_band(d, "omega_r_kmax", 1.0, 2.5 + beyond(0.25, s))),
    ("RT band at rho = 1 (Fig. 3c)", lambda d, s: set_band(d, "omega_r_kmax", 1.0, 2.5 - beyond(0.25, s))),
    ("RT band at rho = 1 (Fig. 3c)", lambda d, s: set_band(d, "omega_r0", 1.0, 4.7 + beyond(0.25, s))),
    ("RT band at rho = 1 (Fig. 3c)", lambda d, s: set_band(d, "omega_r0", 1.0, 4.7 - beyond(0.25, s))),
    ("Lattice model a_r", lambda d, s: d.lattice.update(a_r=0.73 - beyond(0.0365, s))),
    ("Lattice model a_r", lambda d, s: d.lattice.update(a_r=0.73 + beyond(0.0365, s))),
    ("Lattice model l", lambda d, s: d.lattice.update(l=0.446 + beyond(0.0223, s))),
    ("Lattice model l", lambda d, s: d.lattice.update(l=0.446 - beyond(0.0223, s))),
    ("rho > 1: RT follows the model", lambda d, s: scale_fit(d, (2.0, "RT"), "omega", 1 + beyond(0.10, s))),
    ("Gap at k_c in the RT branch", lambda d, s: d.fits[(0.2, "RT")].update(
        omega_lorentz=np.where(K < KC[0.2], 1.5 - beyond(0.15, s), 1.2))),
    ("Gap at k_c in the RT branch", lambda d, s: d.fits[(0.2, "RT")].update(
        omega_lorentz=np.where(K < KC[0.2], 1.5 + beyond(0.15, s), 1.2))),
    ("Gap at k_c in the RT branch", lambda d, s: d.fits[(0.2, "RT")].update(
        omega_lorentz=np.where(K < KC[0.2], 1.5, 1.2 + beyond(0.15, s)))),
    ("Gap at k_c in the RT branch", lambda d, s: d.fits[(0.2, "RT")].update(
        omega_lorentz=np.where(K < KC[0.2], 1.5, 1.2 - beyond(0.15, s)))),
    ("omega_r(0) follows a_r sqrt(40 rho)", lambda d, s: set_band(
        d, "omega_r0", 0.5, lattice.omega_r_zero(0.5, A_R) * (1 + beyond(0.05, s)))),
    ("rho > 1: omega_r(k_max) follows", lambda d, s: set_band(
        d, "omega_r_kmax", 2.0, lattice.omega_r_kmax(2.0, A_R) * (1 - beyond(0.10, s)))),
    ("rho < 1: omega_r(k_max) switches", lambda d, s: set_band(   # closer to the acoustic branch
        d, "omega_r_kmax", 0.5, 0.5 * (lattice.omega_t_kmax(0.5, A_T_EDGE) + lattice.omega_r_kmax(0.5, A_R))
        + s * EDGE)),
    ("Band limits not reversed", lambda d, s: set_band(
        d, "omega_r_kmax", 2.0, lattice.omega_r_zero(2.0, A_R) * (1 + s * EDGE))),
    ("omega_c slightly above omega_r(0)", lambda d, s: d.vdos.update(
        {1.0: (*d.vdos[1.0][:2], 1.25 * (1 + s * EDGE) * lattice.omega_r_zero(1.0, A_R), 0.01, 2)})),
    ("omega_c slightly above omega_r(0)", lambda d, s: d.vdos.update(
        {1.0: (*d.vdos[1.0][:2], (1 - s * EDGE) * lattice.omega_r_zero(1.0, A_R), 0.01, 2)})),
    ("Rayleigh attenuation gamma_l", lambda d, s: d.fits[(1.0, "L")].update(power_law_p=3 + beyond(0.5, s))),
    ("Rayleigh attenuation gamma_t", lambda d, s: d.fits[(1.0, "TR")].update(power_law_p=3 - beyond(0.5, s))),
    ("Frictionless gamma_l is not", lambda d, s: d.fits[(0.0, "L")].update(power_law_p=3 - beyond(0.5, -s))),
    ("Frictionless gamma_t is not", lambda d, s: d.fits[(0.0, "TR")].update(power_law_p=3 + beyond(0.5, -s))),
    ("Longitudinal sound faster", lambda d, s: d.fits[(1.0, "TR")].update(
        c=d.fits[(1.0, "L")]["c"] * (1 + s * EDGE))),
]
PREFIXES = sorted({prefix for prefix, _ in WAVE_CLAIMS})


def test_every_wave_claim_passes_on_the_baseline():
    d = baseline()
    rows = claims.claims(d)
    waves = [r for r in rows if r.claim.startswith((*PREFIXES, "rho < 1: k_c exists"))]
    assert len(waves) == len(PREFIXES) + 1, [r.claim for r in waves]
    failing = [(r.claim, r.measured) for r in waves if r.status != "PASS"]
    assert not failing, failing


@pytest.mark.parametrize("case", range(len(WAVE_CLAIMS)), ids=[f"{i}-{p[:28]}" for i, (p, _) in enumerate(WAVE_CLAIMS)])
def test_wave_claim_flips_at_its_tolerance_edge(case):
    prefix, change = WAVE_CLAIMS[case]
    outcomes = {}
    for side, expected in ((-1, "PASS"), (+1, "FAIL")):
        d = baseline()
        change(d, side)
        outcomes[expected] = status(d, prefix)
    assert outcomes == {"PASS": "PASS", "FAIL": "FAIL"}, f"{prefix}: inside -> {outcomes['PASS']}, " \
                                                         f"beyond -> {outcomes['FAIL']}"


def test_k_c_claim_needs_two_contiguous_non_decreasing_transitions():
    prefix = "rho < 1: k_c exists"
    d = baseline()
    d.fits[(0.5, "RT")]["k_c"] = KC[0.2]  # equal: non-decreasing still
    assert status(d, prefix) == "PASS"
    d.fits[(0.5, "RT")]["k_c"] = KC[0.2] * (1 - EDGE)  # k_c grows as rho decreases
    assert status(d, prefix) == "FAIL"
    d = baseline()
    d.fits[(0.2, "RT")]["k_c"] = np.nan  # found only for 0.5, not from the smallest rho up
    assert status(d, prefix) == "FAIL"


def test_claims_fail_when_what_they_ask_for_is_missing():
    d = baseline()
    d.fits[(2.0, "RT")]["k_c"] = 3.0  # rho > 1 must have no transition
    assert status(d, "rho > 1: RT follows the model") == "FAIL"
    d = baseline()
    d.fits[(0.2, "RT")]["k_c"] = np.nan
    assert status(d, "Gap at k_c in the RT branch") == "FAIL"
    d = baseline()
    d.fits[(1.0, "L")]["power_law_p"] = np.nan
    assert status(d, "Rayleigh attenuation gamma_l") == "FAIL"
    d = baseline()
    d.vdos = {}
    assert status(d, "omega_c slightly above omega_r(0)") == "NOT MEASURED"
    d = baseline()
    d.lattice = None
    assert status(d, "Everything from standing waves") == "NOT MEASURED"
    assert not any(r.claim.startswith(tuple(PREFIXES)) for r in claims.claims(d))
