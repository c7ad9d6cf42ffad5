"""Run a scene: packings -> dynamical matrices -> spectra / waves -> results file. Collective.

The only module that knows stage order.  Stages run only for what the scene asks.  Every unit
(packing i; matrix, spectrum and each mode's waves of (rho, i)) is committed to the unit store
as soon as it is finished; a rerun loads finished units instead of recomputing them, and a
matrix is assembled only if one of its units is missing.  SIGTERM (a batch system's warning)
is honoured at the next unit boundary, on every rank together.
"""

from __future__ import annotations

import dataclasses
import signal
import time

import numpy as np

from . import __version__, parallel
from .analysis import dispersion as analysis
from .analysis import correlations
from .model import dynmat
from .io import hdf5 as h5io
from .spectrum import kpm
from .spectrum import modes
from .packing import jammed as packing
from . import options as petscopts
from .spectrum import slicing as spectrum
from .waves import integrators as waves
from .io.schema import Scene
from .errors import InputError, Interrupted
from .io.units import UnitStore, WindowCheckpoint, content_key, packing_from_unit, packing_unit

_TERMINATE = [False]


def _on_sigterm(signum, frame):  # noqa: ARG001 - signal handler signature
    _TERMINATE[0] = True


def check_interrupt(comm) -> None:
    """Raise Interrupted on every rank if any rank received SIGTERM. Collective."""
    from mpi4py import MPI

    if comm.allreduce(_TERMINATE[0], op=MPI.LOR):
        raise Interrupted("SIGTERM received")


def say(comm, message: str) -> None:
    """Print on rank 0 only."""
    if comm.rank == 0:
        print(message, flush=True)


def make_packings(scene: Scene, comm, store: UnitStore | None = None) -> list[packing.Packing]:
    """Read ``packing.file`` or generate ``packing.count`` configurations. Collective.

    Generation is spread over ranks (configuration i on rank i % size, seeded by
    SeedSequence([seed, i])), so the result does not depend on the number of ranks.  Generated
    packings already in ``store`` are loaded; new ones are committed to it.
    """
    spec = scene.packing
    if spec.file is not None:
        return parallel.owner_compute(comm, [0], lambda _: h5io.read_packings(spec.file, spec.count))[0]
    count = spec.count or 1
    recipe = [content_key("packing", __version__, spec.n, spec.phi, scene.seed, i, spec.force_tol, spec.max_steps)
              for i in range(count)]
    found = [store.load(f"packings/{i:04d}", recipe[i]) if store else None for i in range(count)]
    missing = [i for i in range(count) if found[i] is None]
    made = parallel.owner_compute(
        comm, [parallel.seed_sequence(scene.seed, i) for i in missing],
        lambda s: packing.generate(spec.n, spec.phi, s, spec.force_tol, spec.max_steps))
    for i, p in zip(missing, made):
        if store:
            store.save(f"packings/{i:04d}", *packing_unit(p), key=recipe[i])
    by_index = dict(zip(missing, made))
    return [by_index[i] if found[i] is None else packing_from_unit(found[i]) for i in range(count)]


def _compute(scene, p, rho, r_index, p_index, tag, found, commit, comm, store=None) -> None:
    """Assemble the matrix of (rho, p) and compute the units of ``found`` that are None."""
    from petsc4py import PETSc

    t = time.perf_counter()
    dm = dynmat.assemble(p, rho, PETSc.COMM_WORLD)
    seconds = parallel.global_max(comm, time.perf_counter() - t)
    nnz = int(dm.D.getInfo()["nz_used"])  # PETSc's default is the global sum
    say(comm, f"matrix rho = {rho:g}, packing {p_index}: {dm.size} DOF "
              f"({dm.dof} per disk), {nnz} non-zeros, assembled in {seconds:.3f} s")
    try:
        wave_todo = [m for m in (scene.waves.modes if scene.waves else [])
                     if found.get(f"waves/r{r_index:02d}_{m}_p{p_index:04d}", 0) is None]
        stability = None
        if wave_todo and scene.waves.method == "spectral":
            stability = ("spectral", spectrum.largest_omega(dm), None)
        elif wave_todo:
            stability = _check_time_step(scene.waves, dm, rho)
        if found[f"matrices/{tag}"] is None:
            commit(f"matrices/{tag}", {}, {
                "rho": rho, "packing": p_index, "size": dm.size, "dof_per_disk": dm.dof,
                "nnz": nnz, "n_contacts": dm.n_contacts, "assembly_seconds": seconds})
        if scene.spectrum is not None and found[f"spectra/{tag}"] is None:
            check_interrupt(comm)
            if scene.spectrum.method == "kpm":
                _kpm_unit(scene, dm, rho, r_index, p_index, commit, comm)
            else:
                _spectrum_unit(scene, dm, rho, r_index, p_index, commit, comm,
                               WindowCheckpoint(store, tag) if store else None)
        if wave_todo:
            _wave_units(scene, dm, p, rho, r_index, p_index, commit, comm, stability, wave_todo)
    finally:
        dm.destroy()


def _kpm_unit(scene, dm, rho, r_index, p_index, commit, comm):
    """Stochastic vDOS of one (rho, packing) into ``units``; return (edges, density, omega_max)."""
    spec = scene.spectrum
    t = time.perf_counter()
    omega_max = spectrum.largest_omega(dm)
    edges = np.arange(0.0, spec.bin_width * (np.ceil(1.1 * omega_max / spec.bin_width) + 1), spec.bin_width)
    n_moments = spec.moments or kpm.auto_moments(omega_max**2, spec.bin_width)
    datasets = {"edges": edges}
    if spec.energies and dm.dof == 3:  # K and Q from channel-restricted probes (same cost x 2)
        datasets["density"], datasets["K"], datasets["Q"] = kpm.energies(
            dm, edges, omega_max**2, n_moments, spec.probes, scene.seed + p_index)
    else:
        datasets["density"] = kpm.vdos(dm, edges, omega_max**2, n_moments, spec.probes, scene.seed + p_index)
        if spec.energies:  # rho = 0: no rotations; every mode has K = 1/4N, Q = 0
            populated = datasets["density"] > 0
            datasets["K"] = np.where(populated, 1.0 / (4 * int(dm.active.sum())), np.nan)
            datasets["Q"] = np.where(populated, 0.0, np.nan)
    density = datasets["density"]
    seconds = parallel.global_max(comm, time.perf_counter() - t)
    commit(f"spectra/r{r_index:02d}_p{p_index:04d}", datasets, {
        "rho": rho, "packing": p_index, "method": "kpm", "moments": n_moments, "probes": spec.probes,
        "omega_max": omega_max, "n_zero_modes": 2, "dof": dm.size, "n_disks": int(dm.active.sum()),
        "seconds": seconds})
    say(comm, f"kpm vDOS rho = {rho:g}, packing {p_index}: {n_moments} moments x {spec.probes} probes, "
              f"omega_max = {omega_max:.4f}, {seconds:.1f} s")
    return edges, density, omega_max


def _spectrum_unit(scene, dm, rho, r_index, p_index, commit, comm, checkpoint=None) -> np.ndarray:
    """Solve one (rho, packing) spectrum into ``units``; return its omega. Collective.

    Windows are checkpointed, and SIGTERM is honoured after the window in flight."""
    spec = scene.spectrum
    t = time.perf_counter()

    def progress(done, total, modes):  # large spectra take hours: say how far, window by window
        if total > 1:
            say(comm, f"  spectrum window {done}/{total}: {modes} modes, "
                      f"{time.perf_counter() - t:.0f} s")
        check_interrupt(comm)

    result = spectrum.solve(dm, window=tuple(spec.window) if spec.window else None,
                            vectors=spec.energies, tol=spec.tol, zero_tol=spec.zero_tol,
                            max_window_modes=spec.max_window_modes, progress=progress,
                            checkpoint=checkpoint)
    seconds = parallel.global_max(comm, time.perf_counter() - t)
    datasets = {"omega": result.omega}
    if result.energies is not None:
        datasets.update(result.energies)
    commit(f"spectra/r{r_index:02d}_p{p_index:04d}", datasets, {
        "rho": rho, "packing": p_index, "n_zero_modes": result.n_zero_modes,
        "n_negative_modes": result.n_negative, "max_relative_residual": result.max_residual,
        "inertia_count": result.inertia_count, "windows": result.windows, "seconds": seconds,
        "window": window_label(spec.window), "dof": dm.size, "n_disks": int(dm.active.sum())})
    if checkpoint is not None:
        checkpoint.clear()
    say(comm, f"spectrum rho = {rho:g}, packing {p_index}: {result.omega.size} modes "
              f"(+{result.n_zero_modes} zero modes, {result.n_negative} negative), omega in "
              f"[{result.omega.min():.4f}, {result.omega.max():.4f}], max relative residual "
              f"{result.max_residual:.1e}, {result.windows} windows, {seconds:.1f} s")
    if result.n_negative:
        say(comm, f"rotsound: warning: {result.n_negative} modes with omega^2 < -zero_tol^2: the "
                  f"packing is not a stable minimum")
    return result.omega


def wave_numbers(spec, box_length: float) -> tuple[np.ndarray, np.ndarray]:
    """(n (K,), k (K,)) allowed by the box: k = 2 pi n / L, from waves.n or nearest to waves.kd0."""
    if spec.n is not None:
        ns = np.array(sorted(set(spec.n)))
    else:
        ns = np.array(sorted({max(1, int(round(kd * box_length / (2 * np.pi)))) for kd in spec.kd0}))
    ks = 2 * np.pi * ns / box_length
    if ks.max() > 2 * np.pi:
        raise InputError(f"waves.n = {int(ns.max())}: k d0 = {ks.max():.3f} exceeds 2 pi for box length "
                         f"L = {box_length:.3f} (allowed n <= {int(box_length)})")
    return ns, ks


def integrator_in_use(spec) -> str:
    """waves.integrator, unless -ts_type on the command line / petsc block names another type."""
    from petsc4py import PETSc

    chosen = PETSc.Options().getString("ts_type", spec.integrator)
    return "verlet" if chosen == "python" else chosen


def _check_time_step(spec, dm, rho) -> tuple[str, float, float | None]:
    """Refuse waves.dt at or above the scheme's stability limit, before any solve on ``dm``.

    Returns (integrator, omega_max, limit or None). Collective.
    """
    integrator = integrator_in_use(spec)
    omega_max = spectrum.largest_omega(dm)
    limit = waves.stability_limit(integrator, omega_max)
    if limit is not None and spec.dt >= limit:
        raise InputError(f"waves.dt = {spec.dt}: above the stability limit {limit:.4f} t0 of "
                         f"{integrator} for this packing (omega_max = {omega_max:.4f}/t0, rho = {rho:g})")
    return integrator, omega_max, limit


def wave_modes(spec, dof: int) -> list[str]:
    """Modes that exist for this matrix (no RT without rotations, i.e. at rho = 0)."""
    return [m for m in spec.modes if not (m == "RT" and dof == 2)]


def _wave_units(scene, dm, p, rho, r_index, p_index, commit, comm, stability, todo) -> None:
    """Integrate every (mode, direction, k) of one (rho, packing) into ``units``. Collective."""
    spec = scene.waves
    ns, ks = wave_numbers(spec, p.box_length)
    integrator, omega_max, limit = stability
    if spec.kd0 is not None:
        say(comm, f"waves: k d0 = {', '.join(f'{k:.4f}' for k in ks)} (n = {', '.join(map(str, ns))}, "
                  f"L = {p.box_length:.3f})")
    for mode in todo:
        check_interrupt(comm)
        t0 = time.perf_counter()
        if spec.method == "spectral":
            times = np.arange(0.0, spec.t_end * (1 + 1e-12), spec.dt * spec.sample_every)
            runs = [[waves.spectral(dm, p.positions, mode, d, k, amplitude=spec.amplitude, times=times,
                                    tol=spec.tol, omega_max=omega_max) for k in ks] for d in range(2)]
        elif integrator == "verlet":  # all directions and k at once: one MatMatMult per step
            flat = waves.integrate_block(dm, p.positions, [(mode, d, k) for d in range(2) for k in ks],
                                         amplitude=spec.amplitude, dt=spec.dt, t_end=spec.t_end,
                                         sample_every=spec.sample_every)
            runs = [flat[d * len(ks):(d + 1) * len(ks)] for d in range(2)]
        else:
            runs = [[waves.integrate(dm, p.positions, mode, d, k, amplitude=spec.amplitude, dt=spec.dt,
                                     t_end=spec.t_end, sample_every=spec.sample_every, integrator=integrator)
                     for k in ks] for d in range(2)]
        seconds = parallel.global_max(comm, time.perf_counter() - t0)
        z = np.array([[r.z for r in row] for row in runs])            # (2, K, S)
        z_fixed = np.array([[r.z_fixed for r in row] for row in runs])
        energy = np.array([[r.energy for r in row] for row in runs])
        t = runs[0][0].t
        vaf = np.array([correlations.vaf(z[:, i]) for i in range(len(ks))])
        omega, _ = correlations.power_spectrum(z[:, 0], t[1] - t[0])
        power = np.array([correlations.power_spectrum(z[:, i], t[1] - t[0])[1] for i in range(len(ks))])
        drift = np.abs(energy - energy[..., :1]).max(axis=2) / energy[..., 0]
        estimate = np.array([[r.error_estimate for r in row] for row in runs])
        commit(f"waves/r{r_index:02d}_{mode}_p{p_index:04d}",
            {"k": ks, "n": ns, "t": t, "C": vaf, "omega": omega, "S": power, "z": z, "z_fixed": z_fixed,
             "energy_drift": drift, **({"error_estimate": estimate} if spec.method == "spectral" else {})},
            {"rho": rho, "mode": mode, "packing": p_index, "dt": spec.dt,
             "integrator": "spectral (Lanczos)" if spec.method == "spectral" else integrator,
             "omega_max": omega_max, "dt_limit": limit if limit is not None else np.inf,
             "amplitude": spec.amplitude, "sample_dt": t[1] - t[0], "seconds": seconds})
        how = (f"spectral, up to {max(r.steps for row in runs for r in row)} Lanczos steps, error estimate "
               f"{np.nanmax(estimate):.1e}" if spec.method == "spectral" else
               f"{runs[0][0].steps} steps each ({integrator}, dt = {spec.dt}), max energy drift {drift.max():.1e}")
        say(comm, f"waves rho = {rho:g}, {mode}, packing {p_index}: {len(ks)} k x 2 directions, {how}, "
                  f"{seconds:.1f} s")


def unit_keys(scene: Scene, packings, petsc_argv: list[str]) -> dict[str, str]:
    """Content key of every unit this scene can compute: what determines it, nothing else.

    A packing is keyed by its arrays (so a file and a generated packing with equal contents
    share units); spectra and waves also by their section's settings and the PETSc options
    (which can change a solver's result); KPM's probes by their seed.  The rotsound version is
    part of every key, so a new version never reuses an older one's numbers.
    """
    argv = sorted(petsc_argv)
    keys = {}
    for p_index, p in enumerate(packings):
        pk = content_key(__version__, p.positions, p.diameters, np.float64(p.box_length), p.rattler)
        for r_index, rho in enumerate(scene.model.rho):
            tag = f"r{r_index:02d}_p{p_index:04d}"
            keys[f"matrices/{tag}"] = content_key("matrix", pk, rho)
            if scene.spectrum is not None:
                spec = dataclasses.asdict(scene.spectrum)
                seed = scene.seed + p_index if scene.spectrum.method == "kpm" else None
                keys[f"spectra/{tag}"] = content_key("spectrum", pk, rho, spec, seed, argv)
            if scene.waves is not None:  # one mode's unit does not depend on the others asked
                waves = {k: v for k, v in dataclasses.asdict(scene.waves).items() if k != "modes"}
                for mode in scene.waves.modes:
                    keys[f"waves/r{r_index:02d}_{mode}_p{p_index:04d}"] = content_key(
                        "waves", pk, rho, mode, waves, argv)
    return keys


def window_label(window) -> str:
    """'full' or 'lo,hi' for the results file."""
    return "full" if window is None else f"{window[0]:g},{window[1]:g}"


def _vdos_unit(scene, rho, r_index, omegas, units, comm) -> None:
    """vDOS and omega_c of one rho from all configurations into ``units``."""
    if scene.spectrum.method == "kpm":  # omegas holds (edges, density, omega_max) per configuration
        edges = max((o[0] for o in omegas), key=len)
        density = np.zeros(edges.size - 1)
        for _, d, _ in omegas:
            density[: d.size] += d / len(omegas)
        tops = np.array([o[2] for o in omegas])
        omega_c, spread = float(tops.mean()), float(tops.std(ddof=1)) if tops.size > 1 else 0.0
    else:
        edges, density = modes.vdos(omegas, scene.spectrum.bin_width)
        omega_c, spread = modes.cutoff(omegas)
    units[f"vdos/r{r_index:02d}"] = ({"edges": edges, "density": density}, {
        "rho": rho, "omega_c": omega_c, "omega_c_std": spread, "configurations": len(omegas),
        "window": window_label(scene.spectrum.window)})
    say(comm, f"vDOS rho = {rho:g}: omega_c = {omega_c:.4f} +- {spread:.4f} over {len(omegas)} configurations")


def run(scene: Scene, comm, petsc_argv: list[str], fresh: bool = False) -> dict:
    """Execute ``scene`` on ``comm`` (mpi4py communicator); return a summary. Collective.

    ``fresh`` discards the output file and its finished units first.
    """
    from petsc4py import PETSc

    t0 = time.perf_counter()
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        store = UnitStore(scene.output, scene.to_yaml(), scene.digest(), comm, fresh=fresh,
                          cache=scene.cache_folder())
        packings = make_packings(scene, comm, store)
        units: dict[str, tuple[dict, dict]] = {}
        keys = unit_keys(scene, packings, petsc_argv)

        def commit(name, datasets, attrs):
            units[name] = (datasets, attrs)
            store.save(name, datasets, attrs, keys.get(name))

        for index, p in enumerate(packings):
            i = p.info
            say(comm, f"packing {index}: N = {p.n}, phi = {p.phi:.4f}, z = {i['z']:.3f}, "
                      f"pressure = {i['pressure']:.4e}, energy = {i['energy']:.4e}, "
                      f"rattlers = {100 * i['rattler_fraction']:.2f} %"
                      + (f", FIRE steps = {i['fire_steps']}" if "fire_steps" in i else ""))
        for r_index, rho in enumerate(scene.model.rho):
            per_config = []  # omega arrays (slicing) or (edges, density, omega_max) (kpm)
            for p_index, p in enumerate(packings):
                check_interrupt(comm)
                tag = f"r{r_index:02d}_p{p_index:04d}"
                dof = 3 if rho > 0 else 2
                names = [f"matrices/{tag}"] + ([f"spectra/{tag}"] if scene.spectrum else [])
                modes_here = wave_modes(scene.waves, dof) if scene.waves else []
                if scene.waves and len(modes_here) < len(scene.waves.modes):
                    say(comm, f"waves rho = {rho:g}: RT skipped (no rotational stiffness at rho = 0)")
                names += [f"waves/r{r_index:02d}_{m}_p{p_index:04d}" for m in modes_here]
                found = {name: store.load(name, keys.get(name)) for name in names}
                for name, unit in found.items():
                    if unit is not None:  # a cached unit may come from another scene's numbering
                        unit[1]["packing"] = p_index
                        units[name] = unit
                if any(unit is None for unit in found.values()):
                    _compute(scene, p, rho, r_index, p_index, tag, found, commit, comm, store)
                if scene.spectrum is not None:
                    datasets, attrs = units[f"spectra/{tag}"]
                    per_config.append((datasets["edges"], datasets["density"], float(attrs["omega_max"]))
                                      if "density" in datasets else datasets["omega"])
            if per_config:
                _vdos_unit(scene, rho, r_index, per_config, units, comm)
        say(comm, f"units: {store.summary()} (folder {store.folder}; cache {store.cache or 'off'})")
        if scene.waves is not None:
            t = time.perf_counter()
            derived = parallel.owner_compute(comm, [0], lambda _: analysis.analyse(units, scene.analysis))[0]
            units.update(derived)
            lattice = derived.get("analysis/lattice", ({}, {}))[1]
            say(comm, f"analysis: {len(derived)} groups in {time.perf_counter() - t:.1f} s"
                      + (f"; lattice model a_r = {lattice['a_r']:.3f} +- {lattice['a_r_err']:.3f}/t0, "
                         f"l = {lattice['l']:.3f} +- {lattice['l_err']:.3f} d0, a_t = {lattice['a_t']:.3f}/t0"
                         if lattice else ""))
        names = petscopts.option_names(petsc_argv)
        unused = parallel.owner_compute(comm, [0], lambda _: petscopts.unused(names))[0]
        for name in unused:
            say(comm, f"rotsound: warning: PETSc option -{name} was never used (misspelt, or for a "
                      f"stage this scene does not run)")
        provenance = {
            "rotsound_version": __version__, "scene": scene.to_yaml(), "scene_digest": scene.digest(),
            "petsc_version": ".".join(map(str, PETSc.Sys.getVersion())), "numpy_version": np.__version__,
            "ranks": comm.size, "petsc_options": petscopts.snapshot(), "petsc_options_unused": unused,
        }
        error = None
        if comm.rank == 0:
            try:
                h5io.write_results(scene.output, provenance, packings, units)
            except OSError as exc:
                error = exc
        parallel.agree(comm, error)
        say(comm, f"wrote {scene.output} ({len(packings)} packings, {len(units)} result groups) "
                  f"in {time.perf_counter() - t0:.1f} s")
        return {"packings": packings, "units": units}
    finally:
        signal.signal(signal.SIGTERM, previous)
