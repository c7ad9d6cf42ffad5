"""``rotsound render``: draw a file written by ``rotsound export --format vtp`` with VTK itself, the
library ParaView is built on, the way a viewer shows it: every particle a sphere of its
``radius``, coloured by a field, and a vector field as arrows.  This is the evidence that the
exported fields open and mean what they say outside rotsound (ParaView's GUI needs a display;
OVITO's own reading and rendering of the exports is checked in tests/io/test_export.py), and it
draws the manual's pictures of exports (docs/exports.md).

VTK renders through OpenGL and needs an X server: run under ``xvfb-run`` (Debian's ``xvfb``,
installed by ``scripts/tools/setup.sh``)::

    rotsound export results/localisation.h5 --format vtp --rho 0 --mode 1 --frames 1 --output results/localisation_mode.vtp
    xvfb-run -a rotsound render results/localisation_mode.vtp --color share --arrows displacement \
        --output docs/export_vtk_mode.png

``--color`` names a scalar point array, or a vector one with ``_x``, ``_y`` or ``_z`` appended for
one component; the colour scale is symmetric about 0 (blue, white, red) when the field takes both
signs, white to red otherwise.  ``--arrows`` names a vector point array: the longest arrow is
``--arrow-length`` d0, drawn above the spheres.  ``--view z`` looks down the z axis with a parallel
projection (2D packings); ``--view iso`` looks at a 3D box from a corner.  A file without points,
an unknown or all-zero field is bad input (InputError, exit code 2, naming what the file has).
Needs VTK's Python module (Debian's ``python3-vtk9``; the command refuses without it).  Not
collective; no PETSc or MPI.
"""

from __future__ import annotations

import numpy as np
import vtk
from vtk.util import numpy_support

from ..errors import InputError

COMPONENTS = {"_x": 0, "_y": 1, "_z": 2}


def read(path: str) -> vtk.vtkPolyData:
    """The points of a VTK XML PolyData file (.vtp); InputError naming the file if VTK reads none."""
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(path)
    reader.Update()
    data = reader.GetOutput()
    if data is None or data.GetNumberOfPoints() == 0:
        raise InputError(f"render: {path}: VTK's reader finds no points (not a `rotsound export --format vtp` file?)")
    return data


def point_array(data: vtk.vtkDataSet, name: str) -> np.ndarray:
    """The point array ``name`` as NumPy, or one component of a vector array (``name_x|_y|_z``);
    InputError naming the file's arrays if it has neither."""
    fields = data.GetPointData()
    if fields.GetArray(name) is not None:
        return numpy_support.vtk_to_numpy(fields.GetArray(name))
    base, suffix = name[:-2], name[-2:]
    if suffix in COMPONENTS and fields.GetArray(base) is not None:
        values = numpy_support.vtk_to_numpy(fields.GetArray(base))
        if values.ndim == 2:
            return values[:, COMPONENTS[suffix]]
    have = [fields.GetArrayName(i) for i in range(fields.GetNumberOfArrays())]
    raise InputError(f"render: no point array {name!r}; the file has {have} (vectors take _x, _y or _z)")


def colour_scale(values: np.ndarray) -> vtk.vtkColorTransferFunction:
    """Blue-white-red symmetric about 0 when ``values`` take both signs, white-red otherwise;
    InputError when they are all zero (a rotation at rho = 0, say): nothing to colour by."""
    top = float(np.max(np.abs(values)))
    if top == 0.0:
        raise InputError("render: the --color field is zero everywhere; choose another (share, force_normal, ...)")
    scale = vtk.vtkColorTransferFunction()
    if values.min() < 0 < values.max():
        scale.AddRGBPoint(-top, 0.23, 0.30, 0.75)
        scale.AddRGBPoint(0.0, 0.97, 0.97, 0.97)
    else:
        scale.AddRGBPoint(0.0, 0.97, 0.97, 0.97)
    scale.AddRGBPoint(top, 0.71, 0.02, 0.15)
    return scale


def glyphs(scene: vtk.vtkRenderer, points: vtk.vtkPoints, arrays: dict[str, np.ndarray], source,
           scale: str) -> vtk.vtkGlyph3DMapper:
    """Draw ``source`` (a VTK source) at every one of ``points``, scaled by the magnitude of the
    point array ``scale`` among ``arrays`` (name: (N,) or (N, 3)); black unless the caller colours
    the returned mapper."""
    cloud = vtk.vtkPolyData()
    cloud.SetPoints(points)
    for name, values in arrays.items():
        array = numpy_support.numpy_to_vtk(np.ascontiguousarray(values, dtype=float), deep=True)
        array.SetName(name)
        cloud.GetPointData().AddArray(array)
    mapper = vtk.vtkGlyph3DMapper()
    mapper.SetInputData(cloud)
    mapper.SetSourceConnection(source.GetOutputPort())
    mapper.SetScaleArray(scale)
    mapper.SetScaleModeToScaleByMagnitude()
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().SetColor(0.0, 0.0, 0.0)
    scene.AddActor(actor)
    return mapper


def draw(path: str, output: str, colour: str = "rattler", arrows: str | None = None, arrow_length: float = 3.0,
         view: str = "z", size: int = 1200, title: str = "") -> np.ndarray:
    """Write the PNG ``output`` of the file ``path`` (see the module docstring); return where each
    particle's centre lands in it, (N, 2) pixels from the top-left corner (x right, y down)."""
    data = read(path)
    radius = point_array(data, "radius")
    shade = point_array(data, colour)
    scene = vtk.vtkRenderer()
    scene.SetBackground(1.0, 1.0, 1.0)

    ball = vtk.vtkSphereSource()
    ball.SetRadius(1.0)
    ball.SetThetaResolution(24)
    ball.SetPhiResolution(12)
    mapper = glyphs(scene, data.GetPoints(), {"radius": radius, "shade": shade}, ball, "radius")
    mapper.OrientOff()
    mapper.SetScalarModeToUsePointFieldData()
    mapper.SelectColorArray("shade")
    mapper.SetLookupTable(colour_scale(shade))
    mapper.UseLookupTableScalarRangeOn()

    bar = vtk.vtkScalarBarActor()
    bar.SetLookupTable(mapper.GetLookupTable())
    bar.SetTitle(colour)
    bar.SetNumberOfLabels(3)
    bar.SetWidth(0.07)
    bar.SetPosition(0.9, 0.1)
    for text in (bar.GetTitleTextProperty(), bar.GetLabelTextProperty()):
        text.SetColor(0.0, 0.0, 0.0)
    scene.AddActor2D(bar)

    if arrows is not None:
        vectors = point_array(data, arrows)
        if vectors.ndim != 2:
            raise InputError(f"render: --arrows {arrows!r} is not a vector array")
        longest = float(np.linalg.norm(vectors, axis=1).max()) or 1.0
        points = numpy_support.vtk_to_numpy(data.GetPoints().GetData()).copy()
        points[:, 2] += 1.01 * radius.max()  # above the spheres seen from +z
        tips = vtk.vtkPoints()
        tips.SetData(numpy_support.numpy_to_vtk(points, deep=True))
        arrow = vtk.vtkArrowSource()
        arrow.SetTipLength(0.3)
        arrow.SetTipRadius(0.12)
        arrow.SetShaftRadius(0.04)
        arrow_mapper = glyphs(scene, tips, {"arrow": vectors * (arrow_length / longest)}, arrow, "arrow")
        arrow_mapper.SetOrientationArray("arrow")
        arrow_mapper.ScalarVisibilityOff()

    if title:
        caption = vtk.vtkTextActor()
        caption.SetInput(title)
        caption.GetTextProperty().SetColor(0.0, 0.0, 0.0)
        caption.GetTextProperty().SetFontSize(max(12, size // 50))
        caption.SetPosition(10, size - 10 - max(12, size // 50))
        scene.AddActor2D(caption)

    camera = scene.GetActiveCamera()
    if view == "z":
        camera.ParallelProjectionOn()
        camera.SetViewUp(0.0, 1.0, 0.0)
        camera.SetPosition(0.0, 0.0, 1.0)
        camera.SetFocalPoint(0.0, 0.0, 0.0)
    else:
        camera.SetPosition(1.0, -1.4, 1.0)
        camera.SetFocalPoint(0.0, 0.0, 0.0)
        camera.SetViewUp(0.0, 0.0, 1.0)
    scene.ResetCamera()
    camera.Zoom(1.05)

    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.AddRenderer(scene)
    window.SetSize(size, size)
    window.Render()
    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(window)
    grab.Update()
    writer = vtk.vtkPNGWriter()
    writer.SetFileName(output)
    writer.SetInputConnection(grab.GetOutputPort())
    writer.Write()
    return pixels(scene, numpy_support.vtk_to_numpy(data.GetPoints().GetData()), size)


def pixels(scene: vtk.vtkRenderer, points: np.ndarray, size: int) -> np.ndarray:
    """Image positions (N, 2) of world ``points`` (N, 3) in a rendered ``size``-square ``scene``, by
    the camera's composite projection matrix (world to normalised device coordinates)."""
    matrix = scene.GetActiveCamera().GetCompositeProjectionTransformMatrix(scene.GetTiledAspectRatio(), -1, 1)
    project = np.array([[matrix.GetElement(i, j) for j in range(4)] for i in range(4)])
    device = np.hstack([points, np.ones((len(points), 1))]) @ project.T
    found = 0.5 * (device[:, :2] / device[:, 3:] + 1.0) * size
    found[:, 1] = size - found[:, 1]
    return found
