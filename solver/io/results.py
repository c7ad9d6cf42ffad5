"""Reading results files (written by ``io.hdf5.write_results``) into what the report and the
figures need: plain numpy arrays and dicts, no h5py objects outside this module.

:func:`open_results` is the one door: it refuses a missing or unreadable file, a file without the
root attribute ``format_version`` (not a rotsound results file) and a file of a newer
``format_version`` than this rotsound reads, each with an :class:`~solver.errors.InputError`
naming the file.  The readers take the open file and read one quantity each (the waves' sampled
runs only when asked: they are the largest part).  h5py and numpy only (no PETSc, no MPI); not
collective.  Units as in the file layout (the manual, docs/results_file.md): omega in 1/t0, k in 1/d0, t in t0.
"""

from __future__ import annotations

import json

import os
from typing import NamedTuple

import h5py
import numpy as np

from ..contact_law import ContactModel
from ..errors import InputError
from ..packing import geometry
from . import hdf5
from .hdf5 import FORMAT_VERSION


class Vdos(NamedTuple):
    """``vdos/r<i>``: g(omega) of one rho, every configuration pooled."""

    edges: np.ndarray       #: (B+1,) 1/t0, the bins' edges
    density: np.ndarray     #: (B,) t0, g(omega) on the bins, of unit area
    omega_c: float          #: 1/t0, the mean over the configurations of the largest eigenfrequency
    omega_c_std: float      #: 1/t0, its standard deviation over the configurations
    configurations: int     #: how many configurations were pooled


class Diffusivity(NamedTuple):
    """The Allen-Feldman diffusivity of one rho (the scene's ``transport`` section): per mode
    (``diffusivity/r<i>_p<j>`` of method exact, every configuration pooled, ascending omega) and on
    the vDOS's bins (``diffusivity_binned/r<i>``)."""

    method: str             #: ``exact`` or ``kpm`` (``transport.method``)
    omega: np.ndarray       #: (M,) 1/t0, every non-zero mode of every configuration, ascending (kpm: empty)
    d: np.ndarray           #: (M,) d0^2/t0, each mode's diffusivity (kpm: empty)
    edges: np.ndarray       #: (B+1,) 1/t0, the vDOS's bins
    d_binned: np.ndarray    #: (B,) d0^2/t0, the mean d of each bin's modes, NaN where none
    d_std: np.ndarray       #: (B,) d0^2/t0, exact: their spread (kpm: NaN)
    d_err: np.ndarray       #: (B,) d0^2/t0, kpm: the standard error of d_binned over the probes (exact: NaN)
    count: np.ndarray       #: (B,) modes in each bin (kpm: estimated)
    eta: float              #: 1/t0, exact's Lorentzian half-width (kpm: NaN)
    configurations: int     #: how many configurations were pooled


class BinnedEnergies(NamedTuple):
    """KPM spectra of one rho: per-configuration bin averages, cut to the shortest grid."""

    edges: np.ndarray       #: (B+1,) 1/t0, the bins' edges
    density: np.ndarray     #: (C, B) t0, each configuration's density of states on the bins
    K: np.ndarray           #: (C, B) bin average of the modes' translational kinetic energy K, NaN in near-empty bins
    Q: np.ndarray           #: (C, B) bin average of their rotational kinetic energy Q, NaN in near-empty bins


class DampedModes(NamedTuple):
    """Damped modes of one rho (``spectra/`` groups of method pep), every configuration pooled."""

    lam: np.ndarray         #: (M,) complex 1/t0: -sigma + i omega_d, Im >= 0 (module pep)
    K: np.ndarray | None    #: (M,) each mode's translational kinetic energy K, with spectrum.energies (else None)
    Q: np.ndarray | None    #: (M,) each mode's rotational kinetic energy Q, with spectrum.energies (else None)
    dof: int                #: degrees of freedom of the first configuration


class ModeShapes(NamedTuple):
    """``modes/r<i>_p<j>``: the modes of one (rho, packing) kept whole near target frequencies
    (the scene's ``modes`` section; ``spectrum.shapes``), M modes, N particles."""

    rho: float                      #: the stiffness ratio rho = kt/kn of the modes' matrix
    packing: int                    #: index of its configuration (``packings/<i>``)
    target: np.ndarray              #: (M,) 1/t0, the target each mode was found for
    omega: np.ndarray               #: (M,) 1/t0, the modes' frequencies
    displacement: np.ndarray        #: (M, N, D) d0: u = M^-1/2 e, abs(e) = 1; zero on rattlers
    rotation: np.ndarray | None     #: (M, N, R) rad (R = 1 in 2D, 3 in 3D); None without rotations
    share: np.ndarray               #: (M, N, 2): each particle's part of abs(e)^2 = 1, and its rotations' part
    K: np.ndarray                   #: (M,) each mode's translational kinetic energy K, as spectra's
    Q: np.ndarray                   #: (M,) each mode's rotational kinetic energy Q, as spectra's
    participation: np.ndarray       #: (M,) participation ratio, as spectra's


class WaveSnapshot(NamedTuple):
    """The whole velocity field of one standing wave at chosen times (``waves.snapshots``): the
    first run of a (rho, mode) at the smallest k, on its packing."""

    rho: float                      #: the stiffness ratio rho = kt/kn
    mode: str                       #: the wave's polarisation (L, TR, ...: ``waves.modes``)
    packing: int                    #: index of its configuration (``packings/<i>``)
    k: float                        #: 1/d0, the wave number
    run: str                        #: the run's label, e.g. "v_x, k || x"
    t: np.ndarray                   #: (T,) t0, the snapshots' times
    velocity: np.ndarray            #: (T, N, D) d0/t0, zero on rattlers
    spin: np.ndarray | None         #: (T, N, R) 1/t0; None without rotations


class Sweep(NamedTuple):
    """An amplitude sweep of one (rho, mode) (``waves.engine: lammps`` with a list of
    amplitudes), in ascending amplitude: the fits per amplitude and k, and what the contacts did.
    Its crossover amplitude A*: :func:`crossover`."""

    amplitude: np.ndarray   #: (A,) d0/t0 (1/t0 for RT and R), ascending
    k: np.ndarray           #: (K,) 1/d0
    omega: np.ndarray       #: (A, K) 1/t0, the damped cosine's frequency, NaN where the fit failed
    gamma: np.ndarray       #: (A, K) 1/t0, its decay rate
    omega_err: np.ndarray   #: (A, K) 1/t0, omega's 1-sigma error
    gamma_err: np.ndarray   #: (A, K) 1/t0, gamma's 1-sigma error
    sliding: np.ndarray     #: (A, K) most contacts at the Coulomb limit at once, over runs, configurations, t
    opened: np.ndarray      #: (A, K) most of the start's contacts open at once
    formed: np.ndarray      #: (A, K) most new contacts at once
    #: (A, K) largest abs(E - E(0)) / E(0) of the wave's energy (the share sliding took), mean over
    #: runs and configurations
    energy_change: np.ndarray
    coulomb: np.ndarray     #: (A, K) largest abs(f_t) / (mu abs(f_n)) over contacts, runs, configurations, t (1: sliding)
    opening: np.ndarray     #: (A, K) largest (xi_0 - xi) / xi_0 over the start's contacts (1: one opened)


class Crossover(NamedTuple):
    """The crossover amplitude A* of an amplitude sweep, per k (:func:`crossover`): the smallest
    amplitude at which the wave stops being linear.  In the sweep's amplitude unit (d0/t0; 1/t0 for
    RT and R); 0 where the sweep's smallest amplitude already departs from the linear reference
    (A* is below the sweep), NaN where no amplitude of the sweep departs."""

    omega: np.ndarray       #: (K,) A* of the frequency omega
    gamma: np.ndarray       #: (K,) A* of the decay rate gamma


class Waves(NamedTuple):
    """Sampled Fourier components of one (rho, mode), the runs of every configuration pooled."""

    k: np.ndarray           #: (K,) 1/d0, of the first configuration
    t: np.ndarray           #: (S,) t0, evenly spaced
    z: np.ndarray           #: (R, K, S) complex: R = the runs of the mode (2 in 2D; 3 or 6 in 3D) x configurations
    omega_max: float        #: 1/t0, the largest matrix frequency over the configurations


def open_results(path: str) -> h5py.File:
    """Open a results file for reading after checking it is one this rotsound can read.

    Use as ``with open_results(path) as f:``.  Raises InputError (naming ``path``) when the file
    is missing, not HDF5, has no ``format_version`` root attribute, or a newer one than
    ``io.hdf5.FORMAT_VERSION``.  Older versions are read (there is only version 1 so far).
    """
    if not os.path.isfile(path):
        raise InputError(f"results file {path}: not found (run its scene first)")
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"results file {path}: not a readable HDF5 file ({exc})") from None
    version = f.attrs.get("format_version")
    problem = None
    if version is None:
        problem = "not a rotsound results file (it has no root attribute format_version)"
    elif not np.issubdtype(np.asarray(version).dtype, np.integer) or np.asarray(version).shape != () \
            or int(version) < 1:
        problem = f"not a rotsound results file (format_version = {version!r})"
    elif int(version) > FORMAT_VERSION:
        problem = (f"format_version {int(version)} is newer than this rotsound reads (format_version "
                   f"{FORMAT_VERSION}); update rotsound to read it")
    if problem:
        f.close()
        raise InputError(f"results file {path}: {problem}")
    return f


def _groups(f, name: str) -> list:
    return [f[name][key] for key in sorted(f[name])] if name in f else []


def contents(f) -> list[str]:
    """Which of the top-level result kinds the file holds, in a fixed order."""
    return [name for name in ("vdos", "spectra", "modes", "diffusivity", "waves", "analysis") if name in f]


def packing_summary(f) -> tuple[float, int]:
    """(phi, N) of the first configuration; (NaN, 0) for a file without packings."""
    groups = _groups(f, "packings")
    if not groups:
        return float("nan"), 0
    return float(groups[0].attrs["phi"]), int(groups[0]["diameters"].shape[0])


def contact_model(f) -> ContactModel:
    """What the packings were checked under (``ContactModel.at_rest``): the scene's ``model.law``,
    ``model.lever`` and ``model.cohesion``, from the root attribute ``scene`` (their defaults where
    it gives none)."""
    import yaml

    from .coerce import build
    from .schema import CohesionSpec

    scene = yaml.safe_load(f.attrs["scene"]) if "scene" in f.attrs else {}
    model = scene.get("model") or {}
    wet = model.get("cohesion")
    return ContactModel(law=str(model.get("law", "harmonic")), lever=str(model.get("lever", "radius")),
                        cohesion=None if wet is None else build(CohesionSpec, wet, "model.cohesion.").cohesion())


def packing_friction(f) -> float | None:
    """The Coulomb mu of the first configuration's stored tangential forces (a frictional packing:
    group ``tangential``, attribute ``friction``); None for an unstressed packing or mu unknown."""
    groups = _groups(f, "packings")
    if not groups or "tangential" not in groups[0] or "friction" not in groups[0]["tangential"].attrs:
        return None
    return float(groups[0]["tangential"].attrs["friction"])


def first_packing(f) -> dict | None:
    """The first configuration: positions (N, D) (D = 2 or 3), diameters (N,), rattler (N,) bool and the
    attributes box (D,) side lengths, tilt (T,) the cell's tilt factors (``geometry.TILTS``: xy, or
    xy xz yz; zeros when orthogonal), periodic (D,) bool (which axes are periodic), cell (the three as
    a ``geometry.Cell``: ``cell.matrix`` holds the edge vectors), phi, z (mean contact number; NaN if
    absent: a loaded packing has none), a wet packing's bridges (B, 2) (its bridged pairs apart), and
    a packing between walls its walls ({axis (W,), position (W,)}), its stress tensor stress (D, D)
    with the walls' share stress_walls (D, D), and its gravity (D,) when it has one (docs/walls.md);
    None without packings.  A file written before tilted cells (no attributes tilt, periodic) reads
    as orthogonal and periodic."""
    return packing(f, 0) if _groups(f, "packings") else None


def packing(f, index: int) -> dict:
    """Configuration ``index`` as :func:`first_packing` gives the first; InputError if the file has
    no such configuration."""
    groups = _groups(f, "packings")
    if not 0 <= index < len(groups):
        raise InputError(f"results file {f.filename}: no packing {index} (it has {len(groups)})")
    g = groups[index]
    wet = {"bridges": g["bridges"][()].reshape(-1, 2)} if "bridges" in g else {}
    dim = g["positions"].shape[1]
    cell = geometry.Cell.of(hdf5.box_of(g, dim), dim)
    if "tilt" in g.attrs or "periodic" in g.attrs:
        cell = geometry.Cell(cell.sides, np.asarray(g.attrs.get("tilt", cell.tilt), dtype=float),
                             np.asarray(g.attrs.get("periodic", cell.periodic), dtype=bool))
    walled = {}
    if "walls" in g:  # docs/walls.md
        walled = {"walls": {"axis": g["walls/axis"][()], "position": g["walls/position"][()]},
                  "stress": g.attrs["stress"], "stress_walls": g.attrs["stress_walls"]}
    if "gravity" in g.attrs:
        walled["gravity"] = g.attrs["gravity"]
    return {"positions": g["positions"][()], "diameters": g["diameters"][()], "rattler": g["rattler"][()],
            "box": cell.sides.copy(), "tilt": cell.tilt.copy(), "periodic": cell.periodic.copy(), "cell": cell,
            "phi": float(g.attrs["phi"]), "z": float(g.attrs.get("z", np.nan)), **wet, **walled}


def mode_shapes(f) -> list[ModeShapes]:
    """Every ``modes/`` group, in (rho index, packing) order."""
    return [ModeShapes(float(g.attrs["rho"]), int(g.attrs["packing"]), g["target"][()], g["omega"][()],
                       g["displacement"][()], g["rotation"][()] if "rotation" in g else None, g["share"][()],
                       g["K"][()], g["Q"][()], g["participation"][()])
            for g in _groups(f, "modes")]


def vdos(f) -> dict[float, Vdos]:
    """{rho: Vdos} of every ``vdos/`` group."""
    return {float(g.attrs["rho"]): Vdos(g["edges"][()], g["density"][()], float(g.attrs["omega_c"]),
                                        float(g.attrs["omega_c_std"]), int(g.attrs["configurations"]))
            for g in _groups(f, "vdos")}


def diffusivity(f) -> dict[float, Diffusivity]:
    """{rho: Diffusivity} of the ``diffusivity_binned/`` groups and their ``diffusivity/`` units."""
    per_rho: dict[float, list] = {}
    for g in _groups(f, "diffusivity"):
        per_rho.setdefault(float(g.attrs["rho"]), []).append(g)
    out = {}
    for g in _groups(f, "diffusivity_binned"):
        rho = float(g.attrs["rho"])
        units = [unit for unit in per_rho.get(rho, []) if "omega" in unit]  # exact's per-mode units
        omega = np.concatenate([unit["omega"][()] for unit in units] or [np.empty(0)])
        d = np.concatenate([unit["d"][()] for unit in units] or [np.empty(0)])
        order = np.argsort(omega, kind="stable")
        missing = np.full(g["d"].shape, np.nan)
        out[rho] = Diffusivity(str(g.attrs["method"]), omega[order], d[order], g["edges"][()], g["d"][()],
                               g["d_std"][()] if "d_std" in g else missing, g["d_err"][()] if "d_err" in g else missing,
                               g["count"][()], float(g.attrs["eta"]), int(g.attrs["configurations"]))
    return out


def mode_energies(f) -> dict[float, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """{rho: (omega, K, Q)} per mode (slicing spectra with energies), configurations concatenated."""
    per_rho: dict[float, list] = {}
    for g in _groups(f, "spectra"):
        if "K" in g and "omega" in g:
            per_rho.setdefault(float(g.attrs["rho"]), []).append(g)
    return {rho: tuple(np.concatenate([g[key][()] for g in groups]) for key in ("omega", "K", "Q"))
            for rho, groups in per_rho.items()}


def participation(f) -> dict[float, tuple[np.ndarray, np.ndarray]]:
    """{rho: (omega, participation ratio)} per mode (slicing spectra with energies), configurations
    concatenated."""
    per_rho: dict[float, list] = {}
    for g in _groups(f, "spectra"):
        if "participation" in g and "omega" in g:
            per_rho.setdefault(float(g.attrs["rho"]), []).append(g)
    return {rho: (np.concatenate([g["omega"][()] for g in groups]),
                  np.concatenate([g["participation"][()] for g in groups])) for rho, groups in per_rho.items()}


def damped_modes(f) -> dict[float, DampedModes]:
    """{rho: DampedModes} of the spectra groups holding ``lambda`` (spectrum.method pep)."""
    per_rho: dict[float, list] = {}
    for g in _groups(f, "spectra"):
        if "lambda" in g:
            per_rho.setdefault(float(g.attrs["rho"]), []).append(g)
    out = {}
    for rho, groups in per_rho.items():
        energies = all("K" in g for g in groups)
        out[rho] = DampedModes(np.concatenate([g["lambda"][()] for g in groups]),
                               np.concatenate([g["K"][()] for g in groups]) if energies else None,
                               np.concatenate([g["Q"][()] for g in groups]) if energies else None,
                               int(groups[0].attrs["dof"]))
    return out


def binned_energies(f) -> dict[float, BinnedEnergies]:
    """{rho: BinnedEnergies} of KPM spectra with energies (bin averages, no per-mode data)."""
    per_rho: dict[float, list] = {}
    for g in _groups(f, "spectra"):
        if "K" in g and "edges" in g:  # kpm: per-mode spectra (slicing, pep) have no bins
            per_rho.setdefault(float(g.attrs["rho"]), []).append(g)
    out = {}
    for rho, groups in per_rho.items():
        size = min(g["K"].shape[0] for g in groups)
        out[rho] = BinnedEnergies(groups[0]["edges"][:size + 1],
                                  *(np.array([g[key][:size] for g in groups]) for key in ("density", "K", "Q")))
    return out


def waves(f, rhos=None) -> dict[tuple[float, str], Waves]:
    """{(rho, mode): Waves} of the ``waves/`` groups (only the rho in ``rhos`` when given), an
    amplitude sweep's left out (:func:`sweeps`)."""
    per_key: dict[tuple, list] = {}
    for g in _groups(f, "waves"):
        rho = float(g.attrs["rho"])
        if (rhos is None or rho in rhos) and "amplitude_index" not in g.attrs:  # a sweep's: ``sweeps``
            per_key.setdefault((rho, str(g.attrs["mode"])), []).append(g)
    return {key: Waves(groups[0]["k"][()], groups[0]["t"][()],
                       np.concatenate([g["z"][()] for g in groups], axis=0),
                       max(float(g.attrs["omega_max"]) for g in groups))
            for key, groups in per_key.items()}


def wave_snapshots(f) -> list[WaveSnapshot]:
    """Every waves group holding ``snapshot_t``, in (rho index, mode, packing) order."""
    return [WaveSnapshot(float(g.attrs["rho"]), str(g.attrs["mode"]), int(g.attrs["packing"]),
                         float(g.attrs["snapshot_k"]), str(g.attrs["snapshot_run"]), g["snapshot_t"][()],
                         g["snapshot_velocity"][()], g["snapshot_spin"][()] if "snapshot_spin" in g else None)
            for g in _groups(f, "waves") if "snapshot_t" in g]


def fits(f) -> dict[tuple[float, str], dict]:
    """{(rho, mode): datasets and attributes} of the ``analysis/rho<rho>_<mode>`` groups (an
    amplitude sweep's: :func:`sweeps`)."""
    if "analysis" not in f:
        return {}
    groups = [f["analysis"][name] for name in f["analysis"]
              if "mode" in f["analysis"][name].attrs and "amplitude" not in f["analysis"][name].attrs]
    return {(float(g.attrs["rho"]), str(g.attrs["mode"])): {**{key: g[key][()] for key in g}, **dict(g.attrs)}
            for g in groups}


def sweeps(f) -> dict[tuple[float, str], Sweep]:
    """{(rho, mode): Sweep} of an amplitude sweep's ``analysis/rho<rho>_<mode>_a<LL>`` fits and
    ``waves/..._a<LL>`` contact series; {} without one."""
    per_key: dict[tuple, dict] = {}
    for g in _groups(f, "waves"):
        if "amplitude_index" in g.attrs:
            key = (float(g.attrs["rho"]), str(g.attrs["mode"]))
            per_key.setdefault(key, {}).setdefault(float(g.attrs["amplitude"]), []).append(g)
    fitted = {(float(g.attrs["rho"]), str(g.attrs["mode"]), float(g.attrs["amplitude"])): g
              for g in _groups(f, "analysis") if "amplitude" in g.attrs}
    out = {}
    for (rho, mode), by_amplitude in per_key.items():
        amplitudes = sorted(by_amplitude)
        fits_ = [fitted[(rho, mode, a)] for a in amplitudes]

        def most(name):
            return np.array([np.max([g[name][()].max(axis=(0, 2)) for g in by_amplitude[a]], axis=0)
                             for a in amplitudes])

        lost = np.array([np.mean([g["energy_drift"][()].mean(axis=0) for g in by_amplitude[a]], axis=0)
                         for a in amplitudes])
        out[(rho, mode)] = Sweep(np.array(amplitudes), fits_[0]["k"][()],
                                 *(np.array([g[name][()] for g in fits_]) for name in
                                   ("omega", "gamma", "omega_err", "gamma_err")),
                                 most("contacts_sliding"), most("contacts_opened"), most("contacts_formed"), lost,
                                 most("contacts_coulomb"), most("contacts_opening"))
    return out


def crossover(sweep: Sweep, linear: dict | None = None, tol: float = 0.01) -> Crossover:
    """The measured crossover amplitude A* of one sweep (``sweeps(f)[(rho, mode)]``), per k: the
    smallest amplitude at which omega (and gamma) departs from its linear value by ``tol`` (1 %)
    and by more than twice the two fits' combined 1-sigma error, interpolated log-linearly between
    the two amplitudes that straddle it (``analysis.thresholds.crossover``).  The linear value is
    ``linear``'s when given: the fits of linear waves of the same packing, mode and k
    (``fits(g)[(rho, mode)]`` of that run's file); else the sweep's smallest amplitude's (a
    departure there is then not seen: NaN, not 0).  Not collective."""
    from ..analysis.thresholds import crossover as measured

    def star(name):
        value, error = getattr(sweep, name), getattr(sweep, f"{name}_err")
        if linear is None:
            return measured(sweep.amplitude, value, error, tol)
        return measured(sweep.amplitude, value, error, tol, reference=linear[name],
                        reference_error=linear[f"{name}_err"])

    return Crossover(star("omega"), star("gamma"))


def sweep_friction(f) -> float | None:
    """The Coulomb mu an amplitude sweep's LAMMPS waves ran at (their units' ``solver_settings``);
    None without a sweep."""
    for g in _groups(f, "waves"):
        if "amplitude_index" in g.attrs:
            return float(json.loads(g.attrs["solver_settings"])["lammps"]["friction"])
    return None


def lattice(f) -> dict | None:
    """Attributes of ``analysis/lattice`` (the fitted lattice model), None without it."""
    return dict(f["analysis/lattice"].attrs) if "analysis/lattice" in f else None


def bands(f) -> dict | None:
    """Datasets of ``analysis/bands`` (band limits per rho > 0), None without it."""
    return {key: f["analysis/bands"][key][()] for key in f["analysis/bands"]} if "analysis/bands" in f else None
