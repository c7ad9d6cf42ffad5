"""A stressed frictional packing made by LAMMPS, and standing waves about it integrated by LAMMPS
itself (scripts/crosschecks/crosscheck_stressed.py), against rotsound's stressed matrix: LAMMPS's C(k, t)
converges to the exact C of the stressed D at its time-step order, and misses the unstressed D's
by far more; rotsound's own integrators on the stressed D agree with the exact solution.  The
full table (2D and 3D, both laws, every mode) is in BENCHMARKS.md, "crosscheck"."""

import dataclasses

import numpy as np
import pytest
from conftest import assert_all, assert_close

from scripts.crosschecks import crosscheck_stressed, harness
from solver.contact_law import ContactModel
from solver.model import dynmat
from solver.references import first_order_flow
from solver.waves import excitation

pytestmark = pytest.mark.serial_only  # LAMMPS runs in fresh processes (crosscheck_stressed.fresh)

AMPLITUDE, T_END, SAMPLE = 1e-6, 10.0, 0.1


@pytest.fixture(scope="module")
def made(lammps_present, tmp_path_factory):
    """(packing, restart path): a 2D harmonic stressed packing of 64 disks made by LAMMPS."""
    restart = str(tmp_path_factory.mktemp("stressed") / "stressed.restart")
    (p,) = crosscheck_stressed.fresh(crosscheck_stressed.prepare, (2, "harmonic", 64, 5, restart))
    return p, restart


def pooled(velocities, runs, k, x):
    return harness.pooled_c([v[:, :, c] @ np.exp(-1j * k * x[:, a]) for v, (c, a) in zip(velocities, runs)],
                            SAMPLE)


def tr_waves(p, dm, comm):
    """(k, runs, starts, exact C): the TR runs at k = 2 pi / L, rotsound's start of each (N', dof),
    and the pooled C(k, t) of exp(tJ) on ``dm`` at t = 0, SAMPLE, ..., T_END."""
    k = 2 * np.pi / float(p.box[0])
    runs = excitation.runs("TR", 2)
    starts = [excitation.whole_start(dm, p.positions, c, a, k, AMPLITUDE, comm.tompi4py()) for c, a in runs]
    count = int(round(T_END / SAMPLE)) + 1
    exact = pooled([first_order_flow(dm, s, SAMPLE, count)[:, 1] for s in starts], runs, k, p.positions)
    return k, runs, starts, exact


def test_the_lammps_packing_is_stressed_and_at_rest(made):
    from solver.packing import mechanics

    p, _ = made
    assert p.stressed and not p.rattler.any()
    net, torque = mechanics.net_load(p)
    # LAMMPS stopped at forces and torques below 1e-13; rotsound recomputes them from the same state
    assert np.abs(net).max() < 1e-12 and np.abs(torque).max() < 1e-12
    mean_ft = np.linalg.norm(p.tangential.force, axis=1).mean()
    # without the tangential forces the packing is far from balanced
    bare, _ = mechanics.net_load(dataclasses.replace(p, tangential=None))
    assert np.abs(bare).max() > 0.1 * mean_ft


def test_lammps_waves_converge_to_the_stressed_matrix(made, comm):
    """TR (v_x with k || y, v_y with k || x), k = 2 pi / L, t <= 10, +-A = 1e-6, dt = 0.004 and
    0.002: |C_LAMMPS - C_stressed| falls as dt^2 (ratio 4 +- 1; measured 4.0), and at dt = 0.002
    is less than a tenth of |C_LAMMPS - C_unstressed| (measured 5.5e-7 against 9.0e-4).
    Checked to fail: the stressed blocks left out of the matrix (the error is then flat in dt)."""
    p, restart = made
    model = ContactModel(1.0)
    dm = dynmat.assemble(p, model, comm)
    plain = dynmat.assemble(dataclasses.replace(p, tangential=None), model, comm)
    k, runs, starts, exact = tr_waves(p, dm, comm)
    x = p.positions
    count = int(round(T_END / SAMPLE)) + 1
    unstressed = pooled([first_order_flow(plain, s, SAMPLE, count)[:, 1] for s in starts], runs, k, x)
    errors, misses = [], []
    for dt in (0.004, 0.002):
        every, steps = int(round(SAMPLE / dt)), int(round(T_END / dt))
        both = crosscheck_stressed.fresh(crosscheck_stressed.lammps_velocities,
                                         *[(restart, 2, sign * s, dt, steps, every) for s in starts
                                           for sign in (1.0, -1.0)])
        lmp = pooled([0.5 * (a - b) for a, b in zip(both[0::2], both[1::2])], runs, k, x)
        errors.append(np.abs(lmp - exact).max())
        misses.append(np.abs(lmp - unstressed).max())
    dm.destroy()
    plain.destroy()
    ratio = errors[0] / errors[1]
    assert 3.0 < ratio < 5.0, f"errors {errors}: not LAMMPS's dt^2"
    assert errors[1] < 0.1 * misses[1], f"stressed {errors}, unstressed {misses}"


@pytest.mark.parametrize("integrator", ["verlet", "rk"])
def test_rotsounds_integrators_on_the_stressed_matrix(made, comm, integrator):
    """rotsound's waves (block Verlet; RK4 on the assembled first-order J) on the non-symmetric
    stressed D against exp(tJ): both converge at their order (Verlet 2, RK4 4: the error ratio
    between dt = 0.02 and 0.01 within 25 % of 4 and 16; measured 4.0 and 16.0), to their
    time-step error at dt = 0.01 (measured 1.4e-5 and 5.0e-9 of C(0) = 1; bounded by 1e-4
    and 1e-6)."""
    from conftest import schedule

    from solver.waves import correlations
    from solver.waves import integrators

    p, _ = made
    dm = dynmat.assemble(p, ContactModel(1.0), comm)
    k, runs, _, exact = tr_waves(p, dm, comm)
    x = p.positions
    errors = []
    for dt in (0.02, 0.01):
        plan = schedule(integrator, dt, T_END, int(round(SAMPLE / dt)))
        series = integrators.integrate_all(dm, x, [("TR", r, k) for r in range(len(runs))], amplitude=AMPLITUDE,
                                           schedule=plan)
        c = correlations.pooled(np.array([s.z_fixed for s in series])[:, None, :], SAMPLE)[0][0]
        errors.append(np.abs(c - exact).max())
    dm.destroy()
    order = {"verlet": 4.0, "rk": 16.0}[integrator]
    assert_all(abs(errors[0] / errors[1] / order - 1) < 0.25, f"errors {errors}, ratio {errors[0] / errors[1]}")
    bound = {"verlet": 1e-4, "rk": 1e-6}[integrator]
    assert_close(errors[1], 0.0, rtol=0.0, atol=bound, what="|C - C_exact|, dt = 0.01")
