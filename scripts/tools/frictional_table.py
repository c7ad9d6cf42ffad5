"""The README table of configs/frictional.yaml: what friction does to sound at one pressure.

    .venv/bin/python -m scripts.tools.frictional_table results/frictional_mu0.h5 results/frictional_mu0.1.h5 \
        results/frictional_mu0.3.h5 results/frictional_mu1.h5 results/frictional_mu1_dropped.h5
One column per results file (its packings' mu; "dropped" when the scene dropped the stored
forces), rows: pressure, phi and z (means over the packings), the share of the vDOS below
omega = 0.5, the unstable (complex and negative) eigenvalues of every packing against all of
them, the largest growth rate, c and gamma of L and TR at the smallest k, and omega_r(0) and its
damping (RT at the smallest k).  Prints Markdown.  Not MPI.
"""

from __future__ import annotations

import argparse

import h5py
import numpy as np
import yaml


def column(path: str) -> tuple[str, dict[str, str]]:
    """(header, row name -> cell) of one results file."""
    with h5py.File(path, "r") as f:
        scene = yaml.safe_load(f.attrs["scene"])
        packings = [f["packings"][name].attrs for name in sorted(f["packings"])]
        mu = packings[0].get("friction", 0.0)
        dropped = scene.get("model", {}).get("stored_forces") == "drop"
        header = f"μ = {mu:g}" + (", dropped" if dropped else "")
        vdos = f["vdos/r00"]
        edges, density = vdos["edges"][()], vdos["density"][()]
        below = float((density * np.diff(edges))[edges[1:] <= 0.5 + 1e-12].sum())
        spectra = [f["spectra"][name] for name in sorted(f["spectra"])]
        cells = {"pressure (kn)": f"{np.mean([p['pressure'] for p in packings]):.4e}",
                 "φ": f"{np.mean([p['phi'] for p in packings]):.3f}",
                 "z (non-rattlers)": f"{np.mean([p['z'] for p in packings]):.2f}",
                 "modes below ω = 0.5": f"{100 * below:.1f} %"}
        if "n_complex" in spectra[0].attrs:
            unstable = sum(int(s.attrs["n_complex"]) + int(s.attrs["n_negative_modes"]) for s in spectra)
            total = sum(s["omega2"].size + int(s.attrs["n_zero_modes"]) for s in spectra)
            cells["unstable eigenvalues"] = f"{unstable} of {total:,}".replace(",", " ")
            cells["largest growth rate (1/t0)"] = f"{max(float(s.attrs['max_growth']) for s in spectra):.1e}"
        else:
            cells["unstable eigenvalues"] = "(counted: symmetric)"
            cells["largest growth rate (1/t0)"] = "–"
        analysis = f["analysis"]
        rho = next(name.split("_")[0] for name in analysis if name.endswith("_L"))
        wave = {mode: analysis[f"{rho}_{mode}"] for mode in ("L", "TR", "RT")}
        k = wave["L"]["k"][0]
        cells[f"c_L, c_T at k d0 = {k:.2f} (d0/t0)"] = f"{wave['L']['c'][0]:.3f}, {wave['TR']['c'][0]:.3f}"
        cells[f"γ_L, γ_T at k d0 = {k:.2f} (1/t0)"] = f"{wave['L']['gamma'][0]:.1e}, {wave['TR']['gamma'][0]:.1e}"
        cells["ω_r(0), its damping (1/t0)"] = f"{wave['RT']['omega'][0]:.3f}, {wave['RT']['gamma'][0]:.3f}"
    return header, cells


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="+")
    args = parser.parse_args()
    columns = [column(path) for path in args.files]
    rows = list(dict.fromkeys(name for _, cells in columns for name in cells))
    print("| | " + " | ".join(header for header, _ in columns) + " |")
    print("|---|" + "---|" * len(columns))
    for name in rows:
        print(f"| {name} | " + " | ".join(cells.get(name, "") for _, cells in columns) + " |")


if __name__ == "__main__":
    main()
