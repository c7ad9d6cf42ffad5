"""Analysis of waves results (fits, lattice model, k_c, bands) on synthetic data with a known
answer, and the reproduction report on a tiny real run."""

import re

import h5py
import numpy as np
import pytest

from solver.analysis import claims
from solver.analysis import dispersion
from solver.analysis import lattice
from solver.io.schema import AnalysisSpec
from solver.io.unit_keys import Unit, vdos_name
from conftest import assert_close, main_here, scene_text

pytestmark = pytest.mark.serial_only

A_R, L_MODEL, A_T = 0.73, 0.446, 0.55
RHOS = (0.2, 1.0, 2.0)
K = np.linspace(0.1, 3.4, 24)
K_C = 2.2  # the synthetic rho = 0.2 RT and TR branches exchange here


def _truth(rho, mode):
    """(omega (K,), gamma (K,)) of the synthetic data."""
    w_t, w_r = lattice.lattice_omega(K, rho, L_MODEL, A_T, A_R)
    gamma = 0.02 * K**3 + (0.05 if mode == "RT" else 0.0)
    if mode == "L":
        return 1.6 * w_t, gamma
    if mode == "TR":  # beyond k_c (rho < 1) TR jumps up to the optical branch, branch (iii) of Fig. 5b
        return (np.where(K < K_C, w_t, w_r) if rho < 1 else w_t), gamma
    if rho < 1:  # RT on the acoustic branch beyond k_c, 20 % above the TR model branch
        return np.where(K < K_C, w_r, 1.2 * w_t), gamma
    return w_r, gamma


def _units(rng):
    """Waves units of two configurations whose z(t) are damped cosines with a little noise."""
    t = np.arange(0, 200.0, 0.1)
    units = {}
    for r_index, rho in enumerate(RHOS):
        for mode in ("L", "TR", "RT"):
            omega, gamma = _truth(rho, mode)
            for p in range(2):
                z = np.exp(-gamma[None, :, None] * t) * np.cos(omega[None, :, None] * t) * np.ones((2, 1, 1))
                z = z + 1e-3 * rng.normal(size=z.shape)
                units[Unit("waves", r_index, p, rho, mode).name] = (
                    {"k": K, "t": t, "z": z.astype(complex)}, {"rho": rho, "mode": mode, "packing": p})
    units[vdos_name(2)] = ({}, {"rho": 2.0, "omega_c": 6.7})
    return units


@pytest.fixture(scope="module")
def analysed():
    units = _units(np.random.default_rng(5))
    return dispersion.analyse(units, AnalysisSpec())


def test_fits_recover_frequencies_and_attenuation(analysed):
    for rho in RHOS:
        for mode in ("L", "TR", "RT"):
            g = analysed[f"analysis/rho{rho:g}_{mode}"][0]
            omega, gamma = _truth(rho, mode)
            resolved = gamma * 200 > 1  # the decay must be visible in the run to be measured
            # noise 1e-3 on C: measured 4.8e-4 (omega) and 1.9e-3 (gamma) relative at worst
            assert_close(g["omega"], omega, rtol=2e-3, what=f"omega {rho} {mode}")
            assert_close(g["gamma"][resolved], gamma[resolved], rtol=1e-2, what=f"gamma {rho} {mode}")
            assert_close(g["c"], g["omega"] / K, rtol=np.finfo(float).eps, what="c = omega / k")


def test_power_law_and_transition(analysed):
    for rho in RHOS:
        attrs = analysed[f"analysis/rho{rho:g}_TR"][1]
        assert_close(attrs["power_law_p"], 3.0, rtol=0.01, what=f"p at rho {rho}")  # measured |p - 3| <= 0.004
        assert np.isnan(analysed[f"analysis/rho{rho:g}_RT"][1]["power_law_p"])  # optical branch: not fitted
    # RT and TR exchange abruptly between two grid points around K_C: k_c lies between them
    assert_close(analysed["analysis/rho0.2_RT"][1]["k_c"], K_C, rtol=0, atol=K[1] - K[0], what="k_c")
    for rho in RHOS:  # k_c is a property of rho: the same on every mode's group (NaN for rho >= 1)
        k_c = [analysed[f"analysis/rho{rho:g}_{mode}"][1]["k_c"] for mode in ("L", "TR", "RT")]
        assert np.array_equal(k_c, [k_c[2]] * 3, equal_nan=True) and np.isnan(k_c[2]) == (rho >= 1), (rho, k_c)


def test_lattice_fit_and_bands(analysed):
    lat = analysed["analysis/lattice"][1]
    # fitted to frequencies within 2e-3 of the truth (measured: 1.3e-5 relative at worst)
    assert_close(lat["a_r"], A_R, rtol=2e-3, what="a_r")
    assert_close(lat["l"], L_MODEL, rtol=2e-3, what="l")
    assert_close(lat["a_t"], A_T, rtol=2e-3, what="a_t")             # long-wave TR
    assert_close(lat["a_t_edge"], 1.2 * A_T, rtol=2e-3, what="a_t_edge")  # RT beyond k_c
    bands = analysed["analysis/bands"][0]
    assert list(bands["rho"]) == list(RHOS)
    rt0 = [_truth(rho, "RT")[0] for rho in RHOS]
    assert_close(bands["omega_r0"], [w[0] for w in rt0], rtol=2e-3, what="omega_r(0)")
    assert_close(bands["omega_r_kmax"], [w[-1] for w in rt0], rtol=2e-3, what="omega_r(k_max)")
    assert np.isnan(bands["omega_c"][0]) and bands["omega_c"][2] == 6.7


def test_no_waves_no_analysis():
    assert dispersion.analyse({"vdos/r00": ({}, {"rho": 1.0, "omega_c": 4.0})}, AnalysisSpec()) == {}


def _data(**vdos_omega_c):
    d = claims.Data()
    edges = np.linspace(0, 8, 161)
    for rho, omega_c in vdos_omega_c.items():
        density = np.exp(-((edges[:-1] - 2.3) ** 2))
        d.vdos[float(rho.replace("r", "").replace("_", "."))] = (edges, density, omega_c, 0.01, 2)
    return d


def test_claims_pass_and_fail_on_their_tolerance():
    rows = {r.claim: r for r in claims.claims(_data(r0=2.35, r2=6.7))}
    assert rows["Cutoff omega_c at rho = 2 (Fig. 1)"].status == "PASS"
    rows = {r.claim: r for r in claims.claims(_data(r0=2.35, r2=7.1))}
    assert rows["Cutoff omega_c at rho = 2 (Fig. 1)"].status == "FAIL"
    assert rows["Frictionless main vDOS peak (Fig. 1)"].status == "PASS"
    assert any(r.status == "NOT MEASURED" for r in rows.values())  # no waves given


def test_report_from_a_tiny_run(tmp_path, capsys):
    """``rotsound run`` and ``report`` in this process (the report's claims, not the process, are
    checked here; test_cli runs the commands as processes)."""
    out = tmp_path / "tiny.h5"
    scene = tmp_path / "tiny.yaml"
    scene.write_text(scene_text(out, seed=4, packing={"n": 128, "phi": 0.9, "count": 1},
                                model={"rho": [0.0, 0.2, 0.4, 1.0, 2.0]}, spectrum={"energies": True},
                                waves={"n": [1, 2, 3, 4, 5], "method": "spectral", "t_end": 40.0, "dt": 0.05,
                                       "sample_every": 2}))
    code, _, err = main_here(["run", str(scene)], capsys)
    assert code == 0, err
    with h5py.File(out) as f:
        assert {"lattice", "bands", "rho1_RT", "rho0_L"} <= set(f["analysis"])
        assert "rho0_RT" not in f["analysis"]
    md = tmp_path / "REPRODUCTION.md"
    code, _, err = main_here(["report", str(scene), "--output", str(md)], capsys)
    assert code == 0, err
    text = md.read_text()
    rows = [line for line in text.splitlines() if line.startswith("| ") and line.split("|")[1].strip().isdigit()]
    table = {}  # claim -> (measured, result); cells split on unescaped '|'
    for line in rows:
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
        assert len(cells) == 6 and cells[1] not in table and cells[5] in ("PASS", "**FAIL**", "not measured"), line
        table[cells[1]] = (cells[3], cells[5])

    def row(prefix):
        (found,) = [value for claim, value in table.items() if claim.startswith(prefix)]
        return found

    # The claims a 128-disk, one-configuration run settles with a margin: each must PASS, so a
    # broken claim (or a broken path from the results file to it) fails this test.  The others
    # (main peak at 2.3, k_c, the gap, Rayleigh exponents, l, ...) need the paper's N and t_end.
    for prefix in ("Cutoff omega_c at rho = 0", "Cutoff omega_c at rho = 2", "omega_c grows with rho",
                   "Main vDOS peak shifts up", "Energy partition at rho = 1", "RT oscillates much faster",
                   "L faster than TR", "Friction makes L and TR oscillate faster",
                   "Friction makes L and TR decay more weakly", "Lattice model a_r", "omega_r(0) follows",
                   "Band limits not reversed", "omega_c slightly above omega_r(0)",
                   "Longitudinal sound faster than transverse"):
        assert row(prefix)[1] == "PASS", (prefix, row(prefix))
    assert row("High-frequency band insensitive to phi")[1] == "not measured"  # one phi only
    # the numbers shown are the file's
    with h5py.File(out) as f:
        omega_c = {float(g.attrs["rho"]): float(g.attrs["omega_c"]) for g in f["vdos"].values()}
        a_r = float(f["analysis/lattice"].attrs["a_r"])
    assert row("omega_c grows with rho")[0] == ", ".join(f"{r:g}: {w:.2f}" for r, w in sorted(omega_c.items()))
    assert row("Cutoff omega_c at rho = 2")[0].startswith(f"{omega_c[2.0]:.2f} +- ")
    assert row("Lattice model a_r")[0].startswith(f"{a_r:.3f} +- ")
    for png in ("fig1_vdos", "fig4_dispersion_rt", "fig5_transition", "fig6_energies", "fig7_bands"):
        assert (tmp_path / "reproduction" / f"{png}.png").exists(), png
        assert f"reproduction/{png}.png" in text
    code, _, err = main_here(["report", str(tmp_path / "missing.h5")], capsys)
    assert code == 2 and "missing.h5: not found" in err


def test_report_and_plot_of_a_kpm_file_with_energies(tmp_path, capsys):
    """A KPM spectrum stores bin averages of K and Q, not per-mode values: the report reads only
    per-mode energies for its claims (it died on the missing 'omega' before), and the Fig. 6 plot
    draws the bin averages.  ``rotsound run``, ``report`` and ``plot`` in this process."""
    out = tmp_path / "kpm.h5"
    scene = tmp_path / "kpm.yaml"
    scene.write_text(scene_text(out, cache="off", packing={"n": 64, "phi": 0.9}, model={"rho": 1.0},
                                spectrum={"method": "kpm", "energies": True, "probes": 4}))
    assert main_here(["run", str(scene)], capsys)[0] == 0
    code, _, err = main_here(["report", str(out), "--output", str(tmp_path / "R.md")], capsys)
    assert code == 0, err
    assert "Energy partition at rho = 1 (Fig. 6a) | K > Q low, Q > K high | - |" in (tmp_path / "R.md").read_text()
    code, _, err = main_here(["plot", str(out)], capsys)
    assert code == 0 and (tmp_path / "kpm_energies.png").exists(), err
