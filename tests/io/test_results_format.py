"""Results files of another format_version.  The rule (io/results.open_results): a file of this
rotsound's FORMAT_VERSION or an older one is read, a newer one is refused with one clear message.
tests/data/results_v1.h5 is a version-1 file written by rotsound (tests/data/make_results_v1.py)
and kept as written: every later rotsound must still read it."""

import shutil

import h5py
import numpy as np
import pytest
from conftest import REPO, assert_close

from solver.contact_law import ContactModel
from solver.errors import InputError
from solver.io import hdf5
from solver import report
from solver.io import results
from solver.model import dynmat
from solver.spectrum import slicing

pytestmark = pytest.mark.serial_only  # file reading and the CLI on one rank

V1 = REPO / "tests" / "data" / "results_v1.h5"


def test_version_1_file_is_read_as_written(comm):
    with results.open_results(str(V1)) as f:
        assert int(f.attrs["format_version"]) == 1
        curves = results.vdos(f)
        energies = results.mode_energies(f)
        waves = results.waves(f)
        fits = results.fits(f)
        with h5py.File(V1, "r") as raw:  # the stored arrays, for the readers' bookkeeping
            omega = {rho: raw[f"spectra/r{i:02d}_p0000/omega"][()] for i, rho in enumerate((0.0, 1.0))}
    assert sorted(curves) == [0.0, 1.0] and sorted(energies) == [0.0, 1.0]
    assert sorted(waves) == [(0.0, "L"), (1.0, "L"), (1.0, "RT")], sorted(waves)
    assert sorted(fits) == [(0.0, "L"), (1.0, "L"), (1.0, "RT")], sorted(fits)
    for rho in (0.0, 1.0):
        assert np.array_equal(energies[rho][0], omega[rho])
        assert curves[rho].omega_c == omega[rho].max() and curves[rho].configurations == 1
        assert abs(np.sum(curves[rho].density * np.diff(curves[rho].edges)) - 1) < 1e-12  # unit area
    w = waves[(1.0, "RT")]
    assert w.z.shape == (2, w.k.size, w.t.size) and w.k.size == 2
    # The packing stored in the file is a packing input (docs/packing_files.md) whose spectrum, recomputed by this
    # rotsound, is the one stored: positions, diameters and box are read as they were written.
    data = report.gather([str(V1)])
    assert sorted(data.vdos) == [0.0, 1.0] and data.vdos_file == str(V1)
    (packing,) = hdf5.read_packings(str(V1))
    for rho in (0.0, 1.0):
        dm = dynmat.assemble(packing, ContactModel(rho), comm)
        now = slicing.solve(dm, window=None, vectors=False)
        dm.destroy()
        assert_close(now.omega, omega[rho], rtol=1e-10, what=f"spectrum of the stored packing, rho = {rho}")


def test_claims_read_version_1():
    """The report's table from the version-1 file (its figures are drawn from the same readers)."""
    from solver.analysis import claims

    rows = claims.claims(report.gather([str(V1)]))
    status = {r.claim: r.status for r in rows}
    assert len(rows) >= 7 and set(status.values()) <= {"PASS", "FAIL", "NOT MEASURED"}
    # measured from the file: rho = 0 vDOS and K/Q at rho = 1; no lattice fit in so small a file
    assert status["Cutoff omega_c at rho = 0 (Fig. 1)"] != "NOT MEASURED"
    assert status["Energy partition at rho = 1 (Fig. 6a)"] != "NOT MEASURED"


def test_newer_version_is_refused_with_one_clear_message(tmp_path, capsys):
    from solver.__main__ import main

    newer = tmp_path / "newer.h5"
    shutil.copyfile(V1, newer)
    with h5py.File(newer, "r+") as f:
        f.attrs["format_version"] = hdf5.FORMAT_VERSION + 1
    with pytest.raises(InputError) as info:
        results.open_results(str(newer))
    message = str(info.value)
    assert str(newer) in message and f"format_version {hdf5.FORMAT_VERSION + 1} is newer" in message, message
    for command in (["report", str(newer), "--output", str(tmp_path / "R.md")], ["plot", str(newer)]):
        capsys.readouterr()
        code = main(command)
        lines = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(lines) == 1 and lines[0].startswith("rotsound: error: "), (command, lines)
        assert "newer" in lines[0], lines
    assert not (tmp_path / "R.md").exists() and not list(tmp_path.glob("*.png")), "wrote output anyway"


def test_contact_model_is_the_scenes_law_and_lever(tmp_path):
    """The readers of a results file (plot, export) take the law and lever its scene gave, and the
    defaults where it gave none (``results.contact_model``)."""
    given, bare = tmp_path / "given.h5", tmp_path / "bare.h5"
    with h5py.File(given, "w") as f:
        f.attrs["scene"] = "model:\n  rho: [0.5]\n  law: hertz\n  lever: contact\n"
    with h5py.File(bare, "w") as f:
        f.attrs["scene"] = "model:\n  rho: [0.5]\n"
    with h5py.File(given, "r") as f, h5py.File(bare, "r") as g:
        found = results.contact_model(f), results.contact_model(g)
    assert found == (ContactModel(law="hertz", lever="contact"), ContactModel()), found


def test_the_notebook_api_gives_the_cell_and_reads_older_files_as_orthogonal(tmp_path):
    """``results.packing`` gives the cell next to the box: a packing group's attributes tilt and
    periodic (what the results writer stores for a tilted cell); the version-1 file, written before
    tilted cells, reads as orthogonal and periodic."""
    with results.open_results(str(V1)) as f:
        old = results.packing(f, 0)
    dim = old["positions"].shape[1]
    np.testing.assert_array_equal(old["tilt"], np.zeros(1 if dim == 2 else 3))
    np.testing.assert_array_equal(old["periodic"], np.ones(dim, dtype=bool))
    np.testing.assert_array_equal(old["cell"].matrix, np.diag(old["box"]))
    tilted = tmp_path / "tilted.h5"
    shutil.copyfile(V1, tilted)
    with h5py.File(tilted, "r+") as f:
        group = f["packings"][sorted(f["packings"])[0]]
        group.attrs["tilt"] = np.array([0.25 * old["box"][0]] + [0.0] * (dim - 2) * 2)
        group.attrs["periodic"] = np.ones(dim, dtype=bool)
    with results.open_results(str(tilted)) as f:
        new = results.packing(f, 0)
    np.testing.assert_array_equal(new["box"], old["box"])
    assert new["tilt"][0] == 0.25 * old["box"][0] and new["cell"].tilted
    assert new["cell"].matrix[0, 1] == 0.25 * old["box"][0]  # edge b = (xy, L_y[, 0])
