"""What OVITO itself makes of exported files: run by the export tests with OVITO's own Python
module, in the venv of its own that ``scripts/tools/setup.sh`` makes (``.venv-ovito``: OVITO needs
numpy >= 2, which the project's venv must not get).  Imports nothing of rotsound or its tests.

    .venv-ovito/bin/python tests/io/ovito_check.py [--render PNG] FILE [FILE ...]

Each FILE is opened with ``ovito.io.import_file`` as the desktop application's *Load File* would
(a numbered series by a ``*`` pattern).  Prints one JSON object: ``files``, per FILE its
``frames``, particle ``count`` and, per particle property of frame 0, ``dtype``, ``components``,
``types`` ({id: [name, [r, g, b]]}, typed properties only) and ``values`` (nested lists), the
cell's ``pbc`` and ``cell`` (OVITO's 3 x 4 cell matrix: the edge vectors a, b, c and the origin as
columns; both null without a cell) and ``lines``, per Lines object (e.g. the particle-particle
contacts OVITO reads from a contact network in a .vtm) its ``count`` (points) and ``values`` per
property.  With
``--render``, the first FILE's frame 0 is drawn from the top (+z) by OVITO's default renderer
(StandardRenderer: Vulkan, Mesa's lavapipe without a GPU) into a PNG of 320 x 320 pixels, every
particle a flat disc of its radius in its type's colour, on white, without the cell's lines;
``render`` then gives ``centres`` (N, 2), where each particle's centre lands, pixels from the
top-left corner.
"""

import argparse
import json

import numpy as np
from ovito.io import import_file
from ovito.vis import ParticlesVis, PythonViewportOverlay, StandardRenderer, Viewport, ViewportOverlayInterface

SIZE = (320, 320)


def describe(path: str) -> dict:
    """Frames, particle count and the properties of frame 0 of ``path`` as OVITO reads them."""
    pipeline = import_file(path)
    data = pipeline.compute(0)
    properties = {}
    for name, prop in data.particles.items():
        entry = {"dtype": str(prop.dtype), "components": list(prop.component_names),
                 "values": np.asarray(prop).tolist()}
        if prop.types:
            entry["types"] = {t.id: [t.name, list(t.color)] for t in prop.types}
        properties[name] = entry
    lines = {name: {"count": found.count, "values": {key: np.asarray(found[key]).tolist() for key in found.keys()}}
             for name, found in data.lines.items()}
    return {"frames": pipeline.num_frames, "count": data.particles.count, "properties": properties,
            "pbc": None if data.cell is None else list(data.cell.pbc),
            "cell": None if data.cell is None else np.asarray(data.cell).tolist(), "lines": lines}


class Centres(ViewportOverlayInterface):
    """Draws nothing; records in ``found`` where the particles' centres land in the image."""

    def render(self, canvas, data, **kwargs):
        width, height = canvas.logical_size
        where = [canvas.project_location(p) for p in data.particles.positions]
        # reduced coordinates, origin lower left, to pixels from the top-left corner
        self.found = [[x * width, height - y * height] for x, y in where]


def render(path: str, png: str) -> dict:
    """Draw frame 0 of ``path`` into ``png`` (see the module docstring); the particles' centres in it."""
    pipeline = import_file(path)
    pipeline.source.data.particles.vis.shape = ParticlesVis.Shape.Circle  # flat: one colour per type
    if pipeline.source.data.cell is not None:  # no cell lines across the particles
        pipeline.source.data.cell.vis.enabled = False
    pipeline.add_to_scene()
    viewport = Viewport(type=Viewport.Type.Top)
    centres = Centres()
    viewport.overlays.append(PythonViewportOverlay(delegate=centres))
    viewport.zoom_all(size=SIZE)
    viewport.render_image(size=SIZE, filename=png, background=(1.0, 1.0, 1.0), frame=0,
                          renderer=StandardRenderer())
    return {"png": png, "size": list(SIZE), "centres": centres.found}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="+")
    parser.add_argument("--render", metavar="PNG")
    args = parser.parse_args()
    report = {"files": {path: describe(path) for path in args.files}}
    if args.render:
        report["render"] = render(args.files[0], args.render)
    print(json.dumps(report))


if __name__ == "__main__":
    main()
