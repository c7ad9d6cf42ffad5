"""What a reader needs from a figure, checked on the figures the plot functions draw: every title,
axis label and legend entry inside the figure, symbols in mathtext, rho to 3 significant figures,
at least two labelled ticks on every log axis.  Not collective (plotting is rank 0's)."""

from __future__ import annotations

import importlib
import os
import pkgutil
import re

from solver import plots
from solver.plots import common

PLAIN_SYMBOLS = re.compile(r"\b(omega\w*|rho|gamma\w*|sigma|phi|mu|lambda|log10|[dt]0|kn|k_c|f_[nt]|[vw]_[xyz])\b")
"""Names that a figure must write as mathtext ($\\omega$, $\\rho$, $t_0$, ...), never as words."""

RHO_VALUES = re.compile(r"\\rho\$ = ([-+.\de]+(?:(?:, | to )[-+.\de]+)*)")
"""The numbers after '$\\rho$ = ': one, a list or 'a to b'."""


def capture(monkeypatch) -> dict:
    """{file name of the PNG: figure} of every figure drawn from now on (``common.save`` wherever a
    module of ``solver.plots`` took it); each is still written (and closed by pyplot) as usual, and
    can be drawn again for the checks."""
    figures = {}
    write = common.save

    def keep(fig, stem):
        figures[os.path.basename(stem) + ".png"] = fig
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


def labelled_ticks(axis) -> list[str]:
    """The tick labels that show on ``axis`` (major and minor) inside its limits, after a draw."""
    low, high = sorted(axis.get_view_interval())
    return [tick.label1.get_text() for tick in axis.get_major_ticks() + axis.get_minor_ticks()
            if tick.label1.get_visible() and tick.label1.get_text() and low <= tick.get_loc() <= high]


def problems(name: str, fig) -> list[str]:
    """What a reader would miss in ``fig`` (drawn as ``name``): [] when nothing."""
    fig.canvas.draw()
    renderer, frame = fig.canvas.get_renderer(), fig.bbox
    found = []
    for text in texts(fig):
        words, box = text.get_text(), text.get_window_extent(renderer)
        if box.x0 < frame.x0 - 1 or box.x1 > frame.x1 + 1 or box.y0 < frame.y0 - 1 or box.y1 > frame.y1 + 1:
            found.append(f"{name}: {words!r} leaves the figure ({box.x0:.0f}..{box.x1:.0f} of {frame.x1:.0f} px)")
        plain = PLAIN_SYMBOLS.search(re.sub(r"\$[^$]*\$", "", words))
        if plain:
            found.append(f"{name}: {words!r} writes {plain.group()!r} outside mathtext")
        for values in RHO_VALUES.findall(words):
            for value in re.split(r", | to ", values):
                digits = re.sub(r"^0\.0*|\.|e.*", "", value)
                if len(digits) > 3:
                    found.append(f"{name}: {words!r} gives rho to more than 3 significant figures")
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() == "log" and len(labelled_ticks(axis)) < 2:
                found.append(f"{name}: log axis {axis.label.get_text()!r} labels {labelled_ticks(axis)}")
    return found


def assert_readable(figures: dict) -> None:
    """:func:`problems` of every figure of ``figures`` (:func:`capture`), all reported at once."""
    found = [p for name, fig in sorted(figures.items()) for p in problems(name, fig)]
    assert not found, "\n".join(found)
