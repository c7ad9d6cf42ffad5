"""Packings made by LAMMPS, LIGGGHTS and YADE (tests/data/dem, made by the programs themselves)
through rotsound's loader: rescaled to d0 = 1 and the box's corner, in equilibrium where the
program left them, refused where the normal forces alone do not balance (friction, YADE's 6
digits) and re-minimised by packing.relax, with their own masses under model.masses: density."""


import numpy as np
import pytest
from conftest import COMM, REPO, assert_all, assert_close, scene_of

from solver.contact_law import ContactModel
from solver import pipeline
from solver.errors import InputError
from solver.io import coerce, dem_formats, schema
from solver.io import hdf5
from solver.model import dynmat
from solver.packing import configuration
from solver.packing import mechanics

DATA = REPO / "tests" / "data" / "dem"
BALANCED = ["lammps_2d.data", "lammps_2d.dump", "lammps_3d.data", "lammps_3d.dump", "liggghts_3d.data"]


@pytest.mark.parametrize("name", BALANCED)
def test_balanced_dem_packings_load_in_rotsounds_units(name):
    """Lengths over the file's mean diameter, positions from the box's corner: the contacts, and so
    the equilibrium the program reached (normal residual ~1e-13 of its contact forces), survive
    the rescaling; phi is the file's.  A box or positions not rescaled alike break both."""
    raw = dem_formats.read(DATA / name)
    p = hdf5.read_packings(str(DATA / name))[0]
    unit = raw.diameters.mean()
    assert_close(p.box, (raw.box_hi - raw.box_lo) / unit, rtol=1e-15, what="box")
    assert_close(p.diameters.mean(), 1.0, rtol=1e-15, what="mean diameter")
    volume = np.prod(raw.box_hi - raw.box_lo)
    solid = configuration.solid_volume(raw.diameters, raw.dim)
    assert_close(p.phi, solid / volume, rtol=1e-12, what="phi")
    assert_all(p.dim == raw.dim and mechanics.net_force(p) < 1e-10 and mechanics.jamming_failure(p) is None,
               f"{name}: dim {p.dim}, net force {mechanics.net_force(p)}")


def test_data_file_and_dump_of_one_packing_are_one_packing():
    for dim in (2, 3):
        a, b = (hdf5.read_packings(str(DATA / f"lammps_{dim}d.{kind}"))[0] for kind in ("data", "dump"))
        assert_all(np.array_equal(a.positions, b.positions) and np.array_equal(a.box, b.box), f"{dim}D differ")
        # the data file's masses are density x pi d^3 / 6 worked out by the reader, the dump's LAMMPS's
        assert_close(a.masses, b.masses, rtol=4 * np.finfo(float).eps, what=f"{dim}D masses")


@pytest.mark.parametrize("name, why", [("lammps_3d_friction.data", "friction"), ("yade_3d.txt", "6 digits"),
                                       ("yade_3d.spheres", "6 digits")])
def test_unbalanced_dem_packings_are_refused_and_relax_re_minimises_them(name, why, tmp_path):
    """The frictional LAMMPS packing (its normal forces alone leave 5e-2 kn d0) and YADE's (its
    6-digit export leaves ~2e-3) are refused with the message that offers packing.relax; with
    relax they come back in equilibrium under the normal forces, still jammed (phi 0.65-0.67)."""
    scene = {"packing": {"file": str(DATA / name)}, "output": str(tmp_path / "out.h5")}
    with pytest.raises(InputError, match="not in mechanical equilibrium.*packing.relax: true"):
        pipeline.make_packings(coerce.build(schema.Scene, scene), COMM)
    scene["packing"]["relax"] = True
    p, = pipeline.make_packings(coerce.build(schema.Scene, scene), COMM)
    assert_all(mechanics.net_force(p) < 1e-5 and mechanics.jamming_failure(p) is None and p.info["relaxed"],
               f"{name} ({why}): net force {mechanics.net_force(p)}")


def test_a_files_masses_reach_the_matrix_under_density(comm):
    """LAMMPS's masses (density x pi d^3 / 6, two densities) scaled to a mean of 1 are the
    matrix's translational masses; equal masses ignore them."""
    p = hdf5.read_packings(str(DATA / "lammps_3d.data"))[0]
    raw = dem_formats.read(DATA / "lammps_3d.data")
    for rule, expected in (("density", raw.masses / raw.masses.mean()), ("equal", np.ones(p.n))):
        dm = dynmat.assemble(p, ContactModel(0.5), comm, mass_rule=rule)
        mass = dynmat.in_packing_order(dm, dynmat.gather_vec(dm.M)).reshape(-1, dm.dof)
        dm.destroy()
        assert_close(mass[:, 0], expected[~p.rattler], rtol=4 * np.finfo(float).eps, what=f"masses ({rule})")
    assert_all(np.ptp(raw.masses / raw.masses.mean()) > 0.5, "the file's masses should differ")


def test_scene_on_a_rectangular_lammps_packing_counts_its_spectrum(shared_tmp):
    """A 2D LAMMPS packing in a 12.5 x 9.75 box, density masses, through a counting scene: every
    non-zero mode counted once (2 DOF x 126 non-rattlers + 126 rotations - 2 translations)."""

    scene = scene_of(shared_tmp / "lammps.h5", cache="off", packing={"file": str(DATA / "lammps_2d.data")},
                     model={"rho": 0.5, "masses": "density"}, spectrum={"method": "counting"})
    units = pipeline.run(scene, COMM, [])["units"]
    datasets, attrs = units["spectra/r00_p0000"]
    p = hdf5.read_packings(str(DATA / "lammps_2d.data"))[0]
    active = int((~p.rattler).sum())
    assert_all(int(datasets["counts"].sum()) + attrs["n_zero_modes"] == 3 * active and attrs["n_zero_modes"] == 2,
               f"{datasets['counts'].sum()} + {attrs['n_zero_modes']} modes for {active} disks")


@pytest.mark.parametrize("mode", ["TR", "RT"])
def test_standing_waves_on_a_polydisperse_lammps_packing_match_the_exact_reference(comm, mode):
    """LAMMPS's polydisperse 3D packing (diameters 0.8-1.2, two densities) in its 5.5 x 4.6 x 4.05
    box, with its own masses (model.masses: density): the spectral path along x (waves.axes: [x],
    k = 2 pi / L_x) equals the exact modal solution to 1e-8, run by run.  The exact reference
    reads D and M only through A's eigendecomposition (solver/references.py)."""
    from solver.model import operators
    from solver.references import dense_eigen, exact_z_fixed
    from solver.waves import excitation
    from solver.waves.spectral import spectral

    p = hdf5.read_packings(str(DATA / "lammps_3d.data"))[0]
    dm = dynmat.assemble(p, ContactModel(1.0, rho_roll=0.2), comm, mass_rule="density")
    eig = dense_eigen(dm)
    k = 2 * np.pi / p.box[0]
    times = np.arange(0.0, 30.0 + 1e-9, 0.25)
    runs = excitation.runs(mode, 3)
    for r in [r for r, (_, axis) in enumerate(runs) if axis == 0]:
        s = spectral(dm, p.positions, mode, r, k, amplitude=1e-3, times=times, tol=1e-10,
                     omega_max=operators.largest_omega(dm))
        exact = exact_z_fixed(p, dm, eig, runs[r], k, times, 1e-3)
        error = np.abs(s.z_fixed - exact).max() / np.abs(exact).max()
        assert_all(error < 1e-8, f"{mode} run {runs[r]}: spectral error {error}")
    dm.destroy()
