"""Mode shapes (``spectrum.shapes``) against the dense eigendecomposition: the nearest modes,
their whole vectors mapped back to particles (rattlers zero), the mass scaling u = M^-1/2 e, the
sign convention, K/Q; 2D with equal and unequal masses, 3D with rolling and twisting; 1 and 2 ranks."""

import numpy as np
import pytest
from conftest import assert_all, assert_close, jammed_packing

from solver.contact_law import ContactModel
from solver.model import dynmat
from solver.spectrum import modes, shapes
from solver.references import dense_eigen


def _nearest(lam, target, count):
    """Indices of the ``count`` non-zero dense modes nearest ``target`` in omega^2, by omega."""
    nonzero = np.flatnonzero(lam > 1e-8)
    near = nonzero[np.argsort(np.abs(lam[nonzero] - target**2), kind="stable")[:count]]
    return near[np.argsort(lam[near])]


def _check(dm, p, targets, count):
    lam, vec = dense_eigen(dm)
    data, settings = shapes.solve(dm, targets, count, tol=1e-12)
    assert_all(settings["prefix"] == "modes_" and settings["st_type"] == "sinvert", f"settings {settings}")
    picked = np.concatenate([_nearest(lam, t, count) for t in targets])
    assert_close(data["omega"], np.sqrt(lam[picked]), rtol=1e-11, what="omega vs eigh")  # measured ~1e-15
    assert_close(data["target"], np.repeat(targets, count), rtol=0.0, what="targets")
    masses = dm.M.getArray(readonly=True)
    inv_sqrt = 1.0 / np.sqrt(np.concatenate(dm.M.getComm().tompi4py().allgather(masses.copy())))
    n = p.positions.shape[0]
    for m, j in enumerate(picked):
        e = vec[:, j] if vec[np.argmax(np.abs(vec[:, j])), j] > 0 else -vec[:, j]  # the sign convention
        full = np.zeros((n, dm.dof))
        full[~p.rattler] = (e * inv_sqrt).reshape(-1, dm.dof)
        assert_close(data["displacement"][m], full[:, :dm.dim], rtol=0.0, atol=1e-8,
                     what=f"displacement of mode {m}")  # |e| = 1, entries ~ N^-1/2; gap-limited, measured ~1e-13
        if dm.rotations:
            assert_close(data["rotation"][m], full[:, dm.dim:], rtol=0.0, atol=1e-8, what=f"rotation of mode {m}")
        assert_all(np.all(data["displacement"][m][p.rattler] == 0.0), "rattlers do not move")
        squares = np.zeros((n, dm.dof))
        squares[~p.rattler] = (e**2).reshape(-1, dm.dof)
        assert_close(data["share"][m][:, 0], squares.sum(axis=1), rtol=0.0, atol=1e-10, what="energy share")
        assert_close(data["share"][m][:, 1], squares[:, dm.dim:].sum(axis=1), rtol=0.0, atol=1e-10,
                     what="rotational share")
        assert_close(data["share"][m][:, 0].sum(), 1.0, rtol=1e-12, what="shares add up to |e|^2 = 1")
    reference = modes.energies(modes.local_sums(vec[:, picked].T, dm.dof, dm.dim), int((~p.rattler).sum()), dm.dim)
    for key in ("K", "Q", "participation"):
        assert_close(data[key], reference[key], rtol=1e-9, what=key)
    assert_all(np.all(data["residual"] < 1e-10), f"residuals {data['residual']}")
    assert_all("rotation" in data or not dm.rotations, "rotation stored with rotations")


@pytest.mark.parametrize("rho, masses", [(0.5, "equal"), (1.0, "density"), (0.0, "equal")])
def test_2d_modes_equal_dense(comm, rho, masses):
    p = jammed_packing(64, 0.9, 7)
    dm = dynmat.assemble(p, ContactModel(rho), comm, masses)
    _check(dm, p, [0.05, 1.0, 2.5], 3)  # 0.05: below the band, next to the zero modes
    dm.destroy()


def test_3d_modes_with_rolling_and_twisting_equal_dense(comm):
    p = jammed_packing(32, 0.68, 5, dim=3)
    dm = dynmat.assemble(p, ContactModel(0.5, rho_roll=0.2, rho_twist=0.1), comm)
    _check(dm, p, [0.3, 2.0], 2)
    dm.destroy()


def test_frictionless_modes_have_no_rotation(comm):
    p = jammed_packing(64, 0.9, 7)
    dm = dynmat.assemble(p, ContactModel(0.0), comm)
    assert_all(not dm.rotations, "rho = 0 in 2D has no rotations in the matrix")
    data, _ = shapes.solve(dm, [1.0], 2)
    assert_all("rotation" not in data and data["displacement"].shape == (2, 64, 2), "shapes without rotations")
    dm.destroy()
