"""What every figure module shares: the Agg backend, set here once before pyplot loads (the stage
modules take ``plt`` from here); saving a figure as PNG and PDF (:func:`save`); particles drawn to
scale and the plane section of spheres; rho in labels, legends and log ticks that stay readable.

Never imports petsc4py or mpi4py.  Not collective.  Units: d0.
"""

from __future__ import annotations

from contextlib import contextmanager

import matplotlib

matplotlib.use("Agg")  # files only, no display needed
DPI = 150
"""Resolution of the PNG files.  Figures are made at it too, so that the layout pass and the PNG
share matplotlib's cache of laid-out text, which is keyed by dpi (measured: `rotsound report` of a
128-disk scene with waves, 8 figures, 10.5 s -> 9.0 s)."""
matplotlib.rcParams["figure.dpi"] = DPI
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import EllipseCollection  # noqa: E402
from matplotlib.patches import Polygon  # noqa: E402
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter  # noqa: E402

from ..errors import InputError  # noqa: E402
from ..packing.geometry import Cell  # noqa: E402


LEGEND_PT = 7
"""Font size (points) of a legend's text, the smallest a figure uses for one (tests/figures.py)."""

_kept: dict | None = None
"""{stem: figure} while :func:`kept` holds the figures instead of writing them, else None."""


@contextmanager
def kept():
    """Within: :func:`save` writes nothing and keeps each figure open in the dict this yields,
    {stem: figure}; the caller writes (``save``) or closes them.  The figures are those the files
    would be: the same drawing code, only the last step differs."""
    global _kept
    outer, _kept = _kept, {}
    try:
        yield _kept
    finally:
        _kept = outer


def save(fig, stem: str) -> list[str]:
    """Write ``fig`` as PNG and PDF at ``stem`` and close it; return the two paths (inside
    :func:`kept`: keep it there, write nothing).  A folder that cannot take them is bad input."""
    paths = [f"{stem}.png", f"{stem}.pdf"]
    if _kept is not None:
        _kept[stem] = fig
        return paths
    try:
        for path in paths:
            fig.savefig(path, dpi=DPI)
    except OSError as exc:
        raise InputError(f"figure {path}: cannot write ({exc})") from None
    finally:
        plt.close(fig)
    return paths


SERIES_TOP = 0.6
"""How far along viridis the last of a series of lines goes: beyond, its yellow-greens are too
pale on white."""


def series_colour(index: int, count: int):
    """The colour of line ``index`` of ``count`` in a series (one per rho, per k, per packing):
    viridis from dark blue to ``SERIES_TOP``."""
    return plt.get_cmap("viridis")(SERIES_TOP * index / max(1, count - 1))


def rho_label(rho: float) -> str:
    """rho for a legend or a title, to 3 significant figures (2/7: 0.286)."""
    return rf"$\rho$ = {rho:.3g}"


def rho_list(rhos) -> str:
    """Several rho for a title, each to 3 significant figures; more than 4 as their range."""
    rhos = sorted(rhos)
    if len(rhos) > 4:
        return rf"$\rho$ = {rhos[0]:.3g} to {rhos[-1]:.3g} ({len(rhos)} values)"
    return r"$\rho$ = " + ", ".join(f"{rho:.3g}" for rho in rhos)


def legend(ax, **style) -> None:
    """``ax.legend(**style)`` when ``ax`` has labelled artists (else matplotlib logs a warning), its
    text ``LEGEND_PT`` points unless ``style`` sets a larger size."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(**{"fontsize": LEGEND_PT, **style})


def _log_label(value: float, _position=None) -> str:
    """A log tick's label: plain from 1e-3 to 1e4, else m x 10^e in mathtext."""
    if 1e-3 <= value < 1e4:
        return f"{value:g}"
    exponent = int(np.floor(np.log10(value) + 1e-9))  # 1e-7 is not 9.99...e-8
    mantissa = round(value / 10.0**exponent, 6)
    return rf"${mantissa:g}\times10^{{{exponent}}}$" if mantissa != 1 else rf"$10^{{{exponent}}}$"


def log_ticks(axis) -> None:
    """At least two labelled ticks on the log ``axis`` (``ax.xaxis`` or ``ax.yaxis``), whose limits
    are final.  matplotlib labels the powers of ten, so one on a range of a decade or two: then
    ticks at 1, 2 and 5 times them, labelled plainly (on a range too short to hold two of those,
    matplotlib's LogLocator gives evenly spaced ticks itself).  A linear axis is left alone."""
    if axis.get_scale() != "log":
        return
    low, high = sorted(axis.get_view_interval())
    decades = LogLocator().tick_values(low, high)
    if np.count_nonzero((decades >= low) & (decades <= high)) >= 2:
        return
    axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(_log_label))
    axis.set_minor_formatter(NullFormatter())


def section(positions: np.ndarray, diameters: np.ndarray, box: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(which (N,) bool, diameters (n,)) of the particles drawn in a plane picture: every disk in 2D;
    for spheres (positions (N, 3)) those cut by the plane z = L_z/2, as disks of diameter
    2 sqrt(R^2 - dz^2) (dz the periodic distance of the centre from the plane)."""
    if positions.shape[1] == 2:
        return np.ones(len(diameters), dtype=bool), diameters
    dz = positions[:, 2] - 0.5 * box[2]
    dz -= box[2] * np.rint(dz / box[2])
    cut = np.abs(dz) < 0.5 * diameters
    return cut, 2.0 * np.sqrt(0.25 * diameters[cut] ** 2 - dz[cut] ** 2)


def frame_cell(ax, cell) -> float:
    """Frame ``ax`` (equal aspect) on the picture of ``cell`` (a ``geometry.Cell``, or the (D,) sides
    of an orthogonal one): its xy face (3D: its section z = L_z/2, shifted by c/2); a tilted cell's
    parallelogram drawn as a grey outline, the limits its bounding box.  Returns the framed width
    in x (d0)."""
    cell = Cell.of(cell, np.size(cell))
    h = cell.matrix
    origin = 0.5 * h[:2, 2] if cell.dim == 3 else np.zeros(2)
    corners = origin + np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]) @ h[:2, :2].T
    if cell.tilted:
        ax.add_patch(Polygon(corners, closed=True, fill=False, edgecolor="0.4", linewidth=0.8, zorder=3))
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), aspect="equal")
    return float(hi[0] - lo[0])


def disks(ax, centres: np.ndarray, diameters: np.ndarray, **style) -> EllipseCollection:
    """Add disks of ``diameters`` at ``centres`` (n, 2) to ``ax`` as one collection, to scale (data
    units); ``style``: the collection's facecolors, edgecolors, cmap, ... Returns it."""
    collection = EllipseCollection(diameters, diameters, np.zeros_like(diameters), offsets=centres, units="xy",
                                   offset_transform=ax.transData, **style)
    ax.add_collection(collection)
    return collection
