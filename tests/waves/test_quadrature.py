"""The start's own autocorrelation by Gauss quadrature (waves/quadrature.py): against the exact
eigendecomposition, its step count against the bilinear z(t) of waves/spectral.py at the same
tolerance, and which part of the paper's C(k, t) it is (docs/waves_theory.md, "Gauss quadrature
and what the waves read").  The same on 1 and 2 ranks (both held to the one dense reference)."""

import numpy as np
import pytest
from petsc4py import PETSc
from conftest import assert_all, assert_close, jammed_packing

from solver import references
from solver.contact_law import ContactModel
from solver.model import dynmat
from solver.model.operators import largest_omega
from solver.waves import correlations, quadrature, spectral
from solver.waves.excitation import runs

TOL = 1e-8
TIMES = np.arange(0.0, 200.0 + 1e-9, 0.5)
WAVES = [(mode, run, n) for mode in ("L", "TR", "RT") for run in (0, 1) for n in (1, 3)]


@pytest.fixture(scope="module")
def case():
    """N = 256 disks, rho = 1: the matrix, its dense eigendecomposition, omega_max, and every wave of
    ``WAVES`` by both paths at ``TOL`` (C_a by quadrature, z by spectral)."""
    p = jammed_packing(256, 0.9, 31)
    dm = dynmat.assemble(p, ContactModel(1.0), PETSc.COMM_WORLD)
    omega_max = largest_omega(dm)
    waves = [(mode, run, 2 * np.pi * n / p.box_length) for mode, run, n in WAVES]
    gauss = quadrature.start_correlations(dm, p.positions, waves, amplitude=1e-3, times=TIMES, tol=TOL,
                                          omega_max=omega_max)
    bilinear = spectral.spectral_all(dm, p.positions, waves, amplitude=1e-3, times=TIMES, tol=TOL, omega_max=omega_max)
    yield p, dm, references.dense_eigen(dm), omega_max, waves, gauss, bilinear
    dm.destroy()


def test_gauss_quadrature_gives_the_exact_start_correlation(case):
    """C_a(0) = 1, so the error is relative; the estimate (C_m against C_(m-10)) below TOL."""
    p, dm, eig, _, waves, gauss, _ = case
    for (mode, run, k), result in zip(waves, gauss):
        exact = references.exact_start_correlation(p, dm, eig, runs(mode, dm.dim)[run], k, TIMES)
        assert_close(result.c, exact, rtol=0.0, atol=TOL, what=f"{mode} run {run}, k = {k:.3f}")
        assert_all(result.error_estimate < TOL, f"{mode}: estimate {result.error_estimate}")


def test_gauss_quadrature_takes_at_most_six_tenths_of_the_bilinear_steps(case):
    """Degree 2m - 1 against m - 1 at the same tolerance: about half (here both stop at their first
    count, quadrature.gauss_steps and omega_max t_end / 2 + 40, each estimate ~1e-14: 0.52; the
    smallest counts that reach TOL are compared by scripts/benchmarks/bench_quadrature.py)."""
    _, _, _, omega_max, waves, gauss, bilinear = case
    ratio = np.array([g.steps / b.steps for g, b in zip(gauss, bilinear)])
    assert_all(np.all(ratio <= 0.6), f"steps quadrature / bilinear: {ratio} (omega_max t_end = {omega_max * TIMES[-1]:.0f})")
    assert_all(all(b.error_estimate < TOL for b in bilinear), "the bilinear path reached TOL too")


def test_the_start_correlation_is_the_part_of_z_along_the_start_and_not_the_papers_c(case):
    """With equal masses (L, TR), M v(0) = A (sin(k x) - mean) in the channel, and the mean's part
    is a conserved zero momentum, so v(0)^T M v(t) = -A Im z(t): C_a = Im z(t) / Im z(0).  The
    paper's C adds Re z(0) Re z(t) / |z(0)|^2 (the cosine channel, a bilinear form of its own):
    Re z(0) ~ |z(0)| / sqrt(N), and the disorder turns a sine wave into a cosine wave (max |Re z(t)|
    0.15-0.8 |z(0)| here), so C and C_a differ by ~1e-3 at N = 256: far above TOL."""
    _, _, _, _, waves, gauss, bilinear = case
    for (mode, run, _), g, b in zip(waves, gauss, bilinear):
        if mode == "RT":  # moments of inertia d^2 / 8 differ: M v(0) is not the channel
            continue
        along = b.z.imag / b.z[0].imag
        assert_close(g.c, along, rtol=0.0, atol=10 * TOL, what=f"{mode} run {run}: C_a against Im z / Im z(0)")
    for mode in ("L", "TR"):
        chosen = [i for i, (m, _, n) in enumerate(WAVES) if m == mode and n == 1]
        paper = correlations.vaf(np.array([bilinear[i].z for i in chosen]))
        start = sum(gauss[i].weight * gauss[i].c for i in chosen) / sum(gauss[i].weight for i in chosen)
        difference = np.abs(paper - start).max()
        assert_all(difference > 1e4 * TOL, f"{mode}: max |C - C_a| = {difference:.2e}")
