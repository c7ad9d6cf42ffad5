"""Issue 59's kinds of packing through every stage, as a user runs them: a scene per kind asks for
every output its stages give, and the results file, the figures, the exports and the notebook API
are checked against references that do not share the stage's code.

The kinds (tests/data/dem/README.md for the files):

- ``sheared``: a generated 2D packing in a sheared cell (``packing.shear``, FIRE in the tilted cell);
- ``triclinic``: LAMMPS's frictionless spheres in a triclinic box (lammps_triclinic.data: all three tilts);
- ``walls``: LAMMPS's frictional spheres settled under gravity between two walls in z
  (lammps_3d_walls.*: ``packing.contacts``, ``walls``, ``wall_contacts``, ``gravity``);
- ``mercury``: MercuryDPM's frictional spheres (mercury_3d_friction.data, .fstat).

Each kind's symmetric scene (the frictional files with ``model.stored_forces: drop``, which the
modes and the Allen-Feldman diffusivity need) asks for the spectrum by slicing with energies, a mode
kept whole, the exact diffusivity and, in a tilted cell, standing waves along the reciprocal vector
of x; the frictional files' stressed scene for the non-symmetric spectrum and standing waves (between
the walls along x, the walled z refused); the sheared and walled kinds and LIGGGHTS's dump of the
triclinic state a counted vDOS with the KPM diffusivity.  The references: the dense eigenvalues, the
Allen-Feldman sum and the exact modal sum of a standing wave (``solver.references``) of the matrix
rebuilt from the packing the results file holds (read back as a packing file: at rest, so its stored
forces, walls and gravity are all there); the exports read back by rotsound's dump reader and by
OVITO; brute force over the images for the packet's start between walls."""

import pathlib
import re

import numpy as np
import pytest
import yaml
from conftest import COMM, REPO, assert_all, assert_close, ovito_read, scene_of

from solver import pipeline
from solver.errors import InputError
from solver.io import coerce, dem_formats, export, hdf5, results, schema
from solver.model import dynmat
from solver.references import allen_feldman_dense, dense_eigen, dense_eigenvalues, exact_z_fixed
from solver.waves import excitation

DATA = REPO / "tests" / "data" / "dem"
ETA = 0.05  # transport.eta (1/t0): a few level spacings of these few hundred modes
RHO = 0.5


def _upper_wall() -> float:
    """lammps_3d_walls' upper wall: its data file's zhi (lammps_3d_walls.in puts the wall there)."""
    return float(re.search(r"^0 (\S+) zlo zhi$", (DATA / "lammps_3d_walls.data").read_text(), re.M).group(1))


WALLS = [{"axis": "z", "position": 0.0}, {"axis": "z", "position": _upper_wall()}]
GRAVITY = [0.0, 0.0, -0.002]  # lammps_3d_walls.in's fix gravity, LAMMPS's units

PACKINGS = {
    "sheared": {"n": 64, "phi": 0.9, "shear": 0.1},
    "triclinic": {"file": str(DATA / "lammps_triclinic.data")},
    "walls": {"file": str(DATA / "lammps_3d_walls.data"), "contacts": str(DATA / "lammps_3d_walls.contacts"),
              "friction": 0.5, "walls": WALLS, "wall_contacts": str(DATA / "lammps_3d_walls.walls"),
              "gravity": GRAVITY},
    "mercury": {"file": str(DATA / "mercury_3d_friction.data"), "contacts": str(DATA / "mercury_3d_friction.fstat"),
                "contacts_format": "mercury-fstat", "friction": 0.5},
    "liggghts": {"file": str(DATA / "liggghts_triclinic.dump")},  # LIGGGHTS's dump of the triclinic state
}
KINDS = ("mercury", "sheared", "triclinic", "walls")  # through every stage; liggghts: its counted vDOS
MODEL = {"sheared": {}, "triclinic": {}, "liggghts": {}, "walls": {"stored_forces": "drop"},
         "mercury": {"lever": "contact", "stored_forces": "drop"}}  # MercuryDPM's lever: the overlap's middle
STRESSED = ("walls", "mercury")
TILTED = ("sheared", "triclinic")
WAVES = {"modes": ["L", "TR"], "n": [1], "axes": ["x"], "t_end": 5.0}  # k = the reciprocal vector b_x
PERIODIC = {"sheared": [True, True], "triclinic": [True] * 3, "walls": [True, True, False], "mercury": [True] * 3}


def _run(folder, name: str, kind: str, stressed: bool = False, **sections) -> str:
    """Run a scene of ``kind``'s packing with ``sections`` into ``folder``/``name``.h5, its stored
    forces dropped from the matrix unless ``stressed``. Collective."""
    out = folder / f"{name}.h5"
    model = {"rho": [RHO], **{k: v for k, v in MODEL[kind].items() if not (stressed and k == "stored_forces")}}
    pipeline.run(scene_of(out, cache="off", seed=3, packing=PACKINGS[kind], model=model, **sections), COMM, [])
    return str(out)


@pytest.fixture(scope="module", params=KINDS)
def symmetric(request, tmp_path_factory):
    """(kind, results file) of the kind's symmetric scene: spectrum by slicing with energies, a mode
    near omega = 1 kept whole, the exact Allen-Feldman diffusivity; the tilted kinds' standing waves
    (``WAVES``, by Lanczos). Collective."""
    kind = request.param
    folder = pathlib.Path(COMM.bcast(str(tmp_path_factory.mktemp(kind)) if COMM.rank == 0 else None, root=0))
    waves = {"waves": dict(WAVES, method="spectral")} if kind in TILTED else {}
    return kind, _run(folder, "symmetric", kind, spectrum={"energies": True}, modes={"omega": [1.0]},
                      transport={"eta": ETA}, **waves)


def _stored(path: str):
    """The first packing of results file ``path`` read back as a packing file (equilibrium checked)
    under the scene's model, and that model at RHO."""
    with results.open_results(path) as f:
        model = results.contact_model(f)
        scene = coerce.build(schema.Scene, yaml.safe_load(f.attrs["scene"]))
    return hdf5.read_packings(path, count=1, model=model)[0], scene


def _dense_omega(path: str, comm) -> np.ndarray:
    """Every non-zero mode's omega (ascending, 1/t0; above spectrum.zero_tol) of the matrix at RHO of
    results file ``path``'s stored packing (:func:`_stored`), by dense LAPACK. Collective."""
    p, scene = _stored(path)
    dm = dynmat.assemble(p, scene.model.contact(RHO), comm, scene.model.masses)
    try:
        lam = dense_eigenvalues(dm)
    finally:
        dm.destroy()
    return np.sqrt(lam[lam > scene.spectrum.zero_tol**2])


def test_the_results_file_holds_the_cell_and_rebuilds_at_rest(symmetric):
    """The notebook API gives each kind's cell (tilt, periodic axes), and the packing group reads back
    as a packing at rest (the walls' kind: only with its walls, wall contacts and gravity, which the
    results file must therefore carry)."""
    kind, path = symmetric
    with results.open_results(path) as f:
        given = results.packing(f, 0)
    p, _ = _stored(path)
    assert_all(given["periodic"].tolist() == PERIODIC[kind], f"{kind}: periodic {given['periodic']}")
    assert_close(given["cell"].matrix, p.cell.matrix, rtol=0, atol=0, what="the notebook's cell")
    if kind == "sheared":  # packing.shear: xy = gamma L
        assert_close(given["tilt"], [0.1 * given["box"][0]], rtol=1e-15, atol=0, what="xy = shear L")
    if kind == "triclinic":  # the data file's tilts over its sides xy/lx, xz/lx, yz/ly (no unit in them)
        raw = dem_formats.read_lammps_data(PACKINGS[kind]["file"])
        sides = (raw.box_hi - raw.box_lo)[[0, 0, 1]]
        assert_close(given["tilt"] / given["box"][[0, 0, 1]], raw.tilt / sides, rtol=1e-14, atol=0, what="xy xz yz")
    if kind == "walls":  # the notebook's walls and gravity are the packing's, which the stored forces hold at rest
        assert_close(given["walls"]["axis"], [2, 2], rtol=0, atol=0, what="the walls' axes")
        assert_close(given["walls"]["position"], p.walls.position, rtol=0, atol=0, what="the notebook's walls")
        assert_close(given["gravity"], p.gravity, rtol=0, atol=0, what="the notebook's gravity")
        assert_all(p.walls is not None and p.wall_contacts is not None and p.gravity is not None,
                   "walls, wall contacts and gravity read back from the results file")
        assert_close(p.walls.position / p.box[2], [0.0, 1.0], rtol=1e-14, atol=1e-14,
                     what="the walls at the data file's z bounds (lammps_3d_walls.in)")


def test_the_spectrum_and_modes_are_the_dense_spectrum(symmetric, comm):
    """Slicing's omega of every mode and the kept mode's omega are the dense eigenvalues of the
    matrix rebuilt from the stored packing (its cell, walls and springs as the scene gives them)."""
    kind, path = symmetric
    dense = _dense_omega(path, comm)
    with results.open_results(path) as f:
        omega, participation = results.participation(f)[RHO]
        (shapes,) = results.mode_shapes(f)
    assert_close(np.sort(omega), dense, rtol=1e-9, atol=0, what=f"{kind}: sliced omega")
    assert_all(np.all((participation > 0) & (participation <= 1)), "participation in (0, 1]")
    nearest = dense[np.argmin(np.abs(dense - shapes.omega[0]))]
    assert_close(shapes.omega, [nearest], rtol=1e-9, atol=0, what="the kept mode's omega")


def test_the_exact_diffusivity_is_the_definition_in_the_cell(symmetric, comm):
    """transport's d_n are the Allen-Feldman sum evaluated densely with the positions' nearest images
    in the packing's cell (tilted: through its edge vectors; walled: none across the walls)."""
    kind, path = symmetric
    p, scene = _stored(path)
    dm = dynmat.assemble(p, scene.model.contact(RHO), comm, scene.model.masses)
    try:
        omega, d = allen_feldman_dense(dm, p.positions, p.cell, ETA, zero_tol=scene.transport.zero_tol)
    finally:
        dm.destroy()
    with results.open_results(path) as f:
        got = results.diffusivity(f)[RHO]
    assert_close(got.omega, omega, rtol=1e-9, atol=0, what=f"{kind}: transport's omega")
    assert_close(got.d, d, rtol=1e-7, atol=0, what=f"{kind}: d_n")


@pytest.mark.parametrize("symmetric", TILTED, indirect=True)
def test_standing_waves_run_along_the_reciprocal_vector(symmetric, comm):
    """A tilted kind's standing waves have k = b_x, the cell's reciprocal vector of x (one period along
    x in the cell: |k| = 2 pi / its height across x), and their z(t) is the exact modal sum of the
    stored packing's matrix for that wave vector (``references.exact_z_fixed``: the start
    A sin(k . r) along k for L, across it for TR); k along the x axis itself (2 pi / L_x e_x, the
    orthogonal reading) misses by far more."""
    kind, path = symmetric
    p, scene = _stored(path)
    b = p.cell.reciprocal()[0]
    with results.open_results(path) as f:
        waves = results.waves(f)
    dm = dynmat.assemble(p, scene.model.contact(RHO), comm, scene.model.masses)
    try:
        eig = dense_eigen(dm)
        for mode in WAVES["modes"]:
            w = waves[(RHO, mode)]
            assert_close(w.k, [np.linalg.norm(b)], rtol=1e-14, atol=0, what=f"{kind} {mode}: |k| = |b_x|")
            along_x = [run for run in excitation.runs(mode, p.dim) if run[1] == 0]  # the runs of waves.axes [x]
            assert_all(w.z.shape[:2] == (len(along_x), 1), f"{kind} {mode}: z of shape {w.z.shape}")
            for index, run in enumerate(along_x):
                exact = exact_z_fixed(p, dm, eig, run, b, w.t, scene.waves.amplitude)
                scale = np.abs(exact).max()
                assert_close(w.z[index, 0], exact, rtol=0, atol=1e-7 * scale, what=f"{kind} {mode} run {run}: z(t)")
                orthogonal = exact_z_fixed(p, dm, eig, run, 2 * np.pi / p.box[0], w.t, scene.waves.amplitude)
                assert_all(np.abs(orthogonal - w.z[index, 0]).max() > 1e-3 * scale,
                           f"{kind} {mode}: the orthogonal k misses by only {np.abs(orthogonal - w.z[index, 0]).max()}")
    finally:
        dm.destroy()


@pytest.mark.serial_only  # rank 0's files and figures, and OVITO's process (test_export's reason)
def test_figures_and_exports_carry_the_cell(symmetric, tmp_path, monkeypatch):
    """Every figure of the file passes tests/figures.py's checks; rotsound report takes the file (its
    phi and N among the sources; the paper's claims are not measured on one rho); each export of the packing carries
    the cell: the dump read back by rotsound's reader (tilt, boundary flags, positions),
    extxyz and the dump by OVITO (its cell matrix and periodic flags)."""
    from figures import assert_figures, capture

    from solver import plots, report

    kind, path = symmetric
    figures = capture(monkeypatch, stems=True)  # what plot_results draws and writes, checked without a second draw
    written = plots.plot_results(path)
    assert_figures(figures, written)
    with results.open_results(path) as f:
        given = results.packing(f, 0)
    written, _ = report.write([path], str(tmp_path / "report.md"))  # rotsound report: the file among its sources
    with open(written, encoding="utf-8") as text:
        source = f"symmetric.h5` | {given['phi']:.3f} | {len(given['diameters'])} |"  # its path relative to the report
        assert source in text.read(), source
    files = {fmt: export.export(path, fmt, str(tmp_path / name))[0][0]
             for fmt, name in (("extxyz", "e.xyz"), ("lammps-dump", "e.dump"), ("vtp", "e.vtp"))}
    raw = dem_formats.read_lammps_dump(files["lammps-dump"])
    dim = given["positions"].shape[1]
    assert raw.boundary[:dim] == tuple("pp" if axis else "ff" for axis in given["periodic"]), raw.boundary
    np.testing.assert_allclose(raw.tilt if raw.tilt is not None else 0.0, given["tilt"], rtol=0, atol=1e-15)
    np.testing.assert_allclose(raw.positions[:, :dim], given["positions"], rtol=0, atol=1e-13)
    seen = ovito_read([files["extxyz"], files["lammps-dump"]])["files"]
    matrix = np.eye(3)
    matrix[:dim, :dim] = given["cell"].matrix
    for fmt in ("extxyz", "lammps-dump"):
        cell = np.array(seen[files[fmt]]["cell"])[:dim, :dim]
        np.testing.assert_allclose(cell, given["cell"].matrix, rtol=0, atol=1e-12, err_msg=f"{kind} {fmt}")
        assert seen[files[fmt]]["pbc"][:dim] == given["periodic"].tolist(), (fmt, seen[files[fmt]]["pbc"])
    if kind == "walls":  # the dump's f bounds are walls when rotsound reads it again, where the scene put them
        back = hdf5.read_packings(files["lammps-dump"], check_equilibrium=False)[0]
        np.testing.assert_allclose(back.walls.position, [0.0, given["box"][2]], rtol=0, atol=1e-13)


@pytest.mark.parametrize("kind", ["sheared", "walls", "liggghts"])
def test_the_counted_vdos_and_kpm_diffusivity(kind, shared_tmp, comm):
    """spectrum.method counting gives the dense spectrum's histogram on its bins (exact counts by
    inertia), and transport.method kpm estimates that many modes in all.  LIGGGHTS's dump of the
    triclinic state (its bounding box and tilts) reads as LAMMPS's data file of it."""
    path = _run(shared_tmp, "counted", kind, spectrum={"method": "counting"},
                transport={"method": "kpm", "probes": 4})
    p, _ = _stored(path)
    omega = _dense_omega(path, comm)
    with results.open_results(path) as f:
        (vdos,) = results.vdos(f).values()
        d = results.diffusivity(f)[RHO]
    counts, _ = np.histogram(omega, vdos.edges)
    assert_close(vdos.density * np.diff(vdos.edges) * omega.size, counts, rtol=1e-12, atol=1e-9,
                 what=f"{kind}: counted modes per bin")
    assert_close(d.count.sum(), omega.size, rtol=0.02, atol=0, what="kpm's estimated number of modes")
    if kind == "liggghts":
        lammps = hdf5.read_packings(PACKINGS["triclinic"]["file"])[0]
        assert_close(p.cell.matrix, lammps.cell.matrix, rtol=1e-7, atol=0, what="LIGGGHTS's cell (its %g digits)")


@pytest.mark.parametrize("kind", STRESSED)
def test_a_stressed_file_gives_its_spectrum_and_waves(kind, shared_tmp, monkeypatch):
    """With their stored forces kept, the frictional files give the non-symmetric spectrum (every
    eigenvalue: stable, zero and unstable add up to the DOF) and their standing waves (between the
    walls along x, k = 2 pi / L_x), and their figures pass tests/figures.py's checks."""
    axes = ["x"] if kind == "walls" else None
    path = _run(shared_tmp, "stressed", kind, stressed=True, spectrum={"energies": True},
                waves={"modes": ["L", "TR"], "n": [1], "axes": axes, "t_end": 5.0})
    p, scene = _stored(path)
    with results.open_results(path) as f:
        (vdos,) = results.vdos(f).values()
        waves = results.waves(f)
    assert_close(np.sum(vdos.density * np.diff(vdos.edges)), 1.0, rtol=1e-12, atol=0, what="vDOS area")
    for (rho, mode), w in waves.items():
        assert_close(w.k, [2 * np.pi / p.box[0]], rtol=1e-14, atol=0, what=f"{mode}'s k")
        assert_all(np.all(np.isfinite(w.z)) and np.abs(w.z[:, :, 0]).min() > 0, f"{mode}: z(t) from its start")
    if COMM.rank == 0:
        from figures import assert_figures, capture

        from solver import plots

        figures = capture(monkeypatch, stems=True)  # as in test_figures_and_exports_carry_the_cell
        written = plots.plot_results(path)
        assert_figures(figures, written)


@pytest.mark.parametrize("axes", [["z"], None], ids=["z", "every-axis"])
def test_waves_across_the_walls_are_refused(axes, shared_tmp):
    """Standing waves run along periodic axes only: waves along the walled z, or along every axis (the
    default), are refused naming the axis before any matrix is built."""
    with pytest.raises(InputError, match="walls along z"):
        _run(shared_tmp, "refused", "walls", stressed=True, waves={"modes": ["L"], "n": [1], "axes": axes})
    assert_all(not (shared_tmp / "refused.h5").exists(), "no results file")


def test_the_packet_between_walls_starts_without_images_across_them(comm):
    """The spreading packet on the walls' packing (its unstressed springs): the start region holds the
    non-rattlers within the radius of a centre near the lower wall through the images along x and y
    only (brute force; with images along z too it would also hold spheres under the upper wall), and
    the packet's energy is conserved."""
    import itertools

    from solver.contact_law import ContactModel
    from solver.transport import packet

    keys = PACKINGS["walls"]
    p = hdf5.read_packings(keys["file"], contacts=keys["contacts"], friction=keys["friction"], walls=keys["walls"],
                           wall_contacts=keys["wall_contacts"], gravity=keys["gravity"])[0]
    centre, radius = np.array([1.0, 1.0, 0.5]), 2.5
    dm = dynmat.assemble(p, ContactModel(RHO, stored_forces="drop"), comm)
    try:
        _, at = packet.spreading(dm, p.positions, p.cell, band=(1.0, 2.0), centre=centre, radius=radius,
                                 times=np.linspace(0.0, 2.0, 5), seed=5, comm=comm, tol=1e-10)
    finally:
        dm.destroy()

    def inside(shifts):
        images = np.array(list(itertools.product(*shifts)), dtype=float) @ p.cell.matrix.T
        distance = np.linalg.norm((p.positions - centre)[:, None, :] + images[None], axis=2).min(axis=1)
        return int(((distance <= radius) & ~p.rattler).sum())

    walled, through = inside([[-1, 0, 1], [-1, 0, 1], [0]]), inside([[-1, 0, 1]] * 3)
    assert_all(at["start_particles"] == walled != through,
               f"{at['start_particles']} start particles; brute force {walled} (through the walls {through})")
    assert_close(at["energy_drift"], 0.0, rtol=0, atol=1e-8, what="the packet's energy drift")
