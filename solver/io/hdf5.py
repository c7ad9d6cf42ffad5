"""HDF5 files: packing files (input and output) and the results file. Rank 0 writes.

Packing file format (input from any code, and what rotsound writes under ``/packings``):
  one configuration at the top level, or several as groups ``/packings/<i>`` (sorted by
  name), each holding
    positions   (N, D) float64   centres of disks (D = 2) or spheres (D = 3), any real values
                                 (folded into [0, L)); the dimension is read from this shape
    diameters   (N,)   float64   > 0, units of the mean diameter d0
    rattler     (N,)   bool      optional; computed (iterative < D + 1 contacts rule) if absent
    attribute box_length  float  side L of the periodic square or cubic box, L > 2 max(diameters)
                                 (in 2D and 3D alike: a pair then touches through one image only)
"""

from __future__ import annotations

import json
import os

import h5py
import numpy as np

from ..errors import InputError
from .. import profiling
from ..packing.jammed import NAMES, Packing, from_arrays, min_contacts

FORMAT_VERSION = 1
EQUILIBRIUM_TOL = 1e-4  # kn d0: largest net force accepted on a loaded packing (FIRE reaches 1e-6)


def _open(path: str):
    if not os.path.isfile(path):
        raise InputError(f"packing file {path}: not found")
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"packing file {path}: not a readable HDF5 file ({exc})") from None


def _read_one(group, where: str) -> Packing:
    def fail(msg):
        raise InputError(f"packing file {where}: {msg}")

    for name in ("positions", "diameters"):
        if name not in group or not isinstance(group[name], h5py.Dataset):
            fail(f"dataset '{name}' is missing")
    if "box_length" not in group.attrs:
        fail("attribute 'box_length' is missing")
    try:
        positions = np.asarray(group["positions"][()], dtype=float)
        diameters = np.asarray(group["diameters"][()], dtype=float)
        box_length = float(np.asarray(group.attrs["box_length"]).reshape(()))
        rattler = np.asarray(group["rattler"][()], dtype=bool) if "rattler" in group else None
    except (OSError, ValueError, TypeError) as exc:
        fail(f"cannot read data ({exc})")
    n = diameters.shape[0] if diameters.ndim == 1 else -1
    if diameters.ndim != 1 or n < 2:
        fail(f"'diameters' has shape {diameters.shape}; need (N,) with N >= 2")
    if positions.shape not in ((n, 2), (n, 3)):
        fail(f"'positions' has shape {positions.shape}; need ({n}, 2) (disks) or ({n}, 3) (spheres) to "
             f"match 'diameters'")
    if rattler is not None and rattler.shape != (n,):
        fail(f"'rattler' has shape {rattler.shape}; need ({n},)")
    if not np.all(np.isfinite(positions)):
        fail("'positions' contains NaN or inf")
    if not np.all(np.isfinite(diameters)) or np.any(diameters <= 0):
        fail("'diameters' must be finite and > 0")
    if not np.isfinite(box_length) or box_length <= 2 * diameters.max():
        fail(f"box_length = {box_length}: must be finite and > 2 max(diameters) = {2 * diameters.max():.4g}")
    packing = from_arrays(positions, diameters, box_length, rattler, {"source": where})
    if packing.rattler.all():
        name = NAMES[packing.dim]
        fail(f"no {name[:-1]} has {min_contacts(packing.dim)} or more contacts (not a jammed packing: all "
             f"{name} are rattlers)")
    residual = net_force(packing)
    if residual > EQUILIBRIUM_TOL:
        fail(f"not in mechanical equilibrium: the largest net contact force on a non-rattler is "
             f"{residual:.3e} kn d0 > {EQUILIBRIUM_TOL:g} (the dynamical matrix needs an energy "
             f"minimum; minimise the packing first)")
    return packing


def net_force(packing: Packing) -> float:
    """Largest net normal contact force on a non-rattler particle (units kn d0)."""
    from ..model import contact_law
    from ..packing import geometry as contacts

    active = ~packing.rattler
    found = contacts.find_contacts(packing.positions, packing.diameters, packing.box_length, active)
    f = contact_law.normal_force(found.overlap)[:, None] * found.normal  # eq:eij, on i
    net = np.zeros((packing.n, packing.dim))
    for axis in range(packing.dim):
        net[:, axis] = (np.bincount(found.i, f[:, axis], minlength=packing.n)
                        - np.bincount(found.j, f[:, axis], minlength=packing.n))
    return float(np.sqrt((net[active] ** 2).sum(axis=1)).max())


def read_packings(paths: str | list[str], count: int | None = None) -> list[Packing]:
    """Read configurations from one or more packing files (first ``count``). Not collective."""
    packings: list[Packing] = []
    for path in [paths] if isinstance(paths, str) else paths:
        with _open(path) as f:
            if "positions" in f:
                packings.append(_read_one(f, path))
            elif "packings" in f and len(f["packings"]):
                for name in sorted(f["packings"]):
                    packings.append(_read_one(f["packings"][name], f"{path}:/packings/{name}"))
            else:
                raise InputError(f"packing file {path}: no 'positions' dataset at the top level "
                                 f"and no '/packings/<i>' groups")
    other = next((i for i, p in enumerate(packings) if p.dim != packings[0].dim), None)
    if other is not None:  # one scene is one dimension: its matrices, waves and analysis assume it
        raise InputError(f"packing.file: the files mix disks (2D) and spheres (3D): configuration 0 has "
                         f"positions (N, {packings[0].dim}), configuration {other} (N, {packings[other].dim}); "
                         f"give the files of one dimension per scene")
    if count is not None:
        if count > len(packings):
            raise InputError(f"packing.count = {count}: the file(s) hold only {len(packings)} configurations")
        packings = packings[:count]
    return packings


def write_packing(group, packing: Packing) -> None:
    """Write one configuration into an open h5py group (file format above)."""
    group.create_dataset("positions", data=packing.positions)
    group.create_dataset("diameters", data=packing.diameters)
    group.create_dataset("rattler", data=packing.rattler)
    group.attrs["box_length"] = packing.box_length
    group.attrs["phi"] = packing.phi
    for key, value in packing.info.items():
        group.attrs[key] = value


def save_packings(path: str, packings: list[Packing]) -> None:
    """Write a stand-alone packing file with groups /packings/<i>. Not collective."""
    with h5py.File(path, "w") as f:
        for index, packing in enumerate(packings):
            write_packing(f.create_group(f"packings/{index:04d}"), packing)


@profiling.logged("rsWriteResults")
def write_results(path: str, provenance: dict, packings: list[Packing], units: dict) -> None:
    """Write the results file atomically (temporary file, then rename). Rank 0 only.

    ``units`` maps a group path to (datasets dict, attrs dict).  On any error the temporary
    file is removed and the error raised: nothing is left behind (the caller raises it on
    every rank).
    """
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    partial = path + ".partial"
    try:
        with h5py.File(partial, "w") as f:
            f.attrs["format_version"] = FORMAT_VERSION
            for key, value in provenance.items():
                f.attrs[key] = value if isinstance(value, (str, int, float)) else json.dumps(value)
            for index, packing in enumerate(packings):
                write_packing(f.create_group(f"packings/{index:04d}"), packing)
            for name, (datasets, attrs) in units.items():
                group = f.create_group(name)
                for key, value in datasets.items():
                    group.create_dataset(key, data=value)
                for key, value in attrs.items():
                    group.attrs[key] = value
        os.replace(partial, path)
    except BaseException:
        if os.path.isfile(partial):
            os.remove(partial)
        raise
