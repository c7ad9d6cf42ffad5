"""KPM through the pipeline (``spectrum: {method: kpm}`` scenes), rho = 0 and rho > 0, against the
slicing spectrum of the same packing: an L1 error bound on the vDOS that shrinks as 1/sqrt(probes),
and the per-bin K and Q (rho = 0: filled, K = 1/4N', Q = 0)."""

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close, scene_of

from solver import pipeline
from solver.io.unit_keys import Unit, vdos_name
from solver.spectrum.modes import bin_average

BIN = 0.5          # wide bins: ~20 modes each, so the exact histogram is a fair reference
MOMENTS = 300
PROBES = (4, 64)
RHOS = (0.0, 1.0)


def run(folder, name, spectrum):
    scene = scene_of(folder / f"{name}.h5", cache="off", seed=3, packing={"n": 64, "phi": 0.9, "count": 1},
                     model={"rho": list(RHOS)}, spectrum=spectrum)
    return pipeline.run(scene, COMM, [])["units"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("kpm_pipeline")
    folder = type(folder)(COMM.bcast(str(folder), root=0))  # rank 0's folder on every rank
    exact = run(folder, "slicing", {"energies": True})
    kpm = {p: run(folder, f"kpm{p}", {"method": "kpm", "energies": True, "probes": p, "bin_width": BIN,
                                      "moments": MOMENTS}) for p in PROBES}
    return exact, kpm


def jackson_masses(omega, lam_max, edges):
    """Bin masses of the Jackson-smoothed expansion of the exact spectrum ``omega`` (its
    deterministic part: what KPM returns with infinitely many probes), written from the formula.

    lambda in [-0.01, 1.01] lambda_max maps to x in [-1, 1]; the primitive of
    sum_n g_n mu_n T_n(x) / (pi sqrt(1 - x^2)) (times 2 for n >= 1) is sum_n g_n mu_n sin(n t)/(n pi)
    in t = arccos x, and g_0 mu_0 t / pi for n = 0.
    """
    lo, hi = -0.01 * lam_max, 1.01 * lam_max
    c, h = 0.5 * (hi + lo), 0.5 * (hi - lo)
    m = np.arange(MOMENTS)
    q = np.pi / (MOMENTS + 1)
    g = ((MOMENTS - m + 1) * np.cos(q * m) + np.sin(q * m) / np.tan(q)) / (MOMENTS + 1)
    mu = np.cos(np.outer(m, np.arccos((omega**2 - c) / h))).mean(axis=1)
    theta = np.arccos(np.clip((edges**2 - c) / h, -1, 1))
    primitive = (g[0] * mu[0] * theta + 2 * np.sum(g[1:] * mu[1:] * np.sin(np.outer(theta, m[1:])) / m[1:],
                                                   axis=1)) / np.pi
    return primitive[:-1] - primitive[1:]


@pytest.mark.parametrize("r_index", [0, 1])
def test_kpm_vdos_within_an_error_bound_that_shrinks_with_probes(runs, r_index):
    exact, kpm = runs
    tag = Unit("spectrum", r_index, 0, RHOS[r_index]).name
    omega = exact[tag][0]["omega"]
    n_modes = omega.size
    errors, bounds = [], []
    for probes in PROBES:
        data, attrs = kpm[probes][tag]
        assert_all(attrs["method"] == "kpm" and attrs["probes"] == probes and attrs["moments"] == MOMENTS,
                   f"unit attributes {attrs}")
        edges, density = data["edges"], data["density"]
        width = np.diff(edges)
        assert_close(width, np.full(width.size, BIN), rtol=1e-12, what="bins of the scene's width")
        assert_all(edges[0] == 0 and edges[-1] > omega.max(), "the bins cover the spectrum")
        hist = np.histogram(omega, edges)[0] / n_modes
        smooth = jackson_masses(omega, attrs["omega_max"] ** 2, edges)
        bias = np.abs(smooth / smooth.sum() - hist).sum()
        # Stochastic part: a bin's mass is a Hutchinson trace of f_b(A) / n with 0 <= f_b <= 1
        # (Jackson's kernel is positive), whose standard deviation with R Rademacher probes is at
        # most sqrt(2 tr f_b^2 / R) / n <= sqrt(2 mass_b / (R n)); summed over the bins.
        noise = np.sum(np.sqrt(2 * np.clip(smooth, 0, None) / (probes * n_modes)))
        errors.append(float(np.sum(np.abs(density * width - hist))))
        bounds.append(bias + 3 * noise)
        assert_all(np.array_equal(kpm[probes][vdos_name(r_index)][0]["density"], density),
                   "one configuration: the vDOS is its density")
    assert_all(all(e <= b for e, b in zip(errors, bounds)), f"L1 errors {errors} above bounds {bounds}")
    assert_all(bounds[-1] < 0.25, f"the bound at {PROBES[-1]} probes says nothing: {bounds}")


def test_kpm_energies_at_rho_zero_are_filled_translational(runs):
    """rho = 0: no rotations, every mode has K = 1/(4N') and Q = 0; bins without modes are NaN."""
    exact, kpm = runs
    data, attrs = kpm[PROBES[-1]]["spectra/r00_p0000"]
    n_disks = attrs["n_disks"]
    populated = data["density"] > 0
    assert_all(populated.sum() >= 5, "populated bins")
    assert_close(data["K"][populated], np.full(populated.sum(), 1 / (4 * n_disks)), rtol=1e-15, what="K")
    assert_all(np.all(data["Q"][populated] == 0), "Q = 0")
    assert_all(np.all(np.isnan(data["K"][~populated]) & np.isnan(data["Q"][~populated])), "NaN outside")
    # and the exact per-mode values agree (the slicing unit: K = 1/4N', Q = 0 for every mode)
    k_exact = exact["spectra/r00_p0000"][0]["K"]
    assert_close(k_exact, np.full(k_exact.size, 1 / (4 * n_disks)), rtol=1e-12, what="slicing K at rho = 0")


def test_kpm_energies_at_rho_one_against_exact_bin_averages(runs):
    exact, kpm = runs
    mine = exact["spectra/r01_p0000"][0]
    data, _ = kpm[PROBES[-1]]["spectra/r01_p0000"]
    edges = data["edges"]
    counts = np.histogram(mine["omega"], edges)[0]
    busy = (counts >= 12) & np.isfinite(data["K"])  # bins of >= 12 modes: a stable bin average
    for key in ("K", "Q"):
        ref = bin_average(mine["omega"], mine[key], edges)
        rel = np.abs(data[key][busy] / ref[busy] - 1)
        # a bin of m modes holds a stochastic mass of relative spread <= sqrt(2 / (R m)) = 0.05
        # at R = 64, m = 12 (see the vDOS test): 3 sigma
        assert_all(busy.sum() >= 5 and rel.max() < 0.15, f"{key}: relative errors {rel}")
