"""Standing waves in a tilted (triclinic) cell (issue 59 point 1): k along the reciprocal vectors
(``excitation.wave_vector``), the polarisations turning with k (``excitation.polarisation``), the
periods and log lines, the LAMMPS engine's refusal, the start periodic in the cell and the waves
of a sheared packing against the dense exact reference; and in an orthogonal cell the start,
channel and sampled z the same, bit for bit, as the formulas of k along an axis."""

import dataclasses
import functools

import numpy as np
import pytest
from conftest import COMM, assert_close, scene_of

from solver import pipeline
from solver.contact_law import ContactModel
from solver.errors import InputError
from solver.io import hdf5
from solver.io.schema import WavesSpec
from solver.model import dynmat
from solver.packing import jammed
from solver.packing.geometry import Cell
from solver.references import dense_eigen, exact_z_fixed
from solver.waves import excitation, exponential, rules, spectral
from solver.waves.sampling import FourierSampler

CELL3 = Cell(np.array([4.0, 5.0, 6.0]), np.array([1.1, -0.7, 0.9]), np.ones(3, dtype=bool))
CELL2 = Cell(np.array([4.0, 5.0]), np.array([1.3]), np.ones(2, dtype=bool))


def unit(vector):
    return vector / np.linalg.norm(vector)


def test_k_along_the_reciprocal_vectors_is_periodic_in_the_tilted_cell():
    """k = |k| b_a / |b_a| with |k| = 2 pi n / L_a (L_a the height, ``periods``) is n b_a: its phase
    k . r gains 2 pi n m_a over the image r + H m, so sin(k . r) is the same on every image; and
    k . (edge b) = 2 pi n delta_ab (the edges: H's columns)."""
    for cell in (CELL2, CELL3):
        rng = np.random.default_rng(3)
        r = rng.uniform(0.0, 5.0, size=(50, cell.dim))
        m = rng.integers(-3, 4, size=(50, cell.dim))
        lengths = excitation.periods(cell)
        assert_close(lengths, cell.heights, rtol=0.0, atol=0.0, what="periods of a tilted cell: its heights")
        for axis in range(cell.dim):
            for n in (1, 2, 5):
                k = excitation.wave_vector(2 * np.pi * n / lengths[axis], axis, cell)
                assert_close(k, n * cell.reciprocal()[axis], rtol=1e-14, atol=1e-14, what="k = n b_a")
                assert_close(k @ cell.matrix, 2 * np.pi * n * np.eye(cell.dim)[axis], rtol=0.0, atol=1e-12,
                             what="k . edges")
                moved = excitation.phases(r + m @ cell.matrix.T, axis, k) - excitation.phases(r, axis, k)
                assert_close(moved, 2 * np.pi * n * m[:, axis], rtol=0.0, atol=1e-11, what="phase over images")
                start = np.sin(excitation.phases(r, axis, k))
                assert_close(np.sin(excitation.phases(r + m @ cell.matrix.T, axis, k)), start, rtol=0.0,
                             atol=1e-11, what="sin(k . r) on the images")


def test_orthogonal_cells_keep_k_along_the_axis_and_e_c():
    """In an orthogonal cell (a Cell without tilt, or sides) the wave vector is the float k itself
    and every run's polarisation is e_c exactly, whether k is given as a float or as k e_a."""
    flat = Cell.of(np.array([4.0, 5.0, 6.0]), 3)
    for dim, dof in ((2, 3), (3, 6)):
        for mode in excitation.RUNS[dim]:
            for component, axis in excitation.runs(mode, dim):
                assert excitation.wave_vector(0.7, axis, flat) == 0.7
                vector = np.zeros(dim)
                vector[axis] = 0.7
                for k in (0.7, vector):
                    assert np.array_equal(excitation.polarisation(component, axis, k, dim, dof), np.eye(dof)[component])


def test_polarisations_turn_with_k_in_a_tilted_cell():
    """Along b_a of a tilted cell: L and R along k^ (in the velocity, resp. angular velocity slots),
    each axis' two TR (and two RT) polarisations orthonormal and perpendicular to k^, and each in
    the plane of e_c and what came before it (Gram-Schmidt); 2D: TR perpendicular to k^ in the
    plane, RT e_2."""
    for axis in range(3):
        k = excitation.wave_vector(1.3, axis, CELL3)
        hat = unit(k)
        assert (axis == 2) == np.allclose(hat, np.eye(3)[axis], rtol=0.0, atol=1e-3), "b_x, b_y turned; b_z along z"
        for mode, first in (("L", 0), ("R", 3)):
            (component, _), = [run for run in excitation.runs(mode, 3) if run[1] == axis]
            p = excitation.polarisation(component, axis, k, 3, 6)
            assert_close(p[first:first + 3], hat, rtol=0.0, atol=1e-15, what=mode)
            assert not p[3 - first:6 - first].any()
        for mode, first in (("TR", 0), ("RT", 3)):
            ps = [excitation.polarisation(c, a, k, 3, 6)[first:first + 3]
                  for c, a in excitation.runs(mode, 3) if a == axis]
            frame = np.array([hat, *ps])
            assert_close(frame @ frame.T, np.eye(3), rtol=0.0, atol=1e-15, what=f"{mode}: k^ and p orthonormal")
            c1 = min(c - first for c, a in excitation.runs(mode, 3) if a == axis)
            assert ps[0] @ np.eye(3)[c1] > 0.0, "the first along e_c1's side"
            assert_close(np.cross(hat, np.eye(3)[c1]) @ ps[0], 0.0, rtol=0.0, atol=1e-15, what="in k^, e_c1's plane")
    for axis in range(2):
        k = excitation.wave_vector(1.3, axis, CELL2)
        (tr, _), = [run for run in excitation.runs("TR", 2) if run[1] == axis]
        p = excitation.polarisation(tr, axis, k, 2, 3)
        assert_close(p[:2] @ unit(k), 0.0, rtol=0.0, atol=1e-15, what="2D TR perpendicular to k")
        assert_close(np.linalg.norm(p), 1.0, rtol=0.0, atol=1e-15, what="2D TR unit")
        assert np.array_equal(excitation.polarisation(2, axis, k, 2, 3), np.eye(3)[2])


def test_wave_numbers_and_log_lines_of_a_tilted_cell():
    """|k| = 2 pi n / height: a cube sheared by xy = 0.15 L keeps the period L along b_y and b_z but
    has L / sqrt(1 + 0.15^2) along b_x, 1.1 % shorter: waves.n pooled over x and y is refused (the
    periods differ by more than SPREAD), each axis alone is not; the log gives |k|, the period and
    the direction per axis."""
    cell = Cell(np.full(3, 5.0), np.array([0.75, 0.0, 0.0]), np.ones(3, dtype=bool))
    spec = WavesSpec(n=[1])
    ns, ks = excitation.wave_vectors(spec, cell, [0])
    assert_close(ks[0, 0], 2 * np.pi * np.sqrt(1 + 0.15**2) / 5.0, rtol=1e-15, atol=0.0, what="|k| along b_x")
    ns, ks = excitation.wave_vectors(spec, cell, [1, 2])
    assert_close(ks[0], [2 * np.pi / 5.0] * 2, rtol=1e-15, atol=0.0, what="|k| along b_y, b_z")
    with pytest.raises(InputError, match="waves.axes"):
        excitation.wave_vectors(spec, cell, [0, 1])
    lines = excitation.log_lines(spec, *excitation.wave_vectors(spec, cell, [0]), [0], cell)
    assert lines == ["waves: |k| d0 = 1.2707 (n = 1, period 4.945 along b_x = (0.9889, -0.1483, 0.0000))"]
    assert excitation.log_lines(spec, ns, ks, [1, 2], Cell.of(np.full(3, 5.0), 3)) == []


def test_lammps_engine_refuses_a_tilted_cell(small_packing):
    """waves.engine: lammps on a packing in a tilted cell is refused naming the key and the tilt
    (its finite-amplitude runs build an orthogonal LAMMPS box); the same packing orthogonal passes."""
    spec = WavesSpec(n=[1], engine="lammps", method="ts", integrator="verlet")
    rules.check_boxes(spec, [small_packing])
    tilted = dataclasses.replace(small_packing, tilt=np.array([0.5]))
    with pytest.raises(InputError, match=r"waves.engine: lammps: configuration 0 is in a tilted cell \(xy = 0.5\)"):
        rules.check_boxes(spec, [tilted])
    rules.check_boxes(WavesSpec(n=[1]), [tilted])


def test_orthogonal_start_channel_and_z_as_along_the_axis(small_packing, comm):
    """On an orthogonal packing, every run's start, channel and sampled z, z_fixed are the formulas
    of k along the axis bit for bit: A sin(k r_a) in slot c minus its mass-weighted mean there
    (where slot c is a zero mode), exp(i k r_a), and sum_i v_i,c exp(-i k (r_a + u_a))."""
    dm = dynmat.assemble(small_packing, ContactModel(0.5), comm)
    try:
        mpi = comm.tompi4py()
        start, stop = dm.disk_range
        r0 = small_packing.positions[dm.order[start:stop]]
        mass = dm.M.getArray(readonly=True).reshape(-1, dm.dof)
        rng = np.random.default_rng(5)
        waves = [(c, a, 2 * np.pi * 2 / small_packing.box[a]) for mode in ("L", "TR", "RT") for c, a in
                 excitation.runs(mode, 2)]
        u, v = rng.normal(size=(2, (stop - start) * dm.dof, len(waves))) * 1e-3
        z, z_fixed, _ = FourierSampler(dm, small_packing.positions, waves, mpi)(u, v, np.zeros_like(u))
        comp, axes, ks = (np.array([wave[i] for wave in waves])[None, :] for i in range(3))
        disks, cols = np.arange(stop - start)[:, None], np.arange(len(waves))[None, :]
        fixed = (v.reshape(-1, dm.dof, len(waves))[disks, comp, cols]
                 * np.conj(np.exp(1j * ks * r0[disks, axes])))
        shift = ks * u.reshape(-1, dm.dof, len(waves))[disks, axes, cols]
        assert np.array_equal(z, mpi.allreduce(np.sum(fixed * np.exp(-1j * shift), axis=0)))
        assert np.array_equal(z_fixed, mpi.allreduce(np.sum(fixed, axis=0)))
        for c, a, k in waves:
            expected = np.zeros((stop - start, dm.dof))
            expected[:, c] = 1e-3 * np.sin(k * r0[:, a])
            if any(slot == c for slot, _ in dm.rigid_modes()):
                moment, inertia = mpi.allreduce(np.array([np.sum(mass[:, c] * expected[:, c]), np.sum(mass[:, c])]))
                expected[:, c] -= moment / inertia
            assert np.array_equal(excitation.start_velocity(dm, small_packing.positions, c, a, k, 1e-3, mpi),
                                  expected.ravel())
            b = np.zeros((stop - start, dm.dof), complex)
            b[:, c] = np.exp(1j * k * r0[:, a])
            assert np.array_equal(excitation.channel(dm, small_packing.positions, c, a, k), b.ravel())
    finally:
        dm.destroy()


@functools.lru_cache(maxsize=None)
def sheared_disks():
    """64 disks at phi = 0.9 that FIRE brought to rest in a cell tilted by xy = 0.3 L (seed 7; the
    packing of tests/model/test_tilted_dynmat.py)."""
    return jammed.generate(64, 0.9, np.random.SeedSequence([7, 0]), shear=0.3)


def test_the_start_is_periodic_in_the_tilted_cell(comm):
    """Every run's start v(0) along b_x and b_y of the sheared disks is the same (to 1e-13 of the
    amplitude) when every disk is moved to another of its periodic images r + H m: the wave is
    periodic in the tilted cell.  k along the orthogonal axis x instead (the tilt left out) changes
    it by order the amplitude."""
    p = sheared_disks()
    cell = p.cell
    moved = p.positions + np.random.default_rng(2).integers(-2, 3, size=(p.n, 2)) @ cell.matrix.T
    dm = dynmat.assemble(p, ContactModel(0.5), comm)
    try:
        mpi = comm.tompi4py()
        for mode in ("L", "TR", "RT"):
            for c, a in excitation.runs(mode, 2):
                k = excitation.wave_vector(2 * np.pi / excitation.periods(cell)[a], a, cell)
                start = excitation.whole_start(dm, p.positions, c, a, k, 1.0, mpi)
                assert_close(excitation.whole_start(dm, moved, c, a, k, 1.0, mpi), start, rtol=0.0, atol=1e-13,
                             what=f"{mode} ({c}, {a}) on the images")
        flat = 2 * np.pi / p.box[0]
        along_x = excitation.whole_start(dm, moved, 1, 0, flat, 1.0, mpi) - excitation.whole_start(
            dm, p.positions, 1, 0, flat, 1.0, mpi)
        assert np.abs(along_x).max() > 0.5, np.abs(along_x).max()
    finally:
        dm.destroy()


@pytest.mark.parametrize("path", ["spectral", "exponential"])
def test_waves_of_the_sheared_disks_are_the_dense_reference(comm, path):
    """rotsound's standing waves of every mode and run (k along b_x and b_y, n = 1, to t = 10) on the
    sheared disks' matrix (rotations, rho = 0.5) follow the dense exact reference
    (``references.exact_z_fixed``, its own polarisation: the QR of [k, e_c]) to 1e-8 of max |z|,
    on the Lanczos and the exponential paths."""
    p = sheared_disks()
    cell = p.cell
    dm = dynmat.assemble(p, ContactModel(0.5), comm)
    try:
        eig = dense_eigen(dm)
        times = np.arange(0.0, 10.0 + 1e-9, 0.25)
        waves = [(mode, r, excitation.wave_vector(2 * np.pi * n / excitation.periods(cell)[a], a, cell))
                 for mode in ("L", "TR", "RT") for r, (_, a) in enumerate(excitation.runs(mode, 2)) for n in (1,)]
        if path == "spectral":
            series = spectral.spectral_all(dm, p.positions, waves, amplitude=1e-3, times=times, tol=1e-10)
        else:
            series = exponential.exponential_all(dm, p.positions, waves, amplitude=1e-3, times=times, tol=1e-10,
                                                 rate=float(np.sqrt(eig[0].max())))
        for (mode, r, k), s in zip(waves, series):
            exact = exact_z_fixed(p, dm, eig, excitation.runs(mode, 2)[r], k, times, 1e-3)
            assert_close(s.z_fixed, exact, rtol=0.0, atol=1e-8 * np.abs(exact).max(), what=f"{path} {mode} run {r}")
    finally:
        dm.destroy()


def test_a_scene_runs_its_waves_along_the_reciprocal_vector(shared_tmp, capsys, comm):
    """A scene on the sheared disks' packing file (waves.axes [x], n = 1, L and TR, spectral path):
    the log gives |k| = 2 pi / height and the direction b_x / |b_x|, the results' k is that |k|,
    and each unit's z_fixed is the dense exact reference's along b_x to 1e-8 of max |z|."""
    p = sheared_disks()
    path = shared_tmp / "sheared.h5"
    if COMM.rank == 0:
        hdf5.save_packings(str(path), [p])
    COMM.barrier()
    scene = scene_of(shared_tmp / "waves.h5", cache="off", packing={"file": str(path)}, model={"rho": 0.5},
                     waves={"modes": ["L", "TR"], "n": [1], "axes": ["x"], "method": "spectral", "t_end": 10.0})
    capsys.readouterr()
    units = pipeline.run(scene, COMM, [])["units"]
    log = COMM.bcast(capsys.readouterr().out, root=0)
    cell = p.cell
    k = 2 * np.pi / cell.heights[0]
    direction = unit(cell.reciprocal()[0])
    assert f"waves: |k| d0 = {k:.4f} (n = 1, period {cell.heights[0]:.3f} along b_x = " \
           f"({direction[0]:.4f}, {direction[1]:.4f}))" in log, log
    dm = dynmat.assemble(p, ContactModel(0.5), comm)
    try:
        eig = dense_eigen(dm)
        for mode in ("L", "TR"):
            datasets, _ = units[next(name for name in units if name.startswith("waves/") and f"_{mode}_" in name)]
            assert_close(datasets["k"], [k], rtol=1e-15, atol=0.0, what="|k| in the results")
            exact = exact_z_fixed(p, dm, eig, excitation.runs(mode, 2)[0], k * direction, datasets["t"], 1e-3)
            assert_close(datasets["z_fixed"][0, 0], exact, rtol=0.0, atol=1e-8 * np.abs(exact).max(), what=mode)
    finally:
        dm.destroy()
