"""Figures from results files only (never imports petsc4py or mpi4py). Not collective."""

from __future__ import annotations

import os

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import EllipseCollection  # noqa: E402

from .errors import InputError  # noqa: E402


def _save(fig, stem: str) -> list[str]:
    paths = [f"{stem}.png", f"{stem}.pdf"]
    for path in paths:
        fig.savefig(path, dpi=150)
    plt.close(fig)
    return paths


def plot_packing(group, stem: str) -> list[str]:
    """Disks of one configuration, rattlers in red; units of d0."""
    pos, diam = group["positions"][()], group["diameters"][()]
    rattler, box = group["rattler"][()], float(group.attrs["box_length"])
    fig, ax = plt.subplots(figsize=(6, 6))
    colors = np.where(rattler, "tab:red", np.where(diam > diam.mean(), "0.55", "0.8"))
    ax.add_collection(EllipseCollection(diam, diam, np.zeros_like(diam), offsets=pos,
                                        units="xy", offset_transform=ax.transData,
                                        facecolors=colors, edgecolors="k", linewidths=0.2))
    ax.set(xlim=(0, box), ylim=(0, box), aspect="equal", xlabel="x / d0", ylabel="y / d0",
           title=f"N = {diam.size}, phi = {group.attrs['phi']:.3f}, z = {group.attrs['z']:.2f}, "
                 f"rattlers in red ({int(rattler.sum())})")
    return _save(fig, stem)


def plot_results(path: str) -> list[str]:
    """Write every figure the results file has data for, next to it; return the paths."""
    if not os.path.isfile(path):
        raise InputError(f"results file {path}: not found (run the scene first)")
    stem = os.path.splitext(path)[0]
    written: list[str] = []
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"results file {path}: not a readable HDF5 file ({exc})") from None
    with f:
        if "packings" in f and len(f["packings"]):
            first = sorted(f["packings"])[0]
            written += plot_packing(f["packings"][first], f"{stem}_packing")
    return written
