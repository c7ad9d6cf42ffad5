"""Dispersion analysis of a scene's standing waves: fits per k, lattice model, k_c, band limits.

Pure post-processing (numpy/scipy, no MPI; the pipeline runs it on rank 0): it reads the
``waves/...`` (and, if present, ``vdos/...``) result units and returns new groups
``analysis/...``.  Definitions:

* C_alpha(k, t) and S_alpha(k, omega) pool the runs (both directions in 2D; every direction and
  polarisation in 3D: ``waves.excitation.runs``) and every configuration (``correlations``); C
  is fitted with exp(-gamma t) cos(omega t) (``fits.fit_damped_cosine``) and cross-checked by a
  Lorentzian fit of S.  c = omega / k.
* Modes L, TR, RT and (3D) R are fitted alike; R, the twist mode, is read like RT (peak
  frequency and decay; it enters neither k_c, the lattice model nor the band limits).
* gamma ~ k^p (L and TR only; RT and R are optical-like with gamma(0) > 0) is fitted over
  k d0 <= ``power_law_kd0_max`` where the run resolves the decay (gamma t_end >= 1).
* k_c: where the RT and TR branches exchange (the paper's Fig. 5 text: RT drops from branch (iv)
  to (ii), TR jumps from (i) to (iii)), a property of rho stored on every analysis group of that
  rho: the linearly interpolated zero of omega_RT - omega_TR (damped-cosine fits) after which RT
  stays below TR at every larger k (``fits.exchange_k``); NaN where RT stays above TR (rho >= 1),
  where it is below from the first k, or without both RT and TR.  It has no threshold and no step
  size, so it does not depend on the k spacing.  It replaced a jump detector (the first drop of
  the RT frequency larger than a threshold), which found no k_c at rho = 0.2 on the N = 32768 k
  grid, where one damped cosine spreads the drop over several finer k steps.
* Lattice model: a_r and l fitted jointly over every rho > 0 to the RT frequencies on
  k d0 <= ``lattice_kd0_max`` and below k_c; then a_t (one value, l fixed) to the TR frequencies
  on the same range (``a_t``, the long-wave TR value), and separately to the RT frequencies beyond
  k_c, which follow the acoustic branch (``a_t_edge``; PHYSICS.md section 6: one a_t cannot fit
  both).  Figures 5b and 7 draw omega_t with a_t_edge where it exists, as the paper's do.
* An amplitude sweep (``waves.engine: lammps`` with a list of amplitudes): each amplitude's
  units are pooled and fitted on their own, into ``analysis/rho<rho>_<mode>_a<LL>`` (attribute
  ``amplitude``); k_c, the lattice model and the band limits are the linear waves'.
* Band limits from data: omega_r(0) is the RT frequency at the smallest k, omega_r(k_max) and
  omega_t(k_max) the RT and TR frequencies at the largest k of the run (the report states both
  k); omega_c from the vDOS of the same file when it has one.
Units: omega, gamma in 1/t0, k in 1/d0.
"""

from __future__ import annotations

import re
import warnings

import numpy as np

from . import attenuation, lattice
from ..waves import correlations
from . import fits

_WAVES = re.compile(r"waves/r(\d+)_(L|TR|RT|R)_p(\d+)(_a\d+)?$")


def _fit_one(t, c, omega_grid, power, decay_window):
    """Damped-cosine and Lorentzian fits of one k; NaN where a fit fails."""
    row = dict.fromkeys(("omega", "gamma", "omega_err", "gamma_err", "rms", "t_fit",
                         "omega_lorentz", "gamma_lorentz"), np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # OptimizeWarning (no covariance) is recorded as NaN errors
        try:
            fit = fits.fit_damped_cosine(t, c, decay_window)
            row.update(omega=fit.omega, gamma=fit.gamma, omega_err=fit.omega_err,
                       gamma_err=fit.gamma_err, rms=fit.rms, t_fit=fit.t_max)
        except (RuntimeError, ValueError):
            pass
        try:
            row["omega_lorentz"], row["gamma_lorentz"] = fits.fit_lorentzian(omega_grid, power)
        except (RuntimeError, ValueError):
            pass
    return row


def averaged_waves(units: dict, sweep: bool = False) -> dict:
    """{(rho, mode): (k (K,), t (S,), C (K, S), omega (W,), S (K, W), packings)} from
    ``waves/rXX_MODE_pYYYY`` units (name -> (datasets, attrs)): C and S pool the runs of every
    direction, polarisation and configuration (correlations module), not averages of per-file
    ratios.  ``sweep``: instead the units of an amplitude sweep (``..._aLL``), keyed
    (rho, mode, LL: the amplitude's position in ``waves.amplitude``); each is pooled on its own."""
    groups: dict = {}
    for name, (data, attrs) in sorted(units.items()):
        if _WAVES.match(name) and ("amplitude_index" in attrs) == sweep:
            key = (float(attrs["rho"]), str(attrs["mode"])) + ((int(attrs["amplitude_index"]),) if sweep else ())
            groups.setdefault(key, []).append(data)
    out = {}
    for key, items in groups.items():
        k, t = np.asarray(items[0]["k"]), np.asarray(items[0]["t"])
        z = np.concatenate([np.asarray(d["z"]) for d in items], axis=0)  # (runs x P, K, S)
        c, omega, power = correlations.pooled(z, t[1] - t[0])
        out[key] = (k, t, c, omega, power, len(items))
    return out


def _fit_mode(mode, k, t, c, omega_grid, power, spec) -> tuple[dict, tuple]:
    """The fits of one pooled (rho, mode): their table per k (``_fit_one``; a Lorentzian peak
    outside the grid is a failed fit) and (p, p_err, points) of gamma ~ k^p (L and TR only)."""
    rows = [_fit_one(t, c[i], omega_grid, power[i], spec.decay_window) for i in range(k.size)]
    table = {key: np.array([r[key] for r in rows]) for key in rows[0]}
    for key in ("omega_lorentz", "gamma_lorentz"):
        table[key][(table["omega_lorentz"] <= 0) | (table["omega_lorentz"] > omega_grid[-1])] = np.nan
    law = (_power_law(k, table, t[-1], spec.power_law_kd0_max) if mode in ("L", "TR")
           else (np.nan, np.nan, 0))  # RT and R are optical-like: gamma(0) > 0
    return table, law


def _sweep(units: dict, spec) -> dict:
    """Analysis groups ``analysis/rho<rho>_<mode>_a<LL>`` of an amplitude sweep: each amplitude's
    fits, as for one without (no k_c, lattice or bands: those belong to the linear waves)."""
    out = {}
    amplitudes = {int(a["amplitude_index"]): float(a["amplitude"]) for _, a in units.values() if "amplitude_index" in a}
    for (rho, mode, index), (k, t, c, omega_grid, power, count) in sorted(averaged_waves(units, True).items()):
        table, (p, p_err, p_points) = _fit_mode(mode, k, t, c, omega_grid, power, spec)
        amplitude = amplitudes[index]
        out[f"analysis/rho{rho:g}_{mode}_a{index:02d}"] = (
            {"k": k, **table, "c": table["omega"] / k},
            {"rho": rho, "mode": mode, "amplitude": amplitude, "configurations": count, "t_end": float(t[-1]),
             "power_law_p": p, "power_law_p_err": p_err, "power_law_points": p_points})
    return out


def _power_law(k, fitted, t_end, kd0_max):
    gamma = fitted["gamma"]
    use = (k <= kd0_max) & attenuation.resolved(gamma, t_end)
    if use.sum() < 3:
        return np.nan, np.nan, int(use.sum())
    p, err = fits.power_law(k[use], gamma[use])
    return p, err, int(use.sum())


def _fit_a_t(rows, l):
    """Least-squares a_t (and 1-sigma) of omega_t = a_t sqrt(f - sqrt g) with l fixed; NaN
    with fewer than 2 points."""
    if sum(k.size for _, k, _ in rows) < 2:
        return np.nan, np.nan
    model = np.concatenate([lattice.lattice_omega(k, rho, l, 1.0, 1.0)[0] for rho, k, _ in rows])
    data = np.concatenate([w for _, _, w in rows])
    a_t = float(model @ data / (model @ model))
    resid = data - a_t * model
    err = float(np.sqrt(resid @ resid / max(1, model.size - 1) / (model @ model)))
    return a_t, err


def analyse(units: dict, spec) -> dict:
    """Analysis groups {name: (datasets, attrs)} from result units; {} without waves."""
    waves = averaged_waves(units)
    out: dict = _sweep(units, spec)
    if not waves:
        return out
    fitted: dict = {}
    for (rho, mode), (k, t, c, omega_grid, power, count) in sorted(waves.items()):
        table, (p, p_err, p_points) = _fit_mode(mode, k, t, c, omega_grid, power, spec)
        fitted[(rho, mode)] = (k, table)
        out[f"analysis/rho{rho:g}_{mode}"] = (
            {"k": k, **table, "c": table["omega"] / k},
            {"rho": rho, "mode": mode, "configurations": count, "t_end": float(t[-1]),
             "power_law_p": p, "power_law_p_err": p_err, "power_law_points": p_points})
    k_c = {rho: _exchange(fitted, rho) for rho, _ in fitted}
    fitted = {(rho, mode): (k, table, k_c[rho]) for (rho, mode), (k, table) in fitted.items()}
    for rho, mode in fitted:
        out[f"analysis/rho{rho:g}_{mode}"][1]["k_c"] = k_c[rho]
    params = _lattice(fitted, spec)
    if params:
        out["analysis/lattice"] = ({}, params)
        out["analysis/bands"] = (_bands(fitted, units), {
            "definition": "omega_r0: RT at the smallest k; omega_r_kmax, omega_t_kmax: RT and TR at the "
                          "largest k; omega_c: vDOS of this file (NaN without one)"})
    return out


def _exchange(fitted, rho) -> float:
    """k_c of one rho from its RT and TR fits (``fits.exchange_k``); NaN without both."""
    if (rho, "RT") not in fitted or (rho, "TR") not in fitted:
        return np.nan
    (k_rt, rt), (k_tr, tr) = fitted[(rho, "RT")], fitted[(rho, "TR")]
    return fits.exchange_k(k_rt, rt["omega"], k_tr, tr["omega"])


def _lattice(fitted, spec) -> dict:
    """Joint (a_r, l) fit over rho > 0 on the long-wave RT data below k_c, then a_t from TR."""
    rt, tr = [], []
    for (rho, mode), (k, table, k_c) in sorted(fitted.items()):
        if rho <= 0:
            continue
        keep = (k <= spec.lattice_kd0_max) & np.isfinite(table["omega"])
        if np.isfinite(k_c):
            keep &= k < k_c
        if keep.any() and mode in ("RT", "TR"):
            (rt if mode == "RT" else tr).append((rho, k[keep], table["omega"][keep]))
    if sum(r[1].size for r in rt) < 3:
        return {}
    a_r, a_r_err, l, l_err = fits.fit_lattice(rt, k_max=spec.lattice_kd0_max)
    a_t, a_t_err = _fit_a_t(tr, l)
    edge = [(rho, k[k > k_c], table["omega"][k > k_c]) for (rho, mode), (k, table, k_c) in sorted(fitted.items())
            if mode == "RT" and rho > 0 and np.isfinite(k_c)]
    a_t_edge, a_t_edge_err = _fit_a_t([e for e in edge if np.isfinite(e[2]).all()], l)
    return {"a_r": a_r, "a_r_err": a_r_err, "l": l, "l_err": l_err, "a_t": a_t, "a_t_err": a_t_err,
            "a_t_edge": a_t_edge, "a_t_edge_err": a_t_edge_err,
            "k_max": lattice.k_max(l), "kd0_max_used": spec.lattice_kd0_max,
            "rho_values": np.array(sorted({r[0] for r in rt}))}


def _bands(fitted, units) -> dict:
    """Band limits per rho > 0 from the fitted frequencies (and omega_c of the vDOS, if any)."""
    vdos = {float(a["rho"]): float(a["omega_c"]) for n, (_, a) in units.items() if n.startswith("vdos/")}
    rhos = sorted({rho for rho, mode in fitted if rho > 0 and mode == "RT"})
    cols = {key: [] for key in ("rho", "omega_r0", "omega_r_kmax", "omega_t_kmax", "omega_c",
                                "k_small", "k_large")}
    for rho in rhos:
        k, rt, _ = fitted[(rho, "RT")]
        tr = fitted.get((rho, "TR"), (k, {"omega": np.full(k.size, np.nan)}, None))[1]
        cols["rho"].append(rho)
        cols["omega_r0"].append(rt["omega"][0])
        cols["omega_r_kmax"].append(rt["omega"][-1])
        cols["omega_t_kmax"].append(tr["omega"][-1])
        cols["omega_c"].append(vdos.get(rho, np.nan))
        cols["k_small"].append(k[0])
        cols["k_large"].append(k[-1])
    return {key: np.array(v, float) for key, v in cols.items()}
