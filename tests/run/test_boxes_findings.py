"""scripts/tools/boxes_findings.py (docs/boxes.md) on tiny packings: its long-wave speeds against
the Bloch matrix of the same packing at a tiny wave vector and against a triangular crystal's
speeds by hand, the packing between walls at
rest and the near-wall shares of its modes against a mode-by-mode sum, and the waves' table of
a tiny sheared scene.  Serial."""

import numpy as np
import pytest
from conftest import assert_close, jammed_packing, run_cli, scene_text

from scripts.tools import boxes_findings as findings
from solver.contact_law import ContactModel, pair_blocks
from solver.model import dynmat
from solver.packing import jammed, mechanics

pytestmark = pytest.mark.serial_only


def _bloch_speeds(packing, model, direction, q=1e-4):
    """The two lowest omega / q of the Bloch matrix D(q) of ``packing`` (the cell repeated, a
    plane wave exp(i q r) over the images), q along ``direction``: the long-wave speeds, sorted."""
    order = dynmat.matrix_order(packing)
    n_active = order.size
    contacts = dynmat.local_contacts(packing, order, (0, n_active))
    h_ii, h_ij, h_jj = pair_blocks(*contacts.geometry_args, model, with_rotation=True)
    branch = contacts.geometry_args[0] * contacts.geometry_args[1][:, None]
    phase = np.exp(-1j * q * branch @ direction)  # u_j's phase over u_i's across the contact
    dof = h_ii.shape[1]
    size = n_active * dof
    bloch = np.zeros((size, size), complex)
    for c, (a, b) in enumerate(zip(contacts.a, contacts.b)):  # a reference built contact by contact
        i, j = slice(a * dof, (a + 1) * dof), slice(b * dof, (b + 1) * dof)
        bloch[i, i] += h_ii[c]
        bloch[j, j] += h_jj[c]
        bloch[i, j] += h_ij[c] * phase[c]
        bloch[j, i] += h_ij[c].T * np.conj(phase[c])
    radius = 0.5 * packing.diameters[order]
    mass = np.stack([np.ones(n_active), np.ones(n_active), radius ** 2 / 2], axis=1).ravel()  # m = 1, I = m d^2/8
    scaled = bloch / np.sqrt(np.outer(mass, mass))
    lowest = np.linalg.eigvalsh(scaled)[:2]
    return np.sort(np.sqrt(lowest)) / q


def test_speeds_are_the_bloch_matrix_long_waves_in_a_sheared_cell():
    packing = jammed.generate(64, 0.88, np.random.SeedSequence(3), shear=0.2)
    model = ContactModel(rho=1.0)
    stiffness, density = findings.elastic_tensor(packing, model)
    directions = np.array([[1.0, 0.0], [0.0, 1.0], [np.cos(2.0), np.sin(2.0)]])
    c_l, c_t = findings.speeds(stiffness, density, directions)
    for k, n in enumerate(directions):
        assert_close(np.array([c_t[k], c_l[k]]), _bloch_speeds(packing, model, n), rtol=1e-5, atol=0.0,
                     what=f"speeds along {n}")


def test_speeds_of_a_triangular_crystal():
    """Central springs (rho = 0) on a triangular crystal of spacing a = 1: lambda = mu = sqrt(3) k / 4,
    density 2 / sqrt(3), so c_L^2 = 9/8 and c_T^2 = 3/8 in every direction (no relaxation: each
    particle is a centre of symmetry).  Spacing 1 - 1e-7 to make contacts: the prestress shifts
    c^2 by O(1e-7)."""
    a, rows = 1.0 - 1e-7, 6
    i, j = np.meshgrid(np.arange(rows), np.arange(rows), indexing="ij")
    positions = np.stack((a * (i + 0.5 * (j % 2)), a * np.sqrt(0.75) * j), axis=-1).reshape(-1, 2)
    packing = jammed.from_arrays(positions, np.ones(rows * rows), np.array([rows * a, rows * a * np.sqrt(0.75)]))
    stiffness, density = findings.elastic_tensor(packing, ContactModel(rho=0.0))
    c_l, c_t = findings.speeds(stiffness, density, findings.angles(12)[1])
    assert_close(c_l, np.full(12, np.sqrt(9 / 8)), rtol=1e-6, atol=0.0, what="c_L")
    assert_close(c_t, np.full(12, np.sqrt(3 / 8)), rtol=1e-6, atol=0.0, what="c_T")


def test_walled_packing_at_rest_and_its_layer_shares():
    packing = findings.walled_packing(48, 0.86, 2)
    assert packing.info["n_wall_contacts"] > 0 and not packing.cell.periodic[1]
    assert mechanics.net_force(packing) < 1e-5
    layers = findings.wall_layers(packing, ContactModel(rho=1.0))

    from petsc4py import PETSc

    from solver.references import dense_eigen

    dm = dynmat.assemble(packing, ContactModel(rho=1.0), PETSc.COMM_SELF)
    lam, vec = dense_eigen(dm)
    dm.destroy()
    active = np.flatnonzero(~packing.rattler)
    y = packing.positions[active, 1]
    near = (y < findings.LAYER) | (y > packing.box[1] - findings.LAYER)
    expected = []
    for q in range(lam.size):  # mode by mode, particle by particle
        energy = sum(vec[3 * p:3 * p + 3, q] @ vec[3 * p:3 * p + 3, q] for p in range(active.size) if near[p])
        expected.append(energy)
    assert lam.min() > 1e-8  # between walls with tangential springs: no zero mode
    assert_close(layers["share"], np.array(expected), rtol=1e-10, atol=1e-12, what="layer shares")
    assert layers["layer_fraction"] == pytest.approx(near.mean(), rel=0, abs=0)
    links = findings.contacts_per_particle(packing)[active]
    assert links.mean() == pytest.approx(packing.info["z"] + packing.info["n_wall_contacts"] / active.size, rel=1e-12)
    assert_close(np.array([layers["z_layer"], layers["z_bulk"]]), np.array([links[near].mean(), links[~near].mean()]),
                 rtol=1e-12, atol=0.0, what="contacts per particle")
    width = np.diff(layers["edges"])
    assert_close(np.array([(layers["layer_vdos"] * width).sum(), (layers["bulk_vdos"] * width).sum()]),
                 np.ones(2), rtol=1e-10, atol=0.0, what="local vDOS areas")


def test_waves_scene_of_a_sheared_cell(tmp_path):
    """A 64-disk packing sheared quasi-statically to 0.2 (packing.shear), its L and TR waves along b_x: the
    table's direction is b_x's (180 - atan 0.2 degrees from x), its c the fit's at the smallest k,
    and its long-wave speeds the Christoffel speeds along b_x of the file's packing."""
    from solver.io import results

    output = tmp_path / "waves.h5"
    (tmp_path / "scene.yaml").write_text(scene_text(
        output, seed=3, cache="off", packing={"n": 64, "phi": 0.88, "shear": 0.2}, model={"rho": [1.0]},
        waves={"modes": ["L", "TR"], "n": [1], "axes": ["x"], "t_end": 100.0, "dt": 0.05, "sample_every": 10,
               "method": "spectral"}))
    done = run_cli(["run", str(tmp_path / "scene.yaml")])
    assert done.returncode == 0, done.stderr
    row = findings.waves_scene(str(output))
    assert row["axis"] == "x"
    assert row["degrees"] == pytest.approx(180.0 - np.degrees(np.arctan(0.2)), abs=1e-9)
    with results.open_results(str(output)) as f:
        fits = results.fits(f)
        stored = results.packing(f, 0)
    assert row["c_L"] == fits[(1.0, "L")]["c"][0] and row["c_T"] == fits[(1.0, "TR")]["c"][0]
    direction = np.array([[np.cos(np.radians(row["degrees"])), np.sin(np.radians(row["degrees"]))]])
    long_l, long_t = findings.speeds(*findings.elastic_tensor(findings.configuration(stored), ContactModel(rho=1.0)),
                                     direction)
    assert_close(np.array([row["long_L"], row["long_T"]]), np.array([long_l[0], long_t[0]]), rtol=1e-12, atol=0.0,
                 what="long-wave speeds along b_x")
