"""Run a scene: packings -> dynamical matrices -> spectra / waves -> results file. Collective.

The only module that knows stage order.  Stages run only for what the scene asks.  Every unit
(packing i; matrix, spectrum and each mode's waves of (rho, i)) is committed to the unit store
as soon as it is finished; a rerun loads finished units instead of recomputing them, and a
matrix is assembled only if one of its units is missing.  SIGTERM (a batch system's warning)
is honoured at the next unit boundary, on every rank together.  Everything runs on the
communicator given to :func:`run` (any mpi4py communicator, e.g. half of a split), and each
stage inside its own PETSc log stage (``profiling.STAGES``), so ``-log_view`` splits the time.
With ``group_size``, the (rho, packing) units are dealt to groups of ranks, each solving on its
own sub-communicator (``parallel.Groups``); every rank then holds every unit.
"""

from __future__ import annotations

import dataclasses
import json
import signal
import sys
import time

import numpy as np

from . import __version__, parallel
from .analysis import dispersion
from .model import damping, dynmat
from .io import hdf5
from .packing import jammed
from .packing.configuration import Packing
from .packing import mechanics
from . import options
from .model import operators
from .spectrum import unit as spectrum_unit
from .transport import unit as transport_unit
from .waves import excitation, lammps_dem
from .waves import schedule
from .waves.unit import mode_unit
from .io import scene_rules
from .io.schema import Scene
from .errors import InputError, Interrupted, NumericalFailure
from . import profiling
from .io import unit_keys
from .io.unit_keys import Unit, task_units
from .io.unit_store import UnitStore, WindowCheckpoint, cache_folder, packing_from_unit, packing_unit
from .wording import counted

_TERMINATE = [False]


def _on_sigterm(signum, frame):  # noqa: ARG001 - signal handler signature
    _TERMINATE[0] = True


def check_interrupt(comm) -> None:
    """Raise Interrupted on every rank if any rank received SIGTERM. Collective."""
    from mpi4py import MPI

    if comm.allreduce(_TERMINATE[0], op=MPI.LOR):
        raise Interrupted("SIGTERM received")


def say(comm, message: str) -> None:
    """Print on rank 0 of ``comm`` only, prefixed '[group g/count] ' on a group's communicator
    (``parallel.label``); one write per line, so that the lines of groups printing at the same
    time do not interleave mid-line under mpirun."""
    if comm.rank == 0:
        sys.stdout.write(parallel.label(comm) + message + "\n")
        sys.stdout.flush()


def make_packings(scene: Scene, comm, store: UnitStore | None = None) -> list[Packing]:
    """Read ``packing.file`` or generate ``packing.count`` configurations. Collective.

    Generation is spread over ranks (configuration i on rank i % size, seeded by
    SeedSequence([seed, i])), so the result does not depend on the number of ranks; with
    ``packing.engine: lammps`` each configuration is minimised by LAMMPS on all ranks in turn
    (its round-off, hence possibly its minimum, depends on the number of ranks: see
    ``lammps_engine``).  Generated packings already in ``store`` are loaded; new ones are
    committed to it.
    """
    spec = scene.packing
    if spec.file is not None:
        def load(_):
            read = hdf5.read_packings(spec.file, spec.count, check_equilibrium=not spec.relax,
                                      model=scene.model.at_rest, contacts=spec.contacts, friction=spec.friction,
                                      contacts_format=spec.contacts_format, fmt=spec.format, walls=spec.walls,
                                      wall_contacts=spec.wall_contacts, gravity=spec.gravity)
            return [_relaxed(p, index, scene) for index, p in enumerate(read)] if spec.relax else read

        return parallel.owner_compute(comm, [0], load)[0]
    count = spec.count or 1
    recipe = [unit_keys.packing_key(scene, i) for i in range(count)]
    found = [store.load(f"packings/{i:04d}", recipe[i]) if store else None for i in range(count)]
    missing = [i for i in range(count) if found[i] is None]
    seeds = [parallel.seed_sequence(scene.seed, i) for i in missing]
    if spec.engine == "lammps":  # each configuration on all ranks, one after another
        made = [jammed.generate(spec.n, spec.phi, s, spec.force_tol, spec.max_steps, dim=spec.dim,
                                engine="lammps", comm=comm, law=scene.model.law, friction=spec.friction,
                                pressure=spec.pressure)
                for s in seeds]
    else:
        made = parallel.owner_compute(comm, seeds, lambda s: jammed.generate(
            spec.n, spec.phi, s, spec.force_tol, spec.max_steps, dim=spec.dim, law=scene.model.law,
            cohesion=scene.model.bridges, shear=spec.shear, shear_step=spec.shear_step))
    for i, p in zip(missing, made):
        if store:
            store.save(f"packings/{i:04d}", *packing_unit(p), key=recipe[i])
    by_index = dict(zip(missing, made))
    packings = [by_index[i] if found[i] is None else packing_from_unit(found[i]) for i in range(count)]
    jammed.require_jammed(packings, spec.phi)  # made, resumed or cached alike, before any solver
    return packings


def _relaxed(p: Packing, index: int, scene: Scene) -> Packing:
    """``packing.relax``: configuration ``index`` of the file re-minimised frictionlessly; InputError
    if it does not stay jammed. Not collective."""
    spec = scene.packing
    relaxed = jammed.relax(p, spec.force_tol, spec.max_steps)
    if why := mechanics.jamming_failure(relaxed):
        raise InputError(f"packing.relax: configuration {index} of {spec.file} did not stay jammed without "
                         f"friction: {why}; a packing made with friction can be looser than the frictionless "
                         f"jamming point (phi = {relaxed.phi:.4f} here), and then has no frictionless rigid "
                         f"state to build the matrix on")
    return relaxed


def _solve_in_groups(scene: Scene, packings, keys, store: UnitStore, groups: parallel.Groups) -> dict:
    """Every matrix, spectrum and waves unit of the scene, on every rank. Collective on ``groups.comm``.

    The tasks -- each (rho, packing), rho-major from the largest rho down, an order that does not
    depend on the grouping -- are dealt to the groups in a snake (``groups.mine``): a task's cost
    grows with rho (omega_max sets the Lanczos steps of its waves and the inertias of its counts),
    so each group gets a costly and a cheap one in turn (measured in BENCHMARKS "paper programme":
    round-robin left one group of the waves scene idle for about 5 min).  Each group loads or computes its
    tasks' units on its own communicator, through its own handle to the units folder, and checks
    for SIGTERM on that communicator between units; ``groups.comm`` is not used until every group
    is done.  Then an error of any group is raised on every rank (before an interruption, should
    both happen), else Interrupted if any group was stopped; otherwise every unit is shared among
    all ranks and the groups' counts are added to ``store``'s.  An unexpected error in a group of
    several ranks may be one rank's alone, with the others of its group stuck in a collective:
    it is not caught here, and the command line aborts every rank (as without groups).
    """
    rho = scene.model.rho
    tasks = [(r_index, p_index) for r_index in sorted(range(len(rho)), key=lambda r: -rho[r])
             for p_index in range(len(packings))]
    local = store.on(groups.local)
    agreed = BaseException if groups.size == 1 else (InputError, NumericalFailure, Interrupted)
    units: dict[str, tuple[dict, dict]] = {}
    error = None
    try:
        for r_index, p_index in groups.mine(tasks):
            _solve_task(scene, packings[p_index], task_units(scene, r_index, p_index), keys, local, units)
    except agreed as exc:  # raised on every rank of the group together: on every rank below
        error = exc
    groups.wait()
    parallel.agree(groups.comm, None if isinstance(error, Interrupted) else error)
    parallel.agree(groups.comm, error)  # by now an interruption
    store.absorb(local)
    return groups.share(units, {unit.name: groups.owner(t) for t, task in enumerate(tasks)
                                for unit in task_units(scene, *task)})


def _solve_task(scene: Scene, p, task: list[Unit], keys, store: UnitStore, units: dict) -> None:
    """Load the finished units of one (rho, packing ``p``) ``task`` (``task_units``; the matrix
    first) from ``store`` into ``units``, and compute the others. Collective on ``store.comm``
    (one group)."""
    comm = store.comm
    check_interrupt(comm)

    def commit(unit: Unit, datasets, attrs):  # each unit records the options that produced it
        attrs = {**attrs, "petsc_options": json.dumps(keys[unit.name].options)}
        units[unit.name] = (datasets, attrs)
        store.save(unit.name, datasets, attrs, keys[unit.name])

    todo = []
    for unit in task:
        found = store.load(unit.name, keys.get(unit.name))
        if found is None:
            todo.append(unit)
        else:  # a cached unit may come from another scene's numbering, and from a sweep or not
            found[1]["packing"] = unit.p_index
            found[1].pop("amplitude_index", None)
            if unit.amplitude is not None:  # the same content: here a sweep unit, with its place in this sweep
                found[1]["amplitude_index"] = unit.amplitude
            units[unit.name] = found
    if todo:
        spectrum = next((unit.name for unit in task if unit.kind == "spectrum"), None)
        _compute(scene, p, task[0], todo, commit, comm, WindowCheckpoint(store, task[0].tag, keys.get(spectrum)),
                 units.get(spectrum, (None,))[0], f"{store.folder}/transport_scratch/{task[0].tag}")


def _compute(scene, p, matrix: Unit, todo: list[Unit], commit, comm, checkpoint=None, spectrum=None,
             scratch=None) -> None:
    """Assemble the matrix of task ``matrix`` (its matrix unit) on packing ``p`` and compute the
    units of ``todo`` (``checkpoint``: the spectrum's window checkpoint, a :class:`WindowCheckpoint`;
    ``spectrum``: the datasets of the task's spectrum unit when it was loaded, not computed;
    ``scratch``: the folder of the diffusivity's eigenvectors, None: in memory)."""
    from petsc4py import PETSc

    made = {} if spectrum is None else {"spectrum": spectrum}

    def keep(unit: Unit, datasets, attrs):  # the spectrum's datasets also feed modes.localised
        made[unit.kind] = datasets
        commit(unit, datasets, attrs)

    rho, p_index = matrix.rho, matrix.p_index
    t = time.perf_counter()
    with profiling.stage("assembly"):
        dm = dynmat.assemble(p, scene.model.contact(rho), PETSc.Comm(comm), scene.model.masses)
        if scene.model.damped:
            dm.C = damping.assemble(p, dm, scene.model.masses)
    seconds = parallel.global_max(comm, time.perf_counter() - t)
    nnz = int(dm.D.getInfo()["nz_used"])  # PETSc's default is the global sum
    say(comm, f"matrix rho = {rho:g}, packing {p_index}: {dm.size} DOF "
              f"({dm.dof} per particle), {nnz} non-zeros, assembled in {seconds:.3f} s")
    try:
        wave_todo = [unit for unit in todo if unit.kind == "waves"]
        if wave_todo:  # how the waves run, refused here if it cannot work: before any other solve
            with profiling.stage("waves"):
                plan = schedule.plan(scene.waves, operators.largest_omega(dm), rho,
                                     operators.largest_damping_rate(dm))
        if matrix in todo:
            commit(matrix, {}, {
                "rho": rho, "rho_roll": dm.model.rho_roll, "rho_twist": dm.model.rho_twist, "dim": dm.dim,
                "masses": scene.model.masses, "law": dm.model.law, "packing": p_index,
                "size": dm.size, "dof_per_disk": dm.dof,
                "nnz": nnz, "n_contacts": dm.n_contacts, "assembly_seconds": seconds})
        wanted = next((unit for unit in todo if unit.kind == "spectrum"), None)
        if wanted is not None:
            check_interrupt(comm)

            def between(line):  # windows take hours: say how far, and stop there on SIGTERM
                if line:
                    say(comm, line)
                check_interrupt(comm)

            with profiling.stage(spectrum_unit.log_stage(scene.spectrum)):
                datasets, attrs, lines = spectrum_unit.solve(scene.spectrum, dm, rho, p_index, scene.seed, comm,
                                                             between, checkpoint)
                keep(wanted, datasets, attrs)
                if checkpoint is not None:  # the unit is safe: its windows are not needed any more
                    checkpoint.clear()
                for line in lines:
                    say(comm, line)
        wanted = next((unit for unit in todo if unit.kind == "modes"), None)
        if wanted is not None:
            check_interrupt(comm)
            with profiling.stage("modes"):
                datasets, attrs, line = spectrum_unit.mode_shapes(scene.modes, dm, rho, p_index, comm,
                                                                  made.get("spectrum"))
                commit(wanted, datasets, attrs)
                say(comm, line)
        wanted = next((unit for unit in todo if unit.kind == "transport"), None)
        if wanted is not None:
            check_interrupt(comm)
            with profiling.stage("transport"):
                datasets, attrs, line = transport_unit.solve(scene.transport, dm, p.positions, p.cell, rho, p_index,
                                                             scene.seed, comm, scratch, scene.spectrum)
                commit(wanted, datasets, attrs)
                say(comm, line)
        if wave_todo:
            with profiling.stage("waves"):
                _wave_units(scene, dm, p, wave_todo, commit, comm, plan)
    finally:
        dm.destroy()


def _wave_units(scene, dm, p, todo: list[Unit], commit, comm, plan: schedule.Schedule) -> None:
    """Every (mode, run, k) of the waves units ``todo`` of one (rho, packing) into ``units``
    (``waves.unit.mode_unit``; a mode's runs: ``excitation.runs(mode, dm.dim)``).

    ``plan``: how they run (``schedule.plan``).  Collective."""
    spec = scene.waves
    dem = lammps_dem.Setting(p.diameters, p.box, scene.packing.friction, scene.packing.force_tol,
                             lammps_dem.record_every(spec.contacts_every), p.tangential,
                             *lammps_dem.rolling_limits(spec)) if plan.path == "lammps" else None
    axes = excitation.wave_axes(spec, dm.dim)
    ns, ks = excitation.wave_vectors(spec, p.cell, axes)
    for line in excitation.log_lines(spec, ns, ks, axes, p.cell):
        say(comm, line)
    for unit in todo:
        check_interrupt(comm)
        t0 = time.perf_counter()
        at = spec if unit.amplitude is None else dataclasses.replace(spec, amplitude=spec.sweep[unit.amplitude])
        datasets, attrs, summary = mode_unit(dm, p.positions, at, unit.mode, ns, ks, axes, plan, dem, cell=p.cell)
        seconds = parallel.global_max(comm, time.perf_counter() - t0)
        sweep = {} if unit.amplitude is None else {"amplitude_index": unit.amplitude}
        commit(unit, datasets, {**attrs, "packing": unit.p_index, "seconds": seconds, **sweep})
        say(comm, f"waves rho = {unit.rho:g}, {unit.mode}, packing {unit.p_index}"
                  + ("" if unit.amplitude is None else f", A = {at.amplitude:g}") + f": {len(ks)} k x "
                  f"{len(datasets['runs'])} runs, {summary}, {seconds:.1f} s")


def _vdos_unit(scene, rho, r_index, spectra, units, comm) -> None:
    """vDOS and omega_c of one rho from its configurations' spectrum units into ``units``."""
    datasets, attrs, line = spectrum_unit.vdos(scene.spectrum, rho, spectra)
    units[unit_keys.vdos_name(r_index)] = (datasets, attrs)
    say(comm, line)


def _binned_diffusivity(scene, rho, r_index, count, units, comm) -> None:
    """d(omega) of one rho from its ``count`` configurations' transport units into ``units``, on
    the bins of its vDOS when the scene has one."""
    vdos = units.get(unit_keys.vdos_name(r_index))
    datasets, attrs, line = transport_unit.binned(
        scene.transport, scene.spectrum, rho, [units[Unit("transport", r_index, p_index, rho).name]
                                               for p_index in range(count)], None if vdos is None else vdos[0]["edges"])
    units[unit_keys.binned_diffusivity_name(r_index)] = (datasets, attrs)
    say(comm, line)


def run(scene: Scene, comm, petsc_argv: list[str], fresh: bool = False, group_size: int | None = None) -> dict:
    """Execute ``scene`` on ``comm`` (mpi4py communicator); return a summary. Collective.

    ``fresh`` discards the output file and its finished units first.  ``group_size`` G (a
    divisor of ``comm.size``; default: all ranks) splits the ranks into groups of G that solve
    the (rho, packing) units side by side (:func:`_solve_in_groups`); packings, the vDOS, the
    analysis and the results file are made on ``comm`` as a whole.  A scene refused as bad input
    writes nothing: a packing file is read and checked before the units folder is claimed, and a
    refusal after the claim undoes it (``UnitStore.abandon``: the marker goes, finished units stay).
    """
    t0 = time.perf_counter()
    asked = scene  # spectrum.method auto: as the scene alone gives it until the packings are read
    scene = scene_rules.check_run(asked, group_size or comm.size, f"--group-size {group_size}" if group_size else
                                  f"{comm.size} rank{'s' * (comm.size > 1)} in the run")
    if scene.waves is not None and scene.waves.engine == "lammps":  # LAMMPS missing: refused before any compute
        lammps_dem.require(comm)
    packings = chosen = None
    if scene.packing.file is not None:  # a refused file or scene writes nothing: read and check before the store
        with profiling.stage("packings"):
            packings = make_packings(scene, comm)
        scene, chosen = scene_rules.check_packings(asked, packings)
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        check_interrupt(comm)  # a SIGTERM in an earlier scene of the file: stop before this one's packings
        store = UnitStore(scene.output, scene.to_yaml(), asked.digest(), comm, fresh=fresh,
                          cache=cache_folder(scene))
        try:
            if packings is None:
                with profiling.stage("packings"):
                    packings = make_packings(scene, comm, store)
                scene, chosen = scene_rules.check_packings(asked, packings)
            units, group_ranks = _solve(scene, comm, petsc_argv, group_size, store, packings, chosen)
        except InputError:  # refused after the claim (a generated packing, a solver's check): leave no debris
            store.abandon()
            raise
        return _write(scene, asked, comm, petsc_argv, store, packings, units, group_ranks, t0)
    finally:
        signal.signal(signal.SIGTERM, previous)


def _walls_line(p) -> str:
    """', walls x = 0, 12.5 (9 wall contacts, their share of the pressure 1.2e-03), g = [0, 0, -0.01]'
    for the log (docs/walls.md)."""
    where = ", ".join(f"{'xyz'[a]} = {x:g}" for a, x in zip(p.walls.axis, p.walls.position))
    share = float(np.trace(p.info["stress_walls"])) / p.dim
    gravity = "" if p.gravity is None else f", g = {np.asarray(p.gravity).tolist()}"
    return f", walls {where} ({p.info['n_wall_contacts']} wall contacts, their share of the pressure {share:.3e}){gravity}"


def _solve(scene: Scene, comm, petsc_argv, group_size, store: UnitStore, packings, chosen: str | None
           ) -> tuple[dict, int]:
    """:func:`run` once the units folder is claimed and the packings made or read: solve every unit
    and analyse; return (units, ranks per group).  ``chosen``: what ``spectrum.method: auto`` chose,
    to log.  Collective."""
    keys = unit_keys.scene_keys(scene, packings, petsc_argv)
    for index, p in enumerate(packings):
        i = p.info
        say(comm, f"packing {index}: N = {p.n}, phi = {p.phi:.4f}, z = {i['z']:.3f}, "
                  f"pressure = {i['pressure']:.4e}, energy = {i['energy']:.4e}, "
                  f"rattlers = {100 * i['rattler_fraction']:.2f} %"
                  + (f", bridges = {i['n_bridges']} ({len(p.bridges)} apart)" if p.bridges is not None else "")
                  + (f", FIRE steps = {i['fire_steps']}" if "fire_steps" in i else "")
                  + (_walls_line(p) if p.walls is not None else ""))
    if chosen:
        say(comm, chosen)
    if scene.model.damped:
        dashpots = scene.model.dashpot_record
        say(comm, f"dashpots: gamma_n = {dashpots['gamma_n']:.6g}, gamma_t = {dashpots['gamma_t']:.6g} (1/t0); "
                  f"gamma_n from {dashpots['gamma_n_from']}")
    for rho in scene.model.rho:
        if scene.waves:
            kept = excitation.wave_modes(scene.waves, scene.model.contact(rho).rotations)
            skipped = [m for m in scene.waves.modes if m not in kept]
            if skipped:
                say(comm, f"waves rho = {rho:g}: {', '.join(skipped)} skipped (no rotational stiffness)")
    with parallel.Groups(comm, group_size) as groups:
        if groups.count > 1:
            say(comm, f"{groups.count} groups of {counted(groups.size, 'rank')} share "
                      f"the {len(scene.model.rho) * len(packings)} (rho, packing) tasks")
        units = _solve_in_groups(scene, packings, keys, store, groups)
    if scene.spectrum is not None:
        for r_index, rho in enumerate(scene.model.rho):
            with profiling.stage("analysis"):
                _vdos_unit(scene, rho, r_index, [units[Unit("spectrum", r_index, p_index, rho).name]
                                                 for p_index in range(len(packings))], units, comm)
    if scene.transport is not None:
        for r_index, rho in enumerate(scene.model.rho):
            with profiling.stage("analysis"):
                _binned_diffusivity(scene, rho, r_index, len(packings), units, comm)
    say(comm, f"units: {store.summary()} (folder {store.folder}; cache {store.cache or 'off'})")
    if scene.waves is not None:
        t = time.perf_counter()
        with profiling.stage("analysis"), profiling.event("rsAnalyse"):
            derived = parallel.owner_compute(comm, [0], lambda _: dispersion.analyse(units, scene.analysis))[0]
        units.update(derived)
        lattice = derived.get("analysis/lattice", ({}, {}))[1]
        say(comm, f"analysis: {counted(len(derived), 'group')} in {time.perf_counter() - t:.1f} s"
                  + (f"; lattice model a_r = {lattice['a_r']:.3f} +- {lattice['a_r_err']:.3f}/t0, "
                     f"l = {lattice['l']:.3f} +- {lattice['l_err']:.3f} d0, a_t = {lattice['a_t']:.3f}/t0"
                     if lattice else ""))
    return units, groups.size


def _write(scene: Scene, asked: Scene, comm, petsc_argv, store: UnitStore, packings, units: dict, group_ranks: int,
           t0: float) -> dict:
    """Report unused PETSc options and write the results file (rank 0) of ``scene`` (``asked`` with
    its method resolved; the digest is ``asked``'s); return the run's summary.  Collective."""
    from petsc4py import PETSc

    stages = ([("spectra", scene.spectrum.method)] if scene.spectrum else []) + (
        [("modes", "shapes")] if scene.modes else []) + (
        [("transport", scene.transport.method)] if scene.transport else []) + (
        [("waves", scene.waves.method)] if scene.waves else [])
    unused = options.unused(options.option_names(petsc_argv), stages)  # same on every rank
    for name in unused:
        say(comm, f"rotsound: warning: PETSc option -{name} was never used (misspelt, or for a "
                  f"stage this scene does not run)")
    provenance = {
        "rotsound_version": __version__, "scene": scene.to_yaml(), "scene_digest": asked.digest(),
        "petsc_version": ".".join(map(str, PETSc.Sys.getVersion())), "numpy_version": np.__version__,
        "ranks": comm.size, "group_size": group_ranks, "petsc_options": options.snapshot(),
        "petsc_options_unused": unused, "dashpots": scene.model.dashpot_record,
    }
    try:  # rank 0 writes; any error it meets is raised on every rank (owner_compute)
        with profiling.stage("output"):
            parallel.owner_compute(comm, [0], lambda _: hdf5.write_results(scene.output, provenance,
                                                                           packings, units))
    except OSError as exc:
        raise InputError(f"output = {scene.output}: cannot write the results file ({exc}); the "
                         f"finished units are kept in {store.folder}: run again to resume") from exc
    say(comm, f"wrote {scene.output} ({counted(len(packings), 'packing')}, {counted(len(units), 'result group')}) "
              f"in {time.perf_counter() - t0:.1f} s")
    return {"packings": packings, "units": units}
