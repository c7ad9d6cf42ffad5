"""The plateau onset omega* of the vDOS of frictional packings against z - z_iso (issue 25, item 4),
from the results of configs/frictional_scaling.yaml:

    python -m scripts.tools.frictional_scaling results/scaling_*.h5 [--figure docs/frictional_scaling.png]

Per results file: mu and the pressure of its packings (their attributes), z (the mean over its
configurations; non-rattlers), and omega*: where the vDOS D(omega) first reaches half its plateau
D_p, the mean of D over 0.8 <= omega <= 1.2 (below the bands of the rotations; linear
interpolation between bin centres).  z_iso = D + 1 = 3 for every packing, mu = 0 included: it
is the rigidity count of the matrix the vDOS is of, whose tangential springs give every contact D
constraints on D(D + 1)/2 DOF per particle, contacts at the Coulomb limit sticking
(model.mobilised: stick; their count, n_mobilised, is printed: with mobilised: slide each would
raise z_iso by 2/(D N)).  Prints a Markdown table, fits omega* = a (z - z_iso)^b per mu and over
all (least squares in logs), and draws omega* against z - z_iso.  Reads only: no MPI, no PETSc.
"""

from __future__ import annotations

import argparse
import sys

import h5py
import numpy as np

PLATEAU = (0.8, 1.2)  # 1/t0: the band over which D_p is averaged


def onset(edges: np.ndarray, density: np.ndarray) -> tuple[float, float]:
    """(omega*, D_p) of one vDOS (module docstring)."""
    centres = 0.5 * (edges[1:] + edges[:-1])
    plateau = float(density[(centres >= PLATEAU[0]) & (centres <= PLATEAU[1])].mean())
    above = np.flatnonzero(density >= 0.5 * plateau)[0]
    if above == 0:
        return float(centres[0]), plateau
    lo, hi = density[above - 1], density[above]
    return float(np.interp(0.5 * plateau, [lo, hi], centres[above - 1:above + 1])), plateau


def measure(path: str) -> dict:
    """mu, pressure, z, n_mobilised, omega*, D_p of one results file."""
    with h5py.File(path, "r") as f:
        packings = [f["packings"][k].attrs for k in sorted(f["packings"])]
        vdos = f["vdos"][sorted(f["vdos"])[0]]
        star, plateau = onset(vdos["edges"][()], vdos["density"][()])
        mu = float(packings[0].get("friction", 0.0))
        z = float(np.mean([a["z"] for a in packings]))
        return {"file": path, "mu": mu, "pressure": float(np.mean([a["pressure"] for a in packings])),
                "phi": float(np.mean([a["phi"] for a in packings])), "z": z,
                "z_iso": 3.0, "n_mobilised": int(sum(a.get("n_mobilised", 0) for a in packings)),
                "omega_star": star, "plateau": plateau, "configurations": len(packings)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="+")
    parser.add_argument("--figure", default="docs/frictional_scaling.png")
    args = parser.parse_args()
    rows = sorted((measure(p) for p in args.files), key=lambda r: (r["mu"], r["pressure"]))
    print("| mu | pressure (kn) | phi | z | z - z_iso | n_mobilised | D_p | omega* (1/t0) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['mu']:g} | {r['pressure']:.2e} | {r['phi']:.4f} | {r['z']:.3f} | {r['z'] - r['z_iso']:.3f} | "
              f"{r['n_mobilised']} | {r['plateau']:.3f} | {r['omega_star']:.3f} |")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 4))
    for mu in sorted({r["mu"] for r in rows}):
        sub = [r for r in rows if r["mu"] == mu]
        dz = np.array([r["z"] - r["z_iso"] for r in sub])
        star = np.array([r["omega_star"] for r in sub])
        slope, intercept = np.polyfit(np.log(dz), np.log(star), 1) if len(sub) > 1 else (np.nan, np.nan)
        print(f"mu = {mu:g}: omega* = {np.exp(intercept):.3f} (z - z_iso)^{slope:.2f}")
        ax.loglog(dz, star, "o-", label=f"μ = {mu:g} (slope {slope:.2f})")
    dz = np.array([r["z"] - r["z_iso"] for r in rows])
    star = np.array([r["omega_star"] for r in rows])
    slope, intercept = np.polyfit(np.log(dz), np.log(star), 1)
    spread = np.exp(np.abs(np.log(star) - (intercept + slope * np.log(dz))).max())
    print(f"all: omega* = {np.exp(intercept):.3f} (z - z_iso)^{slope:.2f}, every point within a factor {spread:.2f}")
    grid = np.geomspace(dz.min(), dz.max(), 20)
    ax.loglog(grid, np.exp(intercept) * grid ** slope, "k--", lw=0.8, label=f"all: slope {slope:.2f}")
    ax.set_xlabel("z − z_iso")
    ax.set_ylabel("ω* (1/t0)")
    ax.set_title("vDOS plateau onset, unstressed matrix")
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.figure, dpi=120)
    print(f"wrote {args.figure}")


if __name__ == "__main__":
    sys.exit(main())
