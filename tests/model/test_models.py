"""model.law and model.masses through a scene: the packing is made under the scene's normal law,
and the spectrum is that of the generalised problem D e = omega^2 M e with M from the mass rule,
both checked against references built here from the packing (1 and 2 ranks)."""

import dataclasses

import numpy as np
import scipy.linalg as sl
from conftest import COMM, assert_all, assert_close, scene_of

from solver.contact_law import ContactModel
from solver import pipeline
from solver.packing import mechanics
from solver.model import dynmat


def test_hertz_scene_with_density_masses_has_the_generalised_spectrum(shared_tmp, comm):
    """A scene with law hertz and masses density: its packing balances under Hertz forces, and its
    eigenfrequencies are those of eigh(D, M) with D the Hertz matrix (checked against central
    differences in test_dynmat.py) and M written out here from the rule: m_i = d_i^2 / mean(d^2),
    I_i = m_i d_i^2 / 8.  A scene whose law or masses did not reach the matrix or FIRE fails."""
    scene = scene_of(shared_tmp / "hertz.h5", cache="off", seed=3, packing={"n": 64, "phi": 0.9},
                     model={"rho": 0.5, "law": "hertz", "masses": "density"}, spectrum={"method": "slicing"})
    summary = pipeline.run(scene, COMM, [])
    p = pipeline.make_packings(scene, COMM)[0]
    # accepted as a file under Hertz, refused under harmonic (rattlers' contacts leave ~1e-6 on others)
    assert_all(mechanics.net_force(p) < mechanics.EQUILIBRIUM_TOL < mechanics.net_force(dataclasses.replace(p, model=ContactModel())),
               "packing not made under Hertz")
    omega = summary["units"]["spectra/r00_p0000"][0]["omega"]
    dm = dynmat.assemble(p, ContactModel(0.5, law="hertz"), comm)
    D = dynmat.gather_csr(dm.D).toarray()
    dm.destroy()
    d = p.diameters[~p.rattler]
    m = (p.diameters**2 / np.mean(p.diameters**2))[~p.rattler]
    M = np.column_stack([m, m, m * d**2 / 8]).ravel()
    lam = sl.eigh(D, np.diag(M), eigvals_only=True)
    expected = np.sqrt(lam[lam > 1e-8])
    assert_all(omega.size == expected.size, f"{omega.size} modes, expected {expected.size}")
    # both sides give lam to ~1e-13 lam_max, so omega to ~1e-13 lam_max / (2 lam): ~1e-10 at the lowest modes
    assert_close(omega, expected, rtol=1e-9, what="Hertz + density-mass spectrum")
