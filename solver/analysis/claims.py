"""The paper's quantitative claims, their tolerances and verdicts (the reproduction report's table).

numpy only (no h5py, no PETSc): :func:`claims` takes a :class:`Data` that ``report.gather``
fills from results files (or a test fills by hand) and returns one :class:`Row` per claim with
PASS, FAIL or NOT MEASURED (the data needed is not there).  Every tolerance is fixed here, before
any run, not tuned to the data.  Band edges and branches come from ``lattice`` (eq:omega_t(k),
eq:omega_r(k), fig:band_RT).  Units: omega, gamma in 1/t0; k in 1/d0.  Not collective.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..spectrum.modes import bin_average
from . import lattice

PHI_MAIN = 0.9  # the paper's packing fraction; files at other phi only feed the Fig. S1 claim


@dataclass
class Data:
    """What the claims (and the report around them) need, gathered from all results files by
    ``report.gather``; the arrays are those of the results file layout (docs/results_file.md)."""

    vdos: dict = field(default_factory=dict)        # rho -> (edges, density, omega_c, omega_c_std, configs)
    energies: dict = field(default_factory=dict)    # rho -> (omega, K, Q) per mode, pooled over configurations
    fits: dict = field(default_factory=dict)        # (rho, mode) -> {k, omega, gamma, ...} + attrs
    lattice: dict | None = None                     # attributes of analysis/lattice
    bands: dict | None = None                       # datasets of analysis/bands
    s1: dict = field(default_factory=dict)          # phi -> {rho: (edges, density, omega_c)}
    sources: list = field(default_factory=list)     # (path, phi, N, what)
    vdos_file: str | None = None
    energies_file: dict = field(default_factory=dict)  # rho -> path
    waves_file: str | None = None


@dataclass
class Row:
    """One line of the report's table."""

    claim: str
    paper: str
    measured: str
    tolerance: str
    status: str  # PASS, FAIL, NOT MEASURED


def _peak(edges, density):
    centres = 0.5 * (edges[1:] + edges[:-1])
    return float(centres[np.argmax(density)])


def _near(value, target, tol):
    return "PASS" if abs(value - target) <= tol else "FAIL"


def _at_k(fit, kd0):
    i = int(np.argmin(np.abs(fit["k"] - kd0)))
    return i, float(fit["k"][i])


def _signs(omega, a, b, edges):
    """Sign pattern of the bin-averaged a - b over bins with >= 5 modes: [[sign, lo, hi]].

    Runs of a single bin are dropped as noise before equal neighbours are merged."""
    centres = 0.5 * (edges[1:] + edges[:-1])
    diff = bin_average(omega, a, edges) - bin_average(omega, b, edges)
    counts = np.histogram(omega, edges)[0]
    runs: list[list] = []
    for c, x, n in zip(centres, diff, counts):
        if n < 5 or not np.isfinite(x):
            continue
        sign = "K>Q" if x > 0 else "K<Q"
        if runs and runs[-1][0] == sign:
            runs[-1][2], runs[-1][3] = c, runs[-1][3] + 1
        else:
            runs.append([sign, c, c, 1])
    merged: list[list] = []
    for sign, lo, hi, n in runs:
        if n < 2:
            continue
        if merged and merged[-1][0] == sign:
            merged[-1][2] = hi
        else:
            merged.append([sign, lo, hi])
    return merged


def claims(d: Data) -> list[Row]:
    """Evaluate every claim; tolerances are fixed here, not tuned to the data."""
    rows: list[Row] = []
    nm = "NOT MEASURED"

    def add(claim, paper, measured, tol, status):
        rows.append(Row(claim, paper, measured, tol, status))

    v = d.vdos
    rhos_v = sorted(v)
    if 0.0 in v:
        peak0 = _peak(v[0.0][0], v[0.0][1])
        add("Frictionless main vDOS peak (Fig. 1)", "omega t0 ~ 2.3", f"{peak0:.2f}", "+-0.2",
            _near(peak0, 2.3, 0.2))
        add("Cutoff omega_c at rho = 0 (Fig. 1)", "~ 2.3 / t0", f"{v[0.0][2]:.2f} +- {v[0.0][3]:.2f}",
            "+-10 %", _near(v[0.0][2], 2.3, 0.23))
    else:
        add("Frictionless main vDOS peak (Fig. 1)", "omega t0 ~ 2.3", "-", "+-0.2", nm)
    if 2.0 in v:
        add("Cutoff omega_c at rho = 2 (Fig. 1)", "~ 6.6 / t0", f"{v[2.0][2]:.2f} +- {v[2.0][3]:.2f}",
            "+-5 %", _near(v[2.0][2], 6.6, 0.33))
    else:
        add("Cutoff omega_c at rho = 2 (Fig. 1)", "~ 6.6 / t0", "-", "+-5 %", nm)
    if len(rhos_v) >= 3:
        oc = [v[r][2] for r in rhos_v]
        add("omega_c grows with rho (shoulder develops, Fig. 1)", "monotone",
            ", ".join(f"{r:g}: {w:.2f}" for r, w in zip(rhos_v, oc)), "strictly increasing",
            "PASS" if np.all(np.diff(oc) > 0) else "FAIL")
        p_lo, p_hi = _peak(*v[rhos_v[0]][:2]), _peak(*v[rhos_v[-1]][:2])
        add("Main vDOS peak shifts up with rho (Fig. 1)", "shifts to higher omega",
            f"peak {p_lo:.2f} at rho = {rhos_v[0]:g}, {p_hi:.2f} at rho = {rhos_v[-1]:g}", "> +0.1",
            "PASS" if p_hi > p_lo + 0.1 else "FAIL")
    if 0.4 in v:
        edges, g = v[0.4][0], v[0.4][1]
        smooth = np.convolve(g, np.ones(3) / 3, mode="same")
        maxima = [i for i in range(1, g.size - 1) if smooth[i] > smooth[i - 1] and smooth[i] >= smooth[i + 1]
                  and smooth[i] > 0.1 * smooth.max()]
        centres = 0.5 * (edges[1:] + edges[:-1])
        add("Secondary vDOS peak at rho = 0.4 (Fig. 1)", "present",
            f"{len(maxima)} maxima (3-bin mean, > 10 % of max) at omega = "
            + ", ".join(f"{centres[i]:.2f}" for i in maxima), ">= 2 maxima", "PASS" if len(maxima) >= 2 else "FAIL")
    phis = sorted(d.s1)
    s1 = [(phi, d.s1[phi][2.0][2]) for phi in phis if 2.0 in d.s1[phi]]
    if len(s1) >= 2:
        spread = (max(w for _, w in s1) - min(w for _, w in s1)) / np.mean([w for _, w in s1])
        add("High-frequency band insensitive to phi (Fig. S1): omega_c at rho = 2", "unchanged",
            ", ".join(f"phi {p:g}: {w:.2f}" for p, w in s1), "spread < 5 %", "PASS" if spread < 0.05 else "FAIL")
    else:
        add("High-frequency band insensitive to phi (Fig. S1)", "unchanged", "-", "spread < 5 %", nm)
    if 1.0 in d.energies:
        omega, k, q = d.energies[1.0]
        lo, hi = omega < 1.0, omega > 3.0
        frac_lo = float(np.mean(k[lo] > q[lo])) if lo.any() else np.nan
        frac_hi = float(np.mean(q[hi] > k[hi])) if hi.any() else np.nan
        add("Energy partition at rho = 1 (Fig. 6a)", "K > Q below omega ~ 1, Q > K above ~ 3",
            f"{100 * frac_lo:.0f} % of modes below 1 have K > Q; {100 * frac_hi:.0f} % above 3 have Q > K",
            ">= 90 % each", "PASS" if frac_lo >= 0.9 and frac_hi >= 0.9 else "FAIL")
    else:
        add("Energy partition at rho = 1 (Fig. 6a)", "K > Q low, Q > K high", "-", ">= 90 % each", nm)
    if 0.4 in d.energies and 0.4 in v:
        omega, k, q = d.energies[0.4]
        runs = _signs(omega, k, q, v[0.4][0])
        pattern = [r[0] for r in runs]
        ok = pattern[:4] == ["K>Q", "K<Q", "K>Q", "K<Q"]
        add("Four regions K>Q, K<Q, K>Q, K<Q at rho = 0.4 (Fig. 6b)", "(i)-(iv)",
            "; ".join(f"{s} {a:.2f}-{b:.2f}" for s, a, b in runs), "this order", "PASS" if ok else "FAIL")
    else:
        add("Four regions at rho = 0.4 (Fig. 6b)", "(i)-(iv)", "-", "this order", nm)
    _wave_claims(d, add, nm)
    return rows


def _wave_claims(d: Data, add, nm) -> None:
    fits, lat, b = d.fits, d.lattice, d.bands
    if lat is None:
        add("Everything from standing waves (Figs. 2-5, 7, S2, S3)", "-", "no analysis in the files", "-", nm)
        return
    kd = 0.38 * np.pi
    if all(key in fits for key in ((1.0, "L"), (1.0, "TR"), (1.0, "RT"))):
        (il, kl), (it, _), (ir, _) = (_at_k(fits[(1.0, m)], kd) for m in ("L", "TR", "RT"))
        wl, wt, wr = fits[(1.0, "L")]["omega"][il], fits[(1.0, "TR")]["omega"][it], fits[(1.0, "RT")]["omega"][ir]
        gl, gt, gr = fits[(1.0, "L")]["gamma"][il], fits[(1.0, "TR")]["gamma"][it], fits[(1.0, "RT")]["gamma"][ir]
        add(f"RT oscillates much faster than L, TR (Fig. 2, rho = 1, k d0 = {kl:.3f})", "much faster",
            f"omega_r = {wr:.2f}, omega_l = {wl:.2f}, omega_t = {wt:.2f}", "omega_r > 2 max(omega_l, omega_t)",
            "PASS" if wr > 2 * max(wl, wt) else "FAIL")
        add(f"RT decays faster than L, TR (Fig. 2, rho = 1, k d0 = {kl:.3f})", "stronger attenuation",
            f"gamma_r = {gr:.3f}, gamma_l = {gl:.3f}, gamma_t = {gt:.3f}", "gamma_r > max(gamma_l, gamma_t)",
            "PASS" if gr > max(gl, gt) else "FAIL")
        add(f"L faster than TR (Figs. 2, 3, rho = 1, k d0 = {kl:.3f})", "omega_l > omega_t",
            f"{wl:.3f} vs {wt:.3f}", "strict", "PASS" if wl > wt else "FAIL")
        if (0.0, "L") in fits and (0.0, "TR") in fits:
            (i0l, _), (i0t, _) = _at_k(fits[(0.0, "L")], kd), _at_k(fits[(0.0, "TR")], kd)
            w0l, w0t = fits[(0.0, "L")]["omega"][i0l], fits[(0.0, "TR")]["omega"][i0t]
            g0l, g0t = fits[(0.0, "L")]["gamma"][i0l], fits[(0.0, "TR")]["gamma"][i0t]
            add("Friction makes L and TR oscillate faster (Fig. 2)", "omega(rho=1) > omega(rho=0)",
                f"L: {wl:.3f} vs {w0l:.3f}; TR: {wt:.3f} vs {w0t:.3f}", "both", "PASS" if wl > w0l and wt > w0t else "FAIL")
            add("Friction makes L and TR decay more weakly (Fig. 2)", "gamma(rho=1) < gamma(rho=0)",
                f"L: {gl:.4f} vs {g0l:.4f}; TR: {gt:.4f} vs {g0t:.4f}", "both",
                "PASS" if gl < g0l and gt < g0t else "FAIL")
    if b is not None and 1.0 in list(b["rho"]):
        i = list(b["rho"]).index(1.0)
        lo, hi = b["omega_r_kmax"][i], b["omega_r0"][i]
        add("RT band at rho = 1 (Fig. 3c)", "2.5 <= omega t0 <= 4.7", f"{lo:.2f} - {hi:.2f} (k d0 = "
            f"{b['k_large'][i]:.2f} / {b['k_small'][i]:.3f})", "+-0.25 each end",
            "PASS" if abs(lo - 2.5) <= 0.25 and abs(hi - 4.7) <= 0.25 else "FAIL")
    add("Lattice model a_r (Fig. 4)", "0.73 / t0", f"{lat['a_r']:.3f} +- {lat['a_r_err']:.3f}", "+-5 %",
        _near(lat["a_r"], 0.73, 0.0365))
    add("Lattice model l (Fig. 4)", "0.446 d0", f"{lat['l']:.3f} +- {lat['l_err']:.3f}", "+-5 %",
        _near(lat["l"], 0.446, 0.0223))
    rt = {rho: fits[(rho, "RT")] for rho, mode in fits if mode == "RT" and rho > 0}
    big = [rho for rho in rt if rho > 1]
    if big:
        dev = max(float(np.nanmax(np.abs(rt[r]["omega"] / lattice.lattice_omega(rt[r]["k"], r, lat["l"], 1, lat["a_r"])[1] - 1)))
                  for r in big)
        kcs = [r for r in big if np.isfinite(rt[r]["k_c"])]
        add("rho > 1: RT follows the model at all k (Fig. 4)", "perfectly described",
            f"max |omega_r / model - 1| = {100 * dev:.1f} %; k_c detected for rho = {kcs or 'none'}",
            "< 10 % and no k_c", "PASS" if dev < 0.10 and not kcs else "FAIL")
    small = sorted(r for r in rt if r < 1)
    if small:
        kc = [(r, float(rt[r]["k_c"])) for r in small]
        found = [(r, k) for r, k in kc if np.isfinite(k)]
        contiguous = [r for r, _ in found] == small[:len(found)]
        monotone = all(b2 >= b1 for (_, b1), (_, b2) in zip(found, found[1:]))
        add("rho < 1: k_c exists and decreases as rho decreases (Figs. 4, 5)", "monotone",
            "; ".join(f"rho {r:g}: " + (f"{k:.2f}" if np.isfinite(k) else "none in range") for r, k in kc),
            ">= 2 found, non-decreasing in rho, from the smallest rho up",
            "PASS" if len(found) >= 2 and contiguous and monotone else "FAIL")
    if 0.2 in rt:
        f = rt[0.2]
        dominant = np.where(np.isfinite(f["omega_lorentz"]), f["omega_lorentz"], f["omega"])
        if np.isfinite(f["k_c"]):
            i = int(np.searchsorted(f["k"], f["k_c"]))  # first k beyond k_c
            hi, lo = dominant[i - 1], dominant[i]
            add("Gap at k_c in the RT branch at rho = 0.2 (Fig. 5a)", "1.2 < omega t0 < 1.5",
                f"{lo:.2f} - {hi:.2f} (dominant S_r peak just above / below k_c = {f['k_c']:.2f})",
                "+-0.15 each end", "PASS" if abs(lo - 1.2) <= 0.15 and abs(hi - 1.5) <= 0.15 else "FAIL")
        else:
            add("Gap at k_c in the RT branch at rho = 0.2 (Fig. 5a)", "1.2 < omega t0 < 1.5",
                "no k_c detected", "+-0.15 each end", "FAIL")
    if b is not None:
        r, r0, rk = b["rho"], b["omega_r0"], b["omega_r_kmax"]
        model0 = lattice.omega_r_zero(r, lat["a_r"])
        dev0 = float(np.max(np.abs(r0 / model0 - 1)))
        add("omega_r(0) follows a_r sqrt(40 rho) for all rho (Fig. 7)", "agree well", f"max deviation {100 * dev0:.1f} %",
            "< 5 %", "PASS" if dev0 < 0.05 else "FAIL")
        hi = r > 1
        if hi.any():
            devk = float(np.max(np.abs(rk[hi] / lattice.omega_r_kmax(r[hi], lat["a_r"]) - 1)))
            add("rho > 1: omega_r(k_max) follows 2 a_r sqrt(3 rho + 1) (Fig. 7)", "explained by the model",
                f"max deviation {100 * devk:.1f} % (at k d0 = {b['k_large'][0]:.2f})", "< 10 %",
                "PASS" if devk < 0.10 else "FAIL")
        lo = r < 1
        a_t = lattice.edge_a_t(lat)
        if lo.any():
            to_t = np.abs(rk[lo] - lattice.omega_t_kmax(r[lo], a_t))
            to_r = np.abs(rk[lo] - lattice.omega_r_kmax(r[lo], lat["a_r"]))
            add("rho < 1: omega_r(k_max) switches to the acoustic branch a_t sqrt(10 rho) (Fig. 7)",
                "switches", f"closer to the acoustic branch for {int(np.sum(to_t < to_r))} of {int(lo.sum())} rho "
                f"(a_t = {a_t:.3f}, fitted beyond k_c)", "all", "PASS" if np.all(to_t < to_r) else "FAIL")
        add("Band limits not reversed: omega_r(0) > omega_r(k_max) for every rho (Fig. 7)", "not reversed",
            ", ".join(f"{x:g}: {y:.2f} > {z:.2f}" for x, y, z in zip(r, r0, rk)), "all",
            "PASS" if np.all(r0 > rk) else "FAIL")
        omega_c = {rho: vals[2] for rho, vals in d.vdos.items()}
        both = [(x, omega_c[x], y) for x, y in zip(r, r0) if x in omega_c]
        if both:
            ok = all(c > y and c < 1.25 * y for _, c, y in both)
            add("omega_c slightly above omega_r(0) (Fig. 7)", "slightly higher",
                ", ".join(f"{x:g}: {c:.2f} vs {y:.2f}" for x, c, y in both), "1 < ratio < 1.25",
                "PASS" if ok else "FAIL")
        else:
            add("omega_c slightly above omega_r(0) (Fig. 7)", "slightly higher", "-", "1 < ratio < 1.25", nm)
    for mode in ("L", "TR"):
        if (1.0, mode) in fits:
            f = fits[(1.0, mode)]
            p, err, pts = f["power_law_p"], f["power_law_p_err"], f["power_law_points"]
            add(f"Rayleigh attenuation gamma_{mode.lower()[0]} ~ k^3 at rho = 1 (Fig. S3)", "p = 3",
                f"p = {p:.2f} +- {err:.2f} ({pts} k)", "+-0.5", "FAIL" if not np.isfinite(p) else _near(p, 3.0, 0.5))
        if (0.0, mode) in fits:
            f = fits[(0.0, mode)]
            p = f["power_law_p"]
            add(f"Frictionless gamma_{mode.lower()[0]} is not ~ k^3 (Fig. S3)", "p != 3",
                f"p = {p:.2f} +- {f['power_law_p_err']:.2f}", "|p - 3| > 0.5",
                "FAIL" if not np.isfinite(p) else ("PASS" if abs(p - 3) > 0.5 else "FAIL"))
    speeds = [(rho, fits[(rho, "L")]["c"][0], fits[(rho, "TR")]["c"][0]) for rho, mode in fits
              if mode == "L" and (rho, "TR") in fits]
    if speeds:
        add("Longitudinal sound faster than transverse, lim omega/k (Fig. 3)", "c_l > c_t",
            "; ".join(f"rho {r:g}: {a:.3f} > {c:.3f}" for r, a, c in sorted(speeds)), "every rho",
            "PASS" if all(a > c for _, a, c in speeds) else "FAIL")
