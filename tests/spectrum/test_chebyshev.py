"""The Chebyshev recursion shared by the KPM vDOS, the KPM diffusivity and the packet
(solver/spectrum/chebyshev.py): its terms against T_k(B) of the dense operator, on D with the
mass scaling and on A itself; the chunked hand-over equal to the terms; its Mats freed when an
exception passes.  Every test runs on 1 and 2 ranks against rank-free references."""

import numpy as np
import pytest
from conftest import COMM, FailingProducts, assert_close, jammed_packing

from solver.contact_law import ContactModel
from solver.model import dynmat, operators
from solver.spectrum import chebyshev

TERMS = 30


@pytest.fixture
def matrix(comm):
    dm = dynmat.assemble(jammed_packing(32, 0.9, 7), ContactModel(0.5), comm)
    yield dm
    dm.destroy()


def _dense_terms(a: np.ndarray, c: float, h: float, v: np.ndarray, count: int) -> list:
    """[T_k(B) v] for k < count, B = (a - c) / h dense."""
    b = (a - c * np.eye(a.shape[0])) / h
    out = [v, b @ v]
    while len(out) < count:
        out.append(2 * b @ out[-1] - out[-2])
    return out[:count]


def test_scales_map_their_intervals_onto_minus_one_one():
    """interval_scale maps lo, hi to -1, 1; kpm_scale's interval is [-0.01, 1.01] lam_max."""
    for lo, hi in ((0.0, 7.5), (-0.2, 3.0)):
        c, h = chebyshev.interval_scale(lo, hi)
        assert_close(np.array([(lo - c) / h, (hi - c) / h]), np.array([-1.0, 1.0]), rtol=0, atol=1e-15)
    c, h = chebyshev.kpm_scale(4.0)
    assert_close(np.array([c - h, c + h]), np.array([-0.04, 4.04]), rtol=1e-15, atol=1e-15)


@pytest.mark.parametrize("scaled", [True, False], ids=["D_with_mass_scaling", "A_itself"])
def test_terms_equal_dense_chebyshev(matrix, scaled):
    """T_k(B) V (k < 30, three random columns) equals the dense recursion of B = (A - c) / h to
    1e-12 of |V| (the recurrence's round-off grows ~k^2 eps; |T_k(B)| <= 1 on [-1, 1]), whether B
    is built from D and s = M^-1/2 (kpm's) or from the assembled A (the packet's); one and two
    terms too."""
    dm = matrix
    A = operators.scaled_operator(dm)
    try:
        a = dynmat.gather_csr(A).toarray()
    finally:
        A.destroy()
    c, h = chebyshev.kpm_scale(operators.largest_omega(dm) ** 2)
    v = np.random.default_rng(5).standard_normal((dm.size, 3))
    start, stop = dm.D.getOwnershipRange()
    ref = _dense_terms(a, c, h, v, TERMS)
    for count in (1, 2, TERMS):
        A = None if scaled else operators.scaled_operator(dm)
        try:
            K, s = (dm.D, 1.0 / np.sqrt(dm.M.getArray())) if scaled else (A, None)
            with chebyshev.Recursion(K, c, h, 3, s) as recursion:
                got = [np.array(t) for t in recursion.terms(v[start:stop], count)]
        finally:
            if A is not None:
                A.destroy()
        assert len(got) == count
        for k, t in enumerate(got):
            whole = np.concatenate(COMM.allgather(t))
            assert_close(whole, ref[k], rtol=0, atol=1e-12 * np.abs(v).max(), what=f"T_{k} of {count}")


@pytest.mark.parametrize("chunk", [7, 64])
def test_chunked_hands_over_every_term_in_order(matrix, chunk):
    """chunked(v, 30, chunk) hands T_0 .. T_29 over in order, column k - k0 of each block the term
    raveled in Fortran order, bit for bit the arrays of terms (chunks of 7: a short last chunk)."""
    dm = matrix
    c, h = chebyshev.kpm_scale(operators.largest_omega(dm) ** 2)
    start, stop = dm.D.getOwnershipRange()
    v = np.asfortranarray(np.random.default_rng(6).standard_normal((dm.size, 2))[start:stop])
    s = 1.0 / np.sqrt(dm.M.getArray())
    with chebyshev.Recursion(dm.D, c, h, 2, s) as recursion:
        terms = [t.ravel(order="F").copy() for t in recursion.terms(v, TERMS)]
        handed = []
        recursion.chunked(v, TERMS, chunk, lambda k0, block: handed.append((k0, block.copy())))
    assert [k0 for k0, _ in handed] == list(range(0, TERMS, chunk))
    assert np.array_equal(np.concatenate([block for _, block in handed], axis=1), np.stack(terms, axis=1))


def test_recursion_frees_its_mats_when_an_exception_passes(matrix):
    """An error in the third product leaves neither the block nor the product alive."""
    dm = matrix
    failing = FailingProducts(dm.D, fail_at=3)
    start, stop = dm.D.getOwnershipRange()
    with pytest.raises(RuntimeError, match="injected"):
        with chebyshev.Recursion(failing, 0.0, 10.0, 2, 1.0 / np.sqrt(dm.M.getArray())) as recursion:
            for _ in recursion.terms(np.ones((stop - start, 2)), 10):
                pass
    assert len(failing.seen) >= 2 and failing.live() == 0, f"{failing.live()} Mats left alive"

