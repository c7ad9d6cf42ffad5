"""The scene's rules on its ``waves`` section: what its keys ask together and what the rest of the
scene and the packings must give the waves (a dimension for the axis and mode asked, a symmetric
matrix for the spectral path, a first-order path with dashpots, allowed wave numbers in each box,
what LAMMPS needs and can run for ``engine: lammps``).

Each rule takes the waves section (``io.schema.WavesSpec``; None: the scene has no waves, and the
rule passes) and raises InputError naming the keys; ``where`` is the section's key path prefix
(``waves.``).  Which path the waves then take, and whether a matrix's step is stable, is decided
per matrix by ``schedule.plan``.  Pure and not collective: every rank raises the same error.
"""

from __future__ import annotations

from ..errors import InputError
from ..packing.geometry import TILTS
from . import excitation, lammps_dem
from .schedule import MIN_SAMPLES, SECOND_ORDER


def check_section(spec, where: str) -> None:
    """Refuse keys of the waves section ``spec`` that do not go together. Not collective."""
    if (spec.n is None) == (spec.kd0 is None):
        raise InputError(f"{where}n / {where}kd0: give exactly one of them (the wave numbers)")
    if spec.snapshots is not None and (spec.method != "spectral" or max(spec.snapshots) > spec.t_end):
        raise InputError(f"{where}snapshots = {spec.snapshots}: velocity fields of the spectral path, at times up to "
                         f"{where}t_end = {spec.t_end}" + ("" if spec.method == "spectral" else
                                                           f"; {where}method is {spec.method!r}: use spectral"))
    if spec.sweep is not None and spec.engine != "lammps":
        raise InputError(f"{where}amplitude = {spec.sweep}: a sweep of amplitudes needs {where}engine: lammps; the "
                         "linear waves scale with A, so C(k, t) is the same at every amplitude: give one number")
    if spec.sample_every * spec.dt > spec.t_end / MIN_SAMPLES:
        raise InputError(f"{where}sample_every = {spec.sample_every}: with dt = {spec.dt} that leaves "
                         f"fewer than {MIN_SAMPLES} samples in t_end = {spec.t_end}")


def check_dimension(spec, dim: int, source: str) -> None:
    """Refuse, in ``dim`` < 3 dimensions, what exists only in 3D: waves along z, the twist wave R
    (``source`` says where ``dim`` came from, as a clause: "packing.dim is 2"). Not collective."""
    if dim == 3 or spec is None:
        return
    if spec.axes is not None and "z" in spec.axes:
        raise InputError(f"waves.axes = {spec.axes}: axis z needs 3D, but {source}")
    if "R" in spec.modes:
        raise InputError(f"waves.modes = {spec.modes}: mode R (angular velocity along k) needs 3D, but "
                         f"{source}: in 2D the only rotation is about z (use RT, or spheres)")


def check_stressed(spec, why: str) -> None:
    """Refuse the spectral path on a matrix that is not symmetric (``why``, a clause:
    ``model.rules.asymmetry``). Not collective."""
    if spec is not None and spec.method == "spectral":
        raise InputError(f"waves.method = 'spectral': {why}, so the matrix is not symmetric and has no "
                         f"orthogonal eigendecomposition: use waves.method: exponential (exact) or ts")


def check_damping(spec, dashpots: str) -> None:
    """Refuse, with contact dashpots (``dashpots``: the keys that turn them on as the scene wrote
    them, ``ModelSpec.dashpot_keys``; "" for none), what cannot take them: snapshots (undamped
    Lanczos path), a second-order integrator (``SECOND_ORDER``: no velocity-dependent force).
    Not collective."""
    if spec is None or not dashpots:
        return
    if spec.snapshots is not None:
        raise InputError(f"waves.snapshots with {dashpots}: the snapshots come from the undamped Lanczos path; drop "
                         f"waves.snapshots, or {dashpots} to see the undamped wave")
    if spec.method == "ts" and spec.integrator in SECOND_ORDER:
        raise InputError(f"waves.integrator = {spec.integrator!r} with {dashpots}: it integrates "
                         f"M u'' = -D u and has no velocity-dependent force; use waves.method: spectral or "
                         f"exponential (exact), or waves.integrator: rk (or theta, cn, beuler) on the first-order system")


def check_boxes(spec, packings) -> None:
    """Refuse wave numbers a packing's cell does not allow (``excitation.wave_vectors``: in a tilted
    cell along its reciprocal vectors), waves along an axis a packing's walls close (standing waves
    run along periodic axes only; docs/walls.md), and ``waves.engine: lammps`` on a tilted cell or
    between walls (its finite-amplitude runs build an orthogonal, periodic LAMMPS box: ``lammps_dem``),
    for every packing. Not collective."""
    if spec is None:
        return
    for index, p in enumerate(packings):
        cell = p.cell
        axes = excitation.wave_axes(spec, p.dim)
        closed = [a for a in axes if not cell.periodic[a]]
        if closed:
            periodic = [name for a, name in enumerate("xyz"[:p.dim]) if a not in closed and cell.periodic[a]]
            said = f"waves.axes = {spec.axes}" if spec.axes is not None else "waves.axes = null (every axis)"
            raise InputError(f"{said}: configuration {index} is bounded by walls along {'xyz'[closed[0]]}, which is not "
                             f"periodic: standing waves run along periodic axes only; give waves.axes from "
                             f"{', '.join(periodic) or 'its periodic axes (it has none)'}")
        if p.walls is not None and spec.engine == "lammps":
            raise InputError(f"waves.engine: lammps: configuration {index} has walls, which rotsound's LAMMPS waves do "
                             f"not set up; use rotsound's linear waves (waves.engine: rotsound)")
        if spec.engine == "lammps" and cell.tilted:
            tilt = ", ".join(f"{name} = {value:.6g}" for name, value in zip(TILTS[p.dim], cell.tilt))
            _refuse_tilted_lammps(f"configuration {index} is in a tilted cell ({tilt})")
        excitation.wave_vectors(spec, cell, axes)


def _refuse_tilted_lammps(why: str) -> None:
    raise InputError(f"waves.engine: lammps: {why}, and LAMMPS's finite-amplitude waves run in an orthogonal box "
                     "only; use waves.engine: rotsound (the linear waves take the tilted cell)")


def check_engine(spec, packing, model) -> None:
    """Refuse, with ``waves.engine: lammps``, what LAMMPS's waves cannot take: a sheared cell
    (``packing.shear``; a tilted file: ``check_boxes``), rotsound's own
    path or integrator given too (and ``contacts_every`` without it, the rolling and twisting
    limits without pair granular), no Coulomb coefficient (``packing.friction``), a contact model
    LAMMPS cannot run (``lammps_dem.unsupported``), masses other than equal.  Not collective."""
    if spec is not None and spec.engine != "lammps" and spec.contacts_every is not None:
        raise InputError(f"waves.contacts_every = {spec.contacts_every} with waves.engine: {spec.engine}: it spaces the "
                         "records of LAMMPS's contacts (waves.engine: lammps); rotsound's linear waves have none")
    limits = [] if spec is None else [(key, getattr(spec, key)) for key in ("rolling_friction", "twisting_friction")
                                      if getattr(spec, key) is not None]
    if limits and (spec.engine != "lammps" or model.history != "granular"):
        key, value = limits[0]
        raise InputError(f"waves.{key} = {value:g} with waves.engine: {spec.engine} and model.history: "
                         f"{model.history}: it limits LAMMPS's rolling and twisting springs (waves.engine: lammps with "
                         "model.history: granular, LAMMPS's pair granular); drop it or run those")
    if spec is None or spec.engine != "lammps":
        return
    if packing.shear:
        _refuse_tilted_lammps(f"packing.shear = {packing.shear:g} tilts the cell")
    if spec.method != "ts" or spec.integrator != "verlet":
        key, value = ("method", spec.method) if spec.method != "ts" else ("integrator", spec.integrator)
        raise InputError(f"waves.{key} = {value!r} with waves.engine: lammps: LAMMPS integrates the waves with its "
                         f"own velocity Verlet, and waves.{key} chooses rotsound's linear path: give one of the two")
    if not packing.friction:
        given = "missing or null" if packing.friction is None else f"{packing.friction:g}"
        raise InputError(f"waves.engine: lammps needs packing.friction, the Coulomb coefficient mu > 0 of the contacts "
                         f"LAMMPS moves (packing.friction: {given}); without tangential springs (model.rho: 0) it "
                         f"does not act")
    for rho in model.rho:
        why = lammps_dem.unsupported(model.contact(rho))
        if why is not None:
            raise InputError(f"waves.engine: lammps at model.rho = {rho:g}: {why}")
    if model.masses != "equal":
        raise InputError(f"model.masses = {model.masses!r} with waves.engine: lammps: the LAMMPS waves give every "
                         "particle mass 1 (model.masses: equal)")


def check_history(spec, model, packings: list) -> None:
    """Refuse ``waves.engine: lammps`` on a packing whose stored tangential forces LAMMPS's
    contact history cannot be given (``lammps_dem.history_velocities``: more contacts than the
    particles' freedoms reach), or with more distinct diameters than pair granular's twisting
    springs take atom types for (``lammps_dem.atom_types``), naming the configuration, before
    any wave runs.  Not collective."""
    if spec is None or spec.engine != "lammps":
        return
    for index, p in enumerate(packings):
        try:
            lammps_dem.atom_types(p.diameters, model.contact(model.rho[0]))
        except ValueError as error:
            raise InputError(f"waves.engine: lammps: configuration {index}: {error}") from None
        if p.stressed:
            try:
                lammps_dem.history_velocities(p.positions, p.diameters, p.box, model.contact(model.rho[0]),
                                              p.tangential)
            except InputError as error:
                raise InputError(f"configuration {index}: {error}") from None
