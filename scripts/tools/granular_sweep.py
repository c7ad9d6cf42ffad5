"""The finite-amplitude sweep with rolling and twisting resistance (issue 61 point 2;
docs/finite_amplitude.md section 7): LAMMPS's pair granular on the 3D frictional packing it
settled (tests/data/dem/lammps_3d_granular: 128 spheres, mu = 0.5, its stored tangential forces
in LAMMPS's history), rolling and twisting springs switched on unstressed, R (twist) and TR
standing waves at k = 2 pi / L along x, amplitudes 1e-5 ... 1e-2.

    .venv/bin/python -m scripts.tools.granular_sweep [--figure docs/finite_amplitude_granular.png]

Springs kt = 2/7 kn (the packing's), k_roll = kt / 2, ko = 0.3 kt (``ContactModel`` ratios;
``history: granular``, ``lever: contact``).  Four sets of Coulomb limits: all on (mu = 0.5,
mu_roll = 0.1, mu_twist = 0.05 d0) and each lifted in turn (sliding: mu = 5; rolling, twisting:
1e4), so that what one limit does to the wave is the difference from the run without it:
LAMMPS 2022's ``compute pair/local`` reports no twisting torque, so twisting contacts at their
limit cannot be counted, only their effect seen.  Per run: the most contacts sliding and rolling
at their limits at once (``lammps_dem.Contacts``), omega and gamma of the damped cosine fitted to
C(k, t) (``fits.fit_damped_cosine``) and their departure from the linear wave, exp(tJ) of the
stressed stick matrix (``references.first_order_flow``).  Predicted from that linear wave
(:func:`first_limits`): the amplitude at which its first contact would reach each limit.
Prints Markdown.  One process: LAMMPS
on MPI.COMM_SELF, the matrix on PETSc.COMM_SELF.  About two minutes.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "tests" / "data" / "dem" / "lammps_3d_granular"
KT = 2.0 / 7.0  # the packing's tangential stiffness (lammps_3d_granular.in), kn = 1
RATIOS = (KT, 0.5 * KT, 0.3 * KT)  # rho, rho_roll, rho_twist
LIMITS = {"all": (0.5, 0.1, 0.05), "no sliding": (5.0, 0.1, 0.05), "no rolling limit": (0.5, 1e4, 0.05),
          "no twisting limit": (0.5, 0.1, 1e4)}  # (mu, mu_roll, mu_twist in d0)
AMPLITUDES = (1e-5, 1e-4, 1e-3, 1e-2, 3e-2, 1e-1)  # d0/t0 (TR) or 1/t0 (R)
MODES = ("R", "TR")
SHARE = 0.05  # the first limits' table also gives the amplitude at which this share of the contacts reached each
DT, SAMPLE, T_END = 0.02, 0.1, 100.0  # t0


def packing(model):
    """The committed packing under ``model``'s lever, equal masses, stored forces' mu unknown."""
    from solver.io import hdf5

    p = hdf5.read_packings(str(DATA.with_suffix(".data")), model=model, contacts=str(DATA.with_suffix(".contacts")))[0]
    return dataclasses.replace(p, masses=None, tangential=dataclasses.replace(p.tangential, friction=None))


def first_limits(p, model, active: np.ndarray, flow: np.ndarray, limits: tuple) -> dict[str, np.ndarray]:
    """The amplitudes (2,) at which the first contact, and ``SHARE`` of them, of the linear wave ``flow`` (S, 2, N', 6: u, theta
    and their rates at unit amplitude, ``references.first_order_flow``) reaches each Coulomb limit
    of ``limits`` (mu, mu_roll, mu_twist), every contact's normal force kept at its rest value
    kn xi [choice]: sliding when kt |s_t| reaches mu xi - |f_t0| (f_t0 the stored force, s_t the
    slip at the radii, pair granular's), rolling when k_roll a' |dtheta x n| reaches mu_roll xi,
    twisting when k_twist |n . dtheta| (k_twist = rho_twist a'^2) reaches mu_twist xi
    (dtheta = theta_i - theta_j).  Contacts with a rattler are left out (it does not move).
    Not collective."""
    from solver.packing import geometry

    found = geometry.find_contacts(p.positions, p.diameters, p.box)
    keep = active[found.i] & active[found.j]
    index = np.cumsum(active) - 1  # packing index -> row of the flow
    i, j, n, xi = index[found.i[keep]], index[found.j[keep]], found.normal[keep], found.overlap[keep]
    r_i, r_j = 0.5 * p.diameters[found.i[keep]], 0.5 * p.diameters[found.j[keep]]
    reduced = r_i * r_j / (r_i + r_j)
    stored = np.linalg.norm(p.tangential.on(found.i[keep], found.j[keep]), axis=1)
    u, theta = flow[:, 0, :, :3], flow[:, 0, :, 3:]
    du, turn = u[:, i] - u[:, j], theta[:, i] - theta[:, j]
    normal_part = np.einsum("scd,cd->sc", du, n)[:, :, None] * n
    slip = du - normal_part - np.cross(r_i[:, None] * theta[:, i] + r_j[:, None] * theta[:, j], n)
    mu, mu_roll, mu_twist = limits
    rho, rho_roll, rho_twist = model.rho, model.rho_roll, model.rho_twist
    largest = {"sliding": rho * np.linalg.norm(slip, axis=2).max(axis=0),
               "rolling": rho_roll * reduced * np.linalg.norm(np.cross(turn, n), axis=2).max(axis=0),
               "twisting": rho_twist * reduced**2 * np.abs(np.einsum("scd,cd->sc", turn, n)).max(axis=0)}
    slack = {"sliding": np.maximum(mu * xi - stored, 0.0), "rolling": mu_roll * xi, "twisting": mu_twist * xi}
    return {name: np.quantile(slack[name] / largest[name], (0.0, SHARE)) for name in largest}


def sweep() -> list[dict]:
    """One row per (mode, limits, amplitude), with the linear wave's fit first in each mode
    (limits "linear").  Not collective (one process)."""
    from mpi4py import MPI

    from solver import petscenv, references
    from solver.analysis import fits
    from solver.contact_law import ContactModel
    from solver.model import dynmat
    from solver.waves import correlations, excitation, lammps_dem

    PETSc = petscenv.init([])
    model = ContactModel(*RATIOS, lever="contact", history="granular")
    p = packing(model)
    k = 2 * np.pi / float(p.box[0])
    t = np.arange(int(round(T_END / SAMPLE)) + 1) * SAMPLE
    rows = []
    for mode in MODES:
        component, axis = excitation.runs(mode, 3)[0]
        dm = dynmat.assemble(p, model, PETSc.COMM_SELF)
        try:
            start = excitation.whole_start(dm, p.positions, component, axis, k, 1.0, MPI.COMM_SELF)
            phase = np.exp(-1j * k * p.positions[dm.active, axis])
            flow = references.first_order_flow(dm, start, SAMPLE, t.size)
            linear = flow[:, 1, :, component] @ phase
            active = dm.active
        finally:
            dm.destroy()
        reference = fits.fit_damped_cosine(t, correlations.vaf(linear))
        rows.append({"mode": mode, "limits": "linear", "A": 0.0, "fit": reference, "sliding": 0, "rolling": 0, "opened": 0,
                     "first": first_limits(p, model, active, flow, LIMITS["all"])})
        for name, (mu, mu_roll, mu_twist) in LIMITS.items():
            for amplitude in AMPLITUDES:
                z, contacts = lammps_dem.run(p.positions, p.diameters, p.box, active, model, mu, amplitude * start, DT,
                                             int(round(T_END / DT)), int(round(SAMPLE / DT)), 1e-9, (component, phase),
                                             MPI.COMM_SELF, tangential=p.tangential, rolling_friction=mu_roll,
                                             twisting_friction=mu_twist)
                rows.append({"mode": mode, "limits": name, "A": amplitude, "fit": fits.fit_damped_cosine(t, correlations.vaf(z)),
                             "sliding": int(contacts.sliding.max()), "rolling": int(contacts.rolling.max()),
                             "opened": int(contacts.opened.max()),
                             "C": correlations.vaf(z)})
    return rows


def table(rows: list[dict]) -> str:
    """Markdown: the predicted first limits per mode, then per mode and limits, the amplitude,
    the contacts at their limits and opened (the most at once), omega and gamma with their departure from the linear wave's (%)."""
    lines = [f"| mode | A: first sliding ({100 * SHARE:g} % of contacts) | first rolling | first twisting |",
             "|---|---|---|---|"]
    for row in rows:
        if row["limits"] == "linear":
            cells = " | ".join(f"{a:.1e} ({b:.1e})" for a, b in (row["first"][name] for name in
                                                                 ("sliding", "rolling", "twisting")))
            lines.append(f"| {row['mode']} | {cells} |")
    lines += ["", "| mode | Coulomb limits | A | sliding | rolling | opened | ω | ω / ω_lin − 1 | γ | γ / γ_lin |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        fit = row["fit"]
        if row["limits"] == "linear":
            base = fit
            lines.append(f"| {row['mode']} | linear (stick matrix) | – | – | – | – | {fit.omega:.4f} | – | "
                         f"{fit.gamma:.2e} | – |")
            continue
        lines.append(f"| {row['mode']} | {row['limits']} | {row['A']:.0e} | {row['sliding']} | {row['rolling']} | {row['opened']} | "
                     f"{fit.omega:.4f} | {100 * (fit.omega / base.omega - 1):+.2f} % | {fit.gamma:.2e} | "
                     f"{fit.gamma / base.gamma:.2f} |")
    return "\n".join(lines)


def figure(rows: list[dict], path: str) -> None:
    """C(k, t) of the R wave at every amplitude with all limits on, against the linear wave."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.arange(int(round(T_END / SAMPLE)) + 1) * SAMPLE
    fig, ax = plt.subplots(figsize=(6.0, 3.2))
    for row in rows:
        if row["mode"] == "R" and row["limits"] == "all":
            ax.plot(t, row["C"], lw=0.8, label=f"A = {row['A']:.0e}")
    ax.set_xlabel(r"$t\ (t_0)$")
    ax.set_ylabel(r"$C(k, t)$, R wave")
    ax.set_xlim(0, 30)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figure", help="write the R wave's C(k, t) at every amplitude here (PNG)")
    args = parser.parse_args()
    rows = sweep()
    print(table(rows))
    if args.figure:
        figure(rows, args.figure)


if __name__ == "__main__":
    main()
