"""Content keys of units: what determines each unit of a run, hashed, so that a unit made with
other settings is never mixed in (``unit_store`` keeps the units under these keys).

Every unit is keyed by its content (:class:`UnitKey`): what determines it -- the packing's
arrays (or a packing's recipe), rho, the stage's settings, the PETSc options that act on the
stage (``options.acting_on``: ``-log_view`` changes nothing), the rotsound version.  The key
and its parts are stored in the unit file; a unit whose stored key differs from the key now is
recomputed, and the log says what changed (:meth:`UnitKey.changes`).  Not collective.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json

import numpy as np

from .. import __version__
from .. import options
from ..packing import fire
from ..spectrum.plan import probe_seed
from ..transport.rules import bin_width as transport_bin_width
from ..waves import lammps_dem
from ..waves.excitation import wave_modes

FOLDERS = {"matrix": "matrices", "spectrum": "spectra", "modes": "modes", "transport": "diffusivity", "waves": "waves"}
"""Where each kind of unit lives, in the units folder and the results file."""


@dataclasses.dataclass(frozen=True)
class Unit:
    """One unit of a (rho, packing) task: its matrix summary, its spectrum, its mode shapes, its
    diffusivity, or one mode's waves.

    kind : ``matrix``, ``spectrum``, ``modes``, ``transport`` or ``waves``;  r_index, p_index : positions in ``model.rho``
    and in the scene's packings;  rho : ``model.rho[r_index]`` (kt/kn);  mode : the waves' mode
    (L, TR, RT, R), None for the others;  amplitude : a sweep's waves unit, its position in
    ``waves.amplitude`` (None without a sweep).
    """

    kind: str
    r_index: int
    p_index: int
    rho: float
    mode: str | None = None
    amplitude: int | None = None

    @property
    def tag(self) -> str:
        """``r<rho index>_p<packing index>``: the task's part of every unit name."""
        return f"r{self.r_index:02d}_p{self.p_index:04d}"

    @property
    def name(self) -> str:
        """``matrices/<tag>``, ``spectra/<tag>``, ``modes/<tag>``, ``diffusivity/<tag>`` or
        ``waves/r<i>_<mode>_p<j>`` (a sweep's: ``..._a<l>``, l its amplitude's position): the
        unit's file in the units folder and its group in the results file."""
        if self.kind == "waves":
            sweep = "" if self.amplitude is None else f"_a{self.amplitude:02d}"
            return f"waves/r{self.r_index:02d}_{self.mode}_p{self.p_index:04d}{sweep}"
        return f"{FOLDERS[self.kind]}/{self.tag}"


def vdos_name(r_index: int) -> str:
    """``vdos/r<rho index>``: the results file's group of one rho's vDOS, pooled over its
    configurations (made from the spectrum units, not a unit of its own)."""
    return f"vdos/r{r_index:02d}"


def binned_diffusivity_name(r_index: int) -> str:
    """``diffusivity_binned/r<rho index>``: the results file's group of one rho's d(omega) on the
    vDOS's bins, pooled over its configurations (made from the transport units)."""
    return f"diffusivity_binned/r{r_index:02d}"


def task_units(scene, r_index: int, p_index: int) -> list[Unit]:
    """The units of task (rho index, packing index): its matrix, its spectrum, its mode shapes and
    its diffusivity if the scene has them, and the waves of each mode the matrix has (no RT or R without rotational springs:
    ``excitation.wave_modes``), in that order. Not collective."""
    rho = scene.model.rho[r_index]
    units = [Unit("matrix", r_index, p_index, rho)]
    if scene.spectrum is not None:
        units.append(Unit("spectrum", r_index, p_index, rho))
    if scene.modes is not None:
        units.append(Unit("modes", r_index, p_index, rho))
    if scene.transport is not None:
        units.append(Unit("transport", r_index, p_index, rho))
    if scene.waves is not None:
        rotations = scene.model.contact(rho).rotations
        amplitudes = [None] if scene.waves.sweep is None else range(len(scene.waves.sweep))
        units += [Unit("waves", r_index, p_index, rho, mode, a) for mode in wave_modes(scene.waves, rotations)
                  for a in amplitudes]
    return units


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


@dataclasses.dataclass(frozen=True)
class UnitKey:
    """What determines one unit: ``parts`` (JSON-able: unit, packing, rho, section, settings,
    options, version, ...) and ``digest``, their hash (the cache file name)."""

    parts_json: str

    @classmethod
    def of(cls, **parts) -> UnitKey:
        return cls(json.dumps(parts, sort_keys=True, default=str))

    @property
    def parts(self) -> dict:
        return json.loads(self.parts_json)

    @property
    def digest(self) -> str:
        return hashlib.sha256(self.parts_json.encode()).hexdigest()[:24]

    @property
    def options(self) -> dict:
        """The PETSc options acting on the unit (name without '-' -> value, None for a flag)."""
        return self.parts.get("options", {})

    def changes(self, stored_json: str | None) -> str:
        """What differs between the key stored with a unit and this key, in words."""
        if not stored_json:
            return "no content key stored (written by an older rotsound)"
        old, new = json.loads(stored_json), self.parts
        said = []
        for part in sorted(set(old) | set(new)):
            a, b = old.get(part), new.get(part)
            if a == b:
                continue
            if part == "options":
                said.append(f"PETSc options acting on it changed ({_option_changes(a or {}, b or {})})")
            elif part == "settings":
                said.append(f"{new.get('section', 'stage')} settings changed ("
                            + ", ".join(f"{k} {_show(a.get(k))} -> {_show(b.get(k))}"
                                        for k in sorted(set(a or {}) | set(b or {}))
                                        if (a or {}).get(k) != (b or {}).get(k)) + ")")
            elif part == "packing":
                said.append("packing changed")
            else:
                said.append(f"{part} changed ({_show(a)} -> {_show(b)})")
        return "; ".join(said) or "content key differs"


def _show(value) -> str:
    return "none" if value is None else value if isinstance(value, str) else json.dumps(value)


def _option_changes(old: dict, new: dict) -> str:
    """'-spectrum_eps_tol 1e-3, was none; ...' for the options that differ."""
    said = []
    for name in sorted(set(old) | set(new)):
        if name in old and name in new and old[name] == new[name]:
            continue
        now = (f"-{name}" + (f" {new[name]}" if new[name] is not None else "")) if name in new else f"-{name} not set"
        was = "none" if name not in old else "set" if old[name] is None else old[name]
        said.append(f"{now}, was {was}")
    return "; ".join(said)


def packing_key(scene, index: int) -> UnitKey:
    """Key of generated packing ``index`` of ``scene``: its recipe.

    ``dim`` joins the settings only in 3D, ``engine`` only when it is lammps, ``law`` only when
    it is hertz, ``shear`` with ``shear_method`` (quasistatic: the packings of earlier versions,
    made by FIRE in the tilted cell, are not found again) and ``shear_step`` only when the shear is
    not 0, and ``fire``, the version of rotsound's FIRE (``fire.VERSION``), whenever FIRE makes the packing: a packing made by an earlier FIRE, which
    took other steps, is not found again (and a 3D or LAMMPS recipe never matches a 2D or FIRE one).
    """
    spec = scene.packing
    settings = {"n": spec.n, "phi": spec.phi, "seed": scene.seed, "index": index, "force_tol": spec.force_tol,
                "max_steps": spec.max_steps}
    if spec.dim == 3:
        settings["dim"] = 3
    if spec.engine != "fire":
        settings["engine"] = spec.engine
    else:  # rotsound's FIRE: its version (fire.VERSION), which changes its packings
        settings["fire"] = fire.VERSION
    if scene.model.law != "harmonic":  # the normal law FIRE minimises
        settings["law"] = scene.model.law
    if spec.friction is not None and spec.engine == "lammps":  # a frictional packing made by LAMMPS (with FIRE
        settings["friction"] = spec.friction  # it is the mu of the waves' LAMMPS engine: the packing's recipe is not)
    if spec.pressure is not None:  # held at a pressure
        settings["pressure"] = spec.pressure
    if scene.model.cohesion is not None:  # wet: FIRE runs with the bridges
        settings["cohesion"] = dataclasses.asdict(scene.model.cohesion)
    if spec.shear:  # sheared quasi-statically (not the FIRE in a tilted cell of before); unsheared keys as before
        settings.update(shear=spec.shear, shear_method="quasistatic", shear_step=spec.shear_step)
    return UnitKey.of(unit="packing", section="packing", version=__version__, settings=settings)


def scene_keys(scene, packings, petsc_argv: list[str]) -> dict[str, UnitKey]:
    """Content key of every matrix, spectrum, modes, transport and waves unit of the scene (``task_units``), by unit
    name. Not collective.

    A packing is keyed by its arrays, stored tangential forces, walls and wall contacts included
    (gravity adds no stiffness: not in the keys; so a file and a generated
    packing with equal contents share units, and 2D and 3D never do: the arrays' shapes are
    hashed; a tilted cell's tilt and periodic axes too, an orthogonal periodic one's keys are as before); the
    rolling and twisting ratios join every key when they are not 0, and masses, law,
    mobilised, lever, stored_forces and history when not their defaults, and the dashpots when on (so units made
    before they existed keep their keys); spectra and waves also by their section's settings and the PETSc options that act on
    their stage (``options.acting_on``; ``-log_view`` and the like change no key); KPM's probes
    by their seed (``spectrum.plan.probe_seed``).  The rotsound version is part of every key, so a new version
    never reuses an older one's numbers.
    """
    keys = {}
    springs = {name: value for name in ("rho_roll", "rho_twist")
               if (value := getattr(scene.model, name))}  # only when on: 2D keys stay as before
    for name, default in (("masses", "equal"), ("law", "harmonic"), ("mobilised", "stick"), ("lever", "radius"),
                          ("stored_forces", "keep"), ("history", "lammps")):
        if getattr(scene.model, name) != default:
            springs[name] = getattr(scene.model, name)
    if scene.model.damped:  # likewise: undamped keys stay as before
        springs["damping"] = dict(zip(("gamma_n", "gamma_t"), scene.model.dashpots))  # however it was given
    if scene.model.cohesion is not None:  # likewise: dry keys stay as before
        springs["cohesion"] = dataclasses.asdict(scene.model.cohesion)
    for p_index, p in enumerate(packings):
        box = np.float64(p.box[0]) if np.all(p.box == p.box[0]) else p.box  # cubic: the keys of before
        masses = [] if p.masses is None else [p.masses]  # a file's masses: only then, as before
        stored = [] if p.tangential is None else [p.tangential.pairs, p.tangential.force]  # likewise
        stored += [] if p.bridges is None else [p.bridges]  # a wet packing's bridged pairs apart
        stored += [] if p.walls is None else [p.walls.axis, p.walls.position, p.walls.facing]  # docs/walls.md
        stored += [] if p.wall_contacts is None else [p.wall_contacts.particle, p.wall_contacts.wall,
                                                      p.wall_contacts.force]
        cell = p.cell  # a tilted cell or walls: the cell joins the key (orthogonal periodic keys as before)
        shape = [] if not cell.tilted and cell.periodic.all() else [{"tilt": cell.tilt.tolist(),
                                                                     "periodic": cell.periodic.tolist()}]
        base = {"packing": content_key(p.positions, p.diameters, box, p.rattler, *masses, *stored, *shape),
                "version": __version__, **springs}
        for r_index in range(len(scene.model.rho)):
            for unit in task_units(scene, r_index, p_index):
                keys[unit.name] = _key(scene, unit, base, petsc_argv)
    return keys


TRANSPORT_AFTER = ("bin_width", "max_scratch_gib")
"""Transport keys that a unit's numbers do not depend on: the bins of the pooled d(omega) (made
from exact's units when the results are written; kpm's units are made on their bins, which join
its key) and a guard on the scratch's size."""

LAYOUT_KEYS = ("factor_ranks",)
"""Spectrum keys that say how the work is laid out over ranks, not what is computed: the counts
are the same integers on any layout, so they are left out of the keys (a unit made with one
layout is resumed or reused with another, as on any rank count)."""


def spectrum_settings(spec) -> dict:
    """The spectrum section's settings that a spectrum unit's numbers depend on (LAYOUT_KEYS left out)."""
    return {k: v for k, v in dataclasses.asdict(spec).items() if k not in LAYOUT_KEYS}


def _key(scene, unit: Unit, base: dict, petsc_argv: list[str]) -> UnitKey:
    """Key of one matrix, spectrum, modes, transport or waves ``unit`` on the packing and springs of ``base``."""
    if unit.kind == "matrix":
        return UnitKey.of(unit="matrix", rho=unit.rho, options={}, **base)
    if unit.kind == "spectrum":
        return UnitKey.of(unit="spectrum", rho=unit.rho, section="spectrum",
                          settings=spectrum_settings(scene.spectrum),
                          seed=probe_seed(scene.spectrum, scene.seed, unit.p_index),
                          options=options.acting_on(petsc_argv, "spectra", scene.spectrum.method), **base)
    if unit.kind == "modes":  # modes.localised picks its modes from the spectrum: then its settings count too
        spectrum = {"spectrum": spectrum_settings(scene.spectrum)} if scene.modes.localised else {}
        return UnitKey.of(unit="modes", rho=unit.rho, section="modes", settings=dataclasses.asdict(scene.modes),
                          options=options.acting_on(petsc_argv, "modes", "shapes"), **spectrum, **base)
    if unit.kind == "transport":
        settings = {k: v for k, v in dataclasses.asdict(scene.transport).items() if k not in TRANSPORT_AFTER}
        if scene.transport.method == "kpm":  # its probes' seed; its bins are its own (bin_width)
            settings.update(seed=scene.seed + unit.p_index, bin_width=transport_bin_width(scene.transport,
                                                                                          scene.spectrum))
        return UnitKey.of(unit="transport", rho=unit.rho, section="transport", settings=settings,
                          options=options.acting_on(petsc_argv, "transport", scene.transport.method), **base)
    settings = {k: v for k, v in dataclasses.asdict(scene.waves).items()  # one mode's unit does not depend on
                if k != "modes" and not (k in ("axes", "snapshots") and v is None)  # the others; keys of before
                and not (k == "engine" and v == "rotsound")
                and not (k in ("contacts_every", "rolling_friction", "twisting_friction") and v is None)}
    if unit.amplitude is not None:  # a sweep's unit: its own amplitude
        settings["amplitude"] = scene.waves.sweep[unit.amplitude]
    if scene.waves.engine == "lammps":  # LAMMPS's contacts slide at packing.friction; its rest check
        settings.update(friction=scene.packing.friction, rest_tol=scene.packing.force_tol,
                        contacts_every=lammps_dem.record_every(scene.waves.contacts_every))
    return UnitKey.of(unit="waves", rho=unit.rho, mode=unit.mode, section="waves", settings=settings,
                      options=options.acting_on(petsc_argv, "waves", scene.waves.method), **base)
