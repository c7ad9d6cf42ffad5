"""Mechanics of a packing under its normal contact forces (eq:eij at rho = 0) and, for a packing
made with friction, its stored tangential forces: the force engine FIRE minimises on
(:class:`FrictionlessForces`), the rattler rule, the statistics of a packing (energy, pressure,
z), the net force and torque and the equilibrium check of a loaded packing, and the rigidity
count that decides whether a matrix can be built on a generated one (:func:`jamming_failure`).

Rattlers [choice]: a particle with fewer than D + 1 contacts among the remaining non-rattlers is
a rattler (3 for a disk, 4 for a sphere: fewer cannot hold it in force balance against every
direction); in a stressed (dry) packing, a particle whose contacts carry (almost) no force; in a
wet one, a particle with both too few links (contacts and bridges) and no force in them
(:func:`find_rattlers`).  A wet packing's capillary bridges
(``ContactModel.cohesion``) pull on every contact and on the bridged pairs across a gap
(``Packing.bridges``; docs/capillary_bridges.md).  The rule is applied repeatedly until no new rattler appears.
Rattlers stay in the packing (flagged) and are excluded from the dynamical matrix.
Units kn = d0 = m = 1.  Not collective.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .. import capillary, contact_law
from ..errors import InputError
from ..wording import counted
from . import bridges as bridging
from . import geometry
from . import walls as walling

if TYPE_CHECKING:
    from .configuration import Packing
    from .stressed import TangentialForces
NAMES = {2: "disks", 3: "spheres"}
EQUILIBRIUM_TOL = 1e-4  # kn d0: largest net force (and torque, kn d0^2) on a loaded packing (FIRE reaches 1e-6)


def min_contacts(dim: int) -> int:
    """Contacts a non-rattler needs in ``dim`` dimensions: dim + 1."""
    return dim + 1


class FrictionlessForces:
    """Harmonic or Hertz normal forces on a Verlet list (skin s).

    Positions are not wrapped during minimisation, so each listed pair keeps the periodic
    image shift found when it was listed.  Every particle has a reference position, and none
    moves more than s/2 from it.  In an orthogonal periodic box (jammed.generate's) the whole list,
    out to contact plus s, and its neighbour table are made afresh when one would, compiled and on
    every thread (``cell_list.verlet_list``; the same pairs (to round-off at the skin's edge, where
    no force is), shifts and order as the search below, so the same packings; CPU per list on one
    thread at the random start: 55 ms against 91 for a rebuild by the search below at N = 65536
    (whose refreshes averaged 58), 1.0 s against 2.5 s at N = 1048576; and on every thread where
    those run on one).
    In a tilted or walled cell the list is kept valid by cheap partial refreshes: when one would,
    the particles that moved more than s/4 are re-listed from where they are now, against
    everybody, out to their contact distance plus 1.25 s, and their references reset (a full rebuild, out to contact plus s, when more than
    half of the particles have been re-listed since the last one).  A pair is decided when one of
    its particles is (re-)listed; from then on the other moves at most 3s/4 (s/4 then, s/2 from
    its reference after) and the re-listed one s/2, so an unlisted pair cannot touch.  (Late in
    FIRE a few particles, about 1 %, trip the list while the median has moved s/30: measured at
    N = 2048 in 3D.)  The skin is at most (min L_a/2 - max d)/1.25 (in a tilted cell, the smallest
    height for L_a: ``geometry.narrowest``), so that a listed pair touches through its listed image
    only (tiny 3D boxes).  The pairs stay sorted by (i, j), and each
    change of the list remakes its neighbour table, so each particle's force is summed over its
    neighbours in a fixed order; the pass over them is compiled and threaded, the same bits on any
    number of threads (``pair_forces.net_forces``), and so is each step's check of the largest
    move (``pair_forces.largest_squared_move``).  Measured at N = 32768 in 3D: a refresh of 1 % of the
    particles 30 ms against 150 ms for a rebuild; at N = 8192 the refreshes cut the packing's time
    by a fifth.
    """

    REACH = 1.25  # reach of a partial refresh, in skins (see above)

    def __init__(self, diameters: np.ndarray, box, skin: float = 0.3, law: str = "harmonic"):
        self.diameters, self.box = diameters, box  # box: a geometry.Cell, (D,) sides, or one for a square or cube
        self.hertz = law == "hertz"  # else harmonic (contact_law.LAWS)
        self.largest = float(diameters.max())
        self.skin = min(skin, (0.5 * geometry.narrowest(box) - self.largest) / self.REACH)
        self.reference: np.ndarray | None = None
        self.table: tuple | None = None  # the neighbour table's arrays (pair_forces.neighbour_table), reused
        self.rebuilds = self.refreshes = 0
        from . import pair_forces  # here, not at the top: numba takes 0.5 s
        self.compiled = pair_forces
        self.sides: np.ndarray | None = None  # an orthogonal periodic box's (D,): the compiled list (set at the first call)
        self.room: tuple = ()  # cell_list.verlet_list's arrays, reused

    def _near(self, x: np.ndarray, i: np.ndarray, j: np.ndarray, reach: float):
        """The pairs among (i, j) closer than their contact distance plus ``reach``, as
        (i, j, shift (P, D), contact (P,), reduced radius a' (P,))."""
        delta = x[i] - x[j]
        shift = geometry.minimum_image(delta, self.box) - delta
        contact = 0.5 * (self.diameters[i] + self.diameters[j])
        separation = delta + shift
        near = np.einsum("pd,pd->p", separation, separation) < (contact + reach) ** 2
        i, j = i[near], j[near]
        return i, j, shift[near], contact[near], contact_law.reduced_radius(self.diameters[i], self.diameters[j])

    def _use(self, i: np.ndarray, j: np.ndarray, shift: np.ndarray, contact: np.ndarray,
             reduced: np.ndarray) -> None:
        """Make the list (pairs sorted by (i, j)) current, and its neighbour table (each particle's
        entries in a fixed order: ``pair_forces.neighbour_table``)."""
        self.i, self.j, self.shift, self.contact, self.reduced = i, j, shift, contact, reduced
        rows = 2 * i.size
        if self.table is None or self.table[1].size < rows:  # room for a quarter more: grown rarely
            rows += rows // 4
            self.table = (np.empty(self.diameters.size + 1, dtype=np.int64), np.empty(rows, dtype=np.int64),
                          np.empty((rows, shift.shape[1])), np.empty(rows), np.empty(rows))
        self.compiled.neighbour_table(self.diameters.size, i, j, shift, contact, reduced, *self.table)

    def _rebuild(self, x: np.ndarray) -> None:
        pairs = geometry.candidate_pairs(x, self.box, self.largest + self.skin)  # sorted by (i, j)
        self._use(*self._near(x, pairs[:, 0], pairs[:, 1], self.skin))
        self.reference = x.copy()
        self.relisted = np.zeros(x.shape[0], dtype=bool)
        self.rebuilds += 1

    def _refresh(self, x: np.ndarray, movers: np.ndarray) -> None:
        """Re-list the pairs of ``movers`` (N,) bool from the current positions."""
        n, index = x.shape[0], np.flatnonzero(movers)
        reach = self.REACH * self.skin
        other, mover = geometry.pairs_with(x, self.box, self.largest + reach, index)
        once = (other != mover) & (~movers[other] | (other < mover))  # a pair of two movers once
        fresh = self._near(x, np.minimum(other, mover)[once], np.maximum(other, mover)[once], reach)
        order = np.argsort(fresh[0] * n + fresh[1])
        stay = ~(movers[self.i] | movers[self.j])
        at = np.searchsorted(self.i[stay] * n + self.j[stay], fresh[0][order] * n + fresh[1][order])
        self._use(*(np.insert(old[stay], at, new[order], axis=0) for old, new in
                    zip((self.i, self.j, self.shift, self.contact, self.reduced), fresh)))  # still sorted by (i, j)
        self.reference[movers] = x[movers]
        self.relisted |= movers
        self.refreshes += 1

    def _compiled_sides(self, dim: int) -> np.ndarray | None:
        """The box's sides (D,) if it is orthogonal and periodic (the compiled list's), else None."""
        cell = geometry.Cell.of(self.box, dim)
        return None if cell.tilted or not np.all(cell.periodic) else np.array(cell.sides, dtype=float)

    def _relist(self, x: np.ndarray) -> None:
        """The whole list and its table afresh, compiled on every thread (``cell_list.verlet_list``)."""
        from .cell_list import verlet_list
        listed, self.table, self.room = verlet_list(x, self.diameters, self.sides, self.skin, self.room)
        self.i, self.j, self.shift, self.contact, self.reduced = listed
        self.reference = x.copy()
        self.rebuilds += 1

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, float]:
        moved = None if self.reference is None else self.compiled.largest_squared_move(x, self.reference)  # every step
        if moved is not None and np.isnan(moved):  # a position is NaN: no list can be made, and no force is known
            return np.full_like(x, np.nan), np.nan
        if moved is None:
            self.sides = self._compiled_sides(x.shape[1])
        if self.sides is not None:
            if moved is None or moved > (0.5 * self.skin) ** 2:
                self._relist(x)
        elif moved is None:
            self._rebuild(x)
        elif moved > (0.5 * self.skin) ** 2:
            step = x - self.reference
            movers = np.einsum("nd,nd->n", step, step) > (0.25 * self.skin) ** 2
            if np.count_nonzero(movers | self.relisted) > x.shape[0] // 2:
                self._rebuild(x)
            else:
                self._refresh(x, movers)
        force = np.empty_like(x)
        energy = self.compiled.net_forces(x, *self.table, self.hertz, force)
        return force, energy  # eq:eij at rho = 0


def contact_forces(found: geometry.Contacts, diameters: np.ndarray, law: str,
                   tangential: TangentialForces | None, cohesion: capillary.Cohesion | None = None) -> np.ndarray:
    """Force on i from j (C, D) of each contact of ``found``: the normal force of ``law`` along n,
    less the bridge's pull under ``cohesion``, plus the stored tangential force when
    ``tangential`` is given (units kn d0)."""
    reduced = contact_law.reduced_radius(diameters[found.i], diameters[found.j])
    along = contact_law.normal_force(found.overlap, law, reduced)
    if cohesion is not None:
        along = along - capillary.bridge_force(-found.overlap, 0.5 * diameters[found.i], 0.5 * diameters[found.j],
                                               cohesion)
    force = along[:, None] * found.normal
    return force if tangential is None else force + tangential.on(found.i, found.j)


def wet_pairs(bridges: np.ndarray | None, active: np.ndarray | None = None) -> np.ndarray:
    """The bridged pairs across a gap (B, 2) between ``active`` particles (all when None); (0, 2)
    for a dry packing (``bridges`` None)."""
    if bridges is None:
        return np.zeros((0, 2), dtype=np.int64)
    return bridges if active is None else bridges[active[bridges[:, 0]] & active[bridges[:, 1]]]


def force_magnitudes(packing: Packing) -> tuple[geometry.Contacts, np.ndarray, np.ndarray]:
    """(contacts among non-rattlers, |f_n| (C,), |f_t| (C,)) of ``packing``: the normal force of
    its law (``Packing.model``) and the stored tangential force (zero for an unstressed packing; perpendicular to the
    normal by construction, ``stressed.build``), kn d0.  Not collective."""
    found = geometry.find_contacts(packing.positions, packing.diameters, packing.cell, ~packing.rattler)
    d = packing.diameters
    f_n = contact_law.normal_force(found.overlap, packing.model.law, contact_law.reduced_radius(d[found.i], d[found.j]))
    stored = packing.tangential
    f_t = np.zeros(len(found)) if stored is None else np.linalg.norm(stored.on(found.i, found.j), axis=1)
    return found, f_n, f_t


def find_rattlers(positions: np.ndarray, diameters: np.ndarray, box, tangential: TangentialForces | None = None,
                  law: str = "harmonic", cohesion: capillary.Cohesion | None = None,
                  bridges: np.ndarray | None = None, held: tuple | None = None) -> np.ndarray:
    """Rattler mask (N,), applied until no new rattler appears.

    ``held`` (particle (K,), |force| (K,)): a walled packing's wall contacts, links to a body that
    never rattles, counted and weighed with the contacts by every rule below (docs/walls.md).

    Unstressed (``tangential`` None): particles with fewer than D + 1 contacts among
    non-rattlers.
    Wet (``cohesion``, with or without ``tangential``) [choice]: a particle with fewer than D + 1 links (contacts and bridged
    pairs across a gap, ``bridges``) among non-rattlers that together carry less than
    EQUILIBRIUM_TOL (sum of |(f_n - F) n + f_t|).  A bridge holds what no contact does, and a
    particle on two links in tension is held (their geometric terms stiffen it across), so the
    count alone cuts load-bearing particles; the force alone cuts particles whose contacts the pull
    balances exactly (f_n = F), which are stiff; a dangling particle on one link is both.
    Stressed [choice]: with tangential springs a disk on 2 contacts (a sphere on 2 or 3) carries
    load, so the count rule would cut load-bearing particles; instead a particle is a rattler when
    its contacts among non-rattlers carry together less than EQUILIBRIUM_TOL (sum of
    |f_n n + f_t| under ``law``): removing it changes no neighbour's force balance beyond the
    tolerance the equilibrium check allows.
    """
    found = geometry.find_contacts(positions, diameters, box)
    rattler = np.zeros(diameters.size, dtype=bool)
    counted = tangential is None or cohesion is not None  # the count rule: dry unstressed, and wet (stored forces or not)
    weighed = tangential is not None or cohesion is not None  # the force rule: stressed, and wet
    first, second = found.i, found.j
    weight = np.linalg.norm(contact_forces(found, diameters, law, tangential, cohesion), axis=1) if weighed else None
    if cohesion is not None:
        gap = wet_pairs(bridges)
        pull = np.linalg.norm(bridging.pull_forces(positions, diameters, box, gap, cohesion), axis=1)
        first, second = np.concatenate((first, gap[:, 0])), np.concatenate((second, gap[:, 1]))
        weight = np.concatenate((weight, pull))

    wall_count = wall_weight = np.zeros(rattler.size)
    if held is not None:
        wall_count = np.bincount(held[0], minlength=rattler.size)
        wall_weight = np.bincount(held[0], held[1], minlength=rattler.size)

    def per_particle(values, keep):
        return (np.bincount(first[keep], values[keep], minlength=rattler.size)
                + np.bincount(second[keep], values[keep], minlength=rattler.size))

    while True:
        keep = ~rattler[first] & ~rattler[second]
        new = ~rattler
        if counted:
            new &= per_particle(np.ones(len(first)), keep) + wall_count < min_contacts(positions.shape[1])
        if weighed:
            new &= per_particle(weight, keep) + wall_weight < EQUILIBRIUM_TOL
        if not new.any():
            return rattler
        rattler |= new


def describe(positions: np.ndarray, diameters: np.ndarray, box,
             rattler: np.ndarray, law: str = "harmonic", cohesion: capillary.Cohesion | None = None,
             bridges: np.ndarray | None = None) -> dict:
    """Energy, pressure (virial sum_c f_c r_c / (D V), V the cell's volume, f_c the net normal force),
    mean contact number z and rattler fraction of a packing under the normal ``law`` (units
    kn = d0 = 1); wet (``cohesion``), the bridges' energy and pull join them (every contact, and
    the pairs across a gap ``bridges``), and ``n_bridges`` counts the bridged pairs among
    non-rattlers (contacts and across a gap)."""
    dim = positions.shape[1]
    found = geometry.find_contacts(positions, diameters, box)
    reduced = contact_law.reduced_radius(diameters[found.i], diameters[found.j])
    fn = contact_law.normal_force(found.overlap, law, reduced)
    energy = contact_law.normal_energy(found.overlap, law, reduced)
    distance = found.distance
    active = ~rattler
    keep = active[found.i] & active[found.j]
    n_active = int(active.sum())
    wet = {}
    if cohesion is not None:
        gap = wet_pairs(bridges)
        _, gap_distance, gap_overlap = geometry.pair_geometry(positions, diameters, box, gap)
        first, second = np.concatenate((found.i, gap[:, 0])), np.concatenate((found.j, gap[:, 1]))
        xi = np.concatenate((found.overlap, gap_overlap))
        radii = 0.5 * diameters[first], 0.5 * diameters[second]
        fn = np.concatenate((fn, np.zeros(len(gap)))) - capillary.bridge_force(-xi, *radii, cohesion)
        energy = np.concatenate((energy, np.zeros(len(gap)))) + capillary.bridge_energy(-xi, *radii, cohesion)
        distance = np.concatenate((distance, gap_distance))
        wet = {"n_bridges": int((active[first] & active[second]).sum())}
    return {
        "energy": float(np.sum(energy)),
        "pressure": float(np.sum(fn * distance) / (dim * geometry.Cell.of(box, dim).volume)),
        "z": float(2.0 * keep.sum() / n_active) if n_active else 0.0,
        "rattler_fraction": float(rattler.mean()),
        "n_contacts": int(keep.sum()),
        "mean_overlap": float(found.overlap.mean()) if len(found) else 0.0,
        **wet,
    }




def net_load(packing: Packing) -> tuple[np.ndarray, np.ndarray]:
    """Net contact force (N, D) and torque (N, r) (r = 1 in 2D, 3 in 3D; units kn d0, kn d0^2) on
    every particle from the contacts among non-rattlers, under ``packing.model``: the normal forces
    of its law and the packing's stored tangential forces f_t (torques -l_i n x f_t on i, -l_j n x
    f_t on j, with the arms l of its lever, ``contact_law.lever_arms``: R for LAMMPS;
    docs/stressed_contacts.md)."""
    active = ~packing.rattler
    found = geometry.find_contacts(packing.positions, packing.diameters, packing.cell, active)
    cohesion = packing.model.cohesion
    f = contact_forces(found, packing.diameters, packing.model.law, packing.tangential, cohesion)  # eq:eij, on i
    rot = 1 if packing.dim == 2 else 3
    turn = np.zeros((len(found), rot))
    if packing.tangential is not None:  # n x f_t: the normal part of f has no torque
        turn = contact_law.cross(found.normal, f).reshape(len(found), rot)
    arm_i, arm_j = contact_law.lever_arms(0.5 * packing.diameters[found.i], 0.5 * packing.diameters[found.j],
                                          found.overlap, packing.model.lever)
    net = np.zeros((packing.n, packing.dim))
    torque = np.zeros((packing.n, rot))
    first, second = found.i, found.j
    if cohesion is not None:  # the bridges across a gap pull along their centre lines: no torque
        gap = wet_pairs(packing.bridges, active)
        f = np.concatenate((f, bridging.pull_forces(packing.positions, packing.diameters, packing.cell, gap, cohesion)))
        first, second = np.concatenate((first, gap[:, 0])), np.concatenate((second, gap[:, 1]))
    for axis in range(packing.dim):
        net[:, axis] = (np.bincount(first, f[:, axis], minlength=packing.n)
                        - np.bincount(second, f[:, axis], minlength=packing.n))
    for axis in range(rot):
        torque[:, axis] = -(np.bincount(found.i, arm_i * turn[:, axis], minlength=packing.n)
                            + np.bincount(found.j, arm_j * turn[:, axis], minlength=packing.n))
    if packing.walls is not None:  # the walls push, their stored forces turn (at the lever of model.lever)
        touch, push, turn = walling.loads(packing.positions, packing.diameters, packing.walls, packing.wall_contacts,
                                          packing.model.law, active, packing.model.lever)
        for axis in range(packing.dim):
            net[:, axis] += np.bincount(touch.particle, push[:, axis], minlength=packing.n)
        for axis in range(rot):
            torque[:, axis] += np.bincount(touch.particle, turn[:, axis], minlength=packing.n)
    if packing.gravity is not None:
        net += walling.weights(packing.masses, packing.n, packing.gravity)
    return net, torque


def with_walls(packing: Packing, walls: walling.Walls, wall_contacts: walling.WallContacts | None = None,
               gravity: np.ndarray | None = None) -> Packing:
    """``packing`` between ``walls`` (``walls.build``), with the stored tangential forces of its wall
    contacts and ``gravity`` (D,) (docs/walls.md): the axes of the walls are not periodic, the
    rattlers are found again with the wall contacts as links (:func:`find_rattlers`), and ``info``
    gains the stress tensor (:func:`stress`).  InputError under ``model.cohesion`` (no bridges to a
    wall).  Not collective."""
    import dataclasses

    if packing.model.cohesion is not None:
        raise InputError("walls with model.cohesion: capillary bridges to a wall are not modelled (docs/walls.md); "
                         "read a wet packing without walls, or a dry one with them")
    periodic = packing.cell.periodic.copy()
    periodic[walls.axis] = False
    walled = dataclasses.replace(packing, walls=walls, wall_contacts=wall_contacts, periodic=periodic,
                                 gravity=None if gravity is None else np.asarray(gravity, dtype=float))
    cell, model = walled.cell, packing.model
    touch, push, _ = walling.loads(packing.positions, packing.diameters, walls, wall_contacts, model.law)
    rattler = find_rattlers(packing.positions, packing.diameters, cell, packing.tangential, model.law,
                            model.cohesion, packing.bridges, held=(touch.particle, np.linalg.norm(push, axis=1)))
    walled = dataclasses.replace(walled, rattler=rattler)
    info = describe(packing.positions, packing.diameters, cell, rattler, model.law, model.cohesion, packing.bridges)
    return dataclasses.replace(walled, info={**packing.info, **info, **stress(walled)})


def stress(packing: Packing) -> dict:
    """The stress tensor sigma = (1/V) sum_c r_c (x) f_c over the contacts (r_c = r_i - r_j, f_c the
    force on i from j: normal, stored tangential, bridges' pull) and the wall contacts (r_c = h n, the
    centre's offset from its wall, f_c the wall's force on it), V the cell's volume between its
    walls (``walls.volume_between``); units kn d0^(1-D) (the pressure's).  Returns ``stress`` (D, D),
    ``stress_walls`` (D, D) the wall contacts' share, ``pressure`` = trace / D, and ``n_wall_contacts``."""
    found = geometry.find_contacts(packing.positions, packing.diameters, packing.cell)
    f = contact_forces(found, packing.diameters, packing.model.law, packing.tangential, packing.model.cohesion)
    volume = walling.volume_between(packing.box, packing.walls)
    inner = np.einsum("cd,ce->de", found.normal * found.distance[:, None], f) / volume
    touch, push, _ = walling.loads(packing.positions, packing.diameters, packing.walls, packing.wall_contacts,
                                   packing.model.law)
    offset = (0.5 * packing.diameters[touch.particle] - touch.overlap)[:, None] * touch.normal
    outer = np.einsum("kd,ke->de", offset, push) / volume
    total = inner + outer
    return {"stress": total, "stress_walls": outer, "pressure": float(np.trace(total) / packing.dim),
            "n_wall_contacts": len(touch)}


def net_force(packing: Packing) -> float:
    """Largest net contact force (normal, plus the stored tangential ones) on a non-rattler (kn d0),
    under ``packing.model``."""
    net, _ = net_load(packing)
    return float(np.sqrt((net[~packing.rattler] ** 2).sum(axis=1)).max())


def require_equilibrium(packing: Packing, where: str) -> None:
    """Raise InputError unless the contact forces under ``packing.model`` (its normal law and the
    lever of its stored forces) balance on every non-rattler to EQUILIBRIUM_TOL (and, for a
    stressed packing, the torques too): the matrix is built about a state at rest.
    Unstressed springs need a minimum of the normal energy; a packing made with friction fails
    that (it balances only with its tangential forces): the message names the contact file
    (``packing.contacts``) that holds them, and ``packing.relax``."""
    net, torque = net_load(packing)
    law, lever = packing.model.law, packing.model.lever
    active = ~packing.rattler
    residual = float(np.sqrt((net[active] ** 2).sum(axis=1)).max())
    twist = float(np.sqrt((torque[active] ** 2).sum(axis=1)).max())
    if packing.walls is not None or packing.gravity is not None:
        if residual > EQUILIBRIUM_TOL or twist > EQUILIBRIUM_TOL:
            raise InputError(
                f"packing file {where}: not at rest between its walls under gravity {_gravity(packing)}: the largest "
                f"net force on a non-rattler (contacts, walls and m g, under the {law} normal law) is {residual:.3e} "
                f"kn d0 and the largest net torque {twist:.3e} kn d0^2 (both must be <= {EQUILIBRIUM_TOL:g}); the walls "
                f"(packing.walls, or a LAMMPS file's f bounds), the gravity (packing.gravity) and the stored forces "
                f"(packing.contacts, packing.wall_contacts) must be those the packing came to rest under "
                f"(docs/walls.md)")
        return
    if packing.tangential is not None:
        if residual > EQUILIBRIUM_TOL or twist > EQUILIBRIUM_TOL:
            raise InputError(
                f"packing file {where}: not at rest with its stored tangential forces under the {law} normal law: the "
                f"largest net force on a non-rattler is {residual:.3e} kn d0 and the largest net torque {twist:.3e} "
                f"kn d0^2 (both must be <= {EQUILIBRIUM_TOL:g}); the contact file must be written at the same step as "
                f"the packing, from a packing at rest, with the normal law of model.law and the lever of model.lever "
                f"(= {lever}: R for LAMMPS, contact for LIGGGHTS and YADE)")
        return
    if residual > EQUILIBRIUM_TOL:
        raise InputError(
            f"packing file {where}: not in mechanical equilibrium under the {law} normal contact forces alone: the "
            f"largest net normal force on a non-rattler is {residual:.3e} kn d0 > {EQUILIBRIUM_TOL:g}. The "
            f"dynamical matrix needs a state at rest; a packing made with friction balances only with its "
            f"tangential forces: give them with packing.contacts (the contact file written with the packing: a "
            f"LAMMPS 'dump local' of patom1 patom2 and the pair's tangential force; the manual, docs/stressed_packings.md), or set "
            f"packing.relax: true to re-minimise it frictionlessly with FIRE first (this moves the particles; "
            f"one written with few digits, as YADE's 6, is off balance by its rounding and needs this too)")


def _gravity(packing: Packing) -> str:
    """The packing's gravity for messages: 'g = [..] kn d0 per unit mass' or 'none'."""
    return "none" if packing.gravity is None else f"g = {np.asarray(packing.gravity).tolist()} kn d0 per unit mass"


def jamming_failure(packing: Packing) -> str | None:
    """Why the dynamical matrix cannot be built on ``packing``, or None if it can. Not collective.

    Decision: refused when no particle is left after removing rattlers (FIRE relaxed every
    overlap to ``force_tol``: the packing did not jam; its matrix has 0 DOF and the solvers die),
    or when the N' non-rattlers share fewer than D(N' - 1) + 1 contacts (D = 2 or 3).  A rigid
    contact network in a periodic box needs D(N' - 1) contacts for its DN' DOF less the D
    translations, plus one to carry a positive pressure (the isostatic count; Goodrich, Liu &
    Nagel, PRL 109, 095704 (2012)); fewer means a floppy cluster held only by FIRE's residual
    overlaps, whose matrix has zero modes besides the D translations that the spectrum and KPM
    take as the only ones.  That count is the minimum of non-rattlers, rather than a fixed
    number: in 2D it needs at least 5 disks (4 make at most 6 < 7 contacts), in 3D at least 7
    spheres (6 make at most 15 < 16), and every 2D packing measured that jammed passes it (N = 16
    to 1024, phi = 0.83 to 0.9, 90 seeds; the smallest margin was 1 contact).  A packing with
    stored tangential forces has D + r DOF per particle (r = 1 in 2D, 3 in 3D) and D constraints
    per contact (normal and tangential springs): it needs ceil(((D + r) N' - D + 1) / D) contacts,
    z >= D + 1 for large N' (frictional isostaticity).  In a wet packing every bridged pair
    across a gap is a constraint too (a normal one, as a contact).
    """
    stats = describe(packing.positions, packing.diameters, packing.cell, packing.rattler,
                     packing.info.get("law", "harmonic"), packing.model.cohesion, packing.bridges)
    dim, name = packing.dim, NAMES[packing.dim]
    n_active = packing.n - int(packing.rattler.sum())
    if n_active == 0:
        return f"all {packing.n} {name} are rattlers (pressure {stats['pressure']:.1e})"
    if packing.tangential is not None:  # D constraints per contact on D + r DOF per particle
        per = dim + dim * (dim - 1) // 2
        needed = -(-(per * n_active - dim + 1) // dim)
        rule = f"ceil(({per}N' - {dim - 1}) / {dim})"
    else:
        needed = dim * (n_active - 1) + 1
        rule = f"{dim}N' - {dim - 1}"
    links = stats.get("n_bridges", stats["n_contacts"])  # wet: contacts and bridges across a gap
    if links < needed:
        shared = counted(links, "link") + " (contacts and bridges)" if "n_bridges" in stats else counted(links, "contact")
        return (f"only {n_active} of {packing.n} {name} are not rattlers and they share {shared}, fewer than the "
                f"{rule} = {needed} of a rigid packing (pressure {stats['pressure']:.1e})")
    return None
