"""Findings on wave diffusion (issue 45, point 4) from the results of configs/diffusivity.yaml:

    python -m scripts.tools.diffusivity_findings results/diffusivity_*.h5 [--figures docs/] \
        [--attenuation scripts/tools/rayleigh_table.md] > scripts/tools/diffusivity_findings.md

Per results file and rho: the packing (z over the non-rattlers, Delta z = z - z_iso with z_iso =
2 D for frictionless particles, D + 1 with tangential springs; the pressure), and from the
``transport`` section's per-mode d_n:

- the plateau d_p: the median d_n of the modes between the 40th and 80th percentile of omega
  (above the crossover, below the localised modes at the top of the band);
- the crossover omega* (frictionless packings; with rotations the percentiles above fall in the
  rotational band): scanning the vDOS's bins down from the plateau's lower end, the first bin
  whose mean d exceeds 2 d_p (linear interpolation in log d between bin centres); Xu et al.'s
  omega_d*, which they find proportional to Delta z;
- with rotations (spectrum energies: per-mode K and Q), each mode's rotational share w_R = 2 r N Q
  (r = 1 in 2D, 3 in 3D; ``spectrum.kpm.energies``) and the mean d of the translational (w_R <
  1/2) and the rotational (w_R >= 1/2) modes;
- localisation: the participation ratio P_n beside d_n (Spearman's rank correlation; the mean d of
  the 1 % least extended modes against all).

With ``--attenuation`` (scripts/tools/rayleigh_table.md, the attenuation gamma(k) of the L and TR standing
waves of a 262 144-disk packing at phi = 0.9, rho = 0 and 1): the mean free path l = c / (2 gamma)
(gamma: the amplitude's decay rate, so the energy decays at 2 gamma; c = omega / k) and, per
frequency, the diffusivity those waves predict, d_gamma(omega) = [1/gamma_L + 1/gamma_T] /
(2 D [1/c_L^2 + 1/c_T^2]) (each branch's d = c l / D weighted by its 2D Debye density of states ~
omega / c^2), against the Allen-Feldman d(omega) of the disks of the same phi and rho.
Prints Markdown; draws the figures.  Reads only: no MPI, no PETSc.
"""

from __future__ import annotations

import argparse
import re

import numpy as np
from scipy import stats

from solver.io import results
from solver.plots.common import DPI, plt, series_colour
from solver.spectrum.modes import rotation_components

PLATEAU = (0.4, 0.8)  # percentiles of omega over which d_p is the median d_n
LOCALISED = 0.01      # the fraction of modes of lowest participation


def crossover(g, plateau: float) -> float:
    """omega* of one rho's ``results.Diffusivity`` ``g`` (module docstring); NaN if d never rises
    to 2 d_p below the plateau."""
    return crossover_below(g.edges, g.d_binned, g.count, np.quantile(g.omega, PLATEAU[0]), plateau)


def crossover_below(edges: np.ndarray, d_binned: np.ndarray, count: np.ndarray, lower: float, plateau: float) -> float:
    """Scanning the bins ``edges`` (B+1,) whose centres lie below ``lower`` downwards, the first
    whose mean d (``d_binned`` (B,), from ``count`` (B,) modes; bins of fewer than 3 modes skipped)
    exceeds 2 ``plateau``: omega* by linear interpolation in log d between it and the bin above;
    NaN if none does, or if the first bin scanned does already (omega* would lie above ``lower``)."""
    centres = 0.5 * (edges[1:] + edges[:-1])
    below = np.flatnonzero((centres < lower) & np.isfinite(d_binned) & (count >= 3))[::-1]
    if below.size and d_binned[below[0]] > 2 * plateau:
        return float("nan")
    for i, j in zip(below[:-1], below[1:]):  # i above j
        if d_binned[j] > 2 * plateau:
            x = (np.log(2 * plateau) - np.log(d_binned[i])) / (np.log(d_binned[j]) - np.log(d_binned[i]))
            return float(centres[i] + x * (centres[j] - centres[i]))
    return float("nan")


def measure(path: str) -> list[dict]:
    """One row per rho of the results file ``path`` (module docstring)."""
    rows = []
    with results.open_results(path) as f:
        packing = results.packing(f, 0)
        group = f["packings/0000"]
        dim = packing["positions"].shape[1]
        pressure = float(group.attrs["pressure"])
        energies = results.mode_energies(f)
        participation = results.participation(f)
        for rho, g in sorted(results.diffusivity(f).items()):
            n = int((~packing["rattler"]).sum())
            rotations = rho > 0
            z_iso = dim + 1 if rotations else 2 * dim
            window = (g.omega >= np.quantile(g.omega, PLATEAU[0])) & (g.omega <= np.quantile(g.omega, PLATEAU[1]))
            plateau = float(np.median(g.d[window]))
            row = {"file": path, "dim": dim, "N": n, "rho": rho, "phi": packing["phi"], "z": packing["z"],
                   "dz": packing["z"] - z_iso, "pressure": pressure, "eta": g.eta, "d_p": plateau,
                   "omega_star": float("nan") if rotations else crossover(g, plateau), "g": g,
                   "modes": g.omega.size}
            if rho in participation:
                omega_p, p = participation[rho]
                same = omega_p.size == g.omega.size and np.allclose(omega_p, g.omega, rtol=1e-8, atol=0.0)
                if same:
                    row["P"] = p
                    row["spearman"] = float(stats.spearmanr(p, g.d).statistic)
                    lowest = np.argsort(p)[:max(1, int(LOCALISED * p.size))]
                    row["d_localised"] = float(g.d[lowest].mean())
                    row["omega_localised"] = float(np.median(g.omega[lowest]))
            if rotations and rho in energies:
                omega_e, _, q = energies[rho]
                if omega_e.size == g.omega.size and np.allclose(omega_e, g.omega, rtol=1e-8, atol=0.0):
                    share = 2 * rotation_components(dim) * n * q
                    row["w_R"] = share
                    row["d_T"] = float(g.d[share < 0.5].mean())
                    row["d_R"] = float(g.d[share >= 0.5].mean()) if (share >= 0.5).any() else float("nan")
                    row["n_R"] = int((share >= 0.5).sum())
            rows.append(row)
    return rows


def attenuation_table(path: str) -> dict[tuple[str, float], np.ndarray]:
    """{(mode, rho): (K, 3) array of k d0, omega t0, gamma t0} from scripts/tools/rayleigh_table.md."""
    tables, key = {}, None
    for line in open(path, encoding="utf-8"):
        head = re.match(r"## (\w+), rho = ([\d.]+)", line)
        if head:
            key = (head.group(1), float(head.group(2)))
            tables[key] = []
        elif key and re.match(r"\| [\d.]", line):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            tables[key].append([float(cells[0]), float(cells[1]), float(cells[2])])
    return {k: np.array(v) for k, v in tables.items()}


def predicted(table: dict, rho: float, omega: np.ndarray) -> np.ndarray:
    """d_gamma(omega) (module docstring) where both branches were measured (NaN elsewhere), 2D."""
    parts = []
    for mode in ("L", "TR"):
        k, w, gamma = table[(mode, rho)].T
        c = w / k
        inside = (omega >= w.min()) & (omega <= w.max())
        parts.append((np.where(inside, np.interp(omega, w, gamma), np.nan), np.interp(omega, w, c)))
    (g_l, c_l), (g_t, c_t) = parts
    return (1 / g_l + 1 / g_t) / (2 * 2 * (1 / c_l**2 + 1 / c_t**2))


def _figures(rows: list[dict], table: dict | None, folder: str) -> list[str]:
    """Write the figures (:func:`draw`) into ``folder`` as PNG; return their paths."""
    written = []
    for name, fig in draw(rows, table).items():
        written.append(f"{folder}/{name}.png")
        fig.savefig(written[-1], dpi=DPI)
        plt.close(fig)
    return written


def draw(rows: list[dict], table: dict | None) -> dict:
    """The figures of ``rows`` (:func:`measure`) and the attenuation ``table``, {file name without
    .png: figure}, open: d(omega) of the frictionless spheres and omega* against Delta z, d_n
    coloured by the rotational share, d_n against the participation, d against attenuation."""
    drawn = {}
    spheres = sorted((r for r in rows if r["dim"] == 3 and r["rho"] == 0), key=lambda r: r["dz"])
    if spheres:
        fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4.2))
        for i, r in enumerate(spheres):
            g = r["g"]
            colour = series_colour(i, len(spheres))
            centres = 0.5 * (g.edges[1:] + g.edges[:-1])
            ax.plot(centres, g.d_binned, "-", color=colour, label=rf"$\Delta z$ = {r['dz']:.2f}, $p$ = {r['pressure']:.1e}")
            if np.isfinite(r["omega_star"]):
                ax.axvline(r["omega_star"], color=colour, ls=":", lw=0.8)
        ax.set(xscale="log", yscale="log", xlabel=r"$\omega\,t_0$", ylabel=r"$d(\omega)\;[d_0^2/t_0]$",
               title=f"frictionless spheres, $N$ = {spheres[0]['N']}-{spheres[-1]['N']} (non-rattlers)\n"
                     f"$d(\\omega)$, dotted: $\\omega^*$")
        ax.legend(fontsize=7)
        dz = np.array([r["dz"] for r in spheres])
        star = np.array([r["omega_star"] for r in spheres])
        ok = np.isfinite(star)
        bx.loglog(dz[ok], star[ok], "o", label=r"$\omega^*$")
        if ok.sum() >= 2:
            slope, icpt = np.polyfit(np.log(dz[ok]), np.log(star[ok]), 1)
            line = np.geomspace(dz[ok].min(), dz[ok].max(), 20)
            bx.loglog(line, np.exp(icpt) * line**slope, "k--", lw=0.8, label=rf"fit $\propto \Delta z^{{{slope:.2f}}}$")
        bx.set(xlabel=r"$\Delta z = z - 6$", ylabel=r"$\omega^*\,t_0$", title=r"crossover against $\Delta z$")
        bx.legend(fontsize=8)
        fig.tight_layout()
        drawn["diffusivity_spheres"] = fig
    rotating = [r for r in rows if "w_R" in r]
    if rotating:
        fig, axes = plt.subplots(1, len(rotating), figsize=(4.2 * len(rotating), 4.0), squeeze=False, sharey=True)
        for ax, r in zip(axes[0], rotating):
            g = r["g"]
            dots = ax.scatter(g.omega, g.d, c=r["w_R"], s=2, cmap="coolwarm", vmin=0, vmax=1)
            ax.set(yscale="log", xlabel=r"$\omega\,t_0$", title=rf"{r['dim']}D, N = {r['N']}, $\rho$ = {r['rho']:.3g}")
        axes[0][0].set_ylabel(r"$d_n\;[d_0^2/t_0]$")
        fig.colorbar(dots, ax=axes[0].tolist(), label="rotational share of the mode")
        drawn["diffusivity_rotations"] = fig
    localised = [r for r in rows if "P" in r]
    if localised:
        fig, ax = plt.subplots(figsize=(6.4, 4.2))
        for r in localised:
            ax.loglog(r["P"], r["g"].d, ".", ms=2, alpha=0.4,
                      label=rf"{r['dim']}D $\rho$ = {r['rho']:.3g}, $\phi$ = {r['phi']:.2f}")
        ax.set(xlabel="participation ratio $P_n$", ylabel=r"$d_n\;[d_0^2/t_0]$", title="localised modes carry little")
        ax.legend(fontsize=7, markerscale=4)
        fig.tight_layout()
        drawn["diffusivity_localised"] = fig
    disks = {r["rho"]: r for r in rows if r["dim"] == 2 and abs(r["phi"] - 0.9) < 1e-6}
    if table and any(rho in disks for rho in (0.0, 1.0)):
        fig, ax = plt.subplots(figsize=(6.4, 4.2))
        for rho, colour in ((0.0, "k"), (1.0, "C3")):
            if rho not in disks:
                continue
            g = disks[rho]["g"]
            centres = 0.5 * (g.edges[1:] + g.edges[:-1])
            ax.plot(centres, g.d_binned, "-", color=colour, label=rf"Allen-Feldman, N = {disks[rho]['N']}, $\rho$ = {rho:g}")
            omega = np.geomspace(0.02, 1.8, 200)
            ax.plot(omega, predicted(table, rho, omega), "--", color=colour,
                    label=rf"from $\gamma_L, \gamma_T$ (N = 262144), $\rho$ = {rho:g}")
        ax.set(xscale="log", yscale="log", xlabel=r"$\omega\,t_0$", ylabel=r"$d(\omega)\;[d_0^2/t_0]$",
               title=r"diffusivity against attenuation, disks at $\phi$ = 0.9")
        ax.legend(fontsize=7)
        fig.tight_layout()
        drawn["diffusivity_attenuation"] = fig
    return drawn


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("paths", nargs="+")
    parser.add_argument("--figures", help="folder to draw the figures into")
    parser.add_argument("--attenuation", help="scripts/tools/rayleigh_table.md, for the comparison with gamma(k)")
    args = parser.parse_args(argv)
    rows = [row for path in args.paths for row in measure(path)]
    print("# Wave diffusion: findings from configs/diffusivity.yaml\n")
    print("| file | D | N | rho | phi | z | Delta z | pressure | eta | modes | d_p [d0^2/t0] | omega* t0 | "
          "d of 1 % least extended | Spearman(P, d) | d translational | d rotational (modes) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['file'].split('/')[-1]} | {r['dim']} | {r['N']} | {r['rho']:.3g} | {r['phi']:.3f} | "
              f"{r['z']:.3f} | {r['dz']:.3f} | {r['pressure']:.3e} | {r['eta']:g} | {r['modes']} | {r['d_p']:.4g} | "
              f"{r['omega_star']:.3g} | "
              + (f"{r['d_localised']:.3g} (at omega {r['omega_localised']:.3g}) | {r['spearman']:.2f} | "
                 if "P" in r else "- | - | ")
              + (f"{r['d_T']:.3g} | {r['d_R']:.3g} ({r['n_R']}) |" if "w_R" in r else "- | - |"))
    spheres = [r for r in rows if r["dim"] == 3 and r["rho"] == 0 and np.isfinite(r["omega_star"])]
    if len(spheres) >= 2:
        dz, star = np.array([r["dz"] for r in spheres]), np.array([r["omega_star"] for r in spheres])
        slope, icpt = np.polyfit(np.log(dz), np.log(star), 1)
        print(f"\nomega* = {np.exp(icpt):.3g} Delta z^{slope:.3f} over {len(spheres)} frictionless sphere packings "
              f"(least squares in logs; Xu et al.: exponent 1)")
    table = attenuation_table(args.attenuation) if args.attenuation else None
    if table:
        print("\n## Against attenuation (disks, phi = 0.9)\n")
        print("| rho | omega t0 | d Allen-Feldman | d from gamma_L, gamma_T | ratio | l_L = c_L / (2 gamma_L) [d0] | "
              "l_T = c_T / (2 gamma_T) [d0] | lambda_T / 2 [d0] |")
        print("|---|---|---|---|---|---|---|---|")
        for r in rows:
            if r["dim"] != 2 or abs(r["phi"] - 0.9) > 1e-6 or (("TR", r["rho"]) not in table):
                continue
            g = r["g"]
            centres = 0.5 * (g.edges[1:] + g.edges[:-1])
            k, w, gamma = table[("TR", r["rho"])].T
            for omega in w:
                if omega < centres[np.isfinite(g.d_binned)].min() or omega > 1.8:
                    continue
                d_af = float(np.interp(omega, centres[np.isfinite(g.d_binned)], g.d_binned[np.isfinite(g.d_binned)]))
                d_g = float(predicted(table, r["rho"], np.array([omega]))[0])
                c_t = float(np.interp(omega, w, w / k))
                l_t = c_t / (2 * float(np.interp(omega, w, gamma)))
                k_l, w_l, gamma_l = table[("L", r["rho"])].T
                l_l = (float(np.interp(omega, w_l, w_l / k_l)) / (2 * float(np.interp(omega, w_l, gamma_l)))
                       if w_l.min() <= omega <= w_l.max() else float("nan"))
                print(f"| {r['rho']:g} | {omega:.4g} | {d_af:.3g} | {d_g:.3g} | {d_af / d_g:.2f} | {l_l:.3g} | "
                      f"{l_t:.3g} | {np.pi * c_t / omega:.3g} |")
    if args.figures:
        for path in _figures(rows, table, args.figures):
            print(f"\nfigure: {path}")


if __name__ == "__main__":
    main()
