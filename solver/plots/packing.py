"""Pictures of a packing, from ``io.results``: its particles to scale with the rattlers in red
(:func:`plot_packing`), and its force chains (:func:`plot_force_network`): every contact between
non-rattlers as a line between the two centres, its width proportional to the normal force (the
scene's ``model.law``) on a scale set by the particles' size on the drawing (:data:`SHARE`), so that
chains stand out at any N; and, for a stressed packing (stored tangential forces), the tangential
force as a second, red line on top; particles to scale in light grey, rattlers outlined in red.
Spheres: the particles cut by the plane z = L_z/2 (``common.section``) and the contacts between
two of them, in-plane.

A contact across the periodic boundary is drawn as two halves, one from each centre towards the
other's nearest image, so that every chord shows inside the box.  A tilted cell is drawn as its
parallelogram (``common.frame_cell``), its particles inside it.  Never imports petsc4py or
mpi4py.  Each function writes ``<stem>.png`` and ``.pdf``.  Not collective.  Units: d0, forces in
kn d0.
"""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection

from ..packing import geometry, mechanics
from .common import disks, frame_cell, plt, save, section

SHARE = 0.12
"""Width of the line of a contact carrying the mean normal force, in d0 on the drawing: thin
enough that the strong chains (a few times the mean force) stay apart at any N [choice, by eye
at N = 64 and 4096]."""


def _halves(positions: np.ndarray, found: geometry.Contacts) -> np.ndarray:
    """(2C, 2, 2): per contact, the half chord from i towards j and from j towards i (in-plane)."""
    half = 0.5 * found.distance[:, None] * found.normal[:, :2]  # n points from j to i
    a, b = positions[found.i, :2], positions[found.j, :2]
    return np.concatenate((np.stack((a, a - half), axis=1), np.stack((b, b + half), axis=1)))


def plot_force_network(packing, stem: str) -> list[str]:
    """The force-chain picture of ``packing`` (a ``Packing``) under its normal law (``packing.model``)."""
    found, f_n, f_t = mechanics.force_magnitudes(packing)
    cut, diam = section(packing.positions, packing.diameters, packing.box)
    keep = cut[found.i] & cut[found.j]
    fig, ax = plt.subplots(figsize=(7, 7))
    rattler = packing.rattler[cut]
    disks(ax, packing.positions[cut, :2], diam, facecolors="0.9", edgecolors=np.where(rattler, "tab:red", "0.6"),
          linewidths=np.where(rattler, 0.8, 0.2))
    width = frame_cell(ax, packing.cell)
    ax.apply_aspect()  # the drawn box, in points, fixes how wide d0 is drawn
    d0_points = ax.get_position().width * fig.get_figwidth() * 72.0 / width
    scale = SHARE * d0_points / f_n.mean() if f_n.size else 0.0
    chosen = geometry.Contacts(found.i[keep], found.j[keep], found.normal[keep], found.distance[keep],
                               found.overlap[keep])
    segments = _halves(packing.positions, chosen)
    ax.add_collection(LineCollection(segments, linewidths=np.tile(scale * f_n[keep], 2), colors="k",
                                     capstyle="round"))
    stressed = packing.tangential is not None and f_t.max(initial=0.0) > 0.0
    if stressed:
        ax.add_collection(LineCollection(segments, linewidths=np.tile(scale * f_t[keep], 2), colors="tab:red",
                                         capstyle="round", alpha=0.8))
    plane = ", section $z = L_z/2$" if packing.dim == 3 else ""
    lines = [rf"force network: {len(found)} contacts, $N$ = {packing.n}{plane}, rattlers outlined in red",
             rf"black: $|f_n|$ ({packing.model.law}), width $\propto |f_n|$: the mean, {f_n.mean():.3g} $k_n d_0$, {SHARE:g} $d_0$ wide"]
    if stressed:
        ratio = np.max(f_t / np.maximum(f_n, 1e-300))
        lines.append(rf"red: $|f_t|$ on the same scale (largest $|f_t|/|f_n|$ = {ratio:.2f})")
    ax.set(xlabel=r"$x\,/\,d_0$", ylabel=r"$y\,/\,d_0$", title="\n".join(lines))
    ax.title.set_fontsize(9)
    return save(fig, stem)


def plot_packing(packing: dict, stem: str) -> list[str]:
    """Disks of one configuration (``results.first_packing``), rattlers in red; units of d0.
    Spheres: their sections by the plane z = L_z/2 (``common.section``)."""
    pos, diam = packing["positions"], packing["diameters"]
    rattler, box = packing["rattler"], packing["box"]
    colors = np.where(rattler, "tab:red", np.where(diam > diam.mean(), "0.55", "0.8"))
    cut, diam = section(pos, diam, box)
    pos, colors = pos[cut, :2], colors[cut]
    plane = ", section $z = L_z/2$" if box.size == 3 else ""
    fig, ax = plt.subplots(figsize=(6, 6))
    disks(ax, pos, diam, facecolors=colors, edgecolors="k", linewidths=0.2)
    frame_cell(ax, packing.get("cell", packing["box"]))
    ax.set(xlabel=r"$x\,/\,d_0$", ylabel=r"$y\,/\,d_0$",
           title=rf"$N$ = {packing['diameters'].size}, $\phi$ = {packing['phi']:.3f}, $z$ = {packing['z']:.2f}, "
                 f"rattlers in red ({int(packing['rattler'].sum())}){plane}")
    return save(fig, stem)
