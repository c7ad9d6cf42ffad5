"""What the cross-checks share (scripts/crosschecks/crosscheck_*.py, and their smaller copies in
tests/run/test_crosscheck_*.py): LAMMPS run on rotsound's own packing and start, rotsound's
pooling of C(k, t), the standing-wave options and convergence columns of their tables, and their
JSON records.

- :func:`lammps_velocities`, :func:`lammps_z`: a standing wave of rotsound's packing integrated by
  LAMMPS itself (``fix nve/sphere``, ``gran/hooke/history`` or ``gran/hertz/history``, with or
  without dashpots), from rotsound's v(0) at +A and -A (crosscheck_lammps, crosscheck_damped);
- :func:`pooled_c`: C(k, t) of a mode's runs as rotsound pools them;
- :func:`add_wave_arguments`, :func:`convergence_columns`: the command-line options and table
  columns of the stressed and damped cross-checks;
- :func:`save`: a record in scripts/crosschecks/records/ (benchlib's format: BENCHMARKS.md renders it).

The exact references the cross-checks compare against are the package's
(``solver.references``: the same the tests use); what is particular to one cross-check stays in
its module (crosscheck_stressed's packing made by LAMMPS and its restarts, crosscheck_yade's runs
of YADE).  Run a cross-check from the repository's root as ``python -m scripts.crosschecks.crosscheck_lammps``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from scripts.benchmarks import benchlib
from solver.waves import lammps_dem

RECORDS = Path(__file__).resolve().parent / "records"  # the cross-checks' JSON records (committed)
LAMMPS_PAIR = lammps_dem.PAIR_STYLES
FRICTION = lammps_dem.MAX_FRICTION  # Debian's LAMMPS refuses more; |F_t| / |F_n| stays far below it here
PACKINGS = {2: 0.9, 3: 0.7}  # phi of the 2D and 3D packings (rotsound's default recipes)


def lammps_velocities(positions, diameters, box, law: str, start: np.ndarray, dt: float, steps: int,
                      every: int, comm, rho: float = 1.0, hold: bool = False, gamma_n: float = 0.0,
                      gamma_t: float = 0.0) -> np.ndarray:
    """Velocities (S, N, dof) sampled every ``every`` steps (S = steps // every + 1, t = 0 first)
    of one LAMMPS run from v(0) = ``start`` (N, dof) in rotsound's DOF order (D velocities, then
    the angular velocity: 2D w_z, 3D w_x, w_y, w_z; dof = D + rotations) and zero displacement.

    Particles ``positions`` (N, D) with ``diameters`` (N,) in the periodic box ``box`` (D,) from
    the origin, mass 1, radius d/2; ``pair_style`` of ``law`` with kn = 1, kt = rho, dashpots
    ``gamma_n`` and ``gamma_t`` (default none; LAMMPS's dampflag 1 when gamma_t > 0), friction
    coefficient ``FRICTION``; ``fix nve/sphere`` (2D: ``disc``, I = m d^2/8, and
    ``enforce2d``; 3D: I = m d^2/10).  The tangential springs start unstressed (LAMMPS's shear
    history is zero at the start), as rotsound's matrix assumes.  ``hold``: a constant external
    force, minus LAMMPS's net force at the start, cancels the packing's residual forces.  LAMMPS
    runs on ``comm`` (mpi4py; the result is on every rank). Collective.
    """
    from lammps import lammps

    from solver.packing import lammps_engine

    n, dim = positions.shape
    dof = start.shape[1]
    if start.shape[0] != n or dof not in (dim, dim + (1 if dim == 2 else 3)):
        raise ValueError(f"start of shape {start.shape} for {n} particles in {dim}D")
    if not (0 < every <= steps and np.all((positions >= 0) & (positions < box))):
        raise ValueError("every must be in [1, steps], positions inside [0, L) (LAMMPS would end the process)")
    lmp = lammps(comm=comm, cmdargs=["-log", "none", "-screen", "none", "-nocite"])
    held = np.zeros((n, 3))

    def external(caller, step, nlocal, tag, x, force):
        force[:] = held[np.asarray(tag) - 1]

    try:
        lammps_engine.create_particles(lmp, positions, diameters, box)
        lammps_dem.set_velocities(lmp, np.zeros_like(start), dim)
        lmp.commands_string(f"""
            pair_style {LAMMPS_PAIR[law]} 1.0 {float(rho)!r} {float(gamma_n)!r} {float(gamma_t)!r} {FRICTION!r} {int(gamma_t > 0)}
            pair_coeff * *
            neighbor {lammps_engine.SKIN!r} bin
            neigh_modify every 1 delay 0 check yes
            fix move all nve/sphere{' disc' if dim == 2 else ''}
            fix hold all external pf/callback 1 1
            {'fix plane all enforce2d' if dim == 2 else ''}
            timestep {float(dt)!r}
        """)
        lmp.set_fix_external_callback("hold", external, None)
        lmp.command("run 0")  # forces at rest at the start (the external force is still 0; no dashpot acts)
        if hold:
            held[:] = -lammps_engine.gather(lmp, "f", n, 3)
        lammps_dem.set_velocities(lmp, start, dim)
        lmp.command("run 0")  # the first step's forces, with the dashpots' at v(0)
        samples = [lammps_dem.velocities(lmp, n, dim, dof)]
        for _ in range(steps // every):
            lmp.command(f"run {every} pre no post no")  # a run's setup leaves the shear history alone
            samples.append(lammps_dem.velocities(lmp, n, dim, dof))
    finally:
        lmp.close()
    return np.array(samples)


def lammps_z(p, dm, law: str, run: tuple[int, int], k: float, amplitude: float, dt: float, steps: int,
             every: int, comm, hold: bool = False) -> np.ndarray:
    """z_fixed(t) (S,) of one standing-wave run (excited component, axis of k) integrated by LAMMPS:
    rotsound's start (``excitation.start_velocity`` on ``dm``, rattlers left out; the springs and
    dashpots of ``dm.model``), run at
    +``amplitude`` and -``amplitude``, half the difference, projected on exp(-i k r_i,a(0)).
    ``comm``: mpi4py communicator of ``dm`` and of LAMMPS. Collective."""
    from solver.waves import excitation

    component, axis = run
    start = excitation.whole_start(dm, p.positions, component, axis, k, amplitude, comm)
    active = dm.active
    x, d = p.positions[active], p.diameters[active]
    model = dm.model
    plus, minus = (lammps_velocities(x, d, p.box, law, sign * start, dt, steps, every, comm, model.rho, hold,
                                     model.gamma_n, model.gamma_t)
                   for sign in (1.0, -1.0))
    return 0.5 * (plus - minus)[:, :, component] @ np.exp(-1j * k * x[:, axis])


def pooled_c(z: np.ndarray, sample: float) -> np.ndarray:
    """C(k, t) (S,) of the runs z (R, S) of one (mode, k), as rotsound pools them."""
    from solver.waves import correlations

    return correlations.pooled(np.asarray(z)[:, None, :], sample)[0][0]


def convergence_columns(label: str, dts: list[float], errors: list[float]) -> dict:
    """Table columns '<label>, dt=<dt>' (each error) and 'order' (log2 of successive ratios) of a
    cross-check's errors at the halved steps ``dts`` (crosscheck_stressed, crosscheck_damped)."""
    columns = {f"{label}, dt={dt:g}": f"{e:.2e}" for dt, e in zip(dts, errors)}
    columns["order"] = " ".join(f"{np.log2(a / b):.2f}" for a, b in zip(errors[:-1], errors[1:]))
    return columns


def add_wave_arguments(parser) -> None:
    """The standing-wave options of the stressed, damped and YADE cross-checks: t <= --t-end, --dt
    halved --halvings times, sampled every --sample, velocity amplitude --amplitude."""
    parser.add_argument("--t-end", type=float, default=10.0)
    parser.add_argument("--dt", type=float, default=0.002)
    parser.add_argument("--halvings", type=int, default=2)
    parser.add_argument("--sample", type=float, default=0.1)
    parser.add_argument("--amplitude", type=float, default=1e-6)


def save(name: str, command: str, table: list[dict], notes: str = "") -> None:
    """Write scripts/crosschecks/records/<name>.json (``benchlib.save``: the machine, the date and the table
    BENCHMARKS.md renders)."""
    benchlib.save(name, command, table, notes, records=RECORDS)
