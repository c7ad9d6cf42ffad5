"""What a reader needs from a figure, checked on the figures the plot functions draw
(:func:`problems`; ``plots.draw_results`` gives them in-process):

- every text the figure draws (titles, axis labels, tick labels, legend entries, annotations,
  colour bars' labels) inside the figure, and every annotation's arrow inside its axes, ``CLEAR``
  pixels from the frame;
- every line inside its axes: each finite point of each visible ``Line2D`` (model curves, guides,
  axhline/axvline) falls within its axes' limits; the rule for a curve that would run off is that
  the drawing code cuts it at the limits itself and marks the cut (an arrow or a note), so the
  limits always contain what is drawn; a value a log axis cannot show (<= 0) counts as outside;
- no axes over another (an inset hides what it covers; twin axes, on the same frame, are one);
- legend text at least ``common.LEGEND_PT`` (7) points; no "nan" in any text;
- symbols in mathtext, rho to 3 significant figures, at least two labelled ticks on every log axis.

Not collective (plotting is rank 0's)."""

from __future__ import annotations

import importlib
import os
import pkgutil
import re

import numpy as np
from matplotlib.text import Annotation, Text

from solver import plots
from solver.plots import common

PLAIN_SYMBOLS = re.compile(r"\b(omega\w*|rho|gamma\w*|sigma|phi|mu|lambda|log10|[dt]0|kn|k_c|f_[nt]|[vw]_[xyz])\b")
"""Names that a figure must write as mathtext ($\\omega$, $\\rho$, $t_0$, ...), never as words."""

NAN = re.compile(r"\bnan\b", re.IGNORECASE)
"""A number that was not there, printed."""

PX = 1.0
"""Tolerance (pixels) of the inside-the-figure and inside-the-axes checks: rounding of extents."""

CLEAR = 8.0
"""Pixels (at common.DPI, 1.4 mm) between an annotation's arrow and its axes' frame, so that the
arrow does not merge with the frame (an arrow aimed at the frame, shrunk by matplotlib's default
2 pt, ends 6.5 px from it)."""

RHO_VALUES = re.compile(r"\\rho\$ = ([-+.\de]+(?:(?:, | to )[-+.\de]+)*)")
"""The numbers after '$\\rho$ = ': one, a list or 'a to b'."""


def capture(monkeypatch, stems: bool = False) -> dict:
    """{file name of the PNG: figure} of every figure drawn from now on (``common.save`` wherever a
    module of ``solver.plots`` took it); each is still written (and closed by pyplot) as usual, and
    can be drawn again for the checks.  With ``stems``: {path without .png/.pdf: figure}, as
    ``plots.draw_results`` gives them, so that :func:`assert_figures` checks the figures
    ``plots.plot_results`` drew and wrote without drawing them all again first."""
    figures = {}
    write = common.save

    def keep(fig, stem):
        figures[stem if stems else os.path.basename(stem) + ".png"] = fig
        return write(fig, stem)

    for info in pkgutil.iter_modules(plots.__path__):
        module = importlib.import_module(f"{plots.__name__}.{info.name}")
        if getattr(module, "save", None) is write:
            monkeypatch.setattr(module, "save", keep)
    return figures


def texts(fig) -> list:
    """Titles, axis labels (colour bars' too) and legend entries of ``fig`` that show text."""
    found = []
    for ax in fig.axes:
        found += [ax.title, ax.xaxis.label, ax.yaxis.label]
        if ax.get_legend() is not None:
            found += ax.get_legend().get_texts()
    return [t for t in found if t.get_visible() and t.get_text()]


def every_axes(fig) -> list:
    """The axes of ``fig`` with their insets (``child_axes``, which ``fig.axes`` leaves out)."""
    found, todo = [], list(fig.axes)
    while todo:
        ax = todo.pop(0)
        found.append(ax)
        todo += ax.child_axes
    return found


def drawn_texts(fig) -> list:
    """Every Text artist ``fig`` draws that shows text: titles, axis labels, the tick labels inside
    their axis's limits, legend texts, annotations and free texts (of the figure and its axes, colour
    bars included).  After a draw."""
    hidden = set()
    for ax in every_axes(fig):
        for axis in (ax.xaxis, ax.yaxis):
            low, high = sorted(axis.get_view_interval())
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                if not low - 1e-9 * abs(high - low) <= tick.get_loc() <= high + 1e-9 * abs(high - low):
                    hidden |= {id(tick.label1), id(tick.label2)}
    return [t for t in fig.findobj(Text) if id(t) not in hidden and t.get_visible() and t.get_text().strip()
            and (t.axes is None or t.axes.get_visible())]


def outside(box, frame, px: float = PX) -> bool:
    """Whether the display box ``box`` reaches beyond ``frame`` by more than ``px`` pixels."""
    return box.x0 < frame.x0 - px or box.x1 > frame.x1 + px or box.y0 < frame.y0 - px or box.y1 > frame.y1 + px


def lines_outside(ax) -> list[str]:
    """The visible lines of ``ax`` with a finite point outside its limits (or <= 0 on a log axis)."""
    found = []
    frame = ax.bbox
    for line in ax.get_lines():
        if not line.get_visible():
            continue
        xy = np.column_stack([np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)])
        xy = xy[np.isfinite(xy).all(axis=1)]
        if not xy.size:
            continue
        with np.errstate(all="ignore"):
            shown = line.get_transform().transform(xy)
        bad = ~np.isfinite(shown).all(axis=1)
        bad |= (shown[:, 0] < frame.x0 - PX) | (shown[:, 0] > frame.x1 + PX)
        bad |= (shown[:, 1] < frame.y0 - PX) | (shown[:, 1] > frame.y1 + PX)
        if bad.any():
            found.append(f"line {line.get_label()!r} of {ax.get_title()!r}: {bad.sum()} of {len(xy)} points off the "
                         f"axes, e.g. {tuple(xy[bad][0])} against x {ax.get_xlim()}, y {ax.get_ylim()}")
    return found


def labelled_ticks(axis) -> list[str]:
    """The tick labels that show on ``axis`` (major and minor) inside its limits, after a draw."""
    low, high = sorted(axis.get_view_interval())
    return [tick.label1.get_text() for tick in axis.get_major_ticks() + axis.get_minor_ticks()
            if tick.label1.get_visible() and tick.label1.get_text() and low <= tick.get_loc() <= high]


def problems(name: str, fig) -> list[str]:
    """What a reader would miss in ``fig`` (drawn as ``name``; the module docstring): [] when nothing."""
    fig.canvas.draw()
    renderer, frame = fig.canvas.get_renderer(), fig.bbox
    found = []
    for text in drawn_texts(fig):
        words, box = text.get_text(), text.get_window_extent(renderer)
        if outside(box, frame):
            found.append(f"{name}: {words!r} leaves the figure ({box.x0:.0f}..{box.x1:.0f} x {box.y0:.0f}..{box.y1:.0f}"
                         f" of {frame.x1:.0f} x {frame.y1:.0f} px)")
        if NAN.search(words):
            found.append(f"{name}: {words!r} prints a nan")
    for note in fig.findobj(Annotation):
        if note.get_visible() and note.arrow_patch is not None and note.axes is not None:
            arrow = note.arrow_patch.get_window_extent(renderer)
            if outside(arrow, note.axes.bbox.padded(-CLEAR), px=0):
                found.append(f"{name}: the arrow {note.get_text()!r} at {note.xy} reaches the frame of "
                             f"{note.axes.get_title()!r}")
    for text in texts(fig):  # the texts a reader reads first: titles, labels, legend entries
        words = text.get_text()
        plain = PLAIN_SYMBOLS.search(re.sub(r"\$[^$]*\$", "", words))
        if plain:
            found.append(f"{name}: {words!r} writes {plain.group()!r} outside mathtext")
        for values in RHO_VALUES.findall(words):
            for value in re.split(r", | to ", values):
                digits = re.sub(r"^0\.0*|\.|e.*", "", value)
                if len(digits) > 3:
                    found.append(f"{name}: {words!r} gives rho to more than 3 significant figures")
    shown = [ax for ax in every_axes(fig) if ax.get_visible()]
    for i, ax in enumerate(shown):  # an axes over another (an inset) hides what is drawn under it
        for other in shown[i + 1:]:
            a, b = ax.bbox, other.bbox
            if not np.allclose(a.extents, b.extents, rtol=0, atol=PX) and \
                    min(a.x1, b.x1) - max(a.x0, b.x0) > PX and min(a.y1, b.y1) - max(a.y0, b.y0) > PX:
                found.append(f"{name}: axes {other.get_title()!r} overlaps axes {ax.get_title()!r}")
    for ax in every_axes(fig):
        found += [f"{name}: {line}" for line in lines_outside(ax)]
        legend = ax.get_legend()
        if legend is not None and legend.get_visible():
            found += [f"{name}: legend text {t.get_text()!r} is {t.get_fontsize():g} pt, under {common.LEGEND_PT}"
                      for t in legend.get_texts() if t.get_fontsize() < common.LEGEND_PT]
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() == "log" and len(labelled_ticks(axis)) < 2:
                found.append(f"{name}: log axis {axis.label.get_text()!r} labels {labelled_ticks(axis)}")
    return found


def assert_readable(figures: dict) -> None:
    """:func:`problems` of every figure of ``figures`` (:func:`capture`), all reported at once."""
    found = [p for name, fig in sorted(figures.items()) for p in problems(name, fig)]
    assert not found, "\n".join(found)


def assert_figures(figures: dict, written: list[str] = ()) -> None:
    """:func:`problems` of every figure of ``figures`` ({stem: figure}, ``plots.draw_results``), all
    reported at once; with ``written`` (the paths ``plots.plot_results`` returned for the same
    file), each figure's PNG among them, read back at the figure's size in pixels (inches x
    ``common.DPI``).  Closes the figures."""
    from matplotlib import image

    try:
        assert figures, "no figure drawn"
        found = [p for stem, fig in sorted(figures.items()) for p in problems(os.path.basename(stem), fig)]
        for stem, fig in sorted(figures.items()) if written else ():
            png = f"{stem}.png"
            expected = tuple(int(round(v)) for v in fig.get_size_inches()[::-1] * common.DPI)
            if png not in written:
                found.append(f"{png} not written")
            elif image.imread(png).shape[:2] != expected:
                found.append(f"{png}: {image.imread(png).shape[:2]} pixels, the figure {expected}")
        assert not found, "\n".join(found)
    finally:
        for fig in figures.values():
            common.plt.close(fig)
