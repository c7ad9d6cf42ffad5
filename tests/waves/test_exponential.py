"""``waves.method: exponential`` (solver/waves/exponential.py): X(t) = exp(t J) X(0) by SLEPc's
MFN from sample to sample.  Against the eigendecomposition on symmetric matrices (2D and 3D,
every mode), against a dense exp(t J) built here on stressed, non-symmetric ones (z with the
phase of r_i(t) and of r_i(0)), within the error estimate it reports; its MFN options read back
and a wrong scale refused; on 1 and 2 ranks."""

import numpy as np
import pytest
from conftest import assert_all, assert_close, jammed_packing, with_random_stored_forces

from solver.contact_law import ContactModel
from solver.errors import InputError
from solver.model import dynmat
from solver.waves import excitation, exponential
from solver.references import dense_eigen, exact_z_fixed, first_order_flow

AMPLITUDE = 1e-3
TIMES = np.arange(0.0, 20.0 + 1e-9, 0.1)


def _packing(dim):
    return jammed_packing(64 if dim == 2 else 48, 0.9 if dim == 2 else 0.7, 7, dim)


@pytest.mark.parametrize("dim, mode", [(2, "L"), (2, "TR"), (2, "RT"), (3, "TR"), (3, "R")])
def test_exponential_equals_the_eigendecomposition(comm, dim, mode):
    """Symmetric D: z_fixed(t) = sum_j w_j cos(omega_j t) (references.exact_z_fixed, its own zero-mode
    projection) to 1e-12 |z(0)| (measured 4e-15 to 9e-15; the reported estimate, S x the MFN
    tolerance, is 1e-8: a bound, not a measurement); energy conserved to 1e-12 (measured 5e-15)."""
    p = _packing(dim)
    dm = dynmat.assemble(p, ContactModel(0.5), comm)
    k = 2 * np.pi * 2 / float(p.box[0])
    run = 0
    (series,) = exponential.exponential_all(dm, p.positions, [(mode, run, k)], amplitude=AMPLITUDE, times=TIMES,
                                            tol=1e-8)
    exact = exact_z_fixed(p, dm, dense_eigen(dm), excitation.runs(mode, dim)[run], k, TIMES, AMPLITUDE)
    dm.destroy()
    scale = np.abs(exact[0])
    assert_all(series.error_estimate <= 1e-7, f"estimate {series.error_estimate}")
    assert_close(series.z_fixed, exact, rtol=0.0, atol=1e-12 * scale, what=f"z_fixed, {dim}D {mode}")
    assert_close(series.energy, np.full(len(TIMES), series.energy[0]), rtol=1e-12, atol=0.0, what="energy")


@pytest.mark.parametrize("dim", [2, 3])
def test_exponential_on_a_stressed_matrix_equals_dense_expm(comm, dim):
    """Non-symmetric D (stored forces 3 f_n: |D - D^T| / |D| about 0.1, complex pairs): z with the
    phase of r_i(t) and z_fixed against dense exp(t J) to 1e-12 of max |z| (measured 3e-15)."""
    p = with_random_stored_forces(_packing(dim), 11, ratio=3.0)
    dm = dynmat.assemble(p, ContactModel(0.8), comm)
    d = dynmat.gather_csr(dm.D).toarray()
    mode, run = "TR", 1
    component, axis = excitation.runs(mode, dim)[run]
    k = 2 * np.pi / float(p.box[axis])
    mpi = comm.tompi4py()
    (series,) = exponential.exponential_all(dm, p.positions, [(mode, run, k)], amplitude=AMPLITUDE, times=TIMES,
                                            tol=1e-8)
    start = excitation.start_velocity(dm, p.positions, component, axis, k, AMPLITUDE, mpi)
    whole = np.concatenate(comm.tompi4py().allgather(start))  # every rank's part, the matrix's order
    flow = first_order_flow(dm, whole, TIMES[1] - TIMES[0], len(TIMES), order="matrix")
    dm.destroy()
    assert_all(np.abs(d - d.T).max() > 1e-2 * np.abs(d).max(), "the premise: D is far from symmetric")
    r0 = p.positions[~p.rattler]
    u, v = flow[:, 0], flow[:, 1]
    z_fixed = v[:, :, component] @ np.exp(-1j * k * r0[:, axis])
    z = np.sum(v[:, :, component] * np.exp(-1j * k * (r0[None, :, axis] + u[:, :, axis])), axis=1)
    scale = np.abs(z_fixed).max()
    assert_close(series.z_fixed, z_fixed, rtol=0.0, atol=1e-12 * scale, what=f"z_fixed, {dim}D")
    assert_close(series.z, z, rtol=0.0, atol=1e-12 * scale, what=f"z with r_i(t), {dim}D")


def test_mfn_options_are_read_back_and_a_wrong_scale_is_refused(comm, packing64):
    """-waves_mfn_tol is what the MFN uses (and the estimate follows it); -waves_fn_scale cannot
    change the sample spacing."""
    from petsc4py import PETSc

    dm = dynmat.assemble(packing64, ContactModel(1.0), comm)
    k = 2 * np.pi / packing64.box_length
    options = PETSc.Options()
    try:
        options.setValue("waves_mfn_tol", "1e-12")
        (series,) = exponential.exponential_all(dm, packing64.positions, [("L", 0, k)], amplitude=AMPLITUDE,
                                                times=TIMES[:11], tol=1e-8)
        settings = series.settings
        assert_all(settings["mfn_tol"] == 1e-12 and settings["prefix"] == "waves_" and settings["mfn_ncv"] > 0
                   and series.error_estimate == 11 * 1e-12, str(settings))
        options.setValue("waves_fn_scale", "2.0")
        with pytest.raises(InputError, match="-waves_fn_scale"):
            exponential.exponential_all(dm, packing64.positions, [("L", 0, k)], amplitude=AMPLITUDE,
                                        times=TIMES[:11], tol=1e-8)
    finally:
        options.delValue("waves_mfn_tol")
        options.delValue("waves_fn_scale")
        dm.destroy()
