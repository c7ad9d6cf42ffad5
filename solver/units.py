"""Finished units of a run, kept so that a killed run resumes where it stopped.

Each unit (a packing, a matrix summary, a spectrum, the waves of one mode, ...) is written by
rank 0 as its own small HDF5 file in ``<output>.units/`` -- to a temporary name, then renamed
(atomic on POSIX), because an HDF5 file being written when a process is killed can be left
unreadable as a whole.  A rerun of the same scene loads the finished units and computes the
rest; the final results file is assembled from them atomically.  ``scene.yaml`` in the folder
records which scene the units belong to: another scene pointed at the same output is refused.
Delete the folder to recompute everything.  All methods are collective on ``comm``.
"""

from __future__ import annotations

import os
import shutil

import h5py
import numpy as np

from . import parallel
from .errors import InputError


class UnitStore:
    """The ``<output>.units/`` folder of one scene."""

    def __init__(self, output: str, scene_yaml: str, digest: str, comm, fresh: bool = False):
        self.comm = comm
        self.folder = output + ".units"
        error = None
        if comm.rank == 0:
            try:
                if fresh:
                    shutil.rmtree(self.folder, ignore_errors=True)
                    if os.path.exists(output):
                        os.remove(output)
                self._claim(output, scene_yaml, digest)
            except (InputError, OSError) as exc:
                error = exc if isinstance(exc, InputError) else InputError(f"{self.folder}: {exc}")
        parallel.agree(comm, error)

    def _claim(self, output, scene_yaml, digest):
        marker = os.path.join(self.folder, "scene.yaml")
        if os.path.isfile(marker):
            with open(marker, encoding="utf-8") as stream:
                first = stream.readline().strip()
            if first != f"# digest {digest}":
                raise InputError(f"output {output}: {self.folder} holds units of a different scene "
                                 f"({first[9:] or 'unknown'}, this scene is {digest}); choose another "
                                 f"output, or add --fresh to discard them")
            return
        if os.path.exists(output):
            with h5py.File(output, "r") as f:
                theirs = f.attrs.get("scene_digest", "unknown")
            if theirs != digest:
                raise InputError(f"output {output}: holds results of a different scene (digest {theirs}, "
                                 f"this scene is {digest}); choose another output, or add --fresh to replace it")
        os.makedirs(self.folder, exist_ok=True)
        partial = marker + ".partial"
        with open(partial, "w", encoding="utf-8") as stream:
            stream.write(f"# digest {digest}\n{scene_yaml}")
        os.replace(partial, marker)

    def _path(self, name: str) -> str:
        return os.path.join(self.folder, name.replace("/", "__") + ".h5")

    def load(self, name: str) -> tuple[dict, dict] | None:
        """(datasets, attrs) of a finished unit, or None. A damaged unit file counts as missing."""
        found = None
        if self.comm.rank == 0 and os.path.isfile(self._path(name)):
            try:
                with h5py.File(self._path(name), "r") as f:
                    if f.attrs.get("complete", False):
                        found = ({k: f[k][()] for k in f}, {k: v for k, v in f.attrs.items() if k != "complete"})
            except OSError:
                found = None
            if found is None:
                print(f"rotsound: warning: unit file {self._path(name)} is damaged or incomplete: "
                      f"recomputing it", flush=True)
        return self.comm.bcast(found, root=0)

    def save(self, name: str, datasets: dict, attrs: dict) -> None:
        """Write one finished unit atomically (rank 0)."""
        error = None
        if self.comm.rank == 0:
            partial = self._path(name) + ".partial"
            try:
                with h5py.File(partial, "w") as f:
                    for key, value in datasets.items():
                        f.create_dataset(key, data=value)
                    for key, value in attrs.items():
                        f.attrs[key] = value
                    f.attrs["complete"] = True
                os.replace(partial, self._path(name))
            except OSError as exc:
                error = exc
        parallel.agree(self.comm, error)


def packing_unit(p) -> tuple[dict, dict]:
    """A packing as (datasets, attrs) for the store."""
    return ({"positions": p.positions, "diameters": p.diameters, "rattler": p.rattler},
            {"box_length": p.box_length, **p.info})


def packing_from_unit(unit):
    """Inverse of :func:`packing_unit`."""
    from .packing import Packing

    datasets, attrs = unit
    attrs = dict(attrs)
    box = float(attrs.pop("box_length"))
    info = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in attrs.items()}
    return Packing(datasets["positions"], datasets["diameters"], box, datasets["rattler"].astype(bool), info)
