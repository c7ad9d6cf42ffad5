"""Finished units of a run, kept so that a killed run resumes where it stopped.

Each unit (a packing, a matrix summary, a spectrum, the waves of one mode, ...) is written by
rank 0 as its own small HDF5 file in ``<output>.units/`` -- to a temporary name, then renamed
(atomic on POSIX), because an HDF5 file being written when a process is killed can be left
unreadable as a whole.  A rerun of the same scene loads the finished units and computes the
rest; the final results file is assembled from them atomically.  ``scene.yaml`` in the folder
records which scene the units belong to: another scene pointed at the same output is refused.
Delete the folder to recompute everything.

A shared cache (scene key ``cache``, a folder) holds the same unit files under a content key:
a hash of everything that determines the unit (packing recipe or packing arrays, rho, the
stage's settings, the PETSc options), so another scene or output that needs the same unit
loads it instead of computing it.  Cache entries are hard links to the unit files where the
file system allows (copies otherwise) and are written atomically like the units themselves.
All methods are collective on ``comm``.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil

import h5py
import numpy as np

from .. import parallel
from ..errors import InputError


def content_key(*parts) -> str:
    """Stable hash of JSON-able parts and numpy arrays (a cache key)."""
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, np.ndarray):
            h.update(str((part.dtype.str, part.shape)).encode())
            h.update(np.ascontiguousarray(part).tobytes())
        else:
            h.update(json.dumps(part, sort_keys=True, default=str).encode())
    return h.hexdigest()[:24]


class UnitStore:
    """The ``<output>.units/`` folder of one scene, and the shared cache if it has one.

    ``counts`` says, per stage (packings, matrices, spectra, waves), how many units were
    resumed from the folder, reused from the cache, and computed."""

    def __init__(self, output: str, scene_yaml: str, digest: str, comm, fresh: bool = False,
                 cache: str | None = None):
        self.comm = comm
        self.folder = output + ".units"
        self.cache = cache
        self.fresh = fresh
        self.counts: dict[str, dict[str, int]] = {}
        error = None
        if comm.rank == 0:
            try:
                if fresh:
                    shutil.rmtree(self.folder, ignore_errors=True)
                    if os.path.exists(output):
                        os.remove(output)
                self._claim(output, scene_yaml, digest)
                if cache:
                    os.makedirs(cache, exist_ok=True)
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

    def _cached(self, name: str, key: str) -> str:
        return os.path.join(self.cache, name.split("/")[0], key + ".h5")

    def _count(self, name: str, how: str) -> None:
        stage = self.counts.setdefault(name.split("/")[0], {"resumed": 0, "cache": 0, "computed": 0})
        stage[how] += 1

    @staticmethod
    def _read(path: str):
        try:
            with h5py.File(path, "r") as f:
                if f.attrs.get("complete", False):
                    return {k: f[k][()] for k in f}, {k: v for k, v in f.attrs.items() if k != "complete"}
        except OSError:
            pass
        return None

    def load(self, name: str, key: str | None = None) -> tuple[dict, dict] | None:
        """(datasets, attrs) of a finished unit, or None: from the folder, else from the cache
        under ``key`` (then also linked into the folder). A damaged file counts as missing."""
        found, how = None, None
        if self.comm.rank == 0:
            path = self._path(name)
            if os.path.isfile(path):
                found, how = self._read(path), "resumed"
                if found is None:
                    print(f"rotsound: warning: unit file {path} is damaged or incomplete: recomputing it",
                          flush=True)
            if found is None and key and self.cache and not self.fresh:
                cached = self._cached(name, key)
                if os.path.isfile(cached):
                    found, how = self._read(cached), "cache"
                    if found is not None:
                        self._link(cached, path)
        found, how = self.comm.bcast((found, how), root=0)
        if found is not None:
            self._count(name, how)
        return found

    @staticmethod
    def _link(source: str, target: str) -> None:
        """Hard link (or copy) ``source`` to ``target`` atomically."""
        os.makedirs(os.path.dirname(target), exist_ok=True)
        partial = target + ".partial"
        if os.path.exists(partial):
            os.remove(partial)
        try:
            os.link(source, partial)
        except OSError:
            shutil.copyfile(source, partial)
        os.replace(partial, target)

    def save(self, name: str, datasets: dict, attrs: dict, key: str | None = None) -> None:
        """Write one finished unit atomically (rank 0), and enter it in the cache under ``key``."""
        error = None
        if self.comm.rank == 0:
            partial = self._path(name) + ".partial"
            try:
                with h5py.File(partial, "w") as f:
                    for k, value in datasets.items():
                        f.create_dataset(k, data=value)
                    for k, value in attrs.items():
                        f.attrs[k] = value
                    f.attrs["complete"] = True
                os.replace(partial, self._path(name))
                if key and self.cache:
                    self._link(self._path(name), self._cached(name, key))
            except OSError as exc:
                error = exc
        parallel.agree(self.comm, error)
        self._count(name, "computed")

    def discard(self, name: str) -> None:
        """Remove a unit file from the folder (rank 0), e.g. checkpoints made redundant."""
        if self.comm.rank == 0 and os.path.exists(self._path(name)):
            os.remove(self._path(name))

    def summary(self) -> str:
        """Per stage, how many units were computed, resumed and reused from the cache."""
        words = {"computed": "computed", "resumed": "resumed", "cache": "from the cache"}
        return "; ".join(f"{stage} " + ", ".join(f"{c[how]} {word}" for how, word in words.items() if c[how])
                         for stage, c in sorted(self.counts.items())) or "none"


class WindowCheckpoint:
    """Finished windows of one spectrum unit (``spectrum.solve(checkpoint=...)``), kept in the
    store as ``spectrum_windows/<tag>_<name>`` so that a killed hours-long spectrum resumes
    window by window.  Not cached across scenes: only the whole spectrum unit is."""

    def __init__(self, store: UnitStore, tag: str):
        self.store, self.tag, self.names = store, tag, set()

    def load(self, name: str) -> dict | None:
        self.names.add(name)
        unit = self.store.load(f"spectrum_windows/{self.tag}_{name}")
        return None if unit is None else unit[0]

    def save(self, name: str, datasets: dict) -> None:
        self.names.add(name)
        self.store.save(f"spectrum_windows/{self.tag}_{name}", datasets, {})

    def clear(self) -> None:
        """Drop the window files once the whole spectrum unit is saved."""
        for name in self.names:
            self.store.discard(f"spectrum_windows/{self.tag}_{name}")


def packing_unit(p) -> tuple[dict, dict]:
    """A packing as (datasets, attrs) for the store."""
    return ({"positions": p.positions, "diameters": p.diameters, "rattler": p.rattler},
            {"box_length": p.box_length, **p.info})


def packing_from_unit(unit):
    """Inverse of :func:`packing_unit`."""
    from ..packing.jammed import Packing

    datasets, attrs = unit
    attrs = dict(attrs)
    box = float(attrs.pop("box_length"))
    info = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in attrs.items()}
    return Packing(datasets["positions"], datasets["diameters"], box, datasets["rattler"].astype(bool), info)
