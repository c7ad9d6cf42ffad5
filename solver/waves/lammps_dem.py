"""Standing waves at finite amplitude, integrated by LAMMPS with its full contact law (issue 46;
docs/finite_amplitude.md).

rotsound's other wave paths integrate the linear equations M u'' = -D u.  Here LAMMPS moves the
particles themselves (``fix nve/sphere``: velocity Verlet; 2D ``disc`` and ``enforce2d``) under
``gran/hooke/history`` (harmonic) or ``gran/hertz/history`` (hertz) with kn = 1, kt = rho kn,
the model's dashpots gamma_n, gamma_t, and the Coulomb coefficient mu, or, under ``model.history:
granular``, ``pair granular`` with rolling and twisting springs too (:func:`granular_coefficients`;
docs/finite_amplitude.md section 7): contacts open when their
overlap goes, new ones form, and a tangential spring that reaches mu f_n slides (LAMMPS rescales
it onto the cone).  The start is rotsound's (``excitation.whole_start``: v(0) over the matrix's
active particles, zero displacement); the particles are the packing's (rattlers below), masses 1,
radius d/2 (I = m d^2/8 as a disc in 2D, m d^2/10 in 3D), in its periodic box from the origin.
An orthogonal box only [choice]: a packing in a tilted cell is refused before any run
(``waves.rules.check_engine`` for ``packing.shear``, ``check_boxes`` for a tilted file), since the
LAMMPS box, the history velocities' pair geometry and the contacts' records here are orthogonal
and rotsound's linear waves take the tilted cell (referee: tests/waves/test_sheared_waves.py).

Rattlers [choice]: they stay in LAMMPS's box but touch nothing and do not move, as the matrix
leaves them out; a rattler pushing through its few contacts would add springs the matrix does
not have, and the small-amplitude limit would then not be the matrix's.  The start is held at
rest (:func:`_hold`).  A packing's stored tangential forces are put into LAMMPS's
shear history first (:func:`_load_history`); without them the springs start unstressed.

What a record holds besides the velocities (:class:`Contacts`; a record every ``record_every``-th
sample, z every sample):
- ``sliding``: contacts at the Coulomb limit, |f_t| >= mu |f_n| (1 - ``LIMIT_SLACK``), f_n the
  normal force with its dashpot, as LAMMPS tests it (``compute pair/local``, the pair style's
  ``single``: f_t after the rescaling);
- ``opened``: contacts of the start that no longer overlap; ``formed``: contacts that overlap
  and did not at the start;
- ``opening``: the largest (xi_0 - xi) / xi_0 over the start's contacts still touching; 1 once
  one has opened;
- ``coulomb``: the largest |f_t| / (mu |f_n|) (1: a contact slides);
- ``energy``: the wave's energy: kinetic + the normal springs' (``contact_law.normal_energy``)
  + the tangential springs' |f_t|^2 / (2 k_t) (k_t = rho kn, times sqrt(a' xi) under hertz)
  - the hold force's work, less all that at rest.  With a harmonic law, no dashpots and no
  sliding it is conserved to the scheme's O(dt^2), also as contacts open and form; what goes
  is what sliding, the dashpots and opened stretched tangential springs took (under hertz
  k_t follows the overlap, so |f_t|^2 / (2 k_t) is not a potential and E also moves by that).

LAMMPS is Debian's (scripts/tools/setup_dem.sh); it runs on the communicator given (mpi4py), under the
scene's own ``mpirun``.  A LAMMPS error ends the process: everything is checked before it runs.
Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

from .. import contact_law
from ..errors import InputError
from ..packing import geometry, lammps_engine

PAIR_STYLES = lammps_engine.FRICTIONAL_STYLES  # the normal law -> LAMMPS's pair style with a shear history
MAX_FRICTION = 1e4  # Debian's LAMMPS (29 Sep 2021) refuses xmu above this; also the rolling and twisting limits' default
MAX_TYPES = 256  # pair granular's atom types, one per distinct diameter under twisting springs: T (T + 1) / 2 pair_coeff
# lines (128 types: 8256 lines in 0.4 s; 256: 32896)
RECORDS = ("sliding", "opened", "formed", "opening", "coulomb", "energy", "rolling", "rolling_coulomb")  # Contacts
KEY = "waves.engine: lammps"  # the scene key, in messages
CALLBACK = "rotsound_lammps_sample"  # the name of LAMMPS's python function that samples a run
TORQUE_CALLBACK = "rotsound_lammps_hold_torques"  # ... and of the one that holds a stressed packing's torques
RECORD_EVERY = 10  # waves.contacts_every's default: a record costs more than ten steps (BENCHMARKS "lammps_waves")
LIMIT_SLACK = 1e-9  # relative: |f_t| this close to mu |f_n| is at the Coulomb limit (LAMMPS rescales to it exactly)
HISTORY_STEP = 1e6  # t0: the one step that loads the contact history (:func:`_load_history`)
HISTORY_TOL = 1e-9  # relative to the largest stored force: how close LAMMPS's loaded tangential forces must come
REST_FACTOR = 10.0  # the rest check's allowance over force_tol [choice]: LAMMPS re-evaluates a packing made to
# force_tol in another order and decomposition (2.9e-10 on a packing LAMMPS itself stopped below 1e-10, 2 ranks);
# what the check is for, a lost history or a moved particle, leaves forces of the stored forces' size (1e-3)


@dataclass(frozen=True)
class Setting:
    """What a scene's LAMMPS waves need beyond the matrix: the packing's ``diameters`` (N,) and
    ``box`` (D,), the Coulomb coefficient ``friction`` (packing.friction), ``rest_tol``
    (packing.force_tol: the largest force LAMMPS may find on the packing at rest) and
    ``record_every`` (samples between contact records: :func:`record_every`), the stored
    tangential forces ``tangential`` (``stressed.TangentialForces``, or None) and, under pair
    granular, the rolling and twisting Coulomb limits ``rolling_friction`` (mu_roll, of the
    normal force) and ``twisting_friction`` (mu_twist, d0: a torque per normal force)."""

    diameters: np.ndarray
    box: np.ndarray
    friction: float
    rest_tol: float
    record_every: int = 1
    tangential: object = None
    rolling_friction: float = MAX_FRICTION
    twisting_friction: float = MAX_FRICTION


@dataclass
class Contacts:
    """What a run's contacts did, one entry per record (S_c,) (module docstring)."""

    sliding: np.ndarray
    opened: np.ndarray
    formed: np.ndarray
    opening: np.ndarray
    coulomb: np.ndarray
    energy: np.ndarray
    rolling: np.ndarray
    rolling_coulomb: np.ndarray

    def as_datasets(self) -> dict[str, np.ndarray]:
        """The series under their results-file names (``contacts_<name>``)."""
        return {f"contacts_{name}": getattr(self, name) for name in RECORDS}


def rolling_limits(spec) -> tuple[float, float]:
    """(mu_roll, mu_twist d0) of the waves section ``spec``: ``rolling_friction`` and
    ``twisting_friction``, ``MAX_FRICTION`` (no limit) where null.  Not collective."""
    return tuple(MAX_FRICTION if mu is None else float(mu) for mu in (spec.rolling_friction, spec.twisting_friction))


def record_every(contacts_every: int | None) -> int:
    """Samples between contact records: ``waves.contacts_every``, or ``RECORD_EVERY`` when null."""
    return RECORD_EVERY if contacts_every is None else int(contacts_every)


def pair_style(model) -> str:
    """LAMMPS's pair style that runs ``model`` (a ``ContactModel``): ``granular`` under
    ``history: granular``, else gran/hooke/history or gran/hertz/history.  Not collective."""
    return "granular" if model.history == "granular" else PAIR_STYLES[model.law]


def require(comm) -> None:
    """InputError on every rank, saying how to install it, when LAMMPS cannot start on ``comm``
    (mpi4py), before any compute.  Collective."""
    lammps_engine.open_lammps(comm, False, KEY).close()


def unsupported(model) -> str | None:
    """Why LAMMPS cannot run ``model`` (a ``ContactModel``) as rotsound's matrix has it, as a
    clause naming what it lacks, or None: ``history: granular`` runs LAMMPS's pair granular
    (:func:`granular_coefficients`; rolling and twisting springs need it), any other history its
    gran/*/history.  Not collective."""
    if model.history == "granular":
        if model.law != "harmonic":
            return (f"model.law = {model.law!r} with model.history: granular: LAMMPS's pair granular keeps its "
                    "rolling and twisting stiffnesses (rolling sds, twisting sds) as the overlap changes, while "
                    "rotsound's hertz law scales them by sqrt(a' xi); use law: harmonic")
        if model.lever != "contact":
            return (f"model.lever = {model.lever!r} with model.history: granular: LAMMPS's pair granular puts the "
                    "tangential force's torque at R - xi/2 (lever: contact)")
        if model.damped:
            return (f"contact dashpots (gamma_n = {model.gamma_n:g}, gamma_t = {model.gamma_t:g}) with "
                    "model.history: granular: the engine drives pair granular without dashpots")
        return None
    if model.rho_roll > 0.0 or model.rho_twist > 0.0:
        return (f"rolling and twisting springs (rho_roll = {model.rho_roll:g}, rho_twist = {model.rho_twist:g}) "
                f"need LAMMPS's pair granular: set model.history: granular and model.lever: contact")
    if model.lever != "radius" or model.history != "lammps":
        return (f"model.lever = {model.lever!r}, model.history = {model.history!r}: LAMMPS's gran/*/history "
                "takes the tangential force at the radius, with its own history (lever: radius, history: lammps)")
    return None


def run(positions: np.ndarray, diameters: np.ndarray, box: np.ndarray, active: np.ndarray, model,
        friction: float, start: np.ndarray, dt: float, steps: int, every: int, rest_tol: float,
        channel: tuple[int, np.ndarray], comm, record_every: int = 1,
        tangential=None, rolling_friction: float = MAX_FRICTION,
        twisting_friction: float = MAX_FRICTION) -> tuple[np.ndarray, Contacts]:
    """One standing wave integrated by LAMMPS from v(0) = ``start`` (N', dof), zero displacement.

    ``positions`` (N, D), ``diameters`` (N,): the packing, in the periodic ``box`` (D,) from the
    origin; ``active`` (N,) bool: the particles that move (the matrix's, N' of them; ``start``
    lists them in packing order, dof = D, or D + rotations: 2D w_z, 3D w_x, w_y, w_z; without
    rotations the particles start without spin); the others, the rattlers, stay in LAMMPS's box
    but touch nothing (``neigh_modify exclude``) and do not move; ``model`` the contact model
    (``ContactModel``: law, rho, dashpots; :func:`unsupported` must be None); ``friction`` the
    Coulomb coefficient mu (0 < mu <= ``MAX_FRICTION``).  ``steps`` of ``dt``, sampled every
    ``every`` steps.  ``channel`` = (c, b): the sampled Fourier component is
    z(t) = sum_i v_i,c(t) b_i, b (N',) complex over the moving particles in packing order
    (exp(-i k r_i,a(0)) for z_fixed).

    ``tangential``: the packing's stored tangential forces (``stressed.TangentialForces``), put
    into LAMMPS's contact history first (:func:`_load_history`); None: unstressed springs.
    ``rolling_friction`` (mu_roll) and ``twisting_friction`` (mu_twist, d0): the rolling and
    twisting springs' Coulomb limits under pair granular (:func:`granular_coefficients`); the
    rolling and twisting springs start unstressed.

    Before the wave starts, LAMMPS's own forces and torques on the whole packing at rest must all
    be below ``REST_FACTOR`` ``rest_tol`` (the packing's force tolerance): InputError on every rank naming the
    largest otherwise (a packing LAMMPS does not find at rest would move on its own).  Then the
    rattlers are let go and the rest is held (:func:`_hold`).

    Returns (z (S,) complex, S = steps // every + 1 with t = 0 first; :class:`Contacts` of
    every ``record_every``-th sample, (S - 1) // record_every + 1 of them from t = 0), the same
    on every rank.  Each sample is reduced where LAMMPS holds the atoms: one allreduce of a few
    numbers.  Before the wave, once, every rank gathers the whole packing's forces and torques at
    rest (:func:`_check_rest`, :func:`_hold`, :func:`_hold_torques`) and the start's contacts
    (:class:`_Sampler`; with ``tangential`` LAMMPS's tangential forces too, :func:`_compare_history`).
    Collective on ``comm`` (mpi4py).
    """
    n, dim = positions.shape
    active = np.asarray(active, dtype=bool)
    limits = (friction, rolling_friction, twisting_friction)
    _check_arguments(n, dim, active, start, model, limits, dt, steps, every, record_every)
    atom_types(diameters, model)  # its ValueError before LAMMPS starts
    positions = geometry.wrap(np.asarray(positions, dtype=float), box)
    lmp = lammps_engine.open_lammps(comm, False, KEY)
    try:
        _create_packing(lmp, positions, diameters, box, model, limits, dt)
        if tangential is not None:
            _load_history(lmp, positions, diameters, box, model, tangential, limits, dt, comm)
        lmp.command("run 0")
        _check_rest(lmp, n, rest_tol)
        held = _start_moving(lmp, active, dim)
        if tangential is not None:
            _hold_torques(lmp, n, active)
        component, phase = channel
        weights = np.zeros(n, dtype=complex)
        weights[active] = phase
        sampler = _Sampler(lmp, positions, diameters, box, model, limits, held, component, weights, comm,
                           record_every)
        whole = np.zeros((n, start.shape[1]))
        whole[active] = start
        set_velocities(lmp, whole, dim)
        sampler.sample()
        _sample_in_the_run(lmp, sampler, every)
        lmp.command(f"run {int(steps - steps % every)} post no")  # a new fix needs the setup; no history yet
    finally:
        lmp.close()
        for name in (CALLBACK, TORQUE_CALLBACK):
            sys.modules["__main__"].__dict__.pop(name, None)
    return np.array(sampler.z), sampler.contacts()


def _check_arguments(n: int, dim: int, active: np.ndarray, start: np.ndarray, model, limits: tuple, dt: float,
                     steps: int, every: int, record_every: int) -> None:
    """ValueError unless :func:`run`'s arguments fit together (shapes, ranges, the Coulomb
    ``limits`` (mu, mu_roll, mu_twist), a model LAMMPS can run: :func:`unsupported`), before
    LAMMPS starts.  Not collective (the same on every rank)."""
    dof = start.shape[1]
    if active.shape != (n,) or start.shape[0] != active.sum() or dof not in (dim, dim + (1 if dim == 2 else 3)):
        raise ValueError(f"start of shape {start.shape} for {active.sum()} of {n} particles moving in {dim}D")
    if not (all(0 < mu <= MAX_FRICTION for mu in limits) and 0 < every <= steps and dt > 0 and record_every >= 1):
        raise ValueError(f"friction {limits} in (0, {MAX_FRICTION:g}], every {every} in [1, steps = {steps}], "
                         f"dt {dt} > 0, record_every {record_every} >= 1")
    why = unsupported(model)
    if why is not None:
        raise ValueError(why)


def _create_packing(lmp, positions: np.ndarray, diameters: np.ndarray, box: np.ndarray, model, limits: tuple,
                    dt: float) -> None:
    """The packing's particles in LAMMPS with the model's pair style (kn, rho, dashpots, the
    Coulomb ``limits`` (mu, mu_roll, mu_twist); pair granular: :func:`granular_coefficients`), its
    neighbour lists, time step ``dt`` and the two per-contact computes every record reads
    (:func:`_local_contacts`; under pair granular also the rolling force).  Collective."""
    friction = limits[0]
    if model.history == "granular":
        types, coefficients = granular_coefficients(diameters, model, limits)
        lammps_engine.create_particles(lmp, positions, diameters, box, types)
        lmp.command("pair_style granular")
        lmp.commands_list(coefficients)
        extra = "p1 p2 p3 p4 p5 p6 p7 p8"
    else:
        lammps_engine.create_particles(lmp, positions, diameters, box)
        lmp.commands_string(f"""
            pair_style {PAIR_STYLES[model.law]} {lammps_engine.KN!r} {float(model.rho)!r} {float(model.gamma_n)!r} {float(model.gamma_t)!r} {float(friction)!r} {int(model.gamma_t > 0)}
            pair_coeff * *
        """)
        extra = "p1 p2 p3 p4"
    lmp.commands_string(f"""
        neighbor {lammps_engine.SKIN!r} bin
        neigh_modify every 1 delay 0 check yes
        timestep {float(dt)!r}
        compute pairs all property/local patom1 patom2 cutoff radius
        compute forces all pair/local dist force {extra} cutoff radius
    """)


def granular_coefficients(diameters: np.ndarray, model, limits: tuple) -> tuple[np.ndarray, list[str]]:
    """LAMMPS's pair granular for rotsound's harmonic ``model`` (``history: granular``,
    docs/finite_amplitude.md section 7): each pair of atom types gets ``hooke`` kn, ``tangential
    linear_history`` kt = rho kn with mu, ``rolling sds`` k_roll = rho_roll kn with mu_roll and
    ``twisting sds`` k_twist = rho_twist kn a'^2 with mu_twist (a' the pair's reduced radius: LAMMPS's
    twisting spring is a torque per angle, rotsound's a force per length at the lever a'), no
    dashpots; ``limits`` = (mu, mu_roll, mu_twist).  One atom type per distinct diameter when
    twisting springs are on (else one).  Returns the types (N,) 1..T and the pair_coeff commands.
    Not collective."""
    friction, rolling, twisting = (float(mu) for mu in limits)
    sizes, types = atom_types(diameters, model)
    commands = []
    for a in range(sizes.size):
        for b in range(a, sizes.size):
            reduced = float(contact_law.reduced_radius(sizes[a], sizes[b]))
            line = (f"pair_coeff {a + 1} {b + 1} hooke {lammps_engine.KN!r} 0.0 "
                    f"tangential linear_history {float(model.rho) * lammps_engine.KN!r} 0.0 {friction!r}")
            if model.rho_roll > 0.0:
                line += f" rolling sds {float(model.rho_roll) * lammps_engine.KN!r} 0.0 {rolling!r}"
            if model.rho_twist > 0.0:
                line += f" twisting sds {float(model.rho_twist) * lammps_engine.KN * reduced**2!r} 0.0 {twisting!r}"
            commands.append(line)
    return types, commands


def atom_types(diameters: np.ndarray, model) -> tuple[np.ndarray, np.ndarray]:
    """pair granular's atom types: (the diameter of each type (T,), each particle's type 1..T (N,));
    one type per distinct diameter under twisting springs (their k_twist depends on the pair's
    a'), else one.  ValueError naming the count when more than ``MAX_TYPES`` would be needed (a
    polydisperse packing: T (T + 1) / 2 pair coefficients).  Not collective."""
    if model.history != "granular" or model.rho_twist <= 0.0:
        return np.ones(1), np.ones(len(diameters), dtype=int)
    sizes, inverse = np.unique(diameters, return_inverse=True)
    if sizes.size > MAX_TYPES:
        raise ValueError(f"twisting springs under LAMMPS's pair granular need one atom type per distinct diameter "
                         f"(k_twist = rho_twist kn a'^2 per pair), and the packing has {sizes.size} distinct "
                         f"diameters, more than {MAX_TYPES}: use fewer sizes, or model.rho_twist: 0")
    return sizes, inverse + 1


def _start_moving(lmp, active: np.ndarray, dim: int) -> np.ndarray:
    """Let the rattlers go (a group excluded from the neighbour lists) and give the moving
    particles their integrator (``nve/sphere``; 2D: ``disc`` and ``enforce2d``) and the hold
    force (:func:`_hold`); returns the hold force (N, D), zero on the rattlers.  Collective."""
    n = active.size
    rattlers = " ".join(str(i + 1) for i in np.flatnonzero(~active))
    lmp.commands_string(f"""
        {f'group rattlers id {rattlers}' if rattlers else 'group rattlers empty'}
        group moving subtract all rattlers
        {'neigh_modify exclude group rattlers all' if rattlers else ''}
        fix move moving nve/sphere{' disc' if dim == 2 else ''}
        {'fix plane all enforce2d' if dim == 2 else ''}
        fix hold moving external pf/array 1
    """)
    held = np.zeros((n, dim))
    held[active] = _hold(lmp, n, active)
    return held


def _sample_in_the_run(lmp, sampler, every: int) -> None:
    """Sample every ``every`` steps inside one LAMMPS ``run`` (``fix python/invoke ...
    end_of_step``: after the step's second half-kick, so the velocities are the step's): one
    ``run`` a sample cost 1.4 ms of setup each (N = 1024, one rank), more than the five steps
    between samples.  The callback is LAMMPS's ``python`` function ``CALLBACK``, found in
    ``__main__`` (keyword ``exists``); an exception in it would end the process (LAMMPS is built
    without exceptions), so it only calls the sampler.  Collective (the sampler's reductions, on
    every rank at the same step)."""
    def callback(_):
        sampler.sample()

    sys.modules["__main__"].__dict__[CALLBACK] = callback
    lmp.commands_string(f"""
        python {CALLBACK} input 1 SELF format p exists
        fix sampler all python/invoke {int(every)} end_of_step {CALLBACK}
    """)


def history_velocities(positions, diameters, box, model, tangential) -> np.ndarray:
    """The velocities (N, D + rotations) of the step that loads the stored tangential forces into
    LAMMPS's contact history (:func:`_load_history`).
    LAMMPS's gran/*/history spring is f_t = -k_t s (k_t = rho kn, times sqrt(a' xi) under
    hertz), its stretch s grown each step by the contact's relative tangential velocity times dt,
        v_t,ij = (v_i - v_j) - ((v_i - v_j).n) n + n x (R_i w_i + R_j w_j),  n = (r_i - r_j)/r_ij;
    the velocities solve v_t,ij = -f_t / (k_t HISTORY_STEP) for every touching pair, rattlers'
    included (the minimum-norm solution B^T (B B^T)^-1 s, sparse LU): in 2D C equations in 3N
    unknowns, in 3D 2C in 6N, so a solution exists when the contact number z = 2C/N is below 6
    (less the two or three uniform translations), as in frictional packings near jamming.
    InputError (naming C, N and z) when it does not.  Not collective."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.linalg import splu

    n, dim = positions.shape
    found = geometry.find_contacts(positions, diameters, box)
    reduced = contact_law.reduced_radius(diameters[found.i], diameters[found.j])
    kt = model.rho * contact_law.spring_scale(found.overlap, model.law, reduced)
    target = -tangential.on(found.i, found.j) / (kt * HISTORY_STEP)[:, None]  # (C, D) v_t,ij wanted
    normal, radius = found.normal, 0.5 * diameters
    rot = 1 if dim == 2 else 3
    width = dim + rot  # unknowns per particle: v (D), w (1 in 2D: w_z; 3 in 3D)
    bases = _tangent_bases(normal)  # (C, T, D): T = D - 1 tangent directions per contact
    count = len(found.i)
    rows, cols, vals, rhs = [], [], [], []
    for b in range(bases.shape[1]):  # T <= 2 tangent directions
        t = bases[:, b]
        row = b * count + np.arange(count)
        rhs.append(np.einsum("cd,cd->c", target, t))
        for d in range(dim):  # v_i - v_j: only their tangential part counts (t . n = 0)
            rows += [row, row]
            cols += [found.i * width + d, found.j * width + d]
            vals += [t[:, d], -t[:, d]]
        # t . (n x (R_i w_i + R_j w_j)) = (t x n) . (R_i w_i + R_j w_j)
        lever = np.cross(t, normal) if dim == 3 else (t[:, 0] * normal[:, 1] - t[:, 1] * normal[:, 0])[:, None]
        for r in range(rot):
            for who in (found.i, found.j):
                rows.append(row)
                cols.append(who * width + dim + r)
                vals.append(lever[:, r] * radius[who])
    matrix = coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                        shape=(bases.shape[1] * count, n * width)).tocsr()
    want = np.concatenate(rhs)
    scale = np.abs(want).max(initial=0.0)
    try:
        solution = matrix.T @ splu((matrix @ matrix.T).tocsc()).solve(want)
        residual = np.abs(matrix @ solution - want).max(initial=0.0)
    except RuntimeError:  # exactly singular: dependent equations
        residual = np.inf
    if not residual <= HISTORY_TOL * scale:
        raise InputError(f"{KEY}: the stored tangential forces cannot be put into LAMMPS's contact history: its "
                         f"springs grow only by the contacts' relative motion, and {count} contacts among {n} "
                         f"particles (z = {2 * count / n:.2f}) leave {residual / scale:.1e} of them unreachable "
                         f"(it needs z below {2 * width:d}, less the uniform motions; a packing nearer jamming)")
    return solution.reshape(n, width)


def _load_history(lmp, positions, diameters, box, model, tangential, limits: tuple, dt: float, comm) -> None:
    """Put the stored tangential forces f_t (on i from j) into LAMMPS's shear history, which no
    command or library call sets (and a restart read by a second LAMMPS instance of a process
    loses: docs/finite_amplitude.md): one step of ``HISTORY_STEP`` with no integrator (nothing
    moves) at the velocities of :func:`history_velocities` leaves s = -f_t / k_t on every
    contact.  The step is long so that the velocities, and the dashpots' forces in that step,
    are negligible.  Under pair granular the step's spins would stretch the rolling and twisting
    springs too: their Coulomb limits are 0 for that step, so that LAMMPS's rescaling leaves their
    history at zero, and the ``limits`` (mu, mu_roll, mu_twist) are set again after it.
    Then the velocities are zeroed and LAMMPS's tangential forces are compared
    with the stored ones: InputError on every rank if they differ by more than ``HISTORY_TOL``
    of the largest.  Collective (every rank solves the same small system; one allgather)."""
    velocities = history_velocities(positions, diameters, box, model, tangential)
    dim = positions.shape[1]
    set_velocities(lmp, velocities, dim)
    granular = model.history == "granular"
    if granular:
        lmp.commands_list(granular_coefficients(diameters, model, (limits[0], 0.0, 0.0))[1])
    lmp.commands_string(f"""
        timestep {HISTORY_STEP!r}
        run 1 post no
        timestep {float(dt)!r}
        reset_timestep 0
    """)  # step 0 again: fix python/invoke samples at multiples of its period
    if granular:
        lmp.commands_list(granular_coefficients(diameters, model, limits)[1])
    set_velocities(lmp, np.zeros_like(velocities), dim)
    lmp.command("run 0 post no")
    _compare_history(lmp, tangential, dim, comm)


def _tangent_bases(normal: np.ndarray) -> np.ndarray:
    """(C, D - 1, D) orthonormal tangent directions of each contact normal (C, D): 2D t = (-n_y, n_x);
    3D two unit vectors perpendicular to n and to each other."""
    if normal.shape[1] == 2:
        return np.stack((-normal[:, 1], normal[:, 0]), axis=1)[:, None, :]
    helper = np.where(np.abs(normal[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    first = np.cross(normal, helper)
    first /= np.linalg.norm(first, axis=1)[:, None]
    return np.stack((first, np.cross(normal, first)), axis=1)


def _compare_history(lmp, tangential, dim: int, comm) -> None:
    """InputError on every rank unless LAMMPS's tangential forces at rest equal the stored ones to
    ``HISTORY_TOL`` of the largest.  Collective (one allgather)."""
    pairs, values = _local_contacts(lmp)
    parts = comm.allgather((pairs, values[:, 2:2 + dim]))
    pairs = np.concatenate([p for p, _ in parts])
    force = np.concatenate([f for _, f in parts])
    flip = pairs[:, 0] > pairs[:, 1]  # LAMMPS's force is on its first atom: the stored one on the lower index
    force[flip] *= -1.0
    low, high = np.minimum(pairs[:, 0], pairs[:, 1]), np.maximum(pairs[:, 0], pairs[:, 1])
    stored = tangential.on(low, high)
    scale = np.abs(tangential.force).max(initial=0.0)
    worst = np.abs(force - stored).max(initial=0.0)
    if not worst <= HISTORY_TOL * scale:
        raise InputError(f"{KEY}: LAMMPS's tangential forces after loading its contact history differ from the "
                         f"stored ones by {worst:.3e} (largest stored {scale:.3e}, allowed {HISTORY_TOL:g} of it)")


def _check_rest(lmp, n: int, rest_tol: float) -> None:
    """InputError on every rank when LAMMPS's largest force or torque component on the packing
    at rest is not below ``REST_FACTOR`` ``rest_tol``.  Collective (gather_atoms)."""
    largest, what = max((float(np.abs(lammps_engine.gather(lmp, key, n, 3)).max()), name)
                        for key, name in (("f", "force"), ("torque", "torque")))
    if not largest < REST_FACTOR * rest_tol:
        raise InputError(f"waves.engine: lammps: LAMMPS does not find the packing at rest: its largest {what} "
                         f"component is {largest:.3e}, not below {REST_FACTOR:g} x packing.force_tol = "
                         f"{REST_FACTOR * rest_tol:.1e} (it would move on its own; a packing with stored tangential "
                         "forces needs them in LAMMPS's history)")


def _hold(lmp, n: int, active: np.ndarray) -> np.ndarray:
    """Make the moving particles' start an exact equilibrium: the constant external force
    F_hold = -F (N', D), LAMMPS's net contact forces on them at rest once the rattlers are let go
    (their residual forces, below force_tol, and the rattlers' pushes), is put on each
    (``fix external pf/array``, whose per-atom forces travel with their atoms between ranks) and
    returned.  A constant force has no Hessian, so the linear limit is the matrix's, which has
    no rattler either; without it the packing creeps by F t^2/2 (C off by 2.7 % at A = 1e-5 on a
    packing at force_tol = 1e-6; docs/finite_amplitude.md).  Collective (gather_atoms, run 0)."""
    nlocal = lmp.extract_global("nlocal")
    if nlocal:  # the fix's array starts uninitialised
        lmp.numpy.fix_external_get_force("hold")[:nlocal] = 0.0
    lmp.command("run 0")
    force = lammps_engine.gather(lmp, "f", n, 3)
    force[~active] = 0.0
    nlocal = lmp.extract_global("nlocal")
    if nlocal:
        lmp.numpy.fix_external_get_force("hold")[:nlocal] = -force[lmp.numpy.extract_atom("id")[:nlocal] - 1]
    lmp.command("run 0")
    dim = 3 if lmp.extract_setting("dimension") == 3 else 2
    return -force[active, :dim]


def _hold_torques(lmp, n: int, active: np.ndarray) -> None:
    """Hold the moving particles' residual torques at rest too (``fix external`` takes forces
    only): the constant torque -T, LAMMPS's net torque on each at rest, added after every
    force evaluation (``fix python/invoke 1 post_force``, a Python call per step).  Only for
    packings with stored tangential forces: without them every torque at rest is zero.  Their
    residual torques (up to REST_FACTOR force_tol) otherwise turn the particles by T t^2 / 2I:
    1.1e-5 of max |z| by t = 10 against the matrix's Verlet (2 ranks, 64 disks made to 1e-10).
    Collective (gather_atoms)."""
    torque = lammps_engine.gather(lmp, "torque", n, 3)
    torque[~active] = 0.0

    def callback(*_):  # LAMMPS passes its pointer and the virial flag
        nlocal = lmp.extract_global("nlocal")
        if nlocal:
            lmp.numpy.extract_atom("torque")[:nlocal] -= torque[lmp.numpy.extract_atom("id")[:nlocal] - 1]

    sys.modules["__main__"].__dict__[TORQUE_CALLBACK] = callback
    lmp.commands_string(f"""
        python {TORQUE_CALLBACK} input 2 SELF 0 format pi exists
        fix torques moving python/invoke 1 post_force {TORQUE_CALLBACK}
    """)


def set_velocities(lmp, values: np.ndarray, dim: int) -> None:
    """rotsound's (N, dof) velocities onto this rank's atoms, found by their ids.  Not collective."""
    nlocal = lmp.extract_global("nlocal")
    if not nlocal:
        return
    mine = values[lmp.numpy.extract_atom("id")[:nlocal] - 1]
    v, w = lmp.numpy.extract_atom("v"), lmp.numpy.extract_atom("omega")
    v[:nlocal], w[:nlocal] = 0.0, 0.0
    v[:nlocal, :dim] = mine[:, :dim]
    rotations = values.shape[1] - dim
    if rotations:
        w[:nlocal, 3 - rotations:] = mine[:, dim:]


def velocities(lmp, n: int, dim: int, dof: int) -> np.ndarray:
    """Every particle's (N, dof) velocities in rotsound's order, on every rank.  Collective."""
    w = lammps_engine.gather(lmp, "omega", n, 3)
    return np.hstack((lammps_engine.gather(lmp, "v", n, dim), w[:, 2:] if dim == 2 else w))[:, :dof]


def _local_contacts(lmp) -> tuple[np.ndarray, np.ndarray]:
    """This rank's contacts: pairs (c, 2) 0-based and (r, f_n, f_t x, y, z, |f_t|) (c, 6), under
    pair granular also (f_r x, y, z, |f_r|) (c, 10): the distance, the normal force with its
    dashpot (``compute pair/local force``: r times the pair style's ccel), the tangential force
    after LAMMPS's Coulomb rescaling and the rolling force after its own.  (LAMMPS's pair
    granular reports no twisting torque there: its p9 is 0, measured.)  Not collective."""
    from lammps import LMP_SIZE_COLS, LMP_STYLE_LOCAL, LMP_TYPE_ARRAY

    columns = lmp.extract_compute("forces", LMP_STYLE_LOCAL, LMP_SIZE_COLS)
    arrays = [lmp.numpy.extract_compute(name, LMP_STYLE_LOCAL, LMP_TYPE_ARRAY) for name in ("pairs", "forces")]
    pairs, values = (np.zeros((0, width)) if a is None else np.array(a, dtype=float).reshape(-1, width)
                     for a, width in zip(arrays, (2, columns)))
    return pairs.astype(np.int64) - 1, values


class _Sampler:
    """z(t) every sample and the contact series of one run (:class:`Contacts`) every
    ``record_every``-th, each reduced on the rank that holds the atoms and contacts (one
    allreduce of z's two parts a sample; a record: one of sums and one of maxima).  The start's
    contacts (a key and the overlap of each, 2 C numbers) are gathered onto every rank once, at
    construction, to tell later which have opened and which formed.  A record
    costs LAMMPS's ``compute pair/local`` and numpy over every contact (about 4 ms at N = 8192 on
    two ranks, more than ten steps: BENCHMARKS "lammps_waves"); z costs 0.1-0.2 ms.  Collective."""

    def __init__(self, lmp, positions, diameters, box, model, limits, held, component, weights, comm,
                 record_every: int = 1):
        self.lmp, self.model, self.comm = lmp, model, comm
        self.friction, self.rolling_friction = limits[0], limits[1]
        self.record_every, self.count = record_every, 0
        self.box, self.diameters, self.x0, self.held = box, diameters, positions, held
        self.n, self.dim = positions.shape
        self.component, self.weights = component, weights
        self.inertia = diameters**2 / (8.0 if self.dim == 2 else 10.0)
        pairs, values = _local_contacts(self.lmp)
        keys = np.concatenate(comm.allgather(self._keys(pairs)))
        overlaps = np.concatenate(comm.allgather(self._overlaps(pairs, values[:, 0])))
        order = np.argsort(keys)
        self.keys, self.overlap0 = keys[order], overlaps[order]  # the start's contacts, every rank
        self.z, self.rows = [], {name: [] for name in RECORDS}
        self.rest = self._sums()[3]  # the springs' energy at rest, before the start's velocities

    def _keys(self, pairs: np.ndarray) -> np.ndarray:
        """One integer (c,) per contact, whichever particle LAMMPS lists first."""
        first, second = pairs[:, 0], pairs[:, 1]
        return np.minimum(first, second) * self.n + np.maximum(first, second)  # not min(axis=1): 6x slower

    def _overlaps(self, pairs: np.ndarray, distance: np.ndarray) -> np.ndarray:
        return 0.5 * (self.diameters[pairs[:, 0]] + self.diameters[pairs[:, 1]]) - distance

    def _sums(self) -> np.ndarray:
        """This sample's [Re z, Im z, kinetic, potential, sliding, touching, of the start's,
        rolling] summed over the ranks, and [coulomb, opening, rolling coulomb] maximised
        (appended).  The potential is NaN with twisting springs, whose torques LAMMPS does not
        report per contact.  Collective."""
        lmp, dim = self.lmp, self.dim
        nlocal = lmp.extract_global("nlocal")
        ids = lmp.numpy.extract_atom("id")[:nlocal] - 1 if nlocal else np.zeros(0, dtype=np.int64)
        x = lmp.numpy.extract_atom("x")[:nlocal, :dim] if nlocal else np.zeros((0, dim))
        v = lmp.numpy.extract_atom("v")[:nlocal, :dim] if nlocal else np.zeros((0, dim))
        w = lmp.numpy.extract_atom("omega")[:nlocal] if nlocal else np.zeros((0, 3))
        w = w[:, 2:] if dim == 2 else w
        pairs, values = _local_contacts(self.lmp)
        normal, tangential = np.abs(values[:, 1]), values[:, 5]
        overlap = self._overlaps(pairs, values[:, 0])
        reduced = contact_law.reduced_radius(self.diameters[pairs[:, 0]], self.diameters[pairs[:, 1]])
        potential = contact_law.normal_energy(overlap, self.model.law, reduced).sum()
        if self.model.rho > 0.0:
            kt = self.model.rho * contact_law.spring_scale(overlap, self.model.law, reduced)
            potential += (tangential**2 / (2.0 * kt)).sum()
        rolling = values[:, 9] if values.shape[1] > 6 else np.zeros(len(values))
        if self.model.rho_roll > 0.0:
            potential += (rolling**2 / (2.0 * self.model.rho_roll * contact_law.KN)).sum()
        if self.model.rho_twist > 0.0:
            potential = np.nan
        moved = geometry.minimum_image(x - self.x0[ids], self.box)
        potential -= np.einsum("nd,nd->", self.held[ids], moved)  # the hold force's work
        channel = (v[:, self.component] if self.component < dim else w[:, self.component - dim]) @ self.weights[ids]
        kinetic = 0.5 * (np.einsum("nd,nd->", v, v) + np.einsum("n,nr,nr->", self.inertia[ids], w, w))
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(normal > 0, tangential / (self.friction * normal), 0.0)
            rolled = np.where(normal > 0, rolling / (self.rolling_friction * normal), 0.0)
        keys = self._keys(pairs)
        at = np.minimum(np.searchsorted(self.keys, keys), self.keys.size - 1)
        held = self.keys[at] == keys  # the start's contacts still touching
        start = self.overlap0[at[held]]
        opening = ((start - overlap[held]) / start).max(initial=0.0)
        from mpi4py import MPI  # here, not at the top: importing mpi4py starts MPI (rotsound keys must not)

        sums = np.array([channel.real, channel.imag, kinetic, potential,
                         np.count_nonzero(ratio >= 1.0 - LIMIT_SLACK), keys.size, held.sum(),
                         np.count_nonzero(rolled >= 1.0 - LIMIT_SLACK)], dtype=float)
        maxima = np.array([ratio.max(initial=0.0), opening, rolled.max(initial=0.0)], dtype=float)
        self.comm.Allreduce(MPI.IN_PLACE, sums, op=MPI.SUM)
        self.comm.Allreduce(MPI.IN_PLACE, maxima, op=MPI.MAX)
        return np.concatenate((sums, maxima))

    def _z(self) -> complex:
        """This sample's Fourier component alone (one allreduce of its two parts).  Collective."""
        from mpi4py import MPI

        lmp, dim = self.lmp, self.dim
        nlocal = lmp.extract_global("nlocal")
        parts = np.zeros(2)
        if nlocal:
            ids = lmp.numpy.extract_atom("id")[:nlocal] - 1
            if self.component < dim:
                values = lmp.numpy.extract_atom("v")[:nlocal, self.component]
            else:
                values = lmp.numpy.extract_atom("omega")[:nlocal, self.component - dim + (2 if dim == 2 else 0)]
            channel = values @ self.weights[ids]
            parts[:] = channel.real, channel.imag
        self.comm.Allreduce(MPI.IN_PLACE, parts, op=MPI.SUM)
        return complex(parts[0], parts[1])

    def sample(self) -> None:
        self.count += 1
        if (self.count - 1) % self.record_every:
            self.z.append(self._z())
            return
        re, im, kinetic, potential, sliding, touching, kept, rolling, coulomb, opening, rolled = self._sums()
        opened = self.keys.size - int(kept)
        row = self.rows
        self.z.append(re + 1j * im)
        row["sliding"].append(int(sliding))
        row["opened"].append(opened)
        row["formed"].append(int(touching) - int(kept))
        row["opening"].append(1.0 if opened else float(opening))
        row["coulomb"].append(float(coulomb))
        row["energy"].append(float(kinetic + potential - self.rest))
        row["rolling"].append(int(rolling))
        row["rolling_coulomb"].append(float(rolled))

    def contacts(self) -> Contacts:
        kinds = {"sliding": np.int64, "opened": np.int64, "formed": np.int64, "rolling": np.int64}
        return Contacts(**{name: np.array(values, dtype=kinds.get(name, float)) for name, values in self.rows.items()})
