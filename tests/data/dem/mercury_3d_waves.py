"""Writes mercury_3d_waves.start: the start of one standing wave about MercuryDPM's frictional
packing (mercury_3d_friction.data and .fstat), rotsound's own (solver.waves.excitation.whole_start:
TR, its first run, k = 2 pi / L, amplitude AMPLITUDE in d0/t0), in MercuryDPM's units, one line
"vx vy vz wx wy wz" per particle in MercuryDPM's index order (rattlers at rest), for the driver
mercury_3d_waves.cpp.  Run from the repository root:

    PYTHONPATH=. .venv/bin/python tests/data/dem/mercury_3d_waves.py

rotsound's units: d0 = the mean diameter (1), kn = 1 (the driver's k), m0 = the mean mass
(MercuryDPM's m = d^3 at density 6/pi: m0 = mean(d^3) = 1.12), t0 = sqrt(m0 / kn); a velocity is
v d0 / t0 there, an angular velocity w / t0."""

import pathlib

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from solver.contact_law import ContactModel
from solver.io import hdf5
from solver.model import dynmat
from solver.waves import excitation

HERE = pathlib.Path(__file__).resolve().parent
AMPLITUDE = 1e-7
MODEL = ContactModel(2.0 / 7.0, lever="contact")  # kt / kn of the driver; MercuryDPM's contact point


def start_in_mercury_units(amplitude: float) -> np.ndarray:
    """(N, 6) velocities and angular velocities of the start, in MercuryDPM's units."""
    p = hdf5.read_packings(str(HERE / "mercury_3d_friction.data"), contacts=str(HERE / "mercury_3d_friction.fstat"),
                           contacts_format="mercury-fstat", model=ContactModel(lever="contact"), friction=0.5)[0]
    dm = dynmat.assemble(p, MODEL, PETSc.COMM_SELF, mass_rule="density")
    try:
        component, axis = excitation.runs("TR", 3)[0]
        start = excitation.whole_start(dm, p.positions, component, axis, 2 * np.pi / p.box[axis], amplitude,
                                       MPI.COMM_SELF)
    finally:
        dm.destroy()
    d0 = p.info["length_unit"]
    t0 = np.sqrt(np.mean((p.diameters * d0) ** 3))
    whole = np.zeros((p.n, 6))
    whole[~p.rattler] = start
    whole[:, :3] *= d0 / t0
    whole[:, 3:] /= t0
    return whole


if __name__ == "__main__":
    np.savetxt(HERE / "mercury_3d_waves.start", start_in_mercury_units(AMPLITUDE), fmt="%.17g")
