"""Pictures of single modes (the scene's ``modes`` section), from ``io.results.mode_shapes``: the
particles to scale, each particle's displacement as an arrow and its rotation as its colour, with
omega, K/Q and the participation ratio in the title.  Spheres: the particles cut by the plane
z = L_z/2 (``common.section``), their in-plane displacement and their rotation about z.  And
snapshots of standing waves (``waves.snapshots``, ``io.results.wave_snapshots``) drawn the same
way: velocity arrows, angular-velocity colour.

Never imports petsc4py or mpi4py.  Each picture is ``<stem>_mode_rho<rho>_p<i>_<m>.png`` and
``.pdf`` (rho, packing index, mode index m in the group), or ``<stem>_wave_...``
(:func:`plot_wave_snapshots`).  Not collective.  Units: d0, rad, 1/t0.
"""

from __future__ import annotations

import numpy as np
from matplotlib.colors import CenteredNorm

from ..io.results import ModeShapes, WaveSnapshot
from .common import disks, frame_cell, plt, rho_label, save, section

ARROW = 1.0
"""Length of the longest drawn arrow (d0): a mode's amplitude is arbitrary, only its shape counts."""


ROUND_OFF = 1e-12
"""Q / K below which a mode has no rotation but round-off (frictionless: the rotations decouple)."""


def _draw(packing: dict, arrows: np.ndarray, turn: np.ndarray | None, label: str, title: str, stem: str) -> list[str]:
    """The particles of ``packing`` (``results.packing``) to scale with ``arrows`` (N, D) scaled so
    that the longest is ``ARROW`` d0 and coloured by ``turn`` (N,), the rotation component about z
    (blue-white-red, centred on 0; grey when None), rattlers outlined in red; spheres as their
    section z = L_z/2 (``common.section``); a tilted cell as its parallelogram (``common.frame_cell``).
    ``label``: the colour bar's; ``title``: its lines
    above one on N and the arrows.  Constrained layout: the title stays inside the figure, whose
    colour bar shifts the picture left."""
    pos, box = packing["positions"], packing["box"]
    cut, diam = section(pos, packing["diameters"], box)
    centres, u = pos[cut, :2], arrows[cut, :2]
    rattler = packing["rattler"][cut]
    fig, ax = plt.subplots(figsize=(7, 6), layout="constrained")
    if turn is not None:
        turn = turn[cut]
        drawn = disks(ax, centres, diam, cmap="coolwarm", norm=CenteredNorm(halfrange=max(np.abs(turn).max(), 1e-300)),
                      edgecolors="k", linewidths=0.1)
        drawn.set_array(np.where(rattler, np.nan, turn))
        fig.colorbar(drawn, ax=ax, shrink=0.8, label=label)
    else:
        disks(ax, centres, diam, facecolors=np.where(rattler, "none", "0.85"), edgecolors="k", linewidths=0.1)
    if rattler.any():
        disks(ax, centres[rattler], diam[rattler], facecolors="none", edgecolors="tab:red", linewidths=0.6)
    longest = np.hypot(u[:, 0], u[:, 1]).max()
    ax.quiver(centres[:, 0], centres[:, 1], u[:, 0], u[:, 1], angles="xy", scale_units="xy",
              scale=longest / ARROW if longest > 0 else 1.0, width=0.002, color="k", minlength=0)
    plane = ", section $z = L_z/2$" if box.size == 3 else ""
    frame_cell(ax, packing.get("cell", packing["box"]))
    ax.set(xlabel=r"$x\,/\,d_0$", ylabel=r"$y\,/\,d_0$",
           title=f"{title}\n$N$ = {pos.shape[0]}{plane}; arrows longest {ARROW:g} $d_0$, rattlers red")
    ax.title.set_fontsize(9)
    return save(fig, stem)


def plot_mode(packing: dict, shapes: ModeShapes, m: int, stem: str) -> list[str]:
    """Mode ``m`` of ``shapes`` on its ``packing``: arrows for the displacement, colour for the
    rotation about z (grey without rotations, or when Q / K is round-off)."""
    rotating = shapes.rotation is not None and shapes.Q[m] > ROUND_OFF * shapes.K[m]
    ratio = shapes.K[m] / shapes.Q[m] if rotating else np.inf
    return _draw(packing, shapes.displacement[m], shapes.rotation[m][:, -1] if rotating else None,
                 r"rotation about $z$ (rad, $|e| = 1$)",  # 2D: the one angle; 3D: about z, normal to the picture
                 rf"$\omega$ = {shapes.omega[m]:.4f}$/t_0$ (target {shapes.target[m]:g}), $K/Q$ = {ratio:.3g}, "
                 f"$P$ = {shapes.participation[m]:.3f}\n{rho_label(shapes.rho)}, packing {shapes.packing}, "
                 "displacement",
                 stem)


def _run_text(run: str) -> str:
    """A run's label (``excitation.run_label``: 'w_z, k || x') in mathtext."""
    component, axis = run.split(", k || ")
    return "$" + component.replace("w_", r"\omega_") + rf"$, $k \parallel {axis}$"


def plot_wave_snapshots(packings: dict[int, dict], snapshots: list[WaveSnapshot], stem: str) -> list[str]:
    """Each snapshot of each standing wave (``results.wave_snapshots``) on its packing: arrows for
    the velocity, colour for the angular velocity about z; ``<stem>_wave_rho<rho>_<mode>_p<i>_t<t>``."""
    written = []
    for w in snapshots:
        for i, t in enumerate(w.t):
            spin = None if w.spin is None or not np.abs(w.spin[i]).max() > 0 else w.spin[i][:, -1]
            written += _draw(packings[w.packing], w.velocity[i], spin, r"angular velocity about $z$ ($1/t_0$)",
                             rf"standing wave {w.mode} ({_run_text(w.run)}), $k\,d_0$ = {w.k:.4f}, $t$ = {t:g} $t_0$"
                             f"\n{rho_label(w.rho)}, packing {w.packing}, velocity",
                             f"{stem}_wave_rho{w.rho:g}_{w.mode}_p{w.packing}_t{t:g}")
    return written


def plot_mode_shapes(packings: dict[int, dict], groups: list[ModeShapes], stem: str) -> list[str]:
    """Every mode of every group (``results.mode_shapes``), each on its packing (``packings``:
    packing index -> ``results.packing``)."""
    return [path for g in groups for m in range(g.omega.size)
            for path in plot_mode(packings[g.packing], g, m, f"{stem}_mode_rho{g.rho:g}_p{g.packing}_{m}")]
