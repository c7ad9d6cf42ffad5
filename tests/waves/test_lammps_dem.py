"""Standing waves integrated by LAMMPS with its full contact law (solver/waves/lammps_dem.py,
issue 46): at small amplitude they are rotsound's linear waves, and the contact records keep
their books (energy, the Coulomb limit, opened contacts).  LAMMPS runs on the test's
communicator (one LAMMPS on both ranks under mpirun -n 2)."""

import dataclasses
import functools

import numpy as np
import pytest
from conftest import COMM, REPO, assert_all, jammed_packing

from solver import references
from solver.io import hdf5
from solver.contact_law import ContactModel
from solver.errors import InputError
from solver.model import dynmat
from solver.packing import geometry, jammed
from solver.references import dense_eigen, exact_z_fixed, verlet_eigen
from solver.waves import excitation, lammps_dem

T_END, SAMPLE = 20.0, 0.1
PACKINGS = {2: (64, 0.9), 3: (64, 0.7)}


def wave(comm, dim, amplitude, friction, dt, rho=1.0, mode="TR", packing=None):
    """(z of LAMMPS (S,), the exact z, Verlet's exact z at dt, contacts) of the first run of
    ``mode`` at k = 2 pi / L on the shared packing."""
    p = packing or jammed_packing(*PACKINGS[dim], 1, dim=dim)
    model = ContactModel(rho)
    dm = dynmat.assemble(p, model, comm)
    try:
        eig = dense_eigen(dm)
        k = 2 * np.pi / float(p.box[0])
        run = excitation.runs(mode, dim)[0]
        component, axis = run
        mpi = comm.tompi4py()
        start = excitation.whole_start(dm, p.positions, component, axis, k, amplitude, mpi)
        z, contacts = lammps_dem.run(p.positions, p.diameters, p.box, dm.active, model, friction, start, dt,
                                     int(round(T_END / dt)), int(round(SAMPLE / dt)), 1e-6,
                                     (component, np.exp(-1j * k * p.positions[dm.active, axis])), mpi)
        t = np.arange(z.size) * SAMPLE
        return (z, exact_z_fixed(p, dm, eig, run, k, t, amplitude),
                exact_z_fixed(p, dm, verlet_eigen(eig, dt), run, k, t, amplitude), contacts)
    finally:
        dm.destroy()


# LAMMPS on 2 ranks is the 2D case's in the MPI pass; 3D varies the dimension, not the layout (as in test_frictional)
@pytest.mark.parametrize("dim", [2, pytest.param(3, marks=pytest.mark.serial_only)])
def test_small_amplitude_is_the_linear_wave_at_second_order(lammps_present, comm, dim):
    """TR at A = 1e-5, mu = 1, harmonic, rho = 1: LAMMPS's z equals velocity Verlet on the matrix
    (``verlet_eigen``) to its O(A) nonlinear part (measured 7e-7 of max |z| in 2D, 5e-7 in 3D,
    and ten times that at A = 1e-4: checked here), and converges to the exact z at second order
    in dt (error ratio 4.0 on halving: 2.58e-3 -> 6.4e-4 in 2D); nothing slides or opens and the
    wave's energy drifts at second order too (4.3e-4 -> 1.1e-4 of E(0) in 2D)."""
    runs = {dt: wave(comm, dim, 1e-5, 1.0, dt) for dt in (0.05, 0.025)}
    scale = np.abs(runs[0.05][1]).max()
    errors = [np.abs(z - exact).max() / scale for z, exact, _, _ in runs.values()]
    verlet = [np.abs(z - ver).max() / scale for z, _, ver, _ in runs.values()]
    drift = [np.abs(c.energy / c.energy[0] - 1.0).max() for *_, c in runs.values()]
    assert_all(3.6 < errors[0] / errors[1] < 4.4, f"errors against the exact z {errors}")
    assert_all(max(verlet) < 0.05 * min(errors), f"LAMMPS against Verlet on the matrix {verlet}, dt errors {errors}")
    assert_all(3.6 < drift[0] / drift[1] < 4.4, f"energy drifts {drift}")
    for *_, c in runs.values():
        assert_all(c.sliding.max() == 0 and c.opened.max() == 0 and c.formed.max() == 0 and c.coulomb.max() < 0.2,
                   f"{c}")
    z, _, ver, _ = wave(comm, dim, 1e-4, 1.0, 0.05)
    larger = np.abs(z - ver).max() / (10 * scale)  # relative to A = 1e-4's own max |z|
    assert_all(8.0 < larger / verlet[0] < 12.0, f"the deviation from the linear wave is O(A): {larger / verlet[0]}")


def test_sliding_contacts_sit_on_the_coulomb_limit_and_take_energy(lammps_present, comm):
    """2D, A = 1e-2, mu = 0.1: contacts reach the Coulomb limit (the largest ratio is 1, LAMMPS's
    rescaling), some open, and the wave loses energy it never gets back (E(t) <= E(0) up to the
    scheme's O(dt^2), measured 1e-4 of E(0) at A = 1e-5)."""
    _, _, _, c = wave(comm, 2, 1e-2, 0.1, 0.0125)
    assert_all(c.sliding.max() > 5 and c.opened.max() > 0 and abs(c.coulomb.max() - 1.0) < 1e-9, f"{c}")
    assert_all(c.energy[-1] < 0.5 * c.energy[0] and c.energy.max() < c.energy[0] * (1 + 1e-3), f"{c.energy}")


def test_opening_and_closing_normal_springs_keep_the_energy(lammps_present, comm):
    """2D, A = 1e-2, no tangential spring (rho = 0): contacts open and form, and the harmonic
    normal springs, continuous at xi = 0, conserve the energy to second order in dt (what the
    books would miss if a contact's energy were counted wrong as it opens or forms)."""
    drift = []
    for dt in (0.02, 0.01):
        _, _, _, c = wave(comm, 2, 1e-2, 1.0, dt, rho=0.0, mode="L")
        assert_all(c.opened.max() > 0 and c.formed.max() > 0, f"opened {c.opened.max()}, formed {c.formed.max()}")
        drift.append(np.abs(c.energy / c.energy[0] - 1.0).max())
    assert_all(3.0 < drift[0] / drift[1] < 5.0 and drift[1] < 1e-2, f"energy drifts {drift}")


def test_a_packing_lammps_does_not_find_at_rest_is_refused(lammps_present, comm):
    """One particle moved by 1e-3 d0: LAMMPS's forces are far above force_tol, named, on every rank."""
    p = jammed_packing(*PACKINGS[2], 1)
    moved = p.positions.copy()
    moved[0, 0] += 1e-3
    active = ~p.rattler
    start = np.zeros((active.sum(), 3))
    start[0, 0] = 1e-5
    with pytest.raises(InputError, match=r"does not find the packing at rest: its largest force component is "):
        lammps_dem.run(moved, p.diameters, p.box, active, ContactModel(1.0), 1.0, start, 0.05, 10, 1, 1e-6,
                       (0, np.ones(active.sum(), dtype=complex)), comm.tompi4py())


def test_contact_records_every_mth_sample_leave_the_wave_alone(lammps_present, comm):
    """record_every = 7 against 1 (2D, A = 1e-2, mu = 0.1: contacts slide and open): the same z at
    every sample, bit for bit (the records only read LAMMPS's state), and each record the full
    series' every 7th, from t = 0."""
    p = jammed_packing(*PACKINGS[2], 1)
    model = ContactModel(1.0)
    dm = dynmat.assemble(p, model, comm)
    try:
        k = 2 * np.pi / float(p.box[0])
        mpi = comm.tompi4py()
        start = excitation.whole_start(dm, p.positions, 0, 1, k, 1e-2, mpi)
        runs = [lammps_dem.run(p.positions, p.diameters, p.box, dm.active, model, 0.1, start, 0.02, 400, 5, 1e-6,
                               (0, np.exp(-1j * k * p.positions[dm.active, 1])), mpi, record_every=m) for m in (1, 7)]
    finally:
        dm.destroy()
    (z1, every), (z7, seventh) = runs
    assert_all(z1.size == 81 and np.array_equal(z1, z7), f"z differs: {np.abs(z1 - z7).max()}")
    for name, series in every.as_datasets().items():
        assert_all(np.array_equal(series[::7], seventh.as_datasets()[name]), f"{name}")
    assert_all(every.sliding.max() > 0 and seventh.opened.size == 12, f"{every.sliding.max()}, {seventh.opened.size}")


@functools.lru_cache(maxsize=None)
def lammps_frictional(dim: int):
    """A frictional packing made by LAMMPS (mu = 1, forces below 1e-10), its stored forces kept
    with mu unknown, so that the matrix counts none as mobilised (all stick, as under LAMMPS's
    mu = 1e4 below); made on COMM_WORLD once per session."""
    p = jammed.generate(128, 0.82 if dim == 2 else 0.62, np.random.SeedSequence([1, 0]), force_tol=1e-10, dim=dim,
                        engine="lammps", comm=COMM, friction=1.0)
    return dataclasses.replace(p, tangential=dataclasses.replace(p.tangential, friction=None))


@pytest.mark.serial_only  # four LAMMPS runs and a dense exp(tJ) each; 2 ranks: the stored-forces scene test
@pytest.mark.parametrize("dim", [2, 3])
def test_stored_forces_go_into_lammps_history_and_the_linear_limit_is_the_stressed_matrix(lammps_present, comm, dim):
    """A LAMMPS frictional packing's stored tangential forces loaded into LAMMPS's contact history
    (``_load_history``: LAMMPS's forces equal them to 1e-9 of the largest, and the packing is at
    rest under them to 1e-9): at A = 1e-5 the TR wave converges to the exact one of the stressed,
    non-symmetric matrix (exp(tJ), ``first_order_flow``) at second order in dt (2D: 4.8e-4,
    1.2e-4, 2.9e-5 of max |z| at dt = 0.05, 0.025, 0.0125), and the matrix without its stored
    forces is more than ten times that error away (2D 1.1e-3, 3D 7.4e-3: the stressed terms'
    effect).  Without the history, the same packing is refused as not at rest."""
    p = lammps_frictional(dim)
    model = ContactModel(1.0)
    dm = dynmat.assemble(p, model, comm)
    plain = dynmat.assemble(dataclasses.replace(p, tangential=None), model, comm)
    try:
        k = 2 * np.pi / float(p.box[0])
        component, axis = excitation.runs("TR", dim)[0]
        mpi = comm.tompi4py()
        start = excitation.whole_start(dm, p.positions, component, axis, k, 1e-5, mpi)
        phase = np.exp(-1j * k * p.positions[dm.active, axis])
        count = int(round(T_END / SAMPLE)) + 1
        exact = references.first_order_flow(dm, start, SAMPLE, count)[:, 1, :, component] @ phase
        unstressed = references.first_order_flow(plain, start, SAMPLE, count)[:, 1, :, component] @ phase

        def lammps(dt, stored=p.tangential):
            return lammps_dem.run(p.positions, p.diameters, p.box, dm.active, model, 1e4, start, dt,
                                  int(round(T_END / dt)), int(round(SAMPLE / dt)), 1e-9, (component, phase), mpi,
                                  tangential=stored)[0]

        scale = np.abs(exact).max()
        errors = [np.abs(lammps(dt) - exact).max() / scale for dt in (0.025, 0.0125)]
        missed = np.abs(unstressed - exact).max() / scale
        assert_all(3.6 < errors[0] / errors[1] < 4.4 and missed > 10 * errors[1], f"errors {errors}, stressed terms {missed}")
        with pytest.raises(InputError, match="does not find the packing at rest"):
            lammps(0.05, stored=None)
    finally:
        dm.destroy()
        plain.destroy()


@pytest.mark.serial_only  # numpy and scipy only
def test_stored_forces_beyond_the_particles_freedoms_are_refused():
    """A triangular crystal of 8 x 8 disks squeezed by 1 %: z = 6, so 192 tangential equations in
    192 unknowns of which two (the uniform translations) move no contact: random stored forces
    are out of reach of one step's relative motion, and the message says why (z)."""
    from solver.packing import stressed

    rows, cols = 8, 8
    x = np.array([[(c + 0.5 * (r % 2)) * 0.99, r * 0.99 * np.sqrt(3) / 2] for r in range(rows) for c in range(cols)])
    box = np.array([cols * 0.99, rows * 0.99 * np.sqrt(3) / 2])
    d = np.ones(rows * cols)
    found = geometry.find_contacts(x, d, box)
    assert len(found.i) == 3 * rows * cols
    t = np.stack((-found.normal[:, 1], found.normal[:, 0]), axis=1)
    forces = stressed.TangentialForces(np.stack((found.i, found.j), 1),
                                       1e-3 * np.random.default_rng(0).standard_normal(len(found.i))[:, None] * t)
    with pytest.raises(InputError, match=r"192 contacts among 64 particles \(z = 6.00\) leave .* unreachable"):
        lammps_dem.history_velocities(x, d, box, ContactModel(1.0), forces)


def dem_packing(name: str, model):
    """A committed LAMMPS packing with its contact file (tests/data/dem/<name>.data, .contacts)
    read under ``model``'s lever and history, with equal masses (the LAMMPS waves give every
    particle mass 1) and its stored forces' mu unknown (the matrix counts none as mobilised)."""
    data = REPO / "tests" / "data" / "dem"
    p = hdf5.read_packings(str(data / f"{name}.data"), model=model, contacts=str(data / f"{name}.contacts"))[0]
    return dataclasses.replace(p, masses=None, tangential=dataclasses.replace(p.tangential, friction=None))


@functools.lru_cache(maxsize=None)
def lammps_3d_file():
    """The committed frictionless 3D packing LAMMPS made (tests/data/dem/lammps_3d.data: 128
    spheres, diameters uniform in [0.8, 1.2], so 128 atom types under twisting springs), with
    equal masses, as the LAMMPS waves give every particle mass 1."""
    return dataclasses.replace(hdf5.read_packings(str(REPO / "tests" / "data" / "dem" / "lammps_3d.data"))[0],
                               masses=None)


def granular_waves(comm, cases: list, mode: str, friction: float, rest_tol: float = 1e-9):
    """LAMMPS's pair granular against exact waves: ``cases`` [(ContactModel, packing)], the first
    the one LAMMPS runs (with its packing's stored forces, if any) and whose matrix it must match,
    the others negative controls; the first run of ``mode`` at k = 2 pi / L, A = 1e-5, to T_END,
    LAMMPS at the Coulomb coefficient ``friction`` (rolling and twisting unlimited), its rest check
    at ``rest_tol`` (the packing's force tolerance).  Returns
    (LAMMPS's errors at dt = 0.02 and 0.01 against exp(tJ) of the first case, relative to its max
    |z|; the finer run's distance from every other case's exact wave; the two runs' contacts)."""
    model, p = cases[0]
    k = 2 * np.pi / float(p.box[0])
    component, axis = excitation.runs(mode, p.dim)[0]
    mpi = comm.tompi4py()
    count = int(round(T_END / SAMPLE)) + 1
    exact = []
    for which, (m, packing) in enumerate(cases):
        dm = dynmat.assemble(packing, m, comm)
        try:
            if which == 0:
                active = dm.active
                start = excitation.whole_start(dm, p.positions, component, axis, k, 1e-5, mpi)
                phase = np.exp(-1j * k * p.positions[active, axis])
            exact.append(references.first_order_flow(dm, start, SAMPLE, count)[:, 1, :, component] @ phase)
        finally:
            dm.destroy()
    runs = [lammps_dem.run(p.positions, p.diameters, p.box, active, model, friction, start, dt, int(round(T_END / dt)),
                           int(round(SAMPLE / dt)), rest_tol, (component, phase), mpi, tangential=p.tangential)
            for dt in (0.02, 0.01)]
    scale = np.abs(exact[0]).max()
    errors = [np.abs(z - exact[0]).max() / scale for z, _ in runs]
    missed = [np.abs(runs[1][0] - other).max() / scale for other in exact[1:]]
    return errors, missed, [c for _, c in runs]


def test_rolling_springs_under_pair_granular_in_2d_are_the_matrix_at_small_amplitude(lammps_present, comm):
    """2D (64 disks, phi = 0.9), rho = 1, rho_roll = 0.5 under pair granular: the RT wave at
    A = 1e-5 converges at second order in dt to the exact wave of the matrix under ``history:
    granular`` (1.37e-2, 3.4e-3 of max |z| at dt = 0.02, 0.01, one rank); the matrix without the
    rolling springs misses by 0.31, the one with the lever R by 0.53.  On 1 and 2 ranks."""
    p = jammed_packing(*PACKINGS[2], 1)
    model = ContactModel(1.0, 0.5, lever="contact", history="granular")
    cases = [(model, p), (ContactModel(1.0, lever="contact", history="granular"), p), (ContactModel(1.0, 0.5), p)]
    errors, missed, records = granular_waves(comm, cases, "RT", 1e4, rest_tol=1e-6)
    assert_all(3.6 < errors[0] / errors[1] < 4.4 and min(missed) > 10 * errors[1],
               f"errors {errors}, without rolling springs / with the lever R {missed}")
    assert_all(all(c.rolling.max() == 0 and c.sliding.max() == 0 and np.isfinite(c.energy).all() for c in records),
               f"{records}")


@pytest.mark.serial_only  # three LAMMPS runs and a dense exp(tJ) each; LAMMPS on 2 ranks: the gran/*/history tests
def test_rolling_and_twisting_springs_under_pair_granular_are_the_matrix_at_small_amplitude(lammps_present, comm):
    """LAMMPS's pair granular (hooke, linear_history, rolling sds, twisting sds with k_twist =
    rho_twist kn a'^2; ``lammps_dem.granular_coefficients``) on a committed 3D LAMMPS packing:
    the twist wave R at A = 1e-5, rho = 1, rho_roll = 0.5, rho_twist = 0.3, converges at second
    order in dt to the exact wave (exp(tJ)) of rotsound's matrix with the same springs under
    ``history: granular``, ``lever: contact`` (measured 9.7e-3, 2.4e-3 of max |z| at dt = 0.02,
    0.01: ratio 4.0).  Negative controls, each more than ten times that error away: the matrix
    without rolling and twisting springs (measured 0.27), and the symmetric one with the torque's
    lever R (``history: lammps``, lever radius), whose torques differ by xi/2 n x f_t (0.079)."""
    p = lammps_3d_file()
    model = ContactModel(1.0, 0.5, 0.3, lever="contact", history="granular")
    cases = [(model, p), (ContactModel(1.0, lever="contact", history="granular"), p), (ContactModel(1.0, 0.5, 0.3), p)]
    errors, missed, records = granular_waves(comm, cases, "R", 1e4)
    assert_all(3.6 < errors[0] / errors[1] < 4.4 and min(missed) > 10 * errors[1],
               f"errors {errors}, without rolling and twisting / with the lever R {missed}")
    for c in records:
        assert_all(c.rolling.max() == 0 and c.sliding.max() == 0 and 0 < c.rolling_coulomb.max() < 1e-2
                   and np.isnan(c.energy).all(), f"{c}")


@pytest.mark.serial_only  # six LAMMPS runs and four dense exp(tJ); LAMMPS on 2 ranks: the gran/*/history tests
@pytest.mark.parametrize("mode", ["R", "TR"])
def test_pair_granular_with_stored_forces_is_the_stressed_matrix_at_small_amplitude(lammps_present, comm, mode):
    """The committed 3D packing LAMMPS settled under pair granular (tests/data/dem/lammps_3d_granular:
    mu = 0.5, its stored tangential forces balancing torques at R - xi/2) with rolling and twisting
    springs switched on unstressed (kt = 2/7, k_roll = kt/2, k_twist-ratio 0.3 kt; LAMMPS at mu = 1,
    so that nothing slides): the stored forces go into pair granular's history (the rolling and
    twisting springs' Coulomb limits 0 for that step, ``_load_history``), and the wave at
    A = 1e-5 converges at second order in dt to exp(tJ) of the stressed matrix under
    ``history: granular``, ``lever: contact`` (R: 6.4e-4, 1.6e-4; TR: 3.2e-5, 7.8e-6 of max |z|
    at dt = 0.02, 0.01).  Negative controls, each more than ten times the finer error away: the
    matrix without the stored forces (R 2.3e-3, TR 2.8e-3), without rolling and twisting springs
    (R 0.080, TR 0.56) and with them under the lever R (R 0.041, TR 3.3e-3).  At mu = 1e4 the R
    wave stops converging near 5e-4: LAMMPS turns a spring with the contact only when
    |f_t . n| > 1e-10 mu |f_n| (docs/finite_amplitude.md section 7)."""
    kt = 2.0 / 7.0
    model = ContactModel(kt, 0.5 * kt, 0.3 * kt, lever="contact", history="granular")
    p = dem_packing("lammps_3d_granular", model)
    cases = [(model, p), (model, dataclasses.replace(p, tangential=None)),
             (ContactModel(kt, lever="contact", history="granular"), p), (ContactModel(kt, 0.5 * kt, 0.3 * kt), p)]
    errors, missed, records = granular_waves(comm, cases, mode, 1.0)
    assert_all(3.6 < errors[0] / errors[1] < 4.4 and min(missed) > 10 * errors[1],
               f"errors {errors}; unstressed, without rolling and twisting, lever R: {missed}")
    assert_all(all(c.sliding.max() == 0 and c.rolling.max() == 0 and c.opened.max() == 0 for c in records),
               f"{records}")


@pytest.mark.serial_only  # numpy only
def test_pair_granular_types_follow_the_diameters_and_are_refused_beyond_the_cap():
    """Twisting springs under pair granular: one atom type per distinct diameter (k_twist =
    rho_twist kn a'^2 per pair), whose coefficients follow a' of each type pair; without twisting
    one type; more than MAX_TYPES distinct diameters refused, naming the count."""
    diameters = np.array([1.2, 0.8, 1.2, 1.0])
    model = ContactModel(1.0, 0.5, 0.3, lever="contact", history="granular")
    types, lines = lammps_dem.granular_coefficients(diameters, model, (0.5, 0.1, 0.05))
    assert_all(np.array_equal(types, [3, 1, 3, 2]) and len(lines) == 6, f"{types}, {lines}")
    twist = {line.split()[1] + line.split()[2]: float(line.split()[-3]) for line in lines}
    assert_all(np.isclose(twist["13"], 0.3 * (0.4 * 0.6 / 1.0) ** 2, rtol=1e-15, atol=0.0)
               and np.isclose(twist["33"], 0.3 * 0.3**2, rtol=1e-15, atol=0.0), f"{twist}")
    plain, _ = lammps_dem.granular_coefficients(diameters, ContactModel(1.0, 0.5, lever="contact",
                                                                       history="granular"), (0.5, 0.1, 0.05))
    assert_all(np.array_equal(plain, [1, 1, 1, 1]), f"{plain}")
    many = np.linspace(0.8, 1.2, lammps_dem.MAX_TYPES + 1)
    with pytest.raises(ValueError, match=f"has {lammps_dem.MAX_TYPES + 1} distinct diameters, more than"):
        lammps_dem.atom_types(many, model)
