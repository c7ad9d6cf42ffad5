"""The catalogue of bad inputs: one row per case, each run by tests/io/test_bad_inputs.py and
rendered into the manual (docs/bad_inputs.md) by scripts/tools/render_bad_inputs.py (with the message the
program really prints).  Here, beside its renderer, and not among the tests: both import it
(``from scripts.tools.bad_inputs import CASES, materialise``), neither through the other.

A case is (what, scene text or None, extra command-line words, expected message fragment,
file maker or None).  ``{out}`` in a scene is the output path, ``{file}`` the made packing file;
:func:`materialise` makes a case's files and command line.
"""

import pathlib
import shutil

import h5py
import numpy as np

GOOD = "packing: {n: 64, phi: 0.9}\n"
DEM = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data" / "dem"  # files made by the DEM codes


def _dem(name, keep=lambda text: text):
    """A maker: the committed DEM file ``name``, its text passed through ``keep``."""
    def make(path):
        if keep is None:
            shutil.copyfile(DEM / name, path)
        else:
            pathlib.Path(path).write_text(keep((DEM / name).read_text()))
    return make


def _stressed(keep=lambda lines: lines):
    """A maker: the 2D frictional LAMMPS packing at ``path`` and its contact file at
    ``path.contacts``, whose entry lines (after 'ITEM: ENTRIES') are passed through ``keep``."""
    def make(path):
        shutil.copyfile(DEM / "lammps_2d_friction.data", path)
        lines = (DEM / "lammps_2d_friction.contacts").read_text().splitlines()
        head = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ENTRIES")) + 1
        pathlib.Path(f"{path}.contacts").write_text("\n".join(lines[:head] + keep(lines[head:])) + "\n")
    return make


def _yade(name):
    """A maker: YADE's frictional packing ``name`` (.spheres) at ``path``, its contacts at ``path.contacts``."""
    def make(path):
        shutil.copyfile(DEM / f"{name}.spheres", path)
        shutil.copyfile(DEM / f"{name}.contacts", f"{path}.contacts")
    return make


def _mercury(keep_data=lambda lines: lines, keep_fstat=lambda lines: lines):
    """A maker: MercuryDPM's frictional packing (.data) at ``path``, its .fstat at ``path.fstat``,
    their lines passed through ``keep_data`` and ``keep_fstat``."""
    def make(path):
        for name, to, keep in (("data", path, keep_data), ("fstat", f"{path}.fstat", keep_fstat)):
            lines = (DEM / f"mercury_3d_friction.{name}").read_text().splitlines()
            pathlib.Path(to).write_text("\n".join(keep(lines)) + "\n")
    return make


def _walled(flags="pp pp ff", wall_lines=None, head="# id wall fx fy fz\n"):
    """A maker: the committed 3D LAMMPS dump with boundary ``flags`` at ``path`` and, when given,
    the wall contact file ``wall_lines`` ('id wall fx fy fz') after ``head`` at ``path.walls``."""
    def make(path):
        text = (DEM / "lammps_3d.dump").read_text().replace("BOX BOUNDS pp pp pp", f"BOX BOUNDS {flags}")
        pathlib.Path(path).write_text(text)
        if wall_lines is not None:
            pathlib.Path(f"{path}.walls").write_text(head + wall_lines)
    return make


WALL_DUMP = ("ITEM: TIMESTEP\n1\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS pp pp ff\n-1.5 4\n2 6.6\n0.25 4.3\n"
             "ITEM: ATOMS id v_wall v_fx v_fy v_fz\n1 0 0.0 0.0 0.1\n")  # a one-contact wall contact dump


def _walled_crystal(path):
    """A 2D square crystal of 4 x 3 equal disks (spacing 0.99) pressed between walls at y = 0 and
    y = 2.96 (overlaps 0.01 everywhere): at rest, periodic in x only (docs/walls.md)."""
    x, y = np.meshgrid(0.99 * np.arange(4), 0.49 + 0.99 * np.arange(3), indexing="ij")
    with h5py.File(path, "w") as f:
        f["positions"] = np.column_stack((x.ravel(), y.ravel()))
        f["diameters"] = np.ones(12)
        f.attrs["box"] = [3.96, 2.96]
        f["walls/axis"] = np.array([1, 1])
        f["walls/position"] = np.array([0.0, 2.96])


def _sheared(path):
    """A maker: LAMMPS's sheared frictional packing (lammps_3d_sheared) at ``path``, its contacts at ``path.contacts``."""
    shutil.copyfile(DEM / "lammps_3d_sheared.data", path)
    shutil.copyfile(DEM / "lammps_3d_sheared.contacts", f"{path}.contacts")


MERCURY = "packing: {file: '{file}', contacts: '{file}.fstat', contacts_format: mercury-fstat, friction: 0.5}\n"


def _renamed(lines, column, value):
    """``lines`` with the first entry's ``column`` set to ``value``."""
    row = lines[0].split()
    row[column] = value
    return [" ".join(row)] + lines[1:]


def _valid(path, dim=2, **changes):
    from solver.packing import jammed

    p = jammed.generate(64, 0.9 if dim == 2 else 0.7, np.random.SeedSequence([1, 0]), dim=dim)
    data = {"positions": p.positions, "diameters": p.diameters, "box_length": p.box_length}
    data.update(changes)
    with h5py.File(path, "w") as f:
        for key in ("positions", "diameters"):
            if data[key] is not None:
                f[key] = data[key]
        if data["box_length"] is not None:
            f.attrs["box_length"] = data["box_length"]
        if "tilt" in data:
            f.attrs["tilt"] = data["tilt"]


def _mixed(path):
    _valid(path)
    _valid(f"{path}.3d.h5", dim=3)


def _truncated(path):
    _valid(path)
    with open(path, "r+b") as f:
        f.truncate(800)


def _garbage(path):
    with open(path, "wb") as f:
        f.write(b"not an HDF5 file at all")


def _spread(path, dim=2):
    from solver.packing import jammed

    p = jammed.generate(64, 0.9 if dim == 2 else 0.7, np.random.SeedSequence([1, 0]), dim=dim)
    _valid(path, dim, positions=3 * p.positions, box_length=3 * p.box_length)


def _with_masses(path, scale):
    _valid(path)
    with h5py.File(path, "r+") as f:
        f["masses"] = scale * np.ones(64)


def _rectangular(path):
    """The 64-disk packing and its copy side by side: a valid packing in a (2L, L) box."""
    from solver.packing import jammed

    p = jammed.generate(64, 0.9, np.random.SeedSequence([1, 0]))
    with h5py.File(path, "w") as f:
        f["positions"] = np.concatenate([p.positions, p.positions + [p.box_length, 0.0]])
        f["diameters"] = np.tile(p.diameters, 2)
        f.attrs["box"] = [2 * p.box_length, p.box_length]


def _coincident(path, everywhere=False):
    """Disks 4 and 9 on one centre (or, ``everywhere``, all 64 at the origin)."""
    _valid(path)
    with h5py.File(path, "r+") as f:
        positions = f["positions"][()]
        if everywhere:
            positions[:] = 0.0
        else:
            positions[9] = positions[4]
        f["positions"][...] = positions


def _nan(path):
    _valid(path)
    with h5py.File(path, "r+") as f:
        f["positions"][3, 0] = np.nan


WET = "model: {cohesion: {surface_tension: 0.002, volume: 1.0e-3}}\n"


def _wet(change=None):
    """A maker: a wet 64-disk packing (phi 0.86, the bridges of WET) saved by rotsound, its group
    passed through ``change`` (an h5py group -> None) when given."""
    def make(path):
        from solver.capillary import Cohesion
        from solver.io import hdf5
        from solver.packing import jammed

        p = jammed.generate(64, 0.86, np.random.SeedSequence([1, 0]),
                            cohesion=Cohesion(surface_tension=0.002, volume=1e-3))
        hdf5.save_packings(path, [p])
        if change is not None:
            with h5py.File(path, "r+") as f:
                change(f["packings/0000"])
    return make


def _liggghts_wet(path):
    """A maker: LIGGGHTS's wet packing at ``path``, its contact file at ``path.contacts``."""
    shutil.copyfile(DEM / "liggghts_3d_wet.data", path)
    shutil.copyfile(DEM / "liggghts_3d_wet.contacts", f"{path}.contacts")


LIGGGHTS_WET = "packing: {file: '{file}', contacts: '{file}.contacts', contacts_format: liggghts-local}\n"


def _far_bridge(group):
    """A bridge between particle 0 and the one farthest from it across the periodic box."""
    positions, box = group["positions"][()], group.attrs["box"]
    delta = positions - positions[0]
    far = int(np.argmax(np.linalg.norm(delta - box * np.rint(delta / box), axis=1)))
    pairs = np.concatenate((group["bridges"][()].reshape(-1, 2), [[0, far]]))
    del group["bridges"]
    group["bridges"] = pairs


CASES = [
    # --- YAML and scene keys
    ("YAML syntax error", "packing: {n: 64, phi: 0.9\n", [], "invalid YAML", None),
    ("top level is not a mapping", "- 1\n- 2\n", [], "top level must be a mapping", None),
    ("empty scene", "", [], "packing.n is missing", None),
    ("unknown top-level key", GOOD + "outptu: x.h5\n", [], "unknown key outptu", None),
    ("unknown nested key", "packing: {n: 64, phi: 0.9, size: 3}\n", [], "unknown key packing.size", None),
    ("misspelt key (near miss)", GOOD + "spectrum: {energy: true}\n", [],
     "unknown key spectrum.energy: did you mean spectrum.energies? allowed keys in spectrum are", None),
    ("a section given a number", GOOD + "model: {damping: 0.3}\n", [], "model.damping = 0.3: must be a mapping", None),
    ("N not an integer", "packing: {n: many, phi: 0.9}\n", [], "packing.n = 'many': must be an integer", None),
    ("N a boolean", "packing: {n: true, phi: 0.9}\n", [], "packing.n = True: must be an integer", None),
    ("N odd", "packing: {n: 63, phi: 0.9}\n", [], "packing.n = 63: must be an even integer >= 16", None),
    ("N too small for the box", "packing: {n: 8, phi: 0.9}\n", [], "packing.n = 8: must be an even integer >= 16", None),
    ("phi <= 0", "packing: {n: 64, phi: 0}\n", [], "packing.phi = 0: must be in (0.0, 1.0)", None),
    ("phi >= 1", "packing: {n: 64, phi: 1.2}\n", [], "packing.phi = 1.2: must be in (0.0, 1.0)", None),
    ("phi not a number", "packing: {n: 64, phi: dense}\n", [], "packing.phi = 'dense': must be a number", None),
    ("dimension not 2 or 3", "packing: {n: 64, phi: 0.9, dim: 4}\n", [], "packing.dim = 4: must be 2 or 3", None),
    ("n given without phi", "packing: {n: 64}\n", [], "packing.phi is missing", None),
    ("count 0", "packing: {n: 64, phi: 0.9, count: 0}\n", [], "packing.count = 0", None),
    ("force tolerance 0", "packing: {n: 64, phi: 0.9, force_tol: 0}\n", [], "packing.force_tol = 0", None),
    ("negative rho", GOOD + "model: {rho: -0.5}\n", [], "model.rho = -0.5: must be in [0.0", None),
    ("rho list with a word", GOOD + "model: {rho: [1, high]}\n", [], "model.rho = 'high': must be a number", None),
    ("empty rho list", GOOD + "model: {rho: []}\n", [], "model.rho = []: must not be empty", None),
    ("twisting spring in 2D", GOOD + "model: {rho: 1, rho_twist: 0.1}\n", [],
     "model.rho_twist = 0.1: twisting resistance needs spheres in 3D", None),
    ("twisting spring on a 2D packing file", "packing: {file: '{file}'}\nmodel: {rho: 1, rho_twist: 0.1}\n", [],
     "twisting resistance needs spheres in 3D, but packing.file", _valid),
    ("negative rolling stiffness", GOOD + "model: {rho_roll: -1}\n", [], "model.rho_roll = -1: must be in [0.0", None),
    ("negative seed", GOOD + "seed: -1\n", [], "seed = -1", None),
    ("output not HDF5", GOOD + "output: results.txt\n", [], "output = 'results.txt': must end in .h5", None),
    ("spectrum window reversed", GOOD + "spectrum: {window: [4, 2]}\n", [], "spectrum.window", None),
    ("unknown spectrum method", GOOD + "spectrum: {method: lanczos}\n", [], "spectrum.method = 'lanczos'", None),
    ("counting with energies", GOOD + "spectrum: {method: counting, energies: true}\n", [],
     "method = 'counting' gives mode counts only", None),
    ("factorisations shared by ranks for slicing", GOOD + "spectrum: {method: slicing, factor_ranks: 2}\n", [],
     "spectrum.factor_ranks = 2: the ranks sharing each factorisation of method 'counting'", None),
    ("factor ranks not dividing the ranks", GOOD + "spectrum: {method: counting, factor_ranks: 3}\n", [],
     "spectrum.factor_ranks = 3: must divide the", None),
    ("factor ranks 0", GOOD + "spectrum: {method: counting, factor_ranks: 0}\n", [],
     "spectrum.factor_ranks = 0: must be in [1", None),
    ("factor ranks a word", GOOD + "spectrum: {method: counting, factor_ranks: many}\n", [],
     "spectrum.factor_ranks = 'many': must be auto or a whole number", None),
    ("KPM with a window", GOOD + "spectrum: {method: kpm, window: [1.0, 2.0]}\n", [], "window needs method 'slicing'", None),
    ("two documents, one output", GOOD + "---\n" + GOOD + "output: {out}\n", [],
     "two documents write output", None),
    ("petsc block in a later document", GOOD + "---\n" + GOOD + "output: other.h5\npetsc: {eps_tol: 1e-9}\n", [],
     "document 2: petsc options configure the whole run", None),
    ("analysis window out of range", GOOD + "analysis: {decay_window: 0}\n", [], "analysis.decay_window = 0", None),
    ("energies not a boolean", GOOD + "spectrum: {energies: maybe}\n", [], "spectrum.energies = 'maybe'", None),
    ("empty mode list", GOOD + "waves: {modes: [], n: [1]}\n", [], "waves.modes = []", None),
    ("unknown mode", GOOD + "waves: {modes: [L, SH], n: [1]}\n", [], "from L, TR, RT, R", None),
    ("twist wave R in 2D", GOOD + "waves: {modes: [L, R], n: [1]}\n", [], "mode R (angular velocity along k) needs 3D",
     None),
    ("both n and kd0", GOOD + "waves: {n: [1], kd0: [1.0]}\n", [], "give exactly one of them", None),
    ("neither n nor kd0", GOOD + "waves: {modes: [L]}\n", [], "give exactly one of them", None),
    ("wave number n = 0", GOOD + "waves: {n: [0]}\n", [], "waves.n = [0]", None),
    ("k outside the Brillouin zone", GOOD + "waves: {kd0: [7.0]}\n", [], "waves.kd0 = [7.0]", None),
    ("k not fitting the box", GOOD + "waves: {n: [40]}\n", [], "waves.n = 40: k d0", None),
    ("dt above the stability limit", GOOD + "model: {rho: 1}\nwaves: {n: [1], dt: 0.5}\n", [],
     "waves.dt = 0.5: above the stability limit", None),
    ("unknown integrator", GOOD + "waves: {n: [1], integrator: leapfrog}\n", [], "waves.integrator = 'leapfrog'", None),
    ("too few samples", GOOD + "waves: {n: [1], t_end: 1, sample_every: 50}\n", [], "fewer than 4 samples", None),
    ("bare solver option in the petsc block", GOOD + "petsc: {eps_tol: 1.0e-9}\n", [],
     "PETSc option -eps_tol: acts on no solver", None),
    ("bare solver option on the command line (-ts_dt)", GOOD, ["--set", "seed=1", "-ts_dt", "0.6"],
     "did you mean -waves_ts_dt?", None),
    ("PETSc value of an odd type", GOOD + "petsc: {eps_tol: 2024-01-01}\n", [], "petsc.eps_tol", None),
    # --- generated packings that do not jam (before: SLEPc died of SIGFPE on a 0-DOF matrix)
    ("packing does not jam (spectrum)", "packing: {n: 256, phi: 0.8}\nspectrum: {}\n", [],
     "packing.phi = 0.8: configuration 0 did not jam: all 256 disks are rattlers", None),
    ("packing does not jam (spectral waves)", "packing: {n: 256, phi: 0.8}\nmodel: {rho: 1}\n"
     "waves: {n: [1], method: spectral}\n", [],
     "packing.phi = 0.8: configuration 0 did not jam: all 256 disks are rattlers", None),
    ("3D packing does not jam (no contacts)", "packing: {n: 64, phi: 0.3, dim: 3}\nspectrum: {}\n", [],
     "packing.phi = 0.3: configuration 0 did not jam: all 64 spheres are rattlers", None),
    ("3D box smaller than two diameters (generated)", "packing: {n: 16, phi: 0.9, dim: 3}\n", [],
     "packing.n = 16, packing.phi = 0.9: the 3D box would have side L = 2.16", None),
    # --- HDF5 packing files
    ("packing file missing", "packing: {file: nowhere.h5}\n", [], "packing file nowhere.h5: not found", None),
    ("packing file of no known format", "packing: {file: '{file}'}\n", [], "unknown format; the formats read are",
     _garbage),
    ("packing file truncated", "packing: {file: '{file}'}\n", [], "not a readable HDF5 file", _truncated),
    ("positions missing", "packing: {file: '{file}'}\n", [], "no 'positions' dataset",
     lambda p: _valid(p, positions=None)),
    ("box missing", "packing: {file: '{file}'}\n", [],
     "attribute 'box' (the (D,) side lengths) or 'box_length' (one side of a square or cubic box) is missing",
     lambda p: _valid(p, box_length=None)),
    ("positions of the wrong shape (N, 4)", "packing: {file: '{file}'}\n", [],
     "'positions' has shape (64, 4); need (64, 2) (disks) or (64, 3) (spheres)",
     lambda p: _valid(p, positions=np.zeros((64, 4)))),
    ("NaN positions", "packing: {file: '{file}'}\n", [], "'positions' contains NaN", _nan),
    ("two particles on one centre", "packing: {file: '{file}'}\n", [],
     "particles 4 and 9 (0-based, in the order read) have the same centre", _coincident),
    ("every particle at one point", "packing: {file: '{file}'}\n", [],
     "particles 0 and 1 (0-based, in the order read) have the same centre", lambda p: _coincident(p, True)),
    ("negative diameters", "packing: {file: '{file}'}\n", [], "'diameters' must be finite and > 0",
     lambda p: _valid(p, diameters=-np.ones(64))),
    ("box smaller than two diameters", "packing: {file: '{file}'}\n", [], "must be finite and > 2 max(diameters)",
     lambda p: _valid(p, box_length=2.0)),
    ("no contacts (not jammed)", "packing: {file: '{file}'}\n", [], "all disks are rattlers", _spread),
    ("3D file: box smaller than two diameters", "packing: {file: '{file}'}\n", [],
     "must be finite and > 2 max(diameters)", lambda p: _valid(p, 3, box_length=2.0)),
    ("3D file: no contacts (not jammed)", "packing: {file: '{file}'}\n", [],
     "no sphere has 4 or more contacts (not a jammed packing: all spheres are rattlers)", lambda p: _spread(p, 3)),
    ("files mixing 2D and 3D packings", "packing: {file: ['{file}', '{file}.3d.h5']}\n", [],
     "the files mix disks (2D) and spheres (3D)", _mixed),
    ("not in mechanical equilibrium (e.g. made with friction)", "packing: {file: '{file}'}\n", [],
     "not in mechanical equilibrium under the harmonic normal contact forces alone",
     lambda p: _valid(p, box_length=100.0)),
    ("unknown contact law", GOOD + "model: {law: hooke}\n", [], "model.law = 'hooke': must be one of harmonic, hertz",
     None),
    ("unknown packing engine", GOOD.replace("}", ", engine: gromacs}"), [],
     "packing.engine = 'gromacs': must be one of fire, lammps", None),
    ("unknown mass rule", GOOD + "model: {masses: heavy}\n", [], "model.masses = 'heavy': must be one of equal, density",
     None),
    ("packing file with non-positive masses", "packing: {file: '{file}'}\n", [],
     "'masses' (shape (64,)) must be (64,), finite and > 0", lambda p: _with_masses(p, -1.0)),
    ("waves.n on a rectangular box", "packing: {file: '{file}'}\nwaves: {n: [1]}\n", [],
     "66.7 % apart, more than the 1 % over which runs are pooled; set waves.axes", _rectangular),
    ("waves.axes with z in 2D", GOOD + "waves: {n: [1], axes: [x, z]}\n", [],
     "waves.axes = ['x', 'z']: axis z needs 3D", None),
    ("waves.axes repeated", GOOD + "waves: {n: [1], axes: [x, x]}\n", [],
     "must be a non-empty list of distinct axes from x, y, z", None),
    # --- walls and gravity (docs/walls.md)
    ("walls without a packing file", GOOD.replace("}", ", walls: [{axis: y, position: 0.0}]}"), [],
     "packing.walls: walls and gravity belong to a packing read from packing.file", None),
    ("wall not given as axis and position", "packing: {file: '{file}', walls: [{axis: z}]}\n", [],
     "each wall is a mapping with the keys axis and position", _walled()),
    ("wall through a particle", "packing: {file: '{file}', walls: [{axis: z, position: 2.0}]}\n", [],
     "the wall z = 2 goes through the packing", _walled()),
    ("wall on a periodic axis", "packing: {file: '{file}', walls: [{axis: z, position: 0.25}]}\n", [],
     "wall 0 (z = 0.25) stands on the periodic axis z", _walled("pp pp pp")),
    ("gravity along a periodic axis", "packing: {file: '{file}', gravity: [0.1, 0.0, -1.0]}\n", [],
     "packing.gravity has the component 0.1 along the periodic axis x", _walled()),
    ("gravity with no wall to hold it", "packing: {file: '{file}', gravity: [0.0, 0.0, 1.0]}\n", [],
     "packing.gravity pulls along z (1) but no wall on that side holds the packing", _walled("pp pp fm")),
    ("wall contact naming a missing particle", "packing: {file: '{file}', wall_contacts: '{file}.walls'}\n", [],
     "atom id 9999 is not in the packing file", _walled(wall_lines="9999 0 0.0 0.0 0.1\n")),
    ("wall contact naming a missing wall", "packing: {file: '{file}', wall_contacts: '{file}.walls'}\n", [],
     "names wall 7, but the packing has 2 wall(s)", _walled(wall_lines="1 7 0.0 0.0 0.1\n")),
    ("wall contact dump with two frames", "packing: {file: '{file}', wall_contacts: '{file}.walls'}\n", [],
     "a dump ('ITEM:' lines) with 2 frames; a wall contact dump holds one frame, the step of the packing file",
     _walled(wall_lines=2 * WALL_DUMP, head="")),
    ("waves along a walled axis", "packing: {file: '{file}'}\nmodel: {rho: [0.5]}\nwaves: {n: [1], axes: [y]}\n", [],
     "configuration 0 is bounded by walls along y, which is not periodic: standing waves run along periodic axes "
     "only; give waves.axes from x", _walled_crystal),
    # --- packing files of LAMMPS, LIGGGHTS and YADE (tests/data/dem)
    ("unknown packing.format", GOOD.replace("}", ", format: xyz}"), [],
     "packing.format = 'xyz': must be one of rotsound, lammps-data, lammps-dump, yade, mercury, or null", None),
    ("LAMMPS data file with a tilt beyond half a side", "packing: {file: '{file}'}\n", [],
     "the triclinic box's tilt xy = -2.8 is beyond half the side L_x = 5.5",
     _dem("lammps_triclinic.data", lambda text: text.replace("-1.3 0.9 -0.8 xy xz yz", "-2.8 0.9 -0.8 xy xz yz"))),
    ("2D LAMMPS data file tilted along z (xz or yz)", "packing: {file: '{file}'}\n", [],
     "in 2D only xy shears the cell, so xz and yz must be 0",
     _dem("lammps_2d.data", lambda text: text.replace("1.25 11 ylo yhi", "1.25 11 ylo yhi\n0.75 0.5 0 xy xz yz"))),
    ("triclinic LAMMPS file with walls across its tilt", "packing: {file: '{file}', walls: [{axis: z, position: -50}]}\n",
     [], "the triclinic box's tilt xz = 0.902532 shears across axis z, which has walls",
     _dem("lammps_triclinic.data", None)),
    ("LAMMPS data file cut short", "packing: {file: '{file}'}\n", [],
     "the Atoms section has 117 atom lines where the header says 128 atoms",
     _dem("lammps_3d.data", lambda text: text[:len(text) // 2])),
    ("LAMMPS dump without the packing's columns", "packing: {file: '{file}'}\n", [],
     "lack diameter or radius, x y z", _dem("lammps_3d_friction.forces", None)),
    ("LAMMPS packing made with friction", "packing: {file: '{file}'}\n", [],
     "normal contact forces alone: the largest net normal force on a non-rattler is 5.062e-02",
     _dem("lammps_3d_friction.data", None)),
    ("contact file naming an atom not in the packing", "packing: {file: '{file}', contacts: '{file}.contacts'}\n",
     [], "atom id 9999 is not in the packing file",
     _stressed(lambda lines: _renamed(lines, 1, "9999"))),
    ("contact file cut short", "packing: {file: '{file}', contacts: '{file}.contacts'}\n", [],
     "entry lines where 'ITEM: NUMBER OF ENTRIES' says", _stressed(lambda lines: lines[:-5])),
    ("contact pair that carries a force but does not touch",
     "packing: {file: '{file}', contacts: '{file}.contacts'}\n", [],
     "carry a force but do not touch", _stressed(lambda lines: _renamed(_renamed(lines, 1, "1"), 2, "128"))),
    ("stored force above the Coulomb limit", "packing: {file: '{file}', contacts: '{file}.contacts', friction: 0.1}\n",
     [], "above the Coulomb limit mu f_n with mu = packing.friction = 0.1", _stressed()),
    ("YADE contacts with more than one kn",
     "packing: {file: '{file}', contacts: '{file}.contacts', contacts_format: yade}\n"
     "model: {lever: contact, history: yade}\nspectrum: {method: nonhermitian}\n", [],
     "kn = |normalForce| / overlap differs between contacts", _yade("yade_3d_friction")),
    ("YADE contacts under the Hertz law",
     "packing: {file: '{file}', contacts: '{file}.contacts', contacts_format: yade}\n"
     "model: {law: hertz, lever: contact, history: yade}\nspectrum: {method: nonhermitian}\n", [],
     "YADE's FrictPhys contacts are linear", _yade("yade_3d_friction_uniform")),
    ("YADE contacts under LAMMPS's history",
     "packing: {file: '{file}', contacts: '{file}.contacts', contacts_format: yade}\nmodel: {lever: contact}\n", [],
     "set model.lever: contact and model.history: yade", _yade("yade_3d_friction_uniform")),
    ("LAMMPS contact file read as YADE's",
     "packing: {file: '{file}', contacts: '{file}.contacts', contacts_format: yade}\n"
     "model: {lever: contact, history: yade}\nspectrum: {method: nonhermitian}\n", [],
     "is a LAMMPS/LIGGGHTS dump ('ITEM:' lines), not YADE's table", _stressed()),
    ("unknown stored-force history", GOOD + "model: {history: liggghts}\n", [],
     "model.history = 'liggghts': must be one of lammps, yade", None),
    ("YADE's history with a symmetric-only spectrum",
     GOOD + "model: {history: yade}\nspectrum: {method: slicing}\n", [],
     "model.history: yade takes YADE's tangential slip", None),
    ("frictional packing without its contact file", "packing: {file: '{file}'}\n", [],
     "give its stored tangential forces with its contact file, packing.contacts", _stressed()),
    ("a symmetric-only spectrum on a stressed packing",
     "packing: {file: '{file}', contacts: '{file}.contacts'}\nspectrum: {method: counting}\n", [],
     "slicing, counting and kpm need a symmetric matrix", None),
    ("spectral waves on a stressed packing",
     "packing: {file: '{file}', contacts: '{file}.contacts'}\nwaves: {n: [1], method: spectral}\n", [],
     "has no orthogonal eigendecomposition: use waves.method: exponential (exact) or ts", None),
    ("nonhermitian spectrum too large for the dense solver",
     "packing: {n: 8192, phi: 0.9}\nspectrum: {method: nonhermitian, solver: dense}\n", [],
     "more than the 20000 the dense solver of method nonhermitian takes", None),
    ("a nonhermitian solver for another method", GOOD + "spectrum: {method: counting, solver: windows}\n", [],
     "spectrum.solver = 'windows' chooses how methods nonhermitian and pep find every eigenvalue", None),
    ("sliding contacts without their mu", "packing: {n: 64, phi: 0.9}\nmodel: {mobilised: slide}\n", [],
     "model.mobilised = 'slide': which contacts are at the Coulomb limit needs their mu", None),
    ("pressure without friction", "packing: {n: 64, phi: 0.82, pressure: 0.01}\n", [],
     "packing.pressure = 0.01: the pressure at which LAMMPS holds a frictional packing", None),
    ("a shear beyond LAMMPS's limit", "packing: {n: 64, phi: 0.9, shear: 0.7}\n", [],
     "packing.shear = 0.7: must be in [-0.5, 0.5]", None),
    ("a shear step beyond its limit", "packing: {n: 64, phi: 0.9, shear: 0.2, shear_step: 0.1}\n", [],
     "packing.shear_step = 0.1: must be in (0.0, 0.05]", None),
    ("a sheared cell too narrow for its particles", "packing: {n: 20, phi: 0.7, dim: 3, shear: 0.5}\n", [],
     "tilted by packing.shear = 0.5, a height of 2.263, not more than two large diameters", None),
    ("a shear on a packing file", "packing: {file: '{file}', shear: 0.2}\n", [],
     "packing.shear = 0.2: the shear of a packing rotsound's FIRE generates", _valid),
    ("LAMMPS's waves in a sheared cell", "packing: {n: 64, phi: 0.9, shear: 0.2, friction: 0.5}\n"
     "waves: {engine: lammps, n: [1], amplitude: 1.0e-4}\n", [],
     "waves.engine: lammps: packing.shear = 0.2 tilts the cell, and LAMMPS's finite-amplitude waves run in an "
     "orthogonal box only", None),
    ("LAMMPS's waves on a triclinic packing file", "packing: {file: '{file}', contacts: '{file}.contacts', "
     "friction: 0.5}\nwaves: {engine: lammps, n: [1], amplitude: 1.0e-4}\n", [],
     "waves.engine: lammps: configuration 0 is in a tilted cell (xy = 0.720845, xz = 0, yz = 0)", _sheared),
    ("a packing file whose tilt is beyond half a side", "packing: {file: '{file}'}\n", [],
     "attribute 'tilt' = [9.0]: tilt xy = 9 is beyond half the side L_x",
     lambda path: _valid(path, tilt=np.array([9.0]))),
    ("friction on rotsound's FIRE", "packing: {n: 64, phi: 0.82, friction: 0.5}\n", [],
     "packing.friction = 0.5: the Coulomb mu of a frictional packing", None),
    ("MercuryDPM data file whose counts disagree", MERCURY + "model: {lever: contact}\n", [],
     "frame 0 (header at line 1) has 199 particle lines where its header says N = 200",
     _mercury(keep_data=lambda lines: lines[:5] + lines[6:])),
    ("MercuryDPM contact listed from one side", MERCURY + "model: {lever: contact}\n", [],
     "is not listed once from each side (MercuryDPM writes every contact twice",
     _mercury(keep_fstat=lambda lines: lines[:4] + lines[5:])),
    ("MercuryDPM packing under LAMMPS's lever", MERCURY, [],
     "set model.lever: contact and model.history: lammps", _mercury()),
    ("MercuryDPM contacts under the Hertz law", MERCURY + "model: {law: hertz, lever: contact}\n", [],
     "MercuryDPM's linear species (force k * overlap) are read with model.law: harmonic", _mercury()),
    # --- capillary bridges (model.cohesion)
    ("bridges without a surface tension", GOOD + "model: {cohesion: {volume: 1.0e-3}}\n", [],
     "model.cohesion.surface_tension is required", None),
    ("negative surface tension", GOOD + "model: {cohesion: {surface_tension: -0.1, volume: 1.0e-3}}\n", [],
     "model.cohesion.surface_tension = -0.1: must be in (0.0", None),
    ("contact angle of 90 degrees or more", GOOD + "model: {cohesion: {surface_tension: 0.01, volume: 1.0e-3, "
     "contact_angle: 1.6}}\n", [], "model.cohesion.contact_angle = 1.6: must be in [0.0, 1.57", None),
    ("non-finite bridge volume", GOOD + "model: {cohesion: {surface_tension: 0.01, volume: .inf}}\n", [],
     "model.cohesion.volume = inf: must be in (0.0", None),
    ("bridge volume and liquid content both given", GOOD + "model: {cohesion: {surface_tension: 0.01, volume: 1.0e-3, "
     "liquid_content: 0.01}}\n", [], "model.cohesion.volume and model.cohesion.liquid_content: give exactly one", None),
    ("neither bridge volume nor liquid content", GOOD + "model: {cohesion: {surface_tension: 0.01}}\n", [],
     "got neither", None),
    ("unknown bridge law", GOOD + "model: {cohesion: {law: rabinovich, surface_tension: 0.01, volume: 1.0e-3}}\n", [],
     "model.cohesion.law = 'rabinovich': must be one of willett, soulie", None),
    ("a box too small for the bridges", "packing: {n: 16, phi: 0.86}\nmodel: {cohesion: {surface_tension: 0.002, "
     "volume: 1.0}}\n", [], "a wet packing's box side L = 3.875 d0 must exceed 2 (d + s_c) = 4.333 d0", None),
    ("bridges on LAMMPS's packing engine", "packing: {n: 64, phi: 0.9, engine: lammps}\n" + WET, [],
     "model.cohesion (capillary bridges) with packing.engine: lammps", None),
    ("bridges with a contact file", "packing: {file: '{file}', contacts: '{file}.contacts'}\n" + WET, [],
     "that contact file gives no bridged pairs apart", _stressed()),
    ("bridges with LAMMPS's waves", GOOD + WET + "waves: {engine: lammps, amplitude: 1.0e-4, n: [1]}\n", [],
     "with waves.engine: lammps: LAMMPS's waves have no bridges", None),
    ("a wet packing file read dry", "packing: {file: '{file}'}\n", [],
     "a wet packing (dataset 'bridges'), but the scene is dry", _wet()),
    ("a dry packing file read wet", "packing: {file: '{file}'}\n" + WET, [],
     "model.cohesion asks for a wet packing, but the file has no dataset 'bridges'", _valid),
    ("a wet packing under another law", "packing: {file: '{file}'}\nmodel: {cohesion: {surface_tension: 0.004, "
     "volume: 1.0e-3}}\n", [], "the packing was made with the bridges", _wet()),
    ("a bridge beyond its rupture distance", "packing: {file: '{file}'}\n" + WET, [],
     "bridge(s) span a gap at or beyond the rupture distance", _wet(_far_bridge)),
    ("LIGGGHTS's bridges beyond the rupture distance of the scene's law", LIGGGHTS_WET + "model: {rho: [1.0], "
     "lever: contact, cohesion: {law: soulie, surface_tension: 0.005, liquid_content: 0.001}}\n", [],
     "bridge(s) span a gap at or beyond the rupture distance", _liggghts_wet),
    ("LIGGGHTS's wet packing read dry", LIGGGHTS_WET + "model: {lever: contact}\n", [],
     "a wet packing's bridges are pairs apart too: LIGGGHTS lists them; read it with model.cohesion", _liggghts_wet),
    ("negative dashpot rate", GOOD + "model: {damping: {gamma_n: -0.3}}\n", [],
     "model.damping.gamma_n = -0.3: must be in [0.0", None),
    ("an undamped spectrum method with dashpots", GOOD + "model: {damping: {gamma_n: 0.3}}\n"
     "spectrum: {method: slicing}\n", [], "spectrum.method = 'slicing' with model.damping: it solves the undamped", None),
    ("an undamped spectrum method with a coefficient of restitution", GOOD + "model: {restitution: 0.8}\n"
     "spectrum: {method: slicing}\n", [], "spectrum.method = 'slicing' with model.restitution: it solves the undamped "
     "problem; the damped modes (lambda^2 M + lambda C + D) x = 0 need spectrum.method: pep (or auto); the undamped "
     "vDOS of the same packing: drop model.restitution from this scene", None),
    ("damped modes without dashpots", GOOD + "spectrum: {method: pep}\n", [],
     "spectrum.method = 'pep': the damped modes need dashpots", None),
    ("damped windows on a stressed packing", "packing: {file: '{file}', contacts: '{file}.contacts'}\n"
     "model: {damping: {gamma_n: 0.3}}\nspectrum: {method: pep}\n", [],
     "give spectrum.solver: dense (up to 8000 DOF)", _stressed()),
    ("damped-mode bands for another method", GOOD + "spectrum: {method: slicing, frequencies: [1.0]}\n", [],
     "spectrum.frequencies = [1.0]: bands of damped modes, for method 'pep'", None),
    ("damped modes too large for the dense solver", "packing: {n: 4096, phi: 0.9}\nmodel: {damping: {gamma_n: 0.3}}\n"
     "spectrum: {solver: dense}\n", [], "more than the 8000 the dense solver of method pep takes", None),
    ("Verlet waves with dashpots", GOOD + "model: {damping: {gamma_n: 0.3}}\nwaves: {n: [1]}\n", [],
     "has no velocity-dependent force", None),
    ("damped spectral waves asked for an unreachable tol", GOOD + "model: {damping: {gamma_n: 0.3}}\n"
     "waves: {n: [1], method: spectral, tol: 1e-14, t_end: 400}\n", [],
     "waves.tol = 1e-14: the damped spectral path cannot bound its error below 1e-14", None),
    ("restitution and gamma_n both", GOOD + "model: {restitution: 0.8, damping: {gamma_n: 0.3}}\n", [],
     "model.restitution = 0.8: it sets model.damping.gamma_n, which is given too", None),
    ("restitution under Hertz", GOOD + "model: {restitution: 0.8, law: hertz}\n", [],
     "the coefficient of restitution depends on the impact speed", None),
    ("mode shapes without target frequencies", GOOD + "modes: {count: 2}\n", [],
     "modes.omega is missing: give the target frequencies", None),
    ("mode shapes at a zero frequency", GOOD + "modes: {omega: [0.0, 1.0]}\n", [],
     "modes.omega = [0.0, 1.0]: must be a non-empty list of frequencies > 0", None),
    ("localised modes without per-mode energies", GOOD + "spectrum: {}\nmodes: {localised: 2}\n", [],
     "modes.localised = 2: the participation ratios of every mode come from the spectrum", None),
    ("wave snapshots on the TS path", GOOD + "waves: {n: [1], snapshots: [1.0]}\n", [],
     "waves.snapshots = [1.0]: velocity fields of the spectral path", None),
    ("wave snapshots after t_end", GOOD + "waves: {n: [1], method: spectral, t_end: 10, snapshots: [20.0]}\n", [],
     "at times up to waves.t_end = 10.0", None),
    ("wave snapshots with dashpots", GOOD + "model: {damping: {gamma_n: 0.3}}\n"
     "waves: {n: [1], method: spectral, snapshots: [1.0]}\n", [], "waves.snapshots with model.damping", None),
    ("mode shapes with dashpots", GOOD + "model: {damping: {gamma_n: 0.3}}\nmodes: {omega: [1.0]}\n", [],
     "modes with model.damping: modes keeps the undamped eigenvectors of D", None),
    ("mode shapes with a coefficient of restitution", GOOD + "model: {restitution: 0.8}\nmodes: {omega: [1.0]}\n", [],
     "modes with model.restitution: modes keeps the undamped eigenvectors of D", None),
    ("wave snapshots with a coefficient of restitution", GOOD + "model: {restitution: 0.8}\n"
     "waves: {n: [1], method: spectral, snapshots: [1.0]}\n", [],
     "waves.snapshots with model.restitution: the snapshots come from the undamped Lanczos path; drop waves.snapshots, "
     "or model.restitution to see the undamped wave", None),
    ("mode shapes of a stressed packing", "packing: {file: '{file}', contacts: '{file}.contacts'}\n"
     "modes: {omega: [1.0]}\n", [], "so the dynamical matrix is not symmetric and its modes are not the", _stressed()),
    ("diffusivity without eta", GOOD + "transport: {}\n", [], "transport.eta is missing: give the Lorentzian half-width",
     None),
    ("diffusivity with eta = 0", GOOD + "transport: {eta: 0}\n", [], "transport.eta = 0: must be in (0.0, 1000.0]",
     None),
    ("diffusivity with a non-finite eta", GOOD + "transport: {eta: .inf}\n", [], "transport.eta = inf: must be in (0.0",
     None),
    ("diffusivity by an unknown method", GOOD + "transport: {eta: 0.1, method: kubo}\n", [],
     "transport.method = 'kubo': must be one of exact, kpm", None),
    ("diffusivity bins unlike the vDOS's", GOOD + "spectrum: {bin_width: 0.05}\ntransport: {eta: 0.1, bin_width: 0.1}\n",
     [], "d(omega) is kept on the vDOS's bins", None),
    ("diffusivity with dashpots", GOOD + "model: {damping: {gamma_n: 0.3}}\ntransport: {eta: 0.1}\n", [],
     "transport with model.damping: the Allen-Feldman diffusivity is that of the undamped modes", None),
    ("diffusivity with a coefficient of restitution", GOOD + "model: {restitution: 0.8}\ntransport: {eta: 0.1}\n", [],
     "transport with model.restitution: the Allen-Feldman diffusivity is that of the undamped modes of a conserved "
     "harmonic energy; with dashpots the energy decays and the modes are damped; drop model.restitution from this "
     "scene", None),
    ("diffusivity with restitution and tangential dashpots", GOOD + "model: {restitution: 0.8, damping: {gamma_t: 0.1}}\n"
     "transport: {eta: 0.1}\n", [], "drop model.restitution and model.damping from this scene", None),
    ("diffusivity of a stressed packing", "packing: {file: '{file}', contacts: '{file}.contacts'}\n"
     "transport: {eta: 0.1}\n", [], "no conserved harmonic energy and no orthogonal modes", _stressed()),
    ("eta with the kpm diffusivity", GOOD + "transport: {method: kpm, eta: 0.1}\n", [],
     "method 'kpm' broadens the Allen-Feldman sum by the bin", None),
    ("an exact key with the kpm diffusivity", GOOD + "transport: {method: kpm, block: 200}\n", [],
     "transport.block = 200 is a key of method 'exact'", None),
    ("a kpm key with the exact diffusivity", GOOD + "transport: {eta: 0.1, probes: 64}\n", [],
     "transport.probes = 64 is a key of method 'kpm'", None),
    ("a kpm key at its default with the exact diffusivity", GOOD + "transport: {eta: 0.1, probes: 16}\n", [],
     "transport.probes = 16 is a key of method 'kpm'; transport.method is 'exact': drop it", None),
    ("one probe for the kpm diffusivity", GOOD + "transport: {method: kpm, probes: 1}\n", [],
     "transport.probes = 1: must be in [2", None),
    ("a low-frequency window at omega_top = 0", GOOD + "transport: {eta: 0.1, omega_top: 0}\n", [],
     "transport.omega_top = 0: must be in (0.0, 1000.0]", None),
    ("a low-frequency window with the kpm diffusivity", GOOD + "transport: {method: kpm, omega_top: 0.5}\n", [],
     "transport.omega_top = 0.5 is a key of method 'exact'; transport.method is 'kpm': drop it", None),
    ("a low-frequency window below the first bin", GOOD + "transport: {eta: 0.01, omega_top: 0.02}\n", [],
     "transport.omega_top = 0.02 is below the first bin's top edge 0.05", None),
    ("exact diffusivity beyond its scratch", "packing: {n: 100000, phi: 0.9}\ntransport: {eta: 0.01}\n", [],
     "eigenvectors take 671 GiB of scratch files", None),
    ("finite-amplitude waves with amplitude 0", GOOD + "waves: {engine: lammps, n: [1], amplitude: 0}\n", [],
     "waves.amplitude = 0: must be in (0.0, 1.0]", None),
    ("finite-amplitude waves with a non-finite amplitude", GOOD + "waves: {engine: lammps, n: [1], amplitude: .nan}\n",
     [], "waves.amplitude = nan: must be in (0.0, 1.0]", None),
    ("a sweep of amplitudes of the linear waves", GOOD + "waves: {n: [1], amplitude: [1e-4, 1e-3]}\n", [],
     "waves.amplitude = [0.0001, 0.001]: a sweep of amplitudes needs waves.engine: lammps", None),
    ("an empty sweep of amplitudes", GOOD + "waves: {engine: lammps, n: [1], amplitude: []}\n", [],
     "waves.amplitude = []: must not be empty", None),
    ("a sweep with a negative amplitude", GOOD + "waves: {engine: lammps, n: [1], amplitude: [0.001, -0.001]}\n", [],
     "waves.amplitude = [0.001, -0.001]: must be in (0.0, 1.0]", None),
    ("an unknown waves engine", GOOD + "waves: {engine: yade, n: [1]}\n", [],
     "waves.engine = 'yade': must be one of rotsound, lammps", None),
    ("the LAMMPS engine with rotsound's own method", "packing: {n: 64, phi: 0.9, friction: 0.3}\n"
     "waves: {engine: lammps, method: spectral, n: [1]}\n", [],
     "waves.method = 'spectral' with waves.engine: lammps: LAMMPS integrates the waves with its own velocity "
     "Verlet", None),
    ("the LAMMPS engine with rotsound's own integrator", "packing: {n: 64, phi: 0.9, friction: 0.3}\n"
     "waves: {engine: lammps, integrator: rk, n: [1]}\n", [], "waves.integrator = 'rk' with waves.engine: lammps",
     None),
    ("the LAMMPS engine without a Coulomb coefficient", GOOD + "waves: {engine: lammps, n: [1]}\n", [],
     "waves.engine: lammps needs packing.friction, the Coulomb coefficient mu > 0 of the contacts LAMMPS moves "
     "(packing.friction: missing or null)", None),
    ("the LAMMPS engine with a Coulomb coefficient of 0", "packing: {n: 64, phi: 0.9, friction: 0}\n"
     "waves: {engine: lammps, n: [1]}\n", [], "mu > 0 of the contacts LAMMPS moves (packing.friction: 0)", None),
    ("the LAMMPS engine with rolling springs", "packing: {n: 64, phi: 0.7, dim: 3, friction: 0.3}\n"
     "model: {rho_roll: 0.1}\nwaves: {engine: lammps, n: [1]}\n", [],
     "rolling and twisting springs (rho_roll = 0.1, rho_twist = 0) need LAMMPS's pair granular: set "
     "model.history: granular and model.lever: contact", None),
    ("the LAMMPS engine's pair granular under the hertz law", "packing: {n: 64, phi: 0.7, dim: 3, friction: 0.3}\n"
     "model: {rho_roll: 0.1, law: hertz, lever: contact, history: granular}\nwaves: {engine: lammps, n: [1]}\n", [],
     "model.law = 'hertz' with model.history: granular: LAMMPS's pair granular keeps its rolling and twisting "
     "stiffnesses", None),
    ("a rolling limit without pair granular", "packing: {n: 64, phi: 0.7, dim: 3, friction: 0.3}\n"
     "waves: {engine: lammps, n: [1], rolling_friction: 0.1}\n", [],
     "waves.rolling_friction = 0.1 with waves.engine: lammps and model.history: lammps: it limits LAMMPS's rolling "
     "and twisting springs", None),
    ("a twisting limit of 0", "packing: {n: 64, phi: 0.7, dim: 3, friction: 0.3}\n"
     "model: {rho_twist: 0.1, lever: contact, history: granular}\nwaves: {engine: lammps, n: [1], "
     "twisting_friction: 0}\n", [], "waves.twisting_friction = 0: must be in (0.0, 10000.0]", None),
    ("the LAMMPS engine with YADE's history", "packing: {n: 64, phi: 0.9, friction: 0.3}\n"
     "model: {history: yade}\nwaves: {engine: lammps, n: [1]}\n", [],
     "LAMMPS's gran/*/history takes the tangential force at the radius, with its own history", None),
    ("the LAMMPS engine with density masses", "packing: {n: 64, phi: 0.9, friction: 0.3}\n"
     "model: {masses: density}\nwaves: {engine: lammps, n: [1]}\n", [],
     "model.masses = 'density' with waves.engine: lammps", None),
    ("contact records with the linear waves", GOOD + "waves: {n: [1], contacts_every: 5}\n", [],
     "waves.contacts_every = 5 with waves.engine: rotsound: it spaces the records of LAMMPS's contacts", None),
    ("contact records every 0 samples", "packing: {n: 64, phi: 0.9, friction: 0.3}\n"
     "waves: {engine: lammps, n: [1], contacts_every: 0}\n", [], "waves.contacts_every = 0: must be in [1", None),
    ("YADE export without its periodic cell", "packing: {file: '{file}'}\n", [],
     "the yade file records no periodic box",
     _dem("yade_3d.txt", lambda text: "".join(l for l in text.splitlines(True) if "PERIODIC" not in l))),
    ("relax without a file", "packing: {n: 64, phi: 0.9, relax: true}\n", [],
     "packing.relax = true re-minimises the packings of packing.file", None),
    ("count larger than the file holds", "packing: {file: '{file}', count: 3}\n", [],
     "packing.count = 3: the file(s) hold only 1 configuration", _valid),
    # --- command line
    ("no scene given", None, ["run"], "the following arguments are required: scene", None),
    ("scene file missing", None, ["run", "missing.yaml"], "scene file missing.yaml: not found", None),
    ("unknown command", None, ["frobnicate"], "invalid choice: 'frobnicate'", None),
    ("--set without =", GOOD, ["--set", "packing.n"], "must look like key.path=value", None),
    ("--set to a bad value", GOOD, ["--set", "packing.phi=2"], "packing.phi = 2: must be in (0.0, 1.0)", None),
    ("--group-size 0", GOOD, ["--group-size", "0"],
     "--group-size = 0: must be a whole number that divides the number of ranks", None),
    ("--group-size not dividing the number of ranks", GOOD, ["--group-size", "3"],
     "--group-size = 3: must be a whole number that divides the number of ranks", None),
    ("--group-size not an integer", GOOD, ["--group-size", "two"],
     "--group-size = 'two': must be a whole number that divides the number of ranks", None),
]


def materialise(folder, case) -> tuple[list[str], pathlib.Path]:
    """(the command line of ``case``, the output path it must never write) in ``folder``
    (a pathlib.Path), its files made there: the packing file by the case's maker, the scene with
    ``{file}`` and ``{out}`` filled in (and an ``output:`` line unless the scene is a list, the
    bare GOOD packing or empty)."""
    what, scene, words, message, maker = case
    out = folder / "never.h5"
    file = folder / "packing.h5"
    if maker:
        maker(file)
    args = list(words)
    if scene is not None:
        path = folder / "scene.yaml"
        text = scene.replace("{file}", str(file)).replace("{out}", str(out))
        path.write_text(text if text.startswith(("- ", "packing: {n: 64, phi: 0.9\n")) or not text.strip()
                        else f"output: {out}\n" + text)
        if not words or words[0].startswith("--"):  # options of 'run' (--set, --group-size, ...)
            args = ["run", str(path)] + args
    return args, out
