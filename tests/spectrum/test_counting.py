"""The exact vDOS by counting (``spectrum.counting``): Sylvester inertias at the bin edges.

Oracles: dense ``eigvalsh`` histograms (the counts must be equal, integer for integer), fresh
factorisations at every shift (``slicing.count_below``) against the reused one, and the slicing
scene's pooled vDOS through the pipeline.  Runs on 1 and 2 ranks (edges spread over the ranks).
"""

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close, scene_of

from solver.contact_law import ContactModel
from solver import pipeline
from solver.model import dynmat, operators
from solver.spectrum import counting, slicing

BIN = 0.05


def dense_eigenvalues(dm) -> np.ndarray:
    """Every eigenvalue of A = M^-1/2 D M^-1/2 by LAPACK (the exact reference). Collective."""
    A = operators.scaled_operator(dm)
    try:
        return np.linalg.eigvalsh(dynmat.gather_csr(A).toarray())
    finally:
        A.destroy()


@pytest.mark.parametrize("rho", [0.0, 0.5, 2.0])
def test_counts_equal_dense_eigenvalue_histogram(comm, small_packing, rho):
    dm = dynmat.assemble(small_packing, ContactModel(rho), comm)
    try:
        datasets, attrs, settings = counting.solve(dm, bin_width=BIN, zero_tol=1e-4)
        lam = dense_eigenvalues(dm)
    finally:
        dm.destroy()
    zero = np.abs(lam) < 1e-8
    expected, _ = np.histogram(np.sqrt(lam[~zero]), datasets["edges"])
    assert_all(np.array_equal(datasets["counts"], expected),
               f"counts differ from eigvalsh in bins {np.nonzero(datasets['counts'] != expected)[0]}")
    assert_all(attrs["n_zero_modes"] == zero.sum() == 2 and attrs["n_negative_modes"] == 0, str(attrs))
    assert_all(datasets["edges"][-1] > np.sqrt(lam.max()), "the last edge must lie above every mode")
    assert_close(attrs["omega_max"], np.sqrt(lam.max()), rtol=1e-8, what="omega_max (Lanczos tol 1e-8)")
    assert_all(settings["inertia"]["factor_package"] == "mumps", str(settings))


def test_reused_factorisation_counts_like_fresh_ones(comm, small_packing):
    """Shifts out of order, so every refactorisation starts from another shift's values."""
    dm = dynmat.assemble(small_packing, ContactModel(1.0), comm)
    A = operators.scaled_operator(dm)
    try:
        top = operators.largest_omega(dm) ** 2
        shifts = top * np.array([0.6, 0.05, 0.3, 1e-9, 0.95, 0.15, 0.1, 0.8])
        got, _ = counting.counts_below(A, shifts, COMM)
        fresh = [slicing.count_below(A, float(s)) for s in shifts]
    finally:
        A.destroy()
        dm.destroy()
    assert_all(list(got) == fresh, f"{list(got)} != {fresh}")
    assert_all(len(set(fresh)) == len(fresh), f"the shifts must tell the counts apart: {fresh}")


def test_counting_scene_vdos_equals_the_slicing_histogram(shared_tmp):
    units = {m: pipeline.run(scene_of(shared_tmp / f"{m}.h5", cache="off", seed=4,
                                      packing={"n": 64, "phi": 0.9, "count": 2}, model={"rho": [0.0, 1.0]},
                                      spectrum={"method": m}), COMM, [])["units"] for m in ("counting", "slicing")}
    for r in ("r00", "r01"):
        (c, ca), (s, sa) = units["counting"][f"vdos/{r}"], units["slicing"][f"vdos/{r}"]
        m = min(c["density"].size, s["density"].size)
        assert_close(c["density"][:m], s["density"][:m], rtol=1e-12, what=f"vdos {r}")
        assert_all(not c["density"][m:].any() and not s["density"][m:].any(), "empty tail bins")
        assert_close(ca["omega_c"], sa["omega_c"], rtol=1e-8, what="omega_c (Lanczos tol 1e-8)")
        for p in ("p0000", "p0001"):
            cd, cattrs = units["counting"][f"spectra/{r}_{p}"]
            sd, sattrs = units["slicing"][f"spectra/{r}_{p}"]
            assert_all(cd["counts"].sum() == sd["omega"].size and
                       cattrs["n_zero_modes"] == sattrs["n_zero_modes"], f"{r}_{p}")


def test_low_top_estimate_extends_the_bins(comm, small_packing, monkeypatch):
    """A Lanczos omega_max that falls short (forced here to half the true value) must not lose the
    modes above it: more bins are counted up to the Gershgorin bound, and the counts still equal
    eigvalsh's histogram."""
    dm = dynmat.assemble(small_packing, ContactModel(1.0), comm)
    try:
        true_top = operators.largest_omega(dm)
        monkeypatch.setattr(counting, "largest_omega", lambda _: 0.5 * true_top)
        datasets, attrs, _ = counting.solve(dm, bin_width=BIN, zero_tol=1e-4)
        lam = dense_eigenvalues(dm)
    finally:
        dm.destroy()
    expected, _ = np.histogram(np.sqrt(lam[np.abs(lam) >= 1e-8]), datasets["edges"])
    assert_all(datasets["edges"][-1] > true_top, "bins must reach past the true omega_max")
    assert_all(np.array_equal(datasets["counts"], expected), "counts differ from eigvalsh")
