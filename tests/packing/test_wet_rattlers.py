"""The wet rattler rule as docs/capillary_bridges.md states it, whatever the reader built: a wet
particle is a rattler when it has fewer than D + 1 links among non-rattlers *and* they carry less
than EQUILIBRIUM_TOL.  A contact file's reader always builds a tangential-force object, even with
every stored force zero (issue 62): that object must not switch the count off."""

import numpy as np
import pytest
from scipy.optimize import brentq

from solver.capillary import Cohesion, bridge_force
from solver.packing import geometry, mechanics
from solver.packing.stressed import TangentialForces

pytestmark = pytest.mark.serial_only  # arrays only, no communicator: nothing to gain from a second rank

COHESION = Cohesion("willett", surface_tension=0.01, contact_angle=0.2, volume=1e-3)


def _balanced_square_lattice(n: int = 5):
    """Equal disks (d = 1) on an n x n periodic square lattice, each touching its 4 neighbours at
    the overlap where the harmonic spring (kn = 1) exactly balances the bridge's pull: every
    contact carries zero net force, every particle has 4 >= D + 1 links."""
    overlap = brentq(lambda d: d - bridge_force(np.array([-d]), np.array([0.5]), np.array([0.5]), COHESION)[0],
                     1e-12, 0.5)
    spacing = 1.0 - overlap
    sites = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), axis=-1).reshape(-1, 2)
    return spacing * sites.astype(float), np.ones(n * n), n * spacing, overlap


def test_a_well_linked_wet_particle_with_cancelling_forces_is_no_rattler_with_zero_stored_forces():
    positions, diameters, box, overlap = _balanced_square_lattice()
    found = geometry.find_contacts(positions, diameters, box)
    assert np.all(found.count_per_particle(diameters.size) == 4)  # the construction: 4 links each
    net = mechanics.contact_forces(found, diameters, "harmonic", None, COHESION)
    assert np.max(np.abs(net)) < 1e-12 * overlap  # and no net force in any of them
    pairs = np.stack((found.i, found.j), axis=1)
    zero_stored = TangentialForces(pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))], np.zeros((len(pairs), 2)))
    for tangential in (None, zero_stored):  # as a generated packing has it, as a contact file's reader builds it
        rattler = mechanics.find_rattlers(positions, diameters, box, tangential, cohesion=COHESION,
                                          bridges=np.zeros((0, 2), dtype=np.int64))
        assert not rattler.any(), f"tangential={type(tangential).__name__}: {rattler.sum()} rattlers"


def test_a_wet_particle_on_too_few_unloaded_links_is_a_rattler_with_zero_stored_forces():
    """The rule's other half: a particle removed from three of its four neighbours keeps one
    unloaded link, fewer than D + 1, and is cut under either tangential object."""
    positions, diameters, box, _ = _balanced_square_lattice()
    keep = np.ones(diameters.size, dtype=bool)
    keep[[1, 5, 6]] = False  # site 0's neighbours (0,1), (1,0) and the diagonal; (4,0) and (0,4) remain
    keep[[4]] = False  # leaving site 0 with one link, to (4, 0) = index 20
    positions, diameters = positions[keep], diameters[keep]
    found = geometry.find_contacts(positions, diameters, box)
    assert found.count_per_particle(diameters.size)[0] == 1
    pairs = np.stack((found.i, found.j), axis=1)
    zero_stored = TangentialForces(pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))], np.zeros((len(pairs), 2)))
    for tangential in (None, zero_stored):
        rattler = mechanics.find_rattlers(positions, diameters, box, tangential, cohesion=COHESION,
                                          bridges=np.zeros((0, 2), dtype=np.int64))
        assert rattler[0], f"tangential={type(tangential).__name__}"
