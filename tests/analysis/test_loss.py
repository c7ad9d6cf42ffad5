"""Scattering against loss (solver/analysis/loss.py): the modes' mean damping rate where it is
exact (C = gamma M: gamma/2 at every frequency), and the additivity gamma = gamma_s + <sigma>
measured on a small packing with weak dashpots: the undamped waves (spectral) and the damped ones
(exact, SLEPc MFN) fitted, the damped modes by pep, on the same packing."""

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close, jammed_packing, scene_of

from solver import pipeline
from solver.analysis import loss
from solver.contact_law import ContactModel
from solver.io import results
from solver.model import dynmat
from solver.spectrum import pep


def test_mean_rate_is_gamma_over_2_when_c_is_gamma_m(comm):
    from petsc4py import PETSc

    p = jammed_packing(64, 0.86, 5)
    dm = dynmat.assemble(p, ContactModel(0.5), comm)
    gamma = 0.3
    dm.C = PETSc.Mat().createAIJ(dm.D.getSizes(), nnz=1, comm=dm.D.getComm())
    dm.C.setDiagonal(dm.M)
    dm.C.assemble()
    dm.C.scale(gamma)
    lam = pep.solve(dm, 1e-4, solver="dense").lam
    dm.destroy()
    for omega in (0.5, 1.5, 2.5):
        sigma, count = loss.mean_rate(lam, omega, 0.1)
        assert_close(sigma, gamma / 2, rtol=1e-10, atol=0.0, what=f"<sigma>({omega})")
        assert_all(count > 2, f"{count:.1f} modes near omega = {omega}")
    assert_all(np.isnan(loss.mean_rate(lam, 10.0, 0.1)[0]), "no mode near omega = 10: NaN")


@pytest.mark.serial_only  # two scenes of waves: the 2-rank suite runs the same chain in test_pep and test_damped_waves
def test_weak_dashpots_add_their_rate_to_the_scattering(shared_tmp):
    """gamma_n = 0.05, gamma_t = 0.025 on 128 disks: for L and TR at every k, gamma exceeds gamma_s
    and gamma_s + <sigma>(omega(k)) equals gamma to 8 % (measured: at most 3.6 %)."""
    base = dict(cache="off", packing={"n": 128, "phi": 0.9, "count": 1}, analysis={})
    waves = {"modes": ["L", "TR"], "n": [1, 2, 3], "t_end": 60.0}
    undamped = scene_of(shared_tmp / "undamped.h5", model={"rho": [0.5]}, waves={**waves, "method": "spectral"},
                        **base)
    damped = scene_of(shared_tmp / "damped.h5", model={"rho": [0.5], "damping": {"gamma_n": 0.05, "gamma_t": 0.025}},
                      waves={**waves, "method": "exponential"}, spectrum={}, **base)
    pipeline.run(undamped, COMM, [])
    pipeline.run(damped, COMM, [])
    with results.open_results(str(undamped.output)) as f:
        scattering = results.fits(f)
    with results.open_results(str(damped.output)) as f:
        both, lam = results.fits(f), {rho: m.lam for rho, m in results.damped_modes(f).items()}
    rows = loss.additivity(both, scattering, lam, width=0.05)
    assert_all(len(rows) == 6, f"{len(rows)} rows: every (mode, k) of both runs")
    for row in rows:
        assert_all(row["gamma"] > row["gamma_s"] and row["sigma"] > 0, row)
        assert_all(abs(row["deviation"]) < 0.08, row)
