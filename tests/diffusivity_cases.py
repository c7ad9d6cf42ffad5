"""The packings the diffusivity's three routes are tested on (tests/transport): 32 disks with
tangential springs, and 32 spheres with rolling and twisting springs; the ``case`` fixture gives
(name, packing, assembled matrix) for each, on the suite's communicator (1 or 2 ranks)."""

import pytest
from conftest import jammed_packing

from solver.contact_law import ContactModel
from solver.model import dynmat

CASES = {  # name: (packing, contact model)
    "2d": (lambda: jammed_packing(32, 0.9, 7), ContactModel(0.5)),
    "3d_rolling": (lambda: jammed_packing(32, 0.68, 5, dim=3), ContactModel(0.5, rho_roll=0.2, rho_twist=0.1)),
}


@pytest.fixture(params=sorted(CASES))
def case(request, comm):
    """(name, packing, matrix) of each of CASES; the matrix destroyed after the test."""
    make, model = CASES[request.param]
    p = make()
    dm = dynmat.assemble(p, model, comm)
    yield request.param, p, dm
    dm.destroy()
