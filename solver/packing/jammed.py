"""Jammed 50:50 bidisperse packings of disks (2D) or spheres (3D) (the paper's Materials and Methods).

Diameters d_S = 2/2.4 and d_L = 1.4 d_S (mean d0 = 1), equal masses m = 1, periodic square (2D)
or cubic (3D) box with area or volume fraction phi, uniform random start from a seed, FIRE on
the frictionless harmonic energy E_n = sum kn xi^2 / 2 until max_i |F_i| / m < force_tol
(default 1e-6 kn d0 / m).  The dimension D = 2 or 3 is the number of columns of ``positions``.

Rattlers are flagged by ``mechanics.find_rattlers`` (fewer than D + 1 contacts, applied until
none is new) and stay in the packing. After minimisation particles are renumbered in a spatial
order (2D: horizontal strips by y, x inside a strip; 3D: slabs by z, strips by y inside a slab,
x inside a strip) so that contiguous rank blocks are compact in space; the renumbering depends
only on the packing, never on the number of ranks.  With ``packing.shear`` that packing is then
sheared quasi-statically (``shear.quasistatic``), keeping its numbering.
Not collective.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .. import profiling
from ..capillary import Cohesion
from ..contact_law import ContactModel
from . import bridges, fire, geometry, lammps_engine, mechanics, stressed, wet
from . import shear as shearing
from .configuration import Packing, solid_volume
from .stressed import TangentialForces

SIZE_RATIO = 1.4
MIN_N = 16
"""Fewest particles of a generated packing (a 50:50 mixture; in 2D that also makes the box exceed two
diameters; the scene's packing.n is refused below it)."""
D_SMALL = 2.0 / (1.0 + SIZE_RATIO)
D_LARGE = SIZE_RATIO * D_SMALL


def bidisperse_diameters(n: int) -> np.ndarray:
    """Diameters (n,): first n//2 small, the rest large."""
    d = np.full(n, D_LARGE)
    d[: n // 2] = D_SMALL
    return d


def box_length_for(diameters: np.ndarray, phi: float, dim: int = 2) -> float:
    """Side L of the square (2D) or cubic (3D) box in which ``diameters`` fill fraction ``phi``."""
    volume = solid_volume(diameters, dim) / phi
    return float(np.sqrt(volume) if dim == 2 else np.cbrt(volume))


def smallest_n(phi: float, dim: int, shear: float = 0.0) -> int:
    """Smallest even N >= ``MIN_N`` whose bidisperse box at ``phi``, tilted by ``shear``
    (``shear.sheared_cell``), is more than two large diameters across."""
    pair = solid_volume(np.array([D_SMALL, D_LARGE]), dim)  # one small and one large particle
    n = int(np.floor(2.0 * phi * (2.0 * D_LARGE) ** dim / pair)) + 1  # L^D = (n/2) pair / phi
    n += n % 2

    def across(n):
        side = box_length_for(bidisperse_diameters(n), phi, dim)
        return geometry.narrowest(shearing.sheared_cell(np.full(dim, side), shear))

    while across(n) <= 2.0 * D_LARGE:  # round-off at the edge, and the tilt's narrower height
        n += 2
    return max(MIN_N, n)


def spatial_order(positions: np.ndarray, box) -> np.ndarray:
    """Permutation sorting particles into ~n^(1/D) slices along the last axis (2D: strips by y;
    3D: slabs by z, then ~n^(1/3) strips by y inside a slab), by x inside a strip; in a tilted
    ``geometry.Cell`` the slices are of its fractional coordinates (parallel to its faces)."""
    n, dim = positions.shape
    slices = max(1, int(np.sqrt(n) if dim == 2 else np.cbrt(n)))
    cell = geometry.Cell.of(box, dim)
    across = cell.fractional(positions)[:, 1:] if cell.tilted else positions[:, 1:] / cell.sides[1:]
    slab = np.minimum((across * slices).astype(int), slices - 1)
    return np.lexsort((positions[:, 0], *slab.T))  # the last key (y in 2D, z in 3D) sorts first


@profiling.logged("rsPackingFIRE")
def generate(n: int, phi: float, seed: np.random.SeedSequence, force_tol: float = 1e-6,
             max_steps: int = 2_000_000, dim: int = 2, engine: str = "fire", comm=None,
             law: str = "harmonic", friction: float | None = None, pressure: float | None = None,
             cohesion: Cohesion | None = None, shear: float = 0.0, shear_step: float = 0.01) -> Packing:
    """Make one jammed packing of ``n`` disks (``dim`` = 2) or spheres (3) at area or volume
    fraction ``phi`` under the normal ``law`` (harmonic or hertz), minimised by ``engine``:
    rotsound's FIRE (not collective) or LAMMPS's
    (``lammps_engine.minimize``: the same start and criterion, an equally valid but different
    minimum; collective on ``comm``, an mpi4py communicator).

    With ``friction`` = mu (``engine`` lammps only) the packing is a frictional one as a DEM code
    leaves it, with its stored tangential forces (:func:`_frictional`), held at ``pressure`` when
    one is given (phi is then where the squeeze ends, and the final phi is the packing's).

    With ``cohesion`` (``engine`` fire only) the packing is wet: FIRE runs on the normal forces
    and the capillary bridges' pull from the same random start, the bridges forming at every
    contact met on the way and breaking at their rupture distance (``wet.WetForces``) [protocol
    decision: the particles are wet from the start, so the same seed gives the dry packing of the
    same start]; it keeps its bridged pairs across a gap (``Packing.bridges``).

    With ``shear`` = gamma (``engine`` fire without friction only: ValueError otherwise) the packing
    made at shear 0 (the same one, bit for bit) is sheared quasi-statically to gamma in steps of
    ``shear_step`` (``shear.quasistatic``): a sheared packing at rest in the cell tilted by
    xy = gamma L (``shear.sheared_cell``), its info the sheared state's with the shear's record (``shear``,
    ``shear_step``, ``shear_steps``, ``shear_fire_steps``, ``sigma_xy``) and the square's FIRE record
    (``fire_steps``, ...).

    Raises InputError (naming packing.n and packing.phi) before FIRE if the cell would not be more
    than two large diameters across (a pair could touch through two periodic images: tiny N at
    high phi in 3D), and RuntimeError if FIRE does not reach ``force_tol`` within ``max_steps``.
    """
    if shear and (engine != "fire" or friction is not None):
        raise ValueError(f"shear = {shear}: rotsound's FIRE (engine fire, no friction) makes sheared packings")
    rng = np.random.default_rng(seed)
    diameters = rng.permutation(bidisperse_diameters(n))  # mixed, so the sort below is safe
    box_length = box_length_for(diameters, phi, dim)
    box = np.full(dim, box_length)
    cell = shearing.sheared_cell(box, shear)
    if geometry.narrowest(cell) <= 2.0 * D_LARGE:
        across = (f"side L = {box_length:.4g}" if not shear else
                  f"side L = {box_length:.4g} and, tilted by packing.shear = {shear}, a height of "
                  f"{geometry.narrowest(cell):.4g}")
        raise InputError(f"packing.n = {n}, packing.phi = {phi}: the {dim}D box would have {across}, not more than "
                         f"two large diameters (2 d_L = {2 * D_LARGE:.4g}), so a "
                         f"pair could touch through two periodic images: choose packing.n >= "
                         f"{smallest_n(phi, dim, shear)} at this phi, or a smaller packing.phi")
    if friction is not None:
        return _frictional(diameters, box, phi, rng, force_tol, max_steps, comm, law, friction, pressure)
    square = _minimized(diameters, box, phi, rng, force_tol, max_steps, engine, comm, law, cohesion)
    if not shear:
        return square
    sheared = shearing.quasistatic(square, shear, shear_step, force_tol, max_steps)
    for key, value in square.info.items():  # the square's FIRE record (fire_steps, ...) and wet, its cohesion's
        sheared.info.setdefault(key, value)
    return sheared


def _minimized(diameters: np.ndarray, box: np.ndarray, phi: float, rng, force_tol: float, max_steps: int,
               engine: str, comm, law: str, cohesion: Cohesion | None) -> Packing:
    """:func:`generate`'s frictionless packing in the square or cubic ``box`` (D,) at ``phi``: a uniform
    start from ``rng``, minimised by ``engine``, renumbered in spatial order, its rattlers and statistics."""
    n, dim = diameters.size, box.size
    cell = shearing.sheared_cell(box, 0.0)
    start = rng.uniform(0.0, box[0], size=(n, dim))
    start = start[spatial_order(start, box)]  # spatial order: cache-friendly gathers
    if engine == "lammps":
        x, steps, max_force = lammps_engine.minimize(start, diameters, box, force_tol, max_steps, comm, law=law)
        stats = {"engine": "lammps"}
    else:
        forces = (mechanics.FrictionlessForces(diameters, cell, law=law) if cohesion is None
                  else wet.WetForces(diameters, cell, cohesion, law))
        result = fire.minimize(start, forces, force_tol, max_steps)
        if not result.converged:
            raise RuntimeError(f"FIRE did not converge: max |F| = {result.max_force:.3e} > "
                               f"{force_tol:.1e} after {result.steps} steps (n={n}, phi={phi}, dim={dim})")
        x, steps, max_force = result.x, result.steps, result.max_force
        dry = forces if cohesion is None else forces.dry
        stats = {"neighbour_rebuilds": dry.rebuilds, "neighbour_refreshes": dry.refreshes}
    positions = geometry.wrap(x, cell)
    order = spatial_order(positions, cell)
    positions, diameters = positions[order], diameters[order]
    gap = None
    if cohesion is not None:
        new_index = np.empty_like(order)
        new_index[order] = np.arange(n)
        gap = bridges.build(new_index[forces.bridged(n)], positions, diameters, cell, cohesion, "the wet packing")
        stats.update(bridges_broken=forces.broken, **bridges.cohesion_record(cohesion))
    rattler = mechanics.find_rattlers(positions, diameters, cell, law=law, cohesion=cohesion, bridges=gap)
    info = mechanics.describe(positions, diameters, cell, rattler, law, cohesion, gap)
    info.update(fire_steps=steps, max_force=max_force, force_tol=force_tol, law=law, **stats)
    return Packing(positions, diameters, box, rattler, info, model=ContactModel(law=law, cohesion=cohesion),
                   bridges=gap)


SQUEEZE_FROM = 0.75  # a frictional packing's start: phi_start = 0.75 phi, squeezed to phi


def _frictional(diameters: np.ndarray, box: np.ndarray, phi: float, rng, force_tol: float, max_steps: int,
                comm, law: str, friction: float, pressure: float | None = None) -> Packing:
    """A frictional packing made by LAMMPS (``lammps_engine.settle_frictional``): a uniform random
    start at phi_start = 0.75 phi squeezed to phi (then, with a target ``pressure``, held at it by
    a barostat) and damped to rest (every force and torque component below ``force_tol``) with
    Coulomb coefficient ``friction``; its stored tangential forces read back, particles renumbered
    in spatial order, rattlers by the stressed rule.  Collective on ``comm``."""
    dim = box.size
    start_box = box * SQUEEZE_FROM ** (-1.0 / dim)  # the same particles at 0.75 phi
    start = rng.uniform(0.0, start_box[0], size=(diameters.size, dim))
    x, box, pairs, shear, steps, largest = lammps_engine.settle_frictional(
        start, diameters, start_box, box, friction, force_tol, max_steps, comm, law, pressure=pressure)
    order = spatial_order(x, box)
    new_index = np.empty_like(order)
    new_index[order] = np.arange(order.size)
    positions, diameters = x[order], diameters[order]
    stored = stressed.build(new_index[pairs], shear, positions, diameters, box, law, friction, "LAMMPS's contacts",
                            cap=force_tol)
    info = dict(engine="lammps", friction=friction, settle_steps=steps, max_force=largest, force_tol=force_tol,
                law=law, n_stored=len(stored), **({} if pressure is None else {"target_pressure": pressure}),
                n_mobilised=int(stressed.mobilised(stored, positions, diameters, box, law).sum()))
    return from_arrays(positions, diameters, box, None, info, None, ContactModel(law=law), stored)


@profiling.logged("rsPackingFIRE")
def relax(packing: Packing, force_tol: float = 1e-6, max_steps: int = 2_000_000) -> Packing:
    """``packing.relax``: re-minimise a loaded packing frictionlessly with FIRE from its own
    positions, in its own box, under its normal law (``packing.model``), to ``force_tol`` (kn d0),
    keeping diameters and masses and the model.  The stored tangential forces are dropped.  For
    packings made with friction in a DEM code, which balance only with their tangential forces:
    the result is the nearest frictionless energy minimum, not the file's packing.  Rattlers and
    statistics are recomputed.  Not collective.  Raises RuntimeError if FIRE does not converge.
    """
    law = packing.model.law
    forces = mechanics.FrictionlessForces(packing.diameters, packing.cell, law=law)
    result = fire.minimize(packing.positions, forces, force_tol, max_steps)
    if not result.converged:
        raise RuntimeError(f"packing.relax: FIRE did not converge: max |F| = {result.max_force:.3e} > "
                           f"{force_tol:.1e} after {result.steps} steps ({packing.info.get('source', 'packing')})")
    info = {key: packing.info[key] for key in ("source",) if key in packing.info}
    info.update(relaxed=True, fire_steps=result.steps, max_force=result.max_force, force_tol=force_tol, law=law)
    return from_arrays(result.x, packing.diameters, packing.cell, None, info, packing.masses, packing.model)


def from_arrays(positions: np.ndarray, diameters: np.ndarray, box, rattler: np.ndarray | None = None,
                info: dict | None = None, masses: np.ndarray | None = None,
                model: ContactModel = ContactModel(), tangential: TangentialForces | None = None,
                bridges: np.ndarray | None = None) -> Packing:
    """Build a :class:`Packing` from user arrays (e.g. another code's packing), positions (N, D),
    ``box`` a ``geometry.Cell`` (its tilt and periodic axes kept on the packing), the (D,) sides or
    one side for a square or cubic box, ``masses`` (N,) or None,
    ``tangential`` the stored tangential forces (``stressed.build``) or None, ``bridges`` the
    bridged pairs apart of a wet packing (``bridges.build``) or None, under the contact ``model``
    (its normal law, lever and cohesion, kept on the packing: ``ContactModel.at_rest``): the
    statistics (energy, pressure) are those of its normal law and bridges.

    Rattlers are computed with the iterative rule (``mechanics.find_rattlers``) when ``rattler``
    is None.
    """
    positions = np.asarray(positions, dtype=float)
    cell = geometry.Cell.of(box, positions.shape[1])
    positions = geometry.wrap(positions, cell)
    diameters = np.asarray(diameters, dtype=float)
    if rattler is None:
        rattler = mechanics.find_rattlers(positions, diameters, cell, tangential, model.law, model.cohesion, bridges)
    stats = mechanics.describe(positions, diameters, cell, rattler, model.law, model.cohesion, bridges)
    stats.update(info or {})
    return Packing(positions, diameters, np.array(cell.sides, dtype=float), np.asarray(rattler, dtype=bool), stats,
                   None if masses is None else np.asarray(masses, dtype=float), tangential, model.at_rest(), bridges,
                   tilt=np.array(cell.tilt, dtype=float) if cell.tilted else None,
                   periodic=None if np.all(cell.periodic) else np.array(cell.periodic, dtype=bool))


PHI_JAMMING = {2: 0.84, 3: 0.648}
"""Where this mixture jams, per dimension (O'Hern et al., PRE 68, 011306 (2003): 2D, and their 3D
1:1.4 mixture for 0.648, a value not checked here against the paper's text); finite packings
scatter around it (measured in 2D: at N = 256, 2 of 4 seeds jam at phi = 0.84, all at 0.845; at
N = 16, 19 of 20 at 0.85; in 3D: at N = 256, 0 of 6 seeds jam at 0.63, 1 of 6 at 0.64, all at 0.65)."""


def require_jammed(packings: list[Packing], phi: float) -> None:
    """Raise InputError naming ``packing.phi`` if any generated configuration did not jam
    (``mechanics.jamming_failure``). Not collective (the same verdict on every rank)."""
    failures = [(index, why) for index, p in enumerate(packings) if (why := mechanics.jamming_failure(p))]
    if not failures:
        return
    index, why = failures[0]
    dim = packings[index].dim
    what = (f"configuration {index} did not jam: {why}" if len(failures) == 1 else
            f"configurations {', '.join(str(i) for i, _ in failures)} of {len(packings)} did not jam "
            f"(configuration {index}: {why})")
    mixture, example = ("mixture", "the paper's is 0.9") if dim == 2 else ("3D mixture", "e.g. 0.7")
    raise InputError(f"packing.phi = {phi}: {what}; this {mixture} jams near phi = {PHI_JAMMING[dim]} and "
                     f"small packings scatter around it: choose a larger packing.phi ({example})")
