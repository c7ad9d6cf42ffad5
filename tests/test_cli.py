"""The command line end to end: good runs, bad input on 1 and 2 ranks, PETSc options."""

import json

import h5py
import numpy as np
import pytest
from conftest import run_cli

pytestmark = pytest.mark.serial_only  # these tests launch their own (mpirun) processes

SCENE = """\
output: {out}
cache: off
seed: 2
packing: {{n: 64, phi: 0.9, count: 2}}
model: {{rho: [0, 1]}}
petsc: {{ksp_type: gmres, log_view_not_an_option: null}}
"""


def write(tmp_path, text, name="scene.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("ranks", [1, 2])
def test_run_writes_results_and_reports_unused_options(tmp_path, ranks):
    out = tmp_path / "r.h5"
    scene = write(tmp_path, SCENE.format(out=out))
    proc = run_cli(["run", scene, "--set", "seed=3", "-ksp_type", "cg", "-eps_tpye", "x"], ranks)
    assert proc.returncode == 0, proc.stderr
    assert "wrote" in proc.stdout and str(out) in proc.stdout
    assert proc.stdout.count("wrote") == 1, "rank 1 must not print"
    assert "-eps_tpye was never used" in proc.stdout
    with h5py.File(out) as f:
        assert sorted(f["packings"]) == ["0000", "0001"]
        assert len(f["matrices"]) == 4
        options = json.loads(f.attrs["petsc_options"])
        assert options["ksp_type"] == "cg"  # the command line wins over the scene
        assert "eps_tpye" in json.loads(f.attrs["petsc_options_unused"])
        assert "seed: 3" in f.attrs["scene"]
        assert f.attrs["ranks"] == ranks


def test_results_do_not_depend_on_rank_count(tmp_path):
    files = []
    for ranks in (1, 2):
        out = tmp_path / f"r{ranks}.h5"
        assert run_cli(["run", write(tmp_path, SCENE.format(out=out), f"s{ranks}.yaml")], ranks).returncode == 0
        files.append(h5py.File(out))
    for name in ("0000", "0001"):
        assert (files[0][f"packings/{name}/positions"][()] == files[1][f"packings/{name}/positions"][()]).all()
    for name in files[0]["matrices"]:
        assert files[0][f"matrices/{name}"].attrs["nnz"] == files[1][f"matrices/{name}"].attrs["nnz"]


def test_plot_overlays_several_results(tmp_path):
    outs = []
    for phi in (0.86, 0.92):
        out = tmp_path / f"phi{phi}.h5"
        text = f"output: {out}\npacking: {{n: 64, phi: {phi}}}\nmodel: {{rho: 1}}\nspectrum: {{}}\n"
        assert run_cli(["run", write(tmp_path, text, f"s{phi}.yaml")]).returncode == 0
        outs.append(str(out))
    proc = run_cli(["plot", *outs])
    assert proc.returncode == 0, proc.stderr
    assert "phi0.86_vdos_compare.png" in proc.stdout and (tmp_path / "phi0.86_vdos_compare.pdf").exists()


def test_keys_prints_reference():
    proc = run_cli(["keys"])
    assert proc.returncode == 0 and "`packing.phi`" in proc.stdout


def test_multi_document_scene_runs_each_in_order(tmp_path):
    doc = "output: {out}\npacking: {{n: 32, phi: 0.9}}\nmodel: {{rho: 1}}\nspectrum: {{}}\n"
    outs = [tmp_path / "first.h5", tmp_path / "second.h5"]
    path = write(tmp_path, doc.format(out=outs[0]) + "---\n" + doc.format(out=outs[1]), "multi.yaml")
    proc = run_cli(["run", path, "--set", "seed=5"], ranks=2)
    assert proc.returncode == 0, proc.stderr
    assert "== scene 2 of 2" in proc.stdout and all(out.exists() for out in outs)
    for out in outs:
        with h5py.File(out) as f:
            assert "seed: 5" in f.attrs["scene"]
    proc = run_cli(["plot", path])
    assert proc.returncode == 0 and "first_vdos.png" in proc.stdout and "second_vdos.png" in proc.stdout


def test_cache_reuses_units_across_scenes_by_content(tmp_path):
    """Scene b shares packings and rho = 1 with scene a: those units come from the cache and equal
    what b computes alone; a PETSc option that can change a solve, or --fresh, recomputes."""
    text = ("output: {out}\ncache: {cache}\nseed: 3\npacking: {{n: 64, phi: 0.9, count: 2}}\n"
            "model: {{rho: {rho}}}\nspectrum: {{energies: true}}\nwaves: {{n: [1], method: spectral, t_end: 10}}\n")
    cache = tmp_path / "cache"
    a = write(tmp_path, text.format(out=tmp_path / "a.h5", cache=cache, rho="[0.5, 1.0]"), "a.yaml")
    assert run_cli(["run", a]).returncode == 0
    b = write(tmp_path, text.format(out=tmp_path / "b.h5", cache=cache, rho="[1.0, 2.0]"), "b.yaml")
    proc = run_cli(["run", b])
    assert proc.returncode == 0, proc.stderr
    assert ("packings 2 from the cache" in proc.stdout and "spectra 2 computed, 2 from the cache" in proc.stdout
            and "waves 6 computed, 6 from the cache" in proc.stdout), proc.stdout
    alone = write(tmp_path, text.format(out=tmp_path / "alone.h5", cache="off", rho="[1.0, 2.0]"), "alone.yaml")
    assert run_cli(["run", alone]).returncode == 0
    with h5py.File(tmp_path / "b.h5") as f, h5py.File(tmp_path / "alone.h5") as g:
        for group in ("spectra", "waves", "packings"):
            for name in g[group]:
                for key in g[group][name]:
                    assert np.array_equal(f[group][name][key][()], g[group][name][key][()]), (group, name, key)
    proc = run_cli(["run", b, "--set", "output=" + str(tmp_path / "c.h5"), "-eps_tol", "1e-10"])
    assert "packings 2 from the cache" in proc.stdout and "spectra 4 computed" in proc.stdout, proc.stdout
    proc = run_cli(["run", b, "--fresh"])
    assert "from the cache" not in proc.stdout and "spectra 4 computed" in proc.stdout, proc.stdout
