"""A packing with negative modes: an unstable equilibrium is counted (n_negative_modes, apart from
the zero modes) and warned about, and the counts equal those of a dense eigh.

The packing: equal disks (d = 1) on a compressed rectangular lattice, n_x = 7 columns and n_y = 6
rows in the square box L (spacings a_x = L / 7 < a_y = L / 6 < d < sqrt(a_x^2 + a_y^2): 4 contacts
each), in equilibrium by inversion symmetry.  At rho = 0 the geometric term of the normal force,
-f_n / r t t^T, is the only stiffness of a bond across it, so with g = f_n / r of the bonds along
x (g_x) and y (g_y) the Bloch matrix is diagonal:
    omega_x^2 = 2 (1 - cos k_x a_x) - 2 g_y (1 - cos k_y a_y),
    omega_y^2 = 2 (1 - cos k_y a_y) - 2 g_x (1 - cos k_x a_x),
negative for the transverse waves along a row or a column (k_x = 0 < k_y, or k_y = 0 < k_x, and
no other k here): (n_x - 1) + (n_y - 1) = 11 negative modes, 2 zero modes (translations).
(Not a square lattice: its eigenvalues of multiplicity 8 make today's 2-rank slicing cut a
sub-interval on an eigenvalue and fail, a separate defect.)
"""

import h5py
import numpy as np
from conftest import COMM, assert_all, assert_close, scene_of

from solver.contact_law import ContactModel
from solver import pipeline
from solver.io import hdf5
from solver.model import dynmat
from solver.packing import jammed
from solver.packing import mechanics
from solver.references import dense_eigenvalues
from solver.spectrum import slicing

N_X, N_Y = 7, 6
BOX = N_X * 0.85   # a_x = 0.85 (overlap 0.15 d0), a_y = 0.9917 (overlap 0.008 d0), diagonal 1.31
N_NEGATIVE = (N_X - 1) + (N_Y - 1)
ZERO_TOL = 1e-4


def rectangular_lattice():
    i, j = np.meshgrid(np.arange(N_X), np.arange(N_Y), indexing="xy")
    positions = np.stack((i.ravel() * BOX / N_X, j.ravel() * BOX / N_Y), axis=1)
    return jammed.from_arrays(positions, np.ones(N_X * N_Y), BOX)


def dense_counts(dm):
    """(negative, zero, positive omega) of the gathered A = M^-1/2 D M^-1/2 by dense eigh."""
    lam = dense_eigenvalues(dm)
    cut = ZERO_TOL**2
    return int(np.sum(lam < -cut)), int(np.sum(np.abs(lam) <= cut)), np.sqrt(lam[lam > cut])


def test_compressed_rectangular_lattice_counts_negative_modes_like_dense_eigh(comm):
    p = rectangular_lattice()
    assert not p.rattler.any() and mechanics.net_force(p) < 1e-14, "an equilibrium without rattlers"
    assert np.hypot(*(BOX / np.array([N_X, N_Y]))) > 1.0 > BOX / N_Y, "4 contacts per disk"
    dm = dynmat.assemble(p, ContactModel(0.0), comm)
    negative, zero, omega = dense_counts(dm)
    assert_all(negative == N_NEGATIVE and zero == 2, f"dense eigh: {negative} negative, {zero} zero")
    result = slicing.solve(dm, window=None, vectors=False, zero_tol=ZERO_TOL)
    assert_all(result.n_negative == negative, f"negative modes {result.n_negative}, dense {negative}")
    assert_all(result.n_zero_modes == zero, f"zero modes {result.n_zero_modes}, dense {zero}")
    assert_close(result.omega, omega, rtol=1e-10, what="positive modes")
    window = slicing.solve(dm, window=(0.0, 10.0), vectors=False, zero_tol=ZERO_TOL)
    assert_all(window.n_negative == negative and window.n_zero_modes == zero,
               f"window: {window.n_negative} negative, {window.n_zero_modes} zero")
    dm.destroy()


def test_pipeline_records_and_warns_about_negative_modes(comm, shared_tmp, capsys):
    packing_file = shared_tmp / "lattice.h5"
    if COMM.rank == 0:
        hdf5.save_packings(str(packing_file), [rectangular_lattice()])
    COMM.Barrier()
    scene = scene_of(shared_tmp / "lattice_out.h5", cache="off", packing={"file": str(packing_file)},
                     model={"rho": [0.0]}, spectrum={})
    units = pipeline.run(scene, COMM, [])["units"]
    out = capsys.readouterr().out
    attrs = units["spectra/r00_p0000"][1]
    n_negative = N_NEGATIVE
    assert_all(attrs["n_negative_modes"] == n_negative and attrs["n_zero_modes"] == 2, f"unit attributes {attrs}")
    with h5py.File(shared_tmp / "lattice_out.h5", "r") as f:
        stored = dict(f["spectra/r00_p0000"].attrs)
    assert_all(stored["n_negative_modes"] == n_negative and stored["n_zero_modes"] == 2, f"file {stored}")
    warning = f"rotsound: warning: {n_negative} modes with omega^2 < -zero_tol^2"
    assert_all(COMM.rank != 0 or warning in out, f"no warning on rank 0:\n{out}")  # rank 0 prints
