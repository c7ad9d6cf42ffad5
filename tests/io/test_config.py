"""Scene validation (io.schema) and scene files (io.scenes): every bad input gives one clear
InputError naming key, value and range."""

import pathlib

import pytest

from solver.io import scenes
from solver.io import coerce, scene_rules, schema
from solver.packing.rules import stored_forces_source
from solver import options
from solver.errors import InputError

pytestmark = pytest.mark.serial_only  # validation alone, no communicator (the catalogue's rows run on 2 ranks)

GOOD = {"output": "out.h5", "seed": 3, "packing": {"n": 64, "phi": 0.9, "count": 2},
        "model": {"rho": [0, 0.5]}, "petsc": {"eps": {"tol": 1e-9}}}


def build(raw):
    return coerce.build(schema.Scene, raw)


def test_good_scene_and_defaults():
    scene = build(GOOD)
    assert scene.packing.n == 64 and scene.packing.force_tol == 1e-6
    assert scene.model.rho == [0.0, 0.5]
    assert build({"packing": {"n": 16, "phi": 0.5}, "model": {"rho": 2}}).model.rho == [2.0]


def test_yaml_exponents_without_a_dot_are_numbers_everywhere():
    """PyYAML reads 1e1 and 2e3 (no dot) as strings: windows and integers take them too."""
    scene = build({"packing": {"n": "2e3", "phi": 0.9, "max_steps": "2e6"}, "spectrum": {"window": [0, "1e1"]}})
    assert (scene.packing.n, scene.packing.max_steps, scene.spectrum.window) == (2000, 2000000, [0.0, 10.0])
    with pytest.raises(InputError, match="packing.n = '2.5e1x': must be an integer"):
        build({"packing": {"n": "2.5e1x", "phi": 0.9}})
    assert build(GOOD).model.rho is not build(GOOD).model.rho, "defaults must not be shared between scenes"


def test_yaml_string_floats_are_numbers():
    scene = build({"packing": {"n": 64, "phi": "0.9", "force_tol": "1e-8"}})
    assert scene.packing.force_tol == 1e-8


@pytest.mark.parametrize("raw, words", [
    ({"packing": {"n": 64, "phi": 1.2}}, ["packing.phi", "1.2", "(0.0, 1.0)"]),
    ({"packing": {"n": 64, "phi": 0.0}}, ["packing.phi", "(0.0, 1.0)"]),
    ({"packing": {"n": 63, "phi": 0.9}}, ["packing.n", "63", "even"]),
    ({"packing": {"n": 8, "phi": 0.9}}, ["packing.n", ">= 16"]),
    ({"packing": {"n": "many", "phi": 0.9}}, ["packing.n", "'many'", "an integer"]),
    ({"packing": {"n": True, "phi": 0.9}}, ["packing.n", "an integer"]),
    ({"packing": {"n": 64}}, ["packing.phi is missing"]),
    ({"packing": {"n": 64, "phi": 0.9, "size": 3}}, ["unknown key packing.size", "n, phi, dim, count"]),
    ({"pakcing": {}}, ["unknown key pakcing: did you mean packing? allowed keys"]),
    ({"packing": {"n": 64, "phi": 0.9}, "spectrum": {"energy": True}},
     ["unknown key spectrum.energy: did you mean spectrum.energies? allowed keys in spectrum are window, "]),
    ({"packing": {"n": 64, "phi": 0.9}, "model": {"rho": -1}}, ["model.rho", "-1", "[0.0"]),
    ({"packing": {"n": 64, "phi": 0.9}, "model": {"rho": []}}, ["model.rho", "must not be empty"]),
    ({"packing": {"n": 64, "phi": 0.9}, "model": {"rho": [1, "x"]}}, ["model.rho", "a number"]),
    ({"packing": {"n": 64, "phi": 0.9}, "model": {"rho": float("nan")}}, ["model.rho", "nan"]),
    ({"packing": {"n": 64, "phi": 0.9}, "seed": -1}, ["seed", "-1"]),
    ({"packing": {"n": 64, "phi": 0.9}, "output": "x.txt"}, ["output", ".h5"]),
    ({"packing": {"n": 64, "phi": 0.9, "count": 0}}, ["packing.count", "0"]),
    ({"packing": {"n": 64, "phi": 0.9, "force_tol": 0}}, ["packing.force_tol"]),
    ({"packing": [1, 2]}, ["packing = [1, 2]: must be a mapping"]),
    ({"packing": {"n": 64, "phi": 0.9}, "petsc": [1]}, ["petsc", "a mapping"]),
    ({"packing": {"n": 64, "phi": 0.9}, "waves": {"modes": [], "n": [1]}}, ["waves.modes", "non-empty"]),
    ({"packing": {"n": 64, "phi": 0.9}, "waves": {"modes": ["X"], "n": [1]}}, ["waves.modes", "L, TR, RT"]),
    ({"packing": {"n": 64, "phi": 0.9}, "waves": {}}, ["waves.n / waves.kd0", "exactly one"]),
    ({"packing": {"n": 64, "phi": 0.9}, "waves": {"n": [1], "kd0": [1.0]}}, ["exactly one"]),
    ({"packing": {"n": 64, "phi": 0.9}, "waves": {"n": [0]}}, ["waves.n", ">= 1"]),
    ({"packing": {"n": 64, "phi": 0.9}, "waves": {"kd0": [7.0]}}, ["waves.kd0", "2 pi"]),
    ({"packing": {"n": 64, "phi": 0.9}, "waves": {"n": [1], "dt": -0.1}}, ["waves.dt"]),
    ({"packing": {"n": 64, "phi": 0.9}, "waves": {"n": [1], "integrator": "leapfrog"}}, ["waves.integrator", "verlet"]),
    ({"packing": {"n": 64, "phi": 0.9}, "waves": {"n": [1], "t_end": 1.0, "sample_every": 50}},
     ["waves.sample_every", "fewer than 4 samples"]),
    ({"packing": {"n": 64, "phi": 0.9}, "waves": {"n": [1], "method": "lanczos"}}, ["waves.method", "one of ts, spectral, exponential"]),
    ({"packing": {"n": 64, "phi": 0.9}, "spectrum": {"window": [3, 2]}}, ["spectrum.window", "omega_lo < omega_hi"]),
    ({"packing": {"n": 64, "phi": 0.9}, "spectrum": {"energies": "yes"}}, ["spectrum.energies", "true or false"]),
    ({"packing": {"n": 64, "phi": 0.9}, "spectrum": {"method": "kpm", "window": [1.0, 2.0]}}, ["window needs method 'slicing'"]),
    ({"packing": {"n": 64, "phi": 0.9}, "spectrum": {"method": "lanczos"}},
     ["spectrum.method", "one of auto, slicing, counting, kpm"]),
    ({"packing": {"n": 64, "phi": 0.9}, "spectrum": {"method": "counting", "window": [1.0, 2.0]}},
     ["method = 'counting' gives the whole vDOS", "window needs method 'slicing'"]),
    ({"packing": {"n": 64, "phi": 0.9}, "spectrum": {"method": "counting", "energies": True}},
     ["method = 'counting' gives mode counts only", "spectrum.energies needs"]),
])
def test_bad_scenes_name_the_key(raw, words):
    with pytest.raises(InputError) as info:
        build(raw)
    for word in words:
        assert word in str(info.value), (word, str(info.value))


def test_optional_sections():
    assert build({"packing": {"n": 16, "phi": 0.9}}).spectrum is None
    assert build({"packing": {"n": 16, "phi": 0.9}, "spectrum": {}}).spectrum.bin_width == 0.05
    waves = build({"packing": {"n": 16, "phi": 0.9}, "waves": {"kd0": [1.19]}}).waves
    assert waves.modes == ["L", "TR", "RT"] and waves.integrator == "verlet"


def test_spectrum_method_auto_chooses_the_cheapest_exact_method_that_fits_the_matrix():
    """A scene keeps auto (its packings may decide it); resolved: only counts asked -> counting;
    eigenvectors or a band -> slicing; dashpots -> pep; stored tangential forces that the matrix
    keeps (a contact file, or those a packing file turns out to hold) or YADE's slip ->
    nonhermitian; an explicit choice stays.  The log line says which and why; the digest is the
    scene's as it alone resolves auto, the same as the resolved scene's."""
    base = {"packing": {"n": 16, "phi": 0.9}}

    def method(spectrum, which=None, **sections):
        scene = build({**base, **sections, "spectrum": spectrum})
        return scene_rules.resolve(scene, which)[0].spectrum.method

    assert build({**base, "spectrum": {}}).spectrum.method == "auto"
    assert method({}) == "counting" and method({"method": "auto"}) == "counting"
    assert method({"energies": True}) == "slicing" and method({"window": [1.0, 2.0]}) == "slicing"
    assert method({"method": "slicing"}) == "slicing" and method({"method": "kpm"}) == "kpm"
    assert method({}, model={"damping": {"gamma_n": 0.1}}) == "pep"
    assert method({}, model={"history": "yade"}) == "nonhermitian"
    stored = "configuration(s) 0 carry stored tangential forces"
    assert method({}, stored) == "nonhermitian" and method({"energies": True}, stored) == "nonhermitian"
    assert method({}, stored, model={"stored_forces": "drop"}) == "counting"
    file = {"packing": {"file": "p.data", "contacts": "p.contacts"}, "model": {"rho": 0.3}}
    scene = build({**file, "spectrum": {}})
    resolved, said = scene_rules.resolve(scene, stored_forces_source(scene.packing))
    assert resolved.spectrum.method == "nonhermitian" and said == (
        "spectrum.method auto -> nonhermitian (packing.contacts gives the packings stored tangential forces, so the "
        "matrix is not symmetric)")
    assert "method: nonhermitian" in resolved.to_yaml() and scene.digest() == resolved.digest()
    assert scene_rules.resolve(resolved, None) == (resolved, None)
    counted = build({**base, "spectrum": {}})
    assert counted.digest() == build({**base, "spectrum": {"method": "counting"}}).digest()


def test_file_only_needs_no_n_phi():
    scene = build({"packing": {"file": "some.h5"}})
    assert scene.packing.n is None and scene.packing.file == "some.h5"


def test_set_overrides_and_errors():
    raw = {"packing": {"n": 64}}
    scenes.set_key(raw, "packing.phi=0.85")
    scenes.set_key(raw, "model.rho=[0.1, 1]")
    assert build(raw).model.rho == [0.1, 1.0]
    with pytest.raises(InputError, match="key.path=value"):
        scenes.set_key(raw, "packing.phi")


def test_digest_ignores_output_and_petsc_block_only():
    """The petsc block keys units through the options acting on them (io/unit_keys.py), not the scene."""
    a = build(GOOD)
    b = build({**GOOD, "output": "elsewhere.h5"})
    p = build({**GOOD, "petsc": {"spectrum_eps_tol": 1e-10}})
    c = build({**GOOD, "seed": 4})
    assert a.digest() == b.digest() == p.digest() != c.digest()


def test_digest_counts_only_what_differs_from_the_defaults():
    """A default written out gives the digest of the scene without it (so a
    key added at its default by a later version keeps an unfinished run resumable); an optional
    section counts when present; any value that differs changes it."""
    a = build(GOOD)
    spelled = build({**GOOD, "model": {**GOOD.get("model", {}), "law": "harmonic", "damping": None},
                     "seed": a.seed})
    waves = build({**GOOD, "waves": {"n": [1]}})
    spelled_waves = build({**GOOD, "waves": {"n": [1], "method": "ts", "dt": 0.02}})
    assert a.digest() == spelled.digest() != waves.digest() == spelled_waves.digest()
    assert build({**GOOD, "model": {**GOOD.get("model", {}), "restitution": 0.9}}).digest() != a.digest()


def test_read_yaml_errors(tmp_path):
    with pytest.raises(InputError, match="not found"):
        scenes.read_documents(str(tmp_path / "missing.yaml"))
    bad = tmp_path / "bad.yaml"
    bad.write_text("packing: {n: 64\n")
    with pytest.raises(InputError, match="invalid YAML"):
        scenes.read_documents(str(bad))
    listy = tmp_path / "list.yaml"
    listy.write_text("- 1\n- 2\n")
    with pytest.raises(InputError, match="top level must be a mapping"):
        scenes.read_documents(str(listy))


def test_multi_document_scenes(tmp_path):
    one = "output: results/{}.h5\npacking: {{n: 64, phi: 0.9}}\n"
    path = tmp_path / "multi.yaml"
    path.write_text(one.format("a") + "---\n" + one.format("b"))
    built = scenes.build_all(str(path), scenes.read_documents(str(path)))
    assert [s.output for s in built] == ["results/a.h5", "results/b.h5"]
    path.write_text(one.format("a") + "---\n" + one.format("a"))
    with pytest.raises(InputError, match="two documents write output 'results/a.h5'"):
        scenes.build_all(str(path), scenes.read_documents(str(path)))
    path.write_text(one.format("a") + "---\n" + one.format("b") + "petsc: {eps_tol: 1e-9}\n")
    with pytest.raises(InputError, match="document 2: petsc options configure the whole run"):
        scenes.build_all(str(path), scenes.read_documents(str(path)))
    path.write_text(one.format("a") + "---\n" + one.format("b") + "sead: 1\n")
    with pytest.raises(InputError, match="document 2: unknown key sead"):
        scenes.build_all(str(path), scenes.read_documents(str(path)))
    path.write_text(one.format("a") + "---\n- 1\n")
    with pytest.raises(InputError, match="document 2: top level must be a mapping"):
        scenes.read_documents(str(path))


def test_petsc_flattening_and_argv_split():
    flat = options.flatten({"eps": {"tol": 1e-9, "type": "krylovschur"}, "log_view": None,
                              "st": {"mat_mumps_icntl_13": 1}, "flag": True})
    assert flat == {"eps_tol": "1e-09", "eps_type": "krylovschur", "log_view": None,
                    "st_mat_mumps_icntl_13": "1", "flag": "true"}
    assert options.to_argv({"eps_tol": "1e-09", "log_view": None}) == ["-eps_tol", "1e-09", "-log_view"]
    ours, theirs = options.split_argv(["run", "s.yaml", "--set", "a=1", "-st_shift", "-0.5", "-log_view"])
    assert ours == ["run", "s.yaml", "--set", "a=1"]
    assert theirs == ["-st_shift", "-0.5", "-log_view"]


def test_reference_lists_every_key():
    keys = [row[0] for row in schema.reference()]
    for key in ("output", "seed", "packing.n", "packing.phi", "packing.count", "packing.file",
                "model.rho", "petsc"):
        assert key in keys


@pytest.mark.parametrize("transport", [{"eta": 0.1}, {"method": "kpm", "probes": 32}])
def test_the_stored_scene_reads_back_as_the_same_scene(transport):
    """The scene a results file stores (``Scene.to_yaml``, every default filled in) builds again
    into the same scene: it leaves out the keys of the transport method not in use, which a
    scene may not write (transport.rules.check_given)."""
    import yaml

    scene = build({**GOOD, "spectrum": {}, "transport": transport, "waves": {"n": [1]}})
    assert build(yaml.safe_load(scene.to_yaml())) == scene


CONFIGS = sorted((pathlib.Path(__file__).resolve().parents[2] / "configs").glob("*.yaml"))


@pytest.mark.parametrize("path", CONFIGS, ids=lambda p: p.name)
def test_every_shipped_scene_file_builds(path):
    """Each scene file in configs/ passes the schema, the rules and the multi-document checks (an
    unknown key, a wrong type or a clash would be an error a user meets first), with one output per
    document; packing files need not exist yet (they are read when the scene runs)."""
    built = scenes.build_all(str(path), scenes.read_documents(str(path)))
    assert built and all(s.output for s in built), f"{path.name}: {len(built)} scenes"
