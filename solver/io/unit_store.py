"""Finished units of a run, kept so that a killed run resumes where it stopped; the shared cache.

Each unit (a packing, a matrix summary, a spectrum, the waves of one mode, ...) is written by
rank 0 as its own small HDF5 file in ``<output>.units/`` -- to a temporary name, then renamed
(``atomic.atomic_write``), because an HDF5 file being written when a process is killed can be left
unreadable as a whole.  A rerun of the same scene loads the finished units and computes the
rest; the final results file is assembled from them atomically.  ``scene.yaml`` in the folder
records which scene the units belong to: another scene pointed at the same output is refused.
Delete the folder to recompute everything.

Units are stored under their content keys (``unit_keys``); a unit whose stored key differs
from the key now is recomputed.  The spectrum's window checkpoints carry the key of their
spectrum unit, so a checkpoint made with other settings is discarded, never mixed in.

A shared cache (scene key ``cache``, a folder) holds the same unit files under that key, so
another scene or output that needs the same unit loads it instead of computing it.  Cache
entries are hard links to the unit files where the file system allows (copies otherwise) and
are written atomically like the units themselves.

All methods are collective on ``comm``; rank 0 does the file work, and an error there (of any
type) is raised on every rank.  A run in groups of ranks (``--group-size``) claims the folder once
on all ranks, then gives each group its own handle (:meth:`UnitStore.on`) on the group's
communicator: the groups write different unit files into the same folder side by side.
"""

from __future__ import annotations

import copy
import os
import shutil

import h5py
import numpy as np

from .. import parallel
from ..contact_law import ContactModel
from ..errors import InputError
from ..packing.bridges import cohesion_of
from ..packing.configuration import Packing
from ..packing.stressed import TangentialForces
from .atomic import atomic_write
from .unit_keys import UnitKey

_META = ("complete", "unit_key", "unit_key_parts")
"""Attributes of a unit file that describe the file, not the unit (not in the results file)."""


def cache_folder(scene) -> str | None:
    """The cache folder ``scene`` uses (scene key ``cache``), or None for ``off``."""
    if scene.cache == "off":
        return None
    if scene.cache == "auto":
        return os.path.join(os.path.dirname(scene.output) or ".", "cache")
    return scene.cache


def _missing_folders(path: str) -> list[str]:
    """The folders that ``os.makedirs(path)`` would create, deepest first (absolute paths)."""
    missing, path = [], os.path.abspath(path)
    while not os.path.exists(path):
        missing.append(path)
        path = os.path.dirname(path)
    return missing


def _on_root(comm, work):
    """``work()`` on rank 0; its result on every rank, its error (any type) raised on every rank."""
    return parallel.owner_compute(comm, [0], lambda _: work())[0]


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

        def claim():
            made = _missing_folders(self.folder) + (_missing_folders(cache) if cache else [])
            try:
                if fresh:
                    shutil.rmtree(self.folder, ignore_errors=True)
                    if os.path.exists(output):
                        os.remove(output)
                marked = self._claim(output, scene_yaml, digest)
                if cache:
                    os.makedirs(cache, exist_ok=True)
            except OSError as exc:
                raise InputError(f"{self.folder}: {exc}") from None
            return made, marked
        self._made, self._marked = _on_root(comm, claim)

    def abandon(self) -> None:
        """Undo this store's claim, for a run refused as bad input, so that it blocks no scene: the
        marker ``scene.yaml`` if the claim wrote it, then every folder the claim created that is
        empty by then.  A refusal before any unit was saved so leaves nothing; units finished before
        a later refusal (a packing that did not jam, the other groups' units) stay, in the folder
        and the cache: stored under their content keys, they never mix into another scene, and the
        corrected scene takes those it shares."""
        def remove():
            if self._marked:
                try:
                    os.remove(os.path.join(self.folder, "scene.yaml"))
                except FileNotFoundError:  # removed by hand meanwhile: the refusal, not this, is the news
                    pass
            for folder in self._made:  # deepest first
                try:
                    os.rmdir(folder)
                except OSError:  # not empty (finished units), or already gone
                    pass
        _on_root(self.comm, remove)

    def on(self, comm) -> UnitStore:
        """A handle to the same folder and cache on ``comm`` (one group of this store's ranks,
        ``parallel.Groups``), with counts of its own; it claims nothing (the folder was claimed
        once, by this store).  Groups write different unit files into the folder side by side.
        Not collective."""
        handle = copy.copy(self)
        handle.comm, handle.counts = comm, {}
        return handle

    def absorb(self, handle: UnitStore) -> None:
        """Add to this store's counts those of the handles :meth:`on` made, one per group
        (``handle``: this rank's group's).  Collective on this store's communicator."""
        for counts in self.comm.allgather(handle.counts if handle.comm.rank == 0 else {}):
            for stage, by_how in counts.items():
                for how, number in by_how.items():
                    self.counts.setdefault(stage, {"resumed": 0, "cache": 0, "computed": 0})[how] += number

    def _claim(self, output, scene_yaml, digest) -> bool:
        """Check the folder's marker (or the output) is of this scene, or write the marker: whether
        it was written now.  Rank 0."""
        marker = os.path.join(self.folder, "scene.yaml")
        if os.path.isfile(marker):
            with open(marker, encoding="utf-8") as stream:
                first = stream.readline().strip()
            if first != f"# digest {digest}":
                raise InputError(f"output {output}: {self.folder} holds units of a different scene "
                                 f"({first[9:] or 'unknown'}, this scene is {digest}); choose another "
                                 f"output, or add --fresh to discard them")
            return False
        if os.path.exists(output):
            with h5py.File(output, "r") as f:
                theirs = f.attrs.get("scene_digest", "unknown")
            if theirs != digest:
                raise InputError(f"output {output}: holds results of a different scene (digest {theirs}, "
                                 f"this scene is {digest}); choose another output, or add --fresh to replace it")
        os.makedirs(self.folder, exist_ok=True)
        with atomic_write(marker) as partial, open(partial, "w", encoding="utf-8") as stream:
            stream.write(f"# digest {digest}\n{scene_yaml}")
        return True

    def _path(self, name: str) -> str:
        return os.path.join(self.folder, name.replace("/", "__") + ".h5")

    def _cached(self, name: str, digest: str) -> str:
        return os.path.join(self.cache, name.split("/")[0], digest + ".h5")

    def _count(self, name: str, how: str) -> None:
        stage = self.counts.setdefault(name.split("/")[0], {"resumed": 0, "cache": 0, "computed": 0})
        stage[how] += 1

    @staticmethod
    def _read(path: str):
        """(datasets, attrs, stored key, stored key parts) of a finished unit file, or None if it
        is damaged or incomplete (an unreadable HDF5 file raises OSError in h5py)."""
        try:
            with h5py.File(path, "r") as f:
                if f.attrs.get("complete", False):
                    return ({k: f[k][()] for k in f}, {k: v for k, v in f.attrs.items() if k not in _META},
                            f.attrs.get("unit_key"), f.attrs.get("unit_key_parts"))
        except OSError:
            pass
        return None

    def load(self, name: str, key: UnitKey | None = None, cache: bool = True,
             say_why: bool = True) -> tuple[dict, dict] | None:
        """(datasets, attrs) of a finished unit, or None: from the folder if its stored key is
        ``key``, else from the cache under ``key`` (then also linked into the folder).  A damaged
        file counts as missing; a unit of another key is recomputed, and (``say_why``) the log
        says what changed."""
        def find():
            path = self._path(name)
            found, how, why = None, None, None
            if os.path.isfile(path):
                unit = self._read(path)
                if unit is None:
                    print(f"{parallel.label(self.comm)}rotsound: warning: unit file {path} is damaged or "
                          f"incomplete: recomputing it", flush=True)
                elif key is not None and unit[2] != key.digest:
                    why = key.changes(unit[3])
                else:
                    found, how = unit[:2], "resumed"
            if found is None and key is not None and cache and self.cache and not self.fresh:
                cached = self._cached(name, key.digest)
                if os.path.isfile(cached):
                    unit = self._read(cached)
                    if unit is not None and unit[2] == key.digest:
                        found, how = unit[:2], "cache"
                        self._link(cached, path)
            if why and say_why:
                done = "taken from the cache" if how == "cache" else "recomputing"
                print(f"{parallel.label(self.comm)}{name}: {done}: {why}", flush=True)
            return found, how

        found, how = _on_root(self.comm, find)
        if found is not None:
            self._count(name, how)
        return found

    @staticmethod
    def _link(source: str, target: str) -> None:
        """Hard link (or copy) ``source`` to ``target`` atomically. Rank 0."""
        os.makedirs(os.path.dirname(target), exist_ok=True)
        with atomic_write(target) as partial:
            try:
                os.link(source, partial)
            except OSError:  # no hard links on this file system (or across them): copy
                shutil.copyfile(source, partial)

    def save(self, name: str, datasets: dict, attrs: dict, key: UnitKey | None = None,
             cache: bool = True) -> None:
        """Write one finished unit atomically (rank 0) with its key, and (``cache``) enter it in
        the cache under that key."""
        def write():
            path = self._path(name)
            with atomic_write(path) as partial, h5py.File(partial, "w") as f:
                for k, value in datasets.items():
                    f.create_dataset(k, data=value)
                for k, value in attrs.items():
                    f.attrs[k] = value
                if key is not None:
                    f.attrs["unit_key"] = key.digest
                    f.attrs["unit_key_parts"] = key.parts_json
                f.attrs["complete"] = True
            if key is not None and cache and self.cache:
                self._link(path, self._cached(name, key.digest))

        _on_root(self.comm, write)
        self._count(name, "computed")

    def discard(self, name: str) -> None:
        """Remove a unit file from the folder (rank 0)."""
        def remove():
            if os.path.exists(self._path(name)):
                os.remove(self._path(name))
        _on_root(self.comm, remove)

    def discard_all(self, prefix: str) -> None:
        """Remove every unit file of the folder whose name starts with ``prefix`` (rank 0)."""
        def remove():
            start = os.path.basename(self._path(prefix))[:-3]
            for entry in sorted(os.listdir(self.folder)):
                if entry.startswith(start) and entry.endswith(".h5"):
                    os.remove(os.path.join(self.folder, entry))
        _on_root(self.comm, remove)

    def summary(self) -> str:
        """Per stage, how many units were computed, resumed and reused from the cache."""
        words = {"computed": "computed", "resumed": "resumed", "cache": "from the cache"}
        return "; ".join(f"{stage} " + ", ".join(f"{c[how]} {word}" for how, word in words.items() if c[how])
                         for stage, c in sorted(self.counts.items())) or "none"


class WindowCheckpoint:
    """Finished windows of one spectrum unit (``spectrum.solve(checkpoint=...)``), kept in the
    store as ``spectrum_windows/<tag>_<name>`` under the spectrum unit's key, so that a killed
    hours-long spectrum resumes window by window, on any rank count; a plan or window of another
    key is recomputed (the log says why once, for the plan).  Not cached across scenes: only
    the whole spectrum unit is."""

    def __init__(self, store: UnitStore, tag: str, key: UnitKey | None):
        self.store, self.tag, self.key = store, tag, key

    def load(self, name: str) -> dict | None:
        unit = self.store.load(f"spectrum_windows/{self.tag}_{name}", self.key, cache=False,
                               say_why=name == "plan")
        return None if unit is None else unit[0]

    def save(self, name: str, datasets: dict) -> None:
        self.store.save(f"spectrum_windows/{self.tag}_{name}", datasets, {}, self.key, cache=False)

    def clear(self) -> None:
        """Drop every window file of this spectrum (also stale ones) once its unit is saved."""
        self.store.discard_all(f"spectrum_windows/{self.tag}_")


def packing_unit(p) -> tuple[dict, dict]:
    """A packing as (datasets, attrs) for the store (the box as attribute ``box`` (D,), a tilted
    cell's tilt as ``tilt`` (T,), axes with walls as ``periodic`` (D,))."""
    datasets = {"positions": p.positions, "diameters": p.diameters, "rattler": p.rattler}
    if p.tangential is not None:  # a frictional packing's stored forces
        datasets.update(tangential_pairs=p.tangential.pairs, tangential_force=p.tangential.force)
    if p.bridges is not None:  # a wet packing's bridged pairs apart (its cohesion is in info)
        datasets.update(bridges=p.bridges)
    cell = {name: value for name, value in (("tilt", p.tilt), ("periodic", p.periodic)) if value is not None}
    return datasets, {"box": p.box, **cell, **p.info}  # generated packings only: no masses


def packing_from_unit(unit):
    """Inverse of :func:`packing_unit`."""
    datasets, attrs = unit
    attrs = dict(attrs)
    box = np.broadcast_to(attrs.pop("box") if "box" in attrs else attrs.pop("box_length"),  # older units
                          datasets["positions"].shape[1:]).astype(float)
    tilt, periodic = attrs.pop("tilt", None), attrs.pop("periodic", None)  # absent: orthogonal, periodic
    info = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in attrs.items()}
    stored = None
    if "tangential_pairs" in datasets:
        stored = TangentialForces(datasets["tangential_pairs"], datasets["tangential_force"], info.get("friction"))
    return Packing(datasets["positions"], datasets["diameters"], box, datasets["rattler"].astype(bool), info,
                   tangential=stored, bridges=datasets.get("bridges"), tilt=tilt, periodic=periodic,
                   model=ContactModel(law=info.get("law", "harmonic"), cohesion=cohesion_of(info)))  # as generated
