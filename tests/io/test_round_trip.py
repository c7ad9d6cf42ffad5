"""Every kind of results file rotsound writes, read again by every reader that takes one:
``rotsound plot``, ``rotsound export`` (each format), ``rotsound report``, a scene's
``packing.file``, and the notebook API (``solver.io.results`` and docs/notebook_example.py).

The kinds: frictionless (spectrum with energies, spectral waves), stressed (a frictional LAMMPS
packing with its stored tangential forces: nonhermitian spectrum, exponential waves), damped
(dashpots: pep spectrum), 3D spheres with rolling and twisting springs, modes kept whole, and
an amplitude sweep of LAMMPS's nonlinear waves.
The oracle of the reuse is the spectrum: the packing a results file holds, read back as a
packing file, gives the spectrum stored beside it (cache off, so nothing is taken from a cache).
Serial: the readers are one process each."""

import subprocess
import sys

import h5py
import numpy as np
import pytest
from ase import io as ase_io
from conftest import COMM, REPO, assert_close, ovito_read, scene_of

from solver import pipeline, plots, report
from solver.contact_law import ContactModel
from solver.io import dem_formats, export, hdf5, results

pytestmark = pytest.mark.serial_only

DEM = REPO / "tests" / "data" / "dem"
FRICTIONAL = {"file": str(DEM / "lammps_2d_friction.data"), "contacts": str(DEM / "lammps_2d_friction.contacts"),
              "friction": 1.0}
SMALL = {"n": 64, "phi": 0.9}
SPECTRAL = {"n": [1, 2], "method": "spectral", "t_end": 30, "modes": ["L", "TR"]}

KINDS = {  # kind -> (scene sections, the sections the reuse keeps: only what has a spectrum to compare)
    "frictionless": dict(packing=SMALL, model={"rho": [0.0, 0.5]}, spectrum={"energies": True}, waves=SPECTRAL,
                         transport={"eta": 0.2}),
    "stressed": dict(packing=FRICTIONAL, model={"rho": [2 / 7]}, spectrum={"method": "nonhermitian"},
                     waves={"n": [1], "method": "exponential", "t_end": 10, "modes": ["L"]}),
    "damped": dict(packing=SMALL, model={"rho": [0.5], "damping": {"gamma_n": 0.3, "gamma_t": 0.1}},
                   spectrum={"energies": True}, waves={"n": [1], "method": "spectral", "t_end": 10, "modes": ["TR"]}),
    "spheres": dict(packing={"n": 64, "phi": 0.7, "dim": 3}, model={"rho": [0.5], "rho_roll": 0.2, "rho_twist": 0.1},
                    spectrum={"energies": True}, waves={"n": [1], "method": "spectral", "t_end": 20,
                                                        "modes": ["L", "R"]}, transport={"eta": 0.2}),
    "modes": dict(packing=SMALL, model={"rho": [1.0]}, spectrum={"energies": True},
                  modes={"omega": [1.0], "count": 2, "localised": 1}),
    "finite_amplitude": dict(packing={**SMALL, "friction": 0.3}, model={"rho": [1.0]}, spectrum={"energies": True},
                             waves={"engine": "lammps", "amplitude": [1e-4, 1e-2], "n": [1], "t_end": 10,
                                    "modes": ["TR"]}),
}


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """{kind: path} of each kind's results file, made by its scene."""
    folder = tmp_path_factory.mktemp("kinds")
    paths = {}
    for kind, sections in KINDS.items():
        paths[kind] = folder / f"{kind}.h5"
        pipeline.run(scene_of(paths[kind], cache="off", seed=3, **sections), COMM, [])
    return paths


def _spectra(path) -> dict:
    """{unit name: eigenvalues} of a results file's spectra (omega, or lambda of pep and nonhermitian)."""
    with h5py.File(path, "r") as f:
        return {name: next(g[key][()] for key in ("omega", "lambda", "eigenvalues") if key in g)
                for name, g in f["spectra"].items()}


@pytest.mark.parametrize("kind", KINDS)
def test_packing_file_reuse_gives_the_stored_spectrum(written, tmp_path, kind):
    """The results file as ``packing.file`` of the same model: the same packing (stored tangential
    forces included) hence the same spectrum, eigenvalue by eigenvalue."""
    sections = {key: value for key, value in KINDS[kind].items() if key in ("model", "spectrum")}
    again = tmp_path / "again.h5"
    pipeline.run(scene_of(again, cache="off", seed=3, packing={"file": str(written[kind])}, **sections), COMM, [])
    before, after = _spectra(written[kind]), _spectra(again)
    assert sorted(before) == sorted(after) and before
    for name in before:
        a, b = np.sort_complex(before[name]), np.sort_complex(after[name])
        # atol: eigenvalues near zero (zero modes, overdamped roots) carry the solver's absolute error
        assert_close(b, a, rtol=1e-8, atol=1e-8 * np.abs(a).max(), what=f"{kind} {name}")
    (stored,), (read,) = hdf5.read_packings(str(written[kind])), hdf5.read_packings(str(again))
    assert np.array_equal(stored.positions, read.positions) and np.array_equal(stored.diameters, read.diameters)
    assert (stored.tangential is None) == (kind != "stressed") and (read.tangential is None) == (kind != "stressed")
    if kind == "stressed":
        assert np.array_equal(stored.tangential.pairs, read.tangential.pairs)
        scale = np.abs(stored.tangential.force).max()  # each read projects the force onto the tangent plane again
        assert_close(read.tangential.force, stored.tangential.force, rtol=0, atol=1e-14 * scale, what="stored forces")
        assert stored.tangential.friction == read.tangential.friction == 1.0


@pytest.mark.parametrize("kind", KINDS)
def test_plot_and_report_read_every_kind(written, tmp_path, kind):
    paths = plots.plot_results(str(written[kind]))
    assert paths and all(p.endswith((".png", ".pdf")) for p in paths), paths
    assert any(p.endswith("_diffusivity.png") for p in paths) == ("transport" in KINDS[kind]), paths
    for path in paths:
        with open(path, "rb") as stream:
            head = stream.read(8)
        assert head.startswith((b"\x89PNG", b"%PDF")), (path, head)
    data = report.gather([str(written[kind])])
    assert data is not None


def _points(path: str) -> np.ndarray:
    """The (N, 3) points of an exported file, by a reader of its format (not rotsound's)."""
    if path.endswith(".xyz"):
        return ase_io.read(path, index=0).positions
    if path.endswith(".vtp"):
        from vtkmodules.util.numpy_support import vtk_to_numpy
        from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

        reader = vtkXMLPolyDataReader()
        reader.SetFileName(path)
        reader.Update()
        return vtk_to_numpy(reader.GetOutput().GetPoints().GetData())
    lines = open(path).read().splitlines()  # LAMMPS dump: the first timestep's atoms, by id
    head = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
    columns = lines[head].split()[2:]
    n = int(lines[3])
    rows = np.array([line.split() for line in lines[head + 1:head + 1 + n]])  # str: the element column is a name
    rows = rows[:, [columns.index(c) for c in ("id", "x", "y", "z")]].astype(float)
    return rows[np.argsort(rows[:, 0]), 1:]


@pytest.mark.parametrize("fmt", export.FORMATS)
@pytest.mark.parametrize("kind", KINDS)
def test_export_reads_every_kind(written, tmp_path, kind, fmt):
    """Each format: the packing's particles at the stored positions, and with kept modes a mode's
    frames; read by the format's own readers (ASE, VTK, the dump's text; OVITO's in test_export)."""
    suffix = {"extxyz": ".xyz", "vtp": ".vtp", "lammps-dump": ".dump"}[fmt]
    with results.open_results(str(written[kind])) as f:
        stored = results.packing(f, 0)
    dim = stored["positions"].shape[1]
    out, _ = export.export(str(written[kind]), fmt, str(tmp_path / f"p{suffix}"))
    points = _points(out[0])
    folded = np.mod(stored["positions"], stored["box"])
    # atol: extended XYZ (ASE) writes 8 decimals, a rounding of at most 5e-9 d0; the others keep 1e-9 of the box
    atol = 5e-9 + 1e-12 if fmt == "extxyz" else 1e-9 * stored["box"].max()
    assert_close(points[:, :dim], folded, rtol=0, atol=atol, what=f"{kind} {fmt} positions")
    if fmt == "lammps-dump":  # and by rotsound's own reader of packing.file (2D: 'pp pp ff', an element column)
        raw = dem_formats.read_lammps_dump(out[0])
        assert raw.positions.shape == stored["positions"].shape
        assert_close(raw.positions, folded, rtol=0, atol=atol, what=f"{kind} dump read back: positions")
        assert_close(raw.diameters, stored["diameters"], rtol=1e-15, atol=0, what=f"{kind} dump read back: diameters")
        assert_close(raw.box_hi - raw.box_lo, stored["box"], rtol=1e-15, atol=0, what=f"{kind} dump read back: box")
    if kind == "modes":
        written_frames, what = export.export(str(written[kind]), fmt, str(tmp_path / f"m{suffix}"), mode=0,
                                             frames=4)
        assert "omega" in what and written_frames, what


@pytest.mark.parametrize("kind", KINDS)
def test_notebook_api_reads_every_kind(written, kind):
    """Every reader of ``solver.io.results`` on the file, and docs/notebook_example.py as a process."""
    with results.open_results(str(written[kind])) as f:
        packing = results.packing(f, 0)
        held = results.contents(f)
        readers = [results.vdos, results.mode_energies, results.participation, results.damped_modes,
                   results.binned_energies, results.waves, results.wave_snapshots, results.fits, results.mode_shapes,
                   results.lattice, results.bands, results.packing_summary, results.contact_model,
                   results.packing_friction, results.diffusivity, results.sweeps]
        found = {reader.__name__: reader(f) for reader in readers}
    (read,) = hdf5.read_packings(str(written[kind]))
    assert np.array_equal(packing["positions"], read.positions) and packing["phi"] == read.phi
    assert found["packing_friction"] == (1.0 if kind == "stressed" else None)  # mu of stored forces only
    assert found["contact_model"] == ContactModel() == read.model, "every kind is checked under the defaults"
    assert ("modes" in held) == (kind == "modes") and (len(found["mode_shapes"]) > 0) == (kind == "modes")
    assert bool(found["damped_modes"]) == (kind == "damped")
    assert bool(found["waves"]) == (kind not in ("modes", "finite_amplitude"))  # a sweep's: sweeps
    assert bool(found["sweeps"]) == (kind == "finite_amplitude")
    with_transport = "transport" in KINDS[kind]
    assert ("diffusivity" in held) == with_transport and bool(found["diffusivity"]) == with_transport
    for g in found["diffusivity"].values():  # every non-zero mode once, binned once
        assert g.omega.size == g.d.size == g.count.sum() > 0 and np.all(g.d > 0), (kind, g.count.sum())
    proc = subprocess.run([sys.executable, str(REPO / "docs" / "notebook_example.py"), str(written[kind])],
                          cwd=REPO, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.startswith("holds: "), proc.stderr


def test_ovito_opens_every_kind(written, tmp_path):
    """OVITO itself (its Python module) opens the packing of every kind in every format: every
    particle, its radius, the two sizes as two particle types."""
    suffix = {"extxyz": ".xyz", "vtp": ".vtp", "lammps-dump": ".dump"}
    files = {(kind, fmt): export.export(str(path), fmt, str(tmp_path / f"{kind}{suffix[fmt]}"))[0][0]
             for kind, path in written.items() for fmt in export.FORMATS}
    seen = ovito_read(list(files.values()))["files"]
    for (kind, fmt), path in files.items():
        with results.open_results(str(written[kind])) as f:
            diameters = results.packing(f, 0)["diameters"]
        got = seen[path]
        assert got["count"] == diameters.size, (kind, fmt, got["count"])
        # rtol: OVITO holds the radius in float32
        assert_close(np.array(got["properties"]["Radius"]["values"]), diameters / 2, rtol=1e-6,
                     what=f"{kind} {fmt} radius")
        assert len(got["properties"]["Particle Type"]["types"]) == 2, (kind, fmt)
