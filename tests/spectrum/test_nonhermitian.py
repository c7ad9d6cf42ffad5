"""``spectrum.method: nonhermitian`` (solver/spectrum/nonhermitian.py): every eigenvalue of a
matrix that need not be symmetric.  On a symmetric matrix it gives slicing's spectrum; on a
stressed one, the generalized eigenvalues of (D, M) from an independent dense solve; 1 and 2
ranks agree; a scene on a LAMMPS frictional packing gives its vDOS and its unstable-mode count."""

import numpy as np
import pytest
import scipy.linalg as sl
from conftest import COMM, REPO, assert_all, assert_close, jammed_packing, scene_of, with_random_stored_forces

from solver import pipeline
from solver.errors import InputError
from solver.contact_law import ContactModel
from solver.model import dynmat
from solver.spectrum import nonhermitian, slicing

DATA = REPO / "tests" / "data" / "dem"


def test_on_a_symmetric_matrix_it_is_slicings_spectrum(comm):
    p = jammed_packing(32, 0.9, 3)
    dm = dynmat.assemble(p, ContactModel(0.5), comm)
    dense = nonhermitian.solve(dm, zero_tol=1e-4)
    sliced = slicing.solve(dm, window=None, vectors=False, tol=1e-12, zero_tol=1e-4)
    dm.destroy()
    assert_all(dense.n_complex == 0 and dense.n_negative == 0 and dense.n_zero_modes == sliced.n_zero_modes)
    # both exact to round-off of omega_max^2 ~ 10: relative 1e-10 of the frequencies
    assert_close(dense.omega, sliced.omega, rtol=1e-10, atol=1e-10, what="nonhermitian vs slicing omega")


@pytest.mark.parametrize("dim", [2, 3])
def test_on_a_stressed_matrix_it_is_the_generalized_eigenproblem(comm, dim):
    """lambda of M^-1/2 D M^-1/2 against scipy's generalized eig of (D, diag M) (QZ, another
    algorithm on another form), with stored forces large enough (|f_t| = 3 f_n, not in
    equilibrium) that some eigenvalues turn complex: the classification is checked too."""
    p = with_random_stored_forces(jammed_packing(32 if dim == 2 else 48, 0.9 if dim == 2 else 0.7, 3, dim), 11,
                                  ratio=3.0)
    dm = dynmat.assemble(p, ContactModel(0.8), comm)
    result = nonhermitian.solve(dm, zero_tol=1e-4)
    d = dynmat.gather_csr(dm.D).toarray()
    m = dynmat.gather_vec(dm.M)
    dm.destroy()
    reference = sl.eig(d, np.diag(m), right=False)
    reference = reference[np.abs(reference) >= 1e-8]
    reference = reference[np.argsort(reference.real)]
    assert_all(result.omega2.size == reference.size, f"{result.omega2.size} vs {reference.size} eigenvalues")
    scale = np.abs(reference).max()
    # pairs of conjugates sort by real part in either order: compare the sorted real parts, then |Im|
    assert_close(result.omega2.real, reference.real, rtol=0.0, atol=1e-10 * scale, what="Re lambda")
    assert_close(np.sort(np.abs(result.omega2.imag)), np.sort(np.abs(reference.imag)), rtol=0.0,
                 atol=1e-10 * scale, what="|Im lambda|")
    complex_ = np.abs(reference.imag) > 1e-9 * scale
    assert_all(result.n_complex == int(complex_.sum()) and result.n_complex > 0,
               f"{result.n_complex} complex eigenvalues, the reference has {complex_.sum()}")
    assert_all(result.omega.size + result.n_complex + result.n_negative == reference.size)


def test_a_scene_on_a_lammps_frictional_packing_gives_its_vdos(shared_tmp):
    """The 2D frictional LAMMPS packing with its contact file: every mode found (3 DOF x 120
    non-rattlers less the 2 translations), its vDOS, and its unstable modes counted."""
    scene = scene_of(shared_tmp / "stressed.h5", cache="off",
                     packing={"file": str(DATA / "lammps_2d_friction.data"),
                              "contacts": str(DATA / "lammps_2d_friction.contacts"), "friction": 1.0},
                     model={"rho": 2 / 7}, spectrum={"method": "nonhermitian", "energies": True})
    units = pipeline.run(scene, COMM, [])["units"]
    datasets, attrs = units["spectra/r00_p0000"]
    assert_all(attrs["symmetric"] == 0 and attrs["n_zero_modes"] == 2, str(attrs))
    total = datasets["omega"].size + attrs["n_complex"] + attrs["n_negative_modes"] + attrs["n_zero_modes"]
    assert_all(total == 3 * 120, f"{total} modes for 120 disks")
    assert_all(all(datasets[name].shape == datasets["omega"].shape for name in ("Kx", "Ky", "Q", "K", "participation")))
    edges, density = units["vdos/r00"][0]["edges"], units["vdos/r00"][0]["density"]
    assert_close(np.sum(density * np.diff(edges)), 1.0, rtol=1e-12, what="vDOS area")


def test_dropping_the_stored_forces_allows_the_symmetric_methods(shared_tmp):
    """The same LAMMPS packing with model.stored_forces: drop counts its unstressed spectrum: as
    many modes as the stressed one has eigenvalues."""
    scene = scene_of(shared_tmp / "dropped.h5", cache="off",
                     packing={"file": str(DATA / "lammps_2d_friction.data"),
                              "contacts": str(DATA / "lammps_2d_friction.contacts")},
                     model={"rho": 2 / 7, "stored_forces": "drop"}, spectrum={"method": "counting"})
    datasets, attrs = pipeline.run(scene, COMM, [])["units"]["spectra/r00_p0000"]
    assert_all(int(datasets["counts"].sum()) + attrs["n_zero_modes"] == 3 * 120 and attrs["n_negative_modes"] == 0)


def test_energies_on_a_symmetric_matrix_are_slicings(comm):
    """K, Q and participation of each mode from LAPACK's right eigenvectors equal slicing's (a
    disordered packing has no degenerate non-zero modes, so each mode's vector is unique up to
    sign): to 1e-7 of their scale 1/(2N), the participation to 1e-6 relative (slicing's Krylov
    vectors carry its residual over the modes' gaps: measured 3e-11 and 1.3e-10 on 1 rank,
    3.6e-8 and 5.0e-8 on 2)."""
    p = jammed_packing(32, 0.9, 3)
    dm = dynmat.assemble(p, ContactModel(0.5), comm)
    dense = nonhermitian.solve(dm, zero_tol=1e-4, vectors=True)
    sliced = slicing.solve(dm, window=None, vectors=True, tol=1e-12, zero_tol=1e-4)
    n = int(dm.active.sum())
    dm.destroy()
    for name in ("Kx", "Ky", "Q", "K"):
        assert_close(dense.energies[name], sliced.energies[name], rtol=0.0, atol=1e-7 / (2 * n), what=name)
    assert_close(dense.energies["participation"], sliced.energies["participation"], rtol=1e-6, what="participation")


def test_a_scene_on_a_yade_frictional_packing_gives_its_spectrum(shared_tmp):
    """The 3D frictional YADE packing with its contact file, read with YADE's lever and history
    (a non-symmetric D even where stored forces would vanish): every mode of its 122 non-rattlers
    is accounted for (6 DOF each; 8 zero modes: the 3 translations and one for each of the 5
    spheres on 2 contacts, which the unstressed matrix lifts to 2e-4 to 2e-3), and a symmetric
    method is refused."""
    yade = {"file": str(DATA / "yade_3d_friction_uniform.spheres"),
            "contacts": str(DATA / "yade_3d_friction_uniform.contacts"), "contacts_format": "yade", "friction": 0.5}
    model = {"rho": 2 / 7, "lever": "contact", "history": "yade"}
    scene = scene_of(shared_tmp / "yade.h5", cache="off", packing=yade, model=model,
                     spectrum={"method": "nonhermitian"})
    datasets, attrs = pipeline.run(scene, COMM, [])["units"]["spectra/r00_p0000"]
    total = datasets["omega"].size + attrs["n_complex"] + attrs["n_negative_modes"] + attrs["n_zero_modes"]
    assert_all(attrs["symmetric"] == 0 and attrs["n_zero_modes"] == 8 and total == 6 * 122, str(attrs))
    with pytest.raises(InputError, match="model.history: yade takes YADE's tangential slip"):
        scene_of(shared_tmp / "yade_counted.h5", cache="off", packing={"n": 64, "phi": 0.7, "dim": 3},
                 model=model, spectrum={"method": "counting"})


def test_auto_picks_nonhermitian_on_a_stressed_packing_and_says_so(shared_tmp, capsys):
    """``spectrum: {}`` on the 2D frictional LAMMPS packing with its contact file: method auto becomes
    nonhermitian, the log says which and why, and the results file's scene and unit say it; its TS
    waves' log says that E is not conserved on this matrix.  The packing read back from that results
    file (its ``tangential`` group, no contact file: stressed only once read) gets nonhermitian
    too, the same eigenvalues (the same matrix: measured equal; held to 1e-12 of the largest),
    and a rerun resumes every unit (the store's digest is the one the results file records)."""
    import h5py

    def run(scene):
        capsys.readouterr()
        units = pipeline.run(scene, COMM, [])["units"]
        return units, COMM.bcast(capsys.readouterr().out, root=0)

    said = ("spectrum.method auto -> nonhermitian (configuration(s) 0 carry stored tangential forces, so the "
            "matrix is not symmetric)")
    first = shared_tmp / "auto.h5"
    units, log = run(scene_of(first, cache="off", model={"rho": 2 / 7}, spectrum={},
                              packing={"file": str(DATA / "lammps_2d_friction.data"),
                                       "contacts": str(DATA / "lammps_2d_friction.contacts"), "friction": 1.0},
                              waves={"modes": ["L"], "n": [1], "t_end": 2.0}))
    with h5py.File(first, "r") as f:
        stored = f.attrs["scene"]
    assert_all(said in log and "method: nonhermitian" in stored and units["spectra/r00_p0000"][1]["method"] ==
               "nonhermitian", log)
    assert_all("(not conserved: the matrix is not symmetric)" in log and "drift" not in log, log)
    again = scene_of(shared_tmp / "read_back.h5", cache="off", model={"rho": 2 / 7}, spectrum={},
                     packing={"file": str(first)})
    read_back, log = run(again)
    omega = units["spectra/r00_p0000"][0]["omega"]
    assert_all(said in log, log)
    assert_close(read_back["spectra/r00_p0000"][0]["omega"], omega, rtol=0.0, atol=1e-12 * omega.max(),
                 what="omega read back")
    _, log = run(again)
    assert_all("matrices 1 resumed; spectra 1 resumed" in log, log)
