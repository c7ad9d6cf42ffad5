"""The command line end to end: good runs, bad input on 1 and 2 ranks, PETSc options."""

import json
import subprocess
import sys

import h5py
import numpy as np
import pytest
from conftest import REPO, main_here, run_cli, scene_text

pytestmark = pytest.mark.serial_only  # these tests launch their own (mpirun) processes

SCENE = """\
output: {out}
cache: off
seed: 2
packing: {{n: 64, phi: 0.9, count: 2}}
model: {{rho: [0, 1]}}
petsc: {{waves_ksp_type: gmres, log_view_not_an_option: null}}
"""


def write(tmp_path, text, name="scene.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("ranks", [1, pytest.param(2, marks=pytest.mark.spawns_ranks)])  # 1: a process, no mpirun
def test_run_writes_results_and_reports_unused_options(tmp_path, ranks):
    out = tmp_path / "r.h5"
    scene = write(tmp_path, SCENE.format(out=out))
    proc = run_cli(["run", scene, "--set", "seed=3", "-waves_ksp_type", "cg", "-waves_ts_tpye", "x"], ranks)
    assert proc.returncode == 0, proc.stderr
    assert "wrote" in proc.stdout and str(out) in proc.stdout
    assert proc.stdout.count("wrote") == 1, "rank 1 must not print"
    assert "-waves_ts_tpye was never used" in proc.stdout  # no waves in this scene
    with h5py.File(out) as f:
        assert sorted(f["packings"]) == ["0000", "0001"]
        assert len(f["matrices"]) == 4
        options = json.loads(f.attrs["petsc_options"])
        assert options["waves_ksp_type"] == "cg"  # the command line wins over the scene
        assert "waves_ts_tpye" in json.loads(f.attrs["petsc_options_unused"])
        assert "seed: 3" in f.attrs["scene"]
        assert f.attrs["ranks"] == ranks


# Defect 8: what "results do not depend on the number of ranks" means, quantity by quantity
# (the manual's table "Rank count", docs/scale.md).  Document a has every slicing, spectral-waves and analysis
# quantity (k_c, power-law p, a_r, l, a_t, a_t_edge finite; two configurations for omega_c_std),
# document b the KPM vDOS with K/Q and TS (Verlet) waves.
RANK_SCENE = """\
output: {out}_a.h5
cache: off
seed: 3
packing: {{n: 64, phi: 0.9, count: 2}}
model: {{rho: [0.2, 2.0]}}
spectrum: {{energies: true, max_window_modes: 100}}
waves: {{n: [1, 2, 3, 4, 5], method: spectral, t_end: 60, sample_every: 5}}
analysis: {{power_law_kd0_max: 3.0, lattice_kd0_max: 2.6}}
---
output: {out}_b.h5
cache: off
seed: 3
packing: {{n: 64, phi: 0.9, count: 2}}
model: {{rho: [1.0]}}
spectrum: {{method: kpm, energies: true, probes: 8}}
waves: {{modes: [TR], n: [1, 2], t_end: 40}}
"""


def contents(path):
    """{key: value} of a results file: datasets as 'group/name', attributes as 'group@name'."""
    out = {}

    def visit(name, obj):
        out.update({f"{name}@{key}": value for key, value in obj.attrs.items()})
        if isinstance(obj, h5py.Dataset):
            out[name] = obj[()]
    with h5py.File(path) as f:
        out.update({f"@{key}": value for key, value in f.attrs.items()})
        f.visititems(visit)
    return out


def fit_sensitivity(path, trials=3):
    """{analysis key: largest |change| per element} when the file's z change by 1e-12 relative
    (random, ``trials`` times) and the analysis is redone: what the fits (curve_fit,
    least_squares) make of a change of the size the rank count makes to z (~1e-13)."""
    import yaml

    from solver.analysis import dispersion
    from solver.io import coerce, schema

    with h5py.File(path) as f:
        spec = coerce.build(schema.Scene, yaml.safe_load(f.attrs["scene"])).analysis
        units = {f"{kind}/{name}": ({key: g[key][()] for key in g}, dict(g.attrs))
                 for kind in ("waves", "vdos") for name, g in f[kind].items()}
    base = dispersion.analyse(units, spec)
    change = {}
    for trial in range(trials):
        rng = np.random.default_rng(trial)
        moved = dispersion.analyse({name: ({**data, "z": data["z"] * (1 + 1e-12 * rng.standard_normal(data["z"].shape))}
                                           if "z" in data else data, attrs)
                                    for name, (data, attrs) in units.items()}, spec)
        for group, (data, attrs) in base.items():
            for sep, values, other in (("/", data, moved[group][0]), ("@", attrs, moved[group][1])):
                for key, value in values.items():
                    if np.asarray(value).dtype.kind == "f":
                        with np.errstate(invalid="ignore"):
                            delta = np.nan_to_num(np.abs(np.asarray(other[key]) - value))
                        change[group + sep + key] = np.maximum(change.get(group + sep + key, 0.0), delta)
    return change


def rank_tolerance(key, ref, got, fit_change):
    """(bound on |got - ref| per element, or "skip" / "exact") for one key, with its reason.

    Float quantities without a rule here fail the test: a new result needs a stated tolerance.
    ``fit_change`` is :func:`fit_sensitivity` of the reference file.
    """
    group, _, name = key.rpartition("@") if "@" in key else key.rpartition("/")
    if name in ("ranks", "group_size", "seconds", "assembly_seconds"):
        return "skip"  # the rank count and grouping themselves; timings
    if name in ("max_relative_residual", "error_estimate", "solver_settings"):
        return "skip"  # describe the solver's path (Krylov subspaces, Lanczos estimate ~1e-14, partitions)
    if name == "scene":  # the validated scene, whose output path differs
        return "scene"
    if np.asarray(ref[key]).dtype.kind not in "fc":
        return "exact"  # counts (n_zero_modes, n_negative_modes, inertia_count, windows, nnz, ...), names
    value = np.asarray(ref[key])  # float or complex (z)
    if key.startswith(("packings/", "matrices/")) or name in ("rho", "amplitude", "dt", "sample_dt", "t_end"):
        return "exact"  # each configuration is made serially by one rank from SeedSequence([seed, i])
    if name in ("omega_max", "dt_limit"):  # top Ritz value, residual 1e-8: error <= (1e-8 lam)^2 / gap
        return 1e-12 * np.abs(value)
    if key.startswith("spectra/") and f"{group}/edges" in ref:  # KPM: the same probes on any rank count
        return "exact" if name == "edges" else 1e-11 * np.nanmax(np.abs(value))  # ~700 Chebyshev steps
    if key.startswith("spectra/"):
        lam = ref[f"{group}/omega"] ** 2
        gap = np.minimum(np.diff(lam, prepend=0.0), np.diff(lam, append=np.inf))
        r = max(ref[f"{group}@max_relative_residual"], got[f"{group}@max_relative_residual"])
        n = ref[f"{group}@n_disks"]
        d = 2 * r * lam / gap  # |e - e'| of the two runs' unit eigenvectors (Davis-Kahan)
        if name == "omega":  # Rayleigh quotients, each within 1e-11 of eigh (test_spectrum)
            return 1e-11 * np.abs(value)
        if name in ("Kx", "Ky", "K", "Q"):  # sum |e^2 - e'^2| / 2N <= 2 |e - e'| / 2N
            return 2 * d / (2 * n) + 1e-13 / (2 * n)
        if name == "participation":  # |dS4| <= 2 d (max w + max w'), max w <= sqrt(S4), S4 = 1 / (N P)
            p, q = value, np.asarray(got[key])
            return 2 * d * (1 / np.sqrt(n * p) + 1 / np.sqrt(n * q)) * n * p * q + 1e-13 * p
    if key.startswith("vdos/"):
        if name == "edges":
            return "exact"
        if name == "density":  # histograms of omegas that agree to 1e-11 (slicing: identical), KPM
            return 1e-11 * np.nanmax(np.abs(value))
        if name == "omega_c":  # the largest omega
            return 1e-11 * np.abs(value)
        if name == "omega_c_std":  # std (ddof 1) of tops that each move by <= 1e-11 omega_c
            return np.sqrt(2) * 1e-11 * ref[f"{group}@omega_c"]
    if key.startswith("waves/"):
        if name in ("t", "k", "n", "omega"):
            return "exact"  # sample times, wave numbers, the frequency grid
        if name in ("z", "z_fixed", "C", "S"):  # round-off of MatMult sums; spectral: ~200 Lanczos steps
            spectral = "spectral" in str(ref[f"{group}@integrator"])
            return (1e-10 if spectral else 1e-12) * np.nanmax(np.abs(value))
        if name == "energy_drift":  # |E - E0| / E0, a difference of energies that agree to 1e-12
            return np.full(value.shape, 1e-11)
    if key.startswith("analysis/"):
        if name in ("k", "k_small", "k_large", "kd0_max_used", "rho_values"):
            return "exact"  # wave numbers of the grid, inputs
        if name == "omega_c":
            return 1e-11 * np.abs(value)
        # Fits (curve_fit, least_squares; k_c interpolates the fitted omega of RT and TR): a 1e-12
        # relative change of z moves well-conditioned fitted values by <= 1.1e-7 and their error
        # bars by <= 7e-7 (stopping tolerances ~1.5e-8); an ill-conditioned fit (a Lorentzian peak
        # narrower than the frequency grid) by far more: each element is held to 1e-6 (1e-5 for
        # error bars) or 10x what that change does to it
        return np.maximum((1e-5 if name.endswith("_err") else 1e-6) * np.abs(value), 10 * fit_change[key])
    raise AssertionError(f"{key}: no stated rank-count tolerance")


@pytest.fixture(scope="session")
def rank_runs(tmp_path_factory):
    """``run(name, ranks, *words)``: RANK_SCENE run once per (ranks, words) in the session by
    ``rotsound run`` on that many ranks; returns (stdout, the output files' stem).  The rank-count
    and grouping tests compare against the same runs (each costs 5-15 s of process start and
    work), so they share them."""
    done = {}

    def run(ranks, *words):
        if (ranks, words) not in done:
            stem = tmp_path_factory.mktemp("rank_scene") / f"r{ranks}"
            scene = write(stem.parent, RANK_SCENE.format(out=stem), "scene.yaml")
            proc = run_cli(["run", scene, *words], ranks, timeout=300)
            assert proc.returncode == 0, proc.stderr
            done[ranks, words] = proc.stdout, stem
        return done[ranks, words]
    return run


@pytest.mark.spawns_ranks
def test_results_do_not_depend_on_rank_count(rank_runs):
    """The same scene on 1, 2 and 3 ranks (3 oversubscribed; 3 sub-intervals per slicing window):
    every dataset and attribute agrees to the tolerance rank_tolerance states for it."""
    _, stem = rank_runs(1)
    refs = {doc: contents(f"{stem}_{doc}.h5") for doc in "ab"}
    fit_change = {key: value for doc in "ab" for key, value in fit_sensitivity(f"{stem}_{doc}.h5").items()}
    a = refs["a"]
    for key in ("analysis/rho0.2_RT@k_c", "analysis/rho2_TR@power_law_p", "analysis/lattice@a_r",
                "analysis/lattice@l", "analysis/lattice@a_t", "analysis/lattice@a_t_edge"):
        assert np.isfinite(a[key]), key  # the scene exercises every fitted quantity
    assert a["vdos/r00@omega_c_std"] > 0 and "spectra/r00_p0000/density" in refs["b"]
    for ranks in (2, 3):
        _, stem = rank_runs(ranks)
        for doc, ref in refs.items():
            assert_within_rank_tolerance(contents(f"{stem}_{doc}.h5"), ref, fit_change, (ranks, doc))


def assert_within_rank_tolerance(got, ref, fit_change, what):
    """Every key of two results files' :func:`contents` agrees to :func:`rank_tolerance`."""
    assert sorted(got) == sorted(ref), set(got) ^ set(ref)
    for key in ref:
        bound = rank_tolerance(key, ref, got, fit_change)
        if isinstance(bound, str):
            if bound == "scene":
                assert _without_output(got[key]) == _without_output(ref[key]), key
            elif bound == "exact":
                assert np.array_equal(got[key], ref[key], equal_nan=np.asarray(ref[key]).dtype.kind == "f"), \
                    (what, key)
            continue
        x, y = np.asarray(got[key]), np.asarray(ref[key])
        assert x.shape == y.shape and np.array_equal(np.isnan(x), np.isnan(y)), (what, key)
        with np.errstate(invalid="ignore"):  # equal infinities (dt_limit of spectral waves)
            error = np.where(x == y, 0.0, np.abs(x - y))
        ok = np.isnan(y) | (error <= bound)
        assert np.all(ok), (what, key, float(np.nanmax(error / np.maximum(bound, 1e-300))))


def _without_output(scene):
    return [line for line in str(scene).splitlines() if not line.startswith("output:")]


def test_plot_overlays_several_results(tmp_path, capsys):
    outs = []
    for phi in (0.86, 0.92):  # the results files made in this process; the plot is the command's
        out = tmp_path / f"phi{phi}.h5"
        text = scene_text(out, packing={"n": 64, "phi": phi}, model={"rho": 1}, spectrum={})
        assert main_here(["run", write(tmp_path, text, f"s{phi}.yaml")], capsys)[0] == 0
        outs.append(str(out))
    proc = run_cli(["plot", *outs])
    assert proc.returncode == 0, proc.stderr
    assert "phi0.86_vdos_compare.png" in proc.stdout and (tmp_path / "phi0.86_vdos_compare.pdf").exists()


def test_keys_prints_reference():
    proc = run_cli(["keys"])
    assert proc.returncode == 0 and "`packing.phi`" in proc.stdout


@pytest.mark.spawns_ranks
def test_multi_document_scene_runs_each_in_order(tmp_path, capsys):
    doc = "output: {out}\npacking: {{n: 32, phi: 0.9}}\nmodel: {{rho: 1}}\nspectrum: {{}}\n"
    outs = [tmp_path / "first.h5", tmp_path / "second.h5"]
    path = write(tmp_path, doc.format(out=outs[0]) + "---\n" + doc.format(out=outs[1]), "multi.yaml")
    proc = run_cli(["run", path, "--set", "seed=5"], ranks=2)
    assert proc.returncode == 0, proc.stderr
    assert "== scene 2 of 2" in proc.stdout and all(out.exists() for out in outs)
    for out in outs:
        with h5py.File(out) as f:
            assert "seed: 5" in f.attrs["scene"]
    code, said, err = main_here(["plot", path], capsys)  # in this process: no second process start
    assert code == 0 and "first_vdos.png" in said and "second_vdos.png" in said, err


def test_cache_reuses_units_across_scenes_by_content(tmp_path, capsys):
    """Scene b shares packings and rho = 1 with scene a: those units come from the cache and equal
    what b computes alone; a PETSc option that can change a solve, or --fresh, recomputes.  In
    this process (the cache, not the process, is checked here)."""
    text = ("output: {out}\ncache: {cache}\nseed: 3\npacking: {{n: 64, phi: 0.9, count: 2}}\n"
            "model: {{rho: {rho}}}\nspectrum: {{energies: true}}\nwaves: {{n: [1], method: spectral, t_end: 10}}\n")
    cache = tmp_path / "cache"
    a = write(tmp_path, text.format(out=tmp_path / "a.h5", cache=cache, rho="[0.5, 1.0]"), "a.yaml")
    assert main_here(["run", a], capsys)[0] == 0
    b = write(tmp_path, text.format(out=tmp_path / "b.h5", cache=cache, rho="[1.0, 2.0]"), "b.yaml")
    code, out, err = main_here(["run", b], capsys)
    assert code == 0, err
    assert ("packings 2 from the cache" in out and "spectra 2 computed, 2 from the cache" in out
            and "waves 6 computed, 6 from the cache" in out), out
    alone = write(tmp_path, text.format(out=tmp_path / "alone.h5", cache="off", rho="[1.0, 2.0]"), "alone.yaml")
    assert main_here(["run", alone], capsys)[0] == 0
    with h5py.File(tmp_path / "b.h5") as f, h5py.File(tmp_path / "alone.h5") as g:
        for group in ("spectra", "waves", "packings"):
            for name in g[group]:
                for key in g[group][name]:
                    assert np.array_equal(f[group][name][key][()], g[group][name][key][()]), (group, name, key)
    _, out, _ = main_here(["run", b, "--set", "output=" + str(tmp_path / "c.h5"), "-spectrum_eps_tol", "1e-10"], capsys)
    assert "packings 2 from the cache" in out and "spectra 4 computed" in out, out
    _, out, _ = main_here(["run", b, "--fresh"], capsys)
    assert "from the cache" not in out and "spectra 4 computed" in out, out


def test_version_names_rotsound_petsc_slepc_without_starting_mpi():
    import solver

    proc = run_cli(["--version"])
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == f"rotsound {solver.__version__}"
    assert any(line.startswith("PETSc 3.") for line in lines) and any(line.startswith("SLEPc 3.") for line in lines)
    code = ("import sys\nfrom solver.__main__ import main\ntry:\n    main(['--version'])\nexcept SystemExit as e:\n"
            "    print(e.code, sorted(m for m in ('mpi4py.MPI', 'petsc4py.PETSc', 'slepc4py.SLEPc') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=REPO).stdout
    assert out.splitlines()[-1] == "0 []", out


def test_help_is_plain_text_and_shows_every_command():
    proc = run_cli(["--help"])
    assert proc.returncode == 0, proc.stderr
    assert "``" not in proc.stdout, proc.stdout  # no reStructuredText markup
    for usage in ("rotsound run SCENE.yaml", "rotsound plot RESULTS.h5", "rotsound report RESULTS.h5",
                  "rotsound export RESULTS.h5", "rotsound render EXPORT.vtp", "rotsound keys", "rotsound --version"):
        assert usage in proc.stdout, (usage, proc.stdout)


def test_report_to_an_unwritable_place_is_one_clear_error(tmp_path):
    """A report (or its figures) that cannot be written is bad input: exit 2, one message, no
    traceback (it was an OSError traceback with exit 1)."""
    blocker = tmp_path / "file.txt"
    blocker.write_text("a file, not a folder")
    proc = run_cli(["report", str(REPO / "tests" / "data" / "results_v1.h5"),
                    "--output", str(blocker / "REPRODUCTION.md")])
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("rotsound: error: report output") == 1, proc.stderr
    assert "Traceback" not in proc.stderr
