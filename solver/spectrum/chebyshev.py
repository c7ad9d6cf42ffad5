"""The Chebyshev recursion of the scaled operator on blocks of vectors: the one engine behind the
KPM vDOS (``kpm.moments``), the KPM diffusivity's bin filters (``transport.kpm_diffusivity``) and
the packet's exact propagation (``transport.packet``).

B = (s K s - c) / h with K a symmetric PETSc Mat (the dynamical matrix D with s = M^-1/2, or
A = M^-1/2 D M^-1/2 itself with s = 1) maps the interval [c - h, c + h] holding K's spectrum onto
[-1, 1]; T_0 V = V, T_1 V = B V, T_k+1 V = 2 B T_k V - T_k-1 V for a block V (nloc, p) of this
rank's rows on K's layout.  One MatMatMult per step, its symbolic product made once and reused.
(The damped waves' series, ``waves.chebyshev``, is a different recursion: on the first-order
system, not a symmetric operator.)  Collective on K's communicator.
"""

from __future__ import annotations

import numpy as np

KPM_MARGIN = 0.01
"""KPM's interval [-KPM_MARGIN, 1 + KPM_MARGIN] lambda_max: Jackson's kernel keeps the expansion
inside it, and the Lanczos lambda_max (a lower bound) is inside it with room to spare."""


def interval_scale(lo: float, hi: float) -> tuple[float, float]:
    """(c, h): B = (A - c) / h maps lambda in [lo, hi] onto [-1, 1]. Not collective."""
    return 0.5 * (hi + lo), 0.5 * (hi - lo)


def kpm_scale(lam_max: float) -> tuple[float, float]:
    """(c, h) of the KPM interval [-0.01, 1.01] ``lam_max`` (:data:`KPM_MARGIN`), 1/t0^2. Not collective."""
    return interval_scale(-KPM_MARGIN * lam_max, (1.0 + KPM_MARGIN) * lam_max)


def dense_block(K, local: np.ndarray):
    """A PETSc dense Mat sharing ``local`` (nloc, k) (Fortran order), its rows laid out as K's
    rows, on K's communicator: the caller destroys it.  Collective."""
    from petsc4py import PETSc

    mat = PETSc.Mat().createDense(((local.shape[0], K.getSize()[0]), (PETSc.DECIDE, local.shape[1])), array=local,
                                  comm=K.getComm())
    mat.assemble()
    return mat


class Recursion:
    """T_k(B) V for blocks V (nloc, ``columns``), B = (s K s - c) / h (module docstring); ``s``
    (nloc,) this rank's diagonal, None for 1.  Owns two dense Mats (the block K multiplies and the
    product): use it as a context manager (``with Recursion(...) as rec``), which frees them on
    leaving, an exception included.  Memory: 2 blocks here, 3 more in :meth:`terms`.  Collective."""

    def __init__(self, K, c: float, h: float, columns: int, s: np.ndarray | None = None):
        self.K, self.c, self.h = K, c, h
        self.s = None if s is None else np.asarray(s, dtype=float).reshape(-1, 1)
        self.X = dense_block(K, np.zeros((K.getLocalSize()[0], columns), order="F"))
        self.x = self.X.getDenseArray()
        self.Y = None

    def __enter__(self) -> Recursion:
        return self

    def __exit__(self, *exc) -> None:
        self.destroy()

    def destroy(self) -> None:
        """Free the PETSc Mats (idempotent). Collective."""
        self.X.destroy()
        if self.Y is not None:
            self.Y.destroy()
            self.Y = None

    def apply(self, v: np.ndarray, out: np.ndarray) -> np.ndarray:
        """out = B v for a block v (nloc, columns), in place; returns ``out``."""
        if self.s is None:
            self.x[...] = v
        else:
            np.multiply(self.s, v, out=self.x)
        self.Y = self.K.matMult(self.X) if self.Y is None else self.K.matMult(self.X, self.Y)
        if self.s is None:
            out[...] = self.Y.getDenseArray(readonly=True)
        else:
            np.multiply(self.s, self.Y.getDenseArray(readonly=True), out=out)
        out -= self.c * v
        out /= self.h
        return out

    def terms(self, v: np.ndarray, n_terms: int, *, overwrite: bool = False):
        """Yield T_k(B) v (nloc, columns) for k = 0 .. ``n_terms`` - 1 (n_terms - 1 products).  The
        arrays are reused: T_k stays intact until T_k+2 has been yielded (so T_k-1 may be read
        beside T_k), and must not be written.  ``overwrite``: use ``v`` (Fortran-ordered float64)
        as T_0 and later as work space, saving a block.  Every rank must draw the same terms."""
        t_prev = v if overwrite else np.array(v, dtype=float, order="F")
        yield t_prev
        if n_terms < 2:
            return
        t_curr = self.apply(t_prev, np.empty_like(t_prev, order="F"))
        yield t_curr
        spare = np.empty_like(t_prev, order="F")
        for _ in range(2, n_terms):
            t_next = self.apply(t_curr, spare)
            t_next *= 2.0
            t_next -= t_prev
            yield t_next
            t_prev, t_curr, spare = t_curr, t_next, t_prev

    def chunked(self, v: np.ndarray, n_terms: int, chunk: int, flush) -> None:
        """Hand the terms T_k(B) v, k = 0 .. ``n_terms`` - 1, to ``flush(k0, block)`` ``chunk`` at a
        time, for BLAS3 with their coefficients: block (nloc p, j) holds T_k0 .. T_k0+j-1, each
        column one term raveled in Fortran order (column r of v in rows r nloc .. (r + 1) nloc);
        the buffer is reused after ``flush`` returns.  ``v`` is not written."""
        buffer = np.empty((v.size, min(chunk, n_terms)), order="F")
        k0 = j = 0
        for t in self.terms(v, n_terms):
            buffer[:, j] = t.ravel(order="F")
            j += 1
            if j == buffer.shape[1]:
                flush(k0, buffer)
                k0, j = k0 + j, 0
        if j:
            flush(k0, buffer[:, :j])
