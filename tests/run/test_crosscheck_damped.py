"""Damped standing waves integrated by LAMMPS itself (scripts/crosschecks/crosscheck_damped.py: ``gran/hooke/history``
with gamma_n and gamma_t, dampflag 1) converge to rotsound's exact damped C(k, t), exp(tJ) of
J = [[0, I], [-M^-1 D, -M^-1 C]], and miss the undamped one by far (issue 29, item 6; the script
measures every mode and law, BENCHMARKS.md "crosscheck_damped").  LAMMPS runs on the test's
communicator (one LAMMPS on both ranks under mpirun -n 2)."""

import numpy as np
from conftest import assert_all, jammed_packing

from scripts.crosschecks import harness  # the LAMMPS runner
from solver.contact_law import ContactModel
from solver.model import damping, dynmat
from solver.references import first_order_flow
from solver.waves import excitation

AMPLITUDE, T_END, SAMPLE = 1e-6, 10.0, 0.1


def test_lammps_damped_waves_converge_to_the_damped_matrix(lammps_present, comm):
    """2D, harmonic, TR at k = 2 pi / L, gamma_n = 0.3, gamma_t = 0.15: |C_LAMMPS - C_damped| halves
    with dt (first order: LAMMPS's dashpots see half-step velocities; ratio 2 +- 0.4, measured
    2.00) and at dt = 0.001 is below 1e-3 of |C_LAMMPS - C_undamped| (measured 3.1e-5 against
    0.11).  Checked to fail: the hold force computed with the start's velocities (a constant
    C v(0) on every particle) left the error flat at 0.1."""
    p = jammed_packing(64, 0.9, 1)
    dm = dynmat.assemble(p, ContactModel(1.0, gamma_n=0.3, gamma_t=0.15), comm)
    dm.C = damping.assemble(p, dm)
    plain = dynmat.assemble(p, ContactModel(1.0), comm)
    k = 2 * np.pi / float(p.box[0])
    mpi = comm.tompi4py()
    runs = excitation.runs("TR", 2)
    x = p.positions[dm.active]
    count = int(round(T_END / SAMPLE)) + 1

    def pooled(velocities):
        return harness.pooled_c([v[:, :, c] @ np.exp(-1j * k * x[:, a]) for v, (c, a) in zip(velocities, runs)],
                                SAMPLE)

    starts = [excitation.whole_start(dm, p.positions, c, a, k, AMPLITUDE, mpi) for c, a in runs]
    exact = pooled([first_order_flow(dm, s, SAMPLE, count)[:, 1] for s in starts])
    undamped = pooled([first_order_flow(plain, s, SAMPLE, count)[:, 1] for s in starts])
    errors, misses = [], []
    for dt in (0.002, 0.001):
        lmp = harness.pooled_c([harness.lammps_z(p, dm, "harmonic", run, k, AMPLITUDE, dt,
                                                 int(round(T_END / dt)), int(round(SAMPLE / dt)),
                                                 mpi, hold=True) for run in runs], SAMPLE)
        errors.append(np.abs(lmp - exact).max())
        misses.append(np.abs(lmp - undamped).max())
    dm.destroy()
    plain.destroy()
    assert_all(abs(errors[0] / errors[1] - 2.0) < 0.4, f"errors {errors}")
    assert_all(errors[1] < 1e-3 * misses[1], f"damped {errors}, undamped {misses}")
