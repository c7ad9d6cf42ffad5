"""``rotsound render`` (solver/io/render.py): an exported VTP file drawn by VTK itself (under Xvfb)
shows the mode where the file says it is: the reddest pixel of a picture coloured by the energy
share lies on the particle with the largest share, arrows are drawn, and an unknown field is
refused as bad input, naming the file's fields.  Serial: one process draws."""

import shutil
import subprocess
import sys

import matplotlib.image
import numpy as np
import pytest
from conftest import COMM, REPO, missing, run_cli, scene_of

from solver import pipeline
from solver.io import export, results

pytestmark = pytest.mark.serial_only

SIZE = 400
DRAW = """
import numpy as np
from solver.io import render
np.save({where!r}, render.draw({vtp!r}, {png!r}, "share", "displacement", 2.0, "z", {size}, "test"))
"""


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    """(the picture (H, W, 3), particle centres in it (N, 2) pixels, the same in the file (N, 3) d0,
    the mode's shares (N,), radii (N,) d0, the exported file)."""
    if shutil.which("xvfb-run") is None:
        missing("xvfb-run (Debian's xvfb)", "not on PATH")
    try:
        import vtk
        from vtk.util.numpy_support import vtk_to_numpy
    except ImportError as exc:
        missing("VTK's Python module (python3-vtk9)", exc)
    folder = tmp_path_factory.mktemp("render")
    out = folder / "modes.h5"
    pipeline.run(scene_of(out, cache="off", seed=7, packing={"n": 64, "phi": 0.9}, model={"rho": [0.5]},
                          modes={"omega": [0.3], "count": 1}), COMM, [])
    paths, _ = export.export(str(out), "vtp", str(folder / "mode.vtp"), rho=0.5, mode=0, frames=1)
    path = paths[0]  # the particles; then the cell's outline and the frame's .vtm (export._vtp)
    assert path == str(folder / "mode.vtp") and paths[1:] == [str(folder / "mode.cell.vtp"), str(folder / "mode.vtm")]
    png, where = folder / "mode.png", folder / "where.npy"
    code = DRAW.format(where=str(where), vtp=path, png=str(png), size=SIZE)
    subprocess.run(["xvfb-run", "-a", sys.executable, "-c", code], check=True, timeout=120, cwd=REPO)
    with results.open_results(str(out)) as f:
        group = results.mode_shapes(f)[0]
        p = results.packing(f, 0)
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(path)
    reader.Update()
    points = vtk_to_numpy(reader.GetOutput().GetPoints().GetData())
    return (matplotlib.image.imread(png)[:, :, :3], np.load(where), points, group.share[0].sum(axis=1),
            0.5 * p["diameters"], path)


def test_the_reddest_pixel_is_on_the_particle_with_the_largest_share(drawn):
    image, centres, positions, share, radii, _ = drawn
    assert image.shape == (SIZE, SIZE, 3)  # a parallel projection down z: one scale in x and y
    per_d0 = np.ptp(centres[:, 0]) / np.ptp(positions[:, 0])
    np.testing.assert_allclose(np.ptp(centres[:, 1]) / np.ptp(positions[:, 1]), per_d0, rtol=1e-6, atol=0)
    redness = image[:, :, 0] - image[:, :, 1]
    y, x = np.unravel_index(np.argmax(redness), redness.shape)
    top = np.argmax(share)
    assert np.hypot(*(centres[top] - (x, y))) <= radii[top] * per_d0, (centres[top], (x, y), radii[top] * per_d0)


def test_arrows_are_drawn_in_black(drawn):
    image = drawn[0]
    assert (image.max(axis=2) < 0.15).sum() > 50


def test_an_unknown_field_is_named(drawn):
    done = run_cli(["render", drawn[-1], "--color", "nosuch", "--output", "/dev/null"], timeout=60)
    assert done.returncode == 2, done.stderr  # bad input: one message, no traceback
    assert "no point array 'nosuch'" in done.stderr and "share" in done.stderr, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
