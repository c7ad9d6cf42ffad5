"""scripts/tools/frictional_table.py's cells, on a results file whose answers are known."""

import h5py
import numpy as np
import pytest
import yaml

from scripts.tools import frictional_table

pytestmark = pytest.mark.serial_only  # h5py and numpy only


def _results(path, dropped):
    """Two packings (phi 0.80, 0.82; z 3.5, 3.7; mu 1), a vDOS uniform on [0, 3] in bins of
    0.05 (1/6 of it below omega = 0.5), spectra with 3 + 1 complex and 0 + 2 negative of
    100 + 98 eigenvalues and 2 zero modes each, and waves whose first k holds known c and gamma."""
    with h5py.File(path, "w") as f:
        f.attrs["scene"] = yaml.safe_dump({"model": {"stored_forces": "drop"}} if dropped else {"model": {}})
        for i, (phi, z) in enumerate(((0.80, 3.5), (0.82, 3.7))):
            group = f.create_group(f"packings/{i:04d}")
            group.attrs.update(friction=1.0, phi=phi, z=z, pressure=0.01)
        edges = np.linspace(0.0, 3.0, 61)
        f["vdos/r00/edges"], f["vdos/r00/density"] = edges, np.full(60, 1 / 3)
        for i, (complex_, negative, size) in enumerate(((3, 0, 100), (1, 2, 98))):
            group = f.create_group(f"spectra/r00_p{i:04d}")
            group["omega2"] = np.ones(size, complex)
            group.attrs.update(n_complex=complex_, n_negative_modes=negative, n_zero_modes=2, max_growth=1e-5 * (i + 1))
        for mode, (c, gamma, omega) in {"L": (0.6, 4e-3, 0.1), "TR": (0.3, 3e-3, 0.05), "RT": (9.0, 0.125, 2.2)}.items():
            group = f.create_group(f"analysis/rho0.285714_{mode}")
            group["k"], group["c"] = [0.14, 0.28], [c, 1.0]
            group["gamma"], group["omega"] = [gamma, 1.0], [omega, 1.0]


def test_cells_of_a_known_file(tmp_path):
    _results(tmp_path / "a.h5", dropped=False)
    header, cells = frictional_table.column(str(tmp_path / "a.h5"))
    assert header == "μ = 1"
    assert cells["φ"] == "0.810" and cells["z (non-rattlers)"] == "3.60"
    assert cells["modes below ω = 0.5"] == "16.7 %"
    assert cells["unstable eigenvalues"] == "6 of 202"
    assert cells["largest growth rate (1/t0)"] == "2.0e-05"
    assert cells["c_L, c_T at k d0 = 0.14 (d0/t0)"] == "0.600, 0.300"
    assert cells["γ_L, γ_T at k d0 = 0.14 (1/t0)"] == "4.0e-03, 3.0e-03"
    assert cells["ω_r(0), its damping (1/t0)"] == "2.200, 0.125"
    _results(tmp_path / "b.h5", dropped=True)
    assert frictional_table.column(str(tmp_path / "b.h5"))[0] == "μ = 1, dropped"
