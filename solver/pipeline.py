"""Run a scene: packings -> dynamical matrices (-> later stages). Collective on ``comm``.

The only module that knows stage order.  Stages run only for what the scene asks.
"""

from __future__ import annotations

import time

import numpy as np

from . import __version__, dynmat, h5io, modes, packing, parallel, petscopts, spectrum
from .config import Scene


def say(comm, message: str) -> None:
    """Print on rank 0 only."""
    if comm.rank == 0:
        print(message, flush=True)


def make_packings(scene: Scene, comm) -> list[packing.Packing]:
    """Read ``packing.file`` or generate ``packing.count`` configurations. Collective.

    Generation is spread over ranks (configuration i on rank i % size, seeded by
    SeedSequence([seed, i])), so the result does not depend on the number of ranks.
    """
    spec = scene.packing
    if spec.file is not None:
        return parallel.owner_compute(comm, [0], lambda _: h5io.read_packings(spec.file, spec.count))[0]
    seeds = [parallel.seed_sequence(scene.seed, i) for i in range(spec.count or 1)]
    return parallel.owner_compute(
        comm, seeds, lambda s: packing.generate(spec.n, spec.phi, s, spec.force_tol, spec.max_steps))


def _spectrum_unit(scene, dm, rho, r_index, p_index, units, comm) -> np.ndarray:
    """Solve one (rho, packing) spectrum into ``units``; return its omega. Collective."""
    spec = scene.spectrum
    t = time.perf_counter()
    result = spectrum.solve(dm, window=tuple(spec.window) if spec.window else None,
                            vectors=spec.energies, tol=spec.tol, zero_tol=spec.zero_tol,
                            max_window_modes=spec.max_window_modes)
    seconds = parallel.global_max(comm, time.perf_counter() - t)
    datasets = {"omega": result.omega}
    if result.energies is not None:
        datasets.update(result.energies)
    units[f"spectra/r{r_index:02d}_p{p_index:04d}"] = (datasets, {
        "rho": rho, "packing": p_index, "n_zero_modes": result.n_zero_modes,
        "n_negative_modes": result.n_negative, "max_relative_residual": result.max_residual,
        "inertia_count": result.inertia_count, "windows": result.windows, "seconds": seconds,
        "window": json_window(spec.window), "dof": dm.size, "n_disks": int(dm.active.sum())})
    say(comm, f"spectrum rho = {rho:g}, packing {p_index}: {result.omega.size} modes "
              f"(+{result.n_zero_modes} zero modes, {result.n_negative} negative), omega in "
              f"[{result.omega.min():.4f}, {result.omega.max():.4f}], max relative residual "
              f"{result.max_residual:.1e}, {result.windows} windows, {seconds:.1f} s")
    if result.n_negative:
        say(comm, f"rotsound: warning: {result.n_negative} modes with omega^2 < -zero_tol^2: the "
                  f"packing is not a stable minimum")
    return result.omega


def json_window(window) -> str:
    return "full" if window is None else f"{window[0]:g},{window[1]:g}"


def _vdos_unit(scene, rho, r_index, omegas, units, comm) -> None:
    edges, density = modes.vdos(omegas, scene.spectrum.bin_width)
    omega_c, spread = modes.cutoff(omegas)
    units[f"vdos/r{r_index:02d}"] = ({"edges": edges, "density": density}, {
        "rho": rho, "omega_c": omega_c, "omega_c_std": spread, "configurations": len(omegas),
        "window": json_window(scene.spectrum.window)})
    say(comm, f"vDOS rho = {rho:g}: omega_c = {omega_c:.4f} +- {spread:.4f} over {len(omegas)} configurations")


def run(scene: Scene, comm, petsc_argv: list[str]) -> dict:
    """Execute ``scene`` on ``comm`` (mpi4py communicator); return a summary. Collective."""
    from petsc4py import PETSc

    t0 = time.perf_counter()
    packings = make_packings(scene, comm)
    for index, p in enumerate(packings):
        i = p.info
        say(comm, f"packing {index}: N = {p.n}, phi = {p.phi:.4f}, z = {i['z']:.3f}, "
                  f"pressure = {i['pressure']:.4e}, energy = {i['energy']:.4e}, "
                  f"rattlers = {100 * i['rattler_fraction']:.2f} %"
                  + (f", FIRE steps = {i['fire_steps']}" if "fire_steps" in i else ""))
    units = {}
    for r_index, rho in enumerate(scene.model.rho):
        omegas = []
        for p_index, p in enumerate(packings):
            t = time.perf_counter()
            dm = dynmat.assemble(p, rho, PETSc.COMM_WORLD)
            seconds = parallel.global_max(comm, time.perf_counter() - t)
            nnz = int(dm.D.getInfo()["nz_used"])  # PETSc's default is the global sum
            say(comm, f"matrix rho = {rho:g}, packing {p_index}: {dm.size} DOF "
                      f"({dm.dof} per disk), {nnz} non-zeros, assembled in {seconds:.3f} s")
            units[f"matrices/r{r_index:02d}_p{p_index:04d}"] = ({}, {
                "rho": rho, "packing": p_index, "size": dm.size, "dof_per_disk": dm.dof,
                "nnz": nnz, "n_contacts": dm.n_contacts, "assembly_seconds": seconds})
            if scene.spectrum is not None:
                omegas.append(_spectrum_unit(scene, dm, rho, r_index, p_index, units, comm))
            dm.destroy()
        if omegas:
            _vdos_unit(scene, rho, r_index, omegas, units, comm)
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
