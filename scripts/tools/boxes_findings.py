"""The findings of issue 59 (docs/boxes.md): packings in a sheared cell against the square cell's,
and the modes of a packing between walls near the walls against the bulk.

    .venv/bin/python -m scripts.tools.boxes_findings results/boxes_phi*.h5 [--save results]
        [--waves results/boxes_waves_*.h5] [--figures docs] [--walls-n 1024]

Sheared cells.  Each results file of configs/boxes.yaml is one scene, square or with
packing.shear (made, before rotsound sheared quasi-statically, by FIRE in the tilted cell); its
square configurations are also sheared quasi-statically to ``--strain``
(``solver.packing.shear.quasistatic``; ``--save`` writes them as a packing file for
configs/boxes_waves.yaml).  For each: phi, the pressure and the shear stress sigma_xy
(``mechanics.stress``: compressive positive), the vDOS (every eigenvalue), and the long-wave
sound speeds of every configuration from its own matrix (:func:`elastic_tensor`, :func:`speeds`)
along x (the shear's direction), y (across it), the diagonals, and their spread over every
direction; means over configurations.  Each sheared scene is compared with the square scenes at
its pressure (:func:`comparison`).  ``--waves``: the standing waves of configs/boxes_waves.yaml
at the smallest k against the long-wave speeds along the same reciprocal direction
(:func:`waves_scene`).

Walls.  :func:`walled_packing` makes 2D packings between two flat walls in y, periodic in x (FIRE
on the frictionless energy with the walls' harmonic push; rotsound has no walled generator), at
rho = 1 as the sheared cells; :func:`wall_layers` splits every mode's kinetic energy between the
particles within ``LAYER`` of a wall and the rest (the full eigendecomposition: dense, a few
thousand DOF).

Prints Markdown tables; draws ``boxes_vdos.png`` (the vDOS of the three kinds at the middle phi),
``boxes_speeds.png`` (c(theta) at the middle phi; c_L, c_T along x and along the compressed
diagonal against the pressure) and ``boxes_walls.png`` (the layer's share of each mode's kinetic
energy against omega, and the local vDOS of the layer and of the bulk) into ``--figures``.  Not
MPI (one process; the matrix on PETSc.COMM_SELF).
"""

from __future__ import annotations

import argparse
import os

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl
import yaml

from solver.contact_law import ContactModel, pair_blocks
from solver.io import hdf5, results
from solver.model import dynmat
from solver.packing import fire, geometry, jammed, mechanics, shear
from solver.packing import walls as walling
from solver.packing.configuration import Packing
from solver.plots.common import DPI, legend, plt

LAYER = 2.0
"""The near-wall layer: particles whose centres are within LAYER d0 of a wall."""

RHO = 1.0
"""kt / kn of every matrix here (configs/boxes.yaml; the paper's rotational band)."""

DIRECTIONS = 72
"""Directions of the speeds' angular scan over [0, pi)."""


def elastic_tensor(packing, model: ContactModel) -> tuple[np.ndarray, float]:
    """(A (D, D, D, D), rho_m): the relaxed long-wave stiffness of ``packing`` under ``model``,
    A[a, b, c, d] = (1/V) d^2 E / dG_ab dG_cd with every particle's non-affine displacement and
    rotation relaxed, for the displacement gradient G (u_i = G r_i) of the matrix's own quadratic
    form (its geometric prestress term included, so A is what a long plane wave meets:
    rho_m omega^2 e_a = k^2 A[a, b, c, d] n_b n_d e_c), units kn d0^(2-D); rho_m the mass of the
    non-rattlers over the cell's volume V (m d0^-D).  Born's term sums each contact's translational
    block on the affine stretch G r_ij (r_ij the minimum-image branch, r_i - r_j); the relaxation
    solves D y = Xi (the affine forces) with one particle's translations held (D's only zero
    modes at rho > 0 are the translations, which Xi does not load).  Not collective."""
    order = dynmat.matrix_order(packing)
    n_active, dim = order.size, packing.dim
    csr, dof, _ = dynmat.local_csr(packing, model, order, (0, n_active))
    contacts = dynmat.local_contacts(packing, order, (0, n_active))
    normal, distance = contacts.geometry_args[0], contacts.geometry_args[1]
    h_ii, h_ij, _ = pair_blocks(*contacts.geometry_args, model, with_rotation=dof > dim)
    branch = normal * distance[:, None]  # (C, D) r_i - r_j
    born = np.einsum("cxy,cb,cd->xbyd", h_ii[:, :dim, :dim], branch, branch)
    xi = np.zeros((dim * dim, n_active, dof))
    for a in range(dim):  # G = e_a e_b^T: the contact's affine stretch is e_a r_b
        for b in range(dim):
            on_i = h_ii[:, :, a] * branch[:, b, None]
            on_j = np.transpose(h_ij, (0, 2, 1))[:, :, a] * branch[:, b, None]
            np.add.at(xi[a * dim + b], contacts.a, on_i)
            np.add.at(xi[a * dim + b], contacts.b, on_j)
    xi = xi.reshape(dim * dim, -1).T  # (n_active dof, D^2)
    free = np.ones(n_active * dof, dtype=bool)
    free[:dim] = False  # hold particle 0's translations
    y = spl.splu(sp.csc_matrix(csr[free][:, free])).solve(xi[free])
    relaxed = (xi[free].T @ y).reshape(dim, dim, dim, dim)
    volume = packing.cell.volume
    mass = float(dynmat.particle_masses(packing)[order].sum())
    return (born - relaxed) / volume, mass / volume


def speeds(stiffness: np.ndarray, density: float, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(c_L, c_T) (K,) of long plane waves along ``directions`` (K, D) unit vectors: the
    Christoffel matrix Gamma_ac = A[a, b, c, d] n_b n_d / rho_m (:func:`elastic_tensor`), its
    eigenvector nearest n the longitudinal one, the other(s) transverse (in 3D the mean of the two
    speeds).  Units d0/t0."""
    gamma = np.einsum("abcd,kb,kd->kac", stiffness, directions, directions) / density
    gamma = 0.5 * (gamma + np.transpose(gamma, (0, 2, 1)))
    value, vector = np.linalg.eigh(gamma)
    along = np.abs(np.einsum("kaj,ka->kj", vector, directions))
    longitudinal = np.argmax(along, axis=1)
    c = np.sqrt(np.clip(value, 0.0, None))
    pick = np.arange(len(directions))
    c_l = c[pick, longitudinal]
    c_t = (c.sum(axis=1) - c_l) / (c.shape[1] - 1)
    return c_l, c_t


def angles(count: int = DIRECTIONS) -> tuple[np.ndarray, np.ndarray]:
    """(theta (K,), unit vectors (K, 2)) of ``count`` directions over [0, pi)."""
    theta = np.linspace(0.0, np.pi, count, endpoint=False)
    return theta, np.stack((np.cos(theta), np.sin(theta)), axis=1)


def configuration(stored: dict) -> Packing:
    """A results file's configuration (``results.packing``) as a Packing in its cell."""
    return jammed.from_arrays(stored["positions"], stored["diameters"], stored["cell"], stored["rattler"])


class WalledForces:
    """FIRE's forces (:class:`mechanics.FrictionlessForces` on the pairs) plus the harmonic push
    kn xi n of ``walls`` on every particle that overlaps one (xi = R - h); returns (force (N, D),
    energy) as FrictionlessForces does."""

    def __init__(self, diameters: np.ndarray, cell: geometry.Cell, walls: walling.Walls):
        self.pairs, self.diameters, self.walls = mechanics.FrictionlessForces(diameters, cell), diameters, walls

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, float]:
        force, energy = self.pairs(x)
        touch = walling.touching(x, self.diameters, self.walls)
        for axis in range(x.shape[1]):
            force[:, axis] += np.bincount(touch.particle, touch.overlap * touch.normal[:, axis], minlength=x.shape[0])
        return force, energy + 0.5 * float(np.sum(touch.overlap ** 2))


def walled_packing(n: int, phi: float, seed: int, force_tol: float = 1e-6, max_steps: int = 200_000):
    """A 2D packing of ``n`` bidisperse disks between flat walls at y = 0 and y = L (periodic in x,
    square: L by L, phi the disks' area over L^2), FIRE from a uniform start between the walls;
    returned between its walls (``mechanics.with_walls``: rattlers with the wall contacts as
    links).  RuntimeError if FIRE does not converge."""
    rng = np.random.default_rng(seed)
    diameters = rng.permutation(jammed.bidisperse_diameters(n))
    side = jammed.box_length_for(diameters, phi, 2)
    cell = geometry.Cell(np.array([side, side]), np.zeros(1), np.array([True, False]))
    walls = walling.Walls(np.array([1, 1]), np.array([0.0, side]), np.array([1.0, -1.0]))
    largest = diameters.max() / 2
    start = np.stack((rng.uniform(0.0, side, n), rng.uniform(largest, side - largest, n)), axis=1)
    result = fire.minimize(start, WalledForces(diameters, cell, walls), force_tol, max_steps)
    if not result.converged:
        raise RuntimeError(f"FIRE between walls did not converge: max |F| = {result.max_force:.2e}")
    packing = jammed.from_arrays(geometry.wrap(result.x, cell), diameters, cell)
    return mechanics.with_walls(packing, walls)


def wall_layers(packing, model: ContactModel, bin_width: float = 0.1) -> dict:
    """Every mode of ``packing`` (between walls) split between the near-wall layer (centres within
    ``LAYER`` of a wall) and the bulk: omega (M,) of the non-zero modes, share (M,) the layer's
    part of each mode's kinetic energy (translations and rotations), layer_fraction its share of
    the non-rattlers (what a mode spread evenly gives), and the local vDOS of the layer and of the
    bulk on ``edges`` (each the modes' energy in it, per particle of it: both integrate to 1).
    Dense eigendecomposition (references.dense_eigen).  Not collective (PETSc.COMM_SELF)."""
    from petsc4py import PETSc

    from solver.references import dense_eigen

    dm = dynmat.assemble(packing, model, PETSc.COMM_SELF)
    try:
        lam, vec = dense_eigen(dm)
    finally:
        dm.destroy()
    active = np.flatnonzero(~packing.rattler)
    dof = vec.shape[0] // active.size
    height = np.min(np.abs(packing.positions[active][:, packing.walls.axis] - packing.walls.position[None, :]), axis=1)
    near = height < LAYER
    weight = (vec ** 2).reshape(active.size, dof, -1).sum(axis=1)  # (particles, modes): e^T e = 1 per mode
    keep = lam > 1e-8
    omega = np.sqrt(lam[keep])
    share = weight[near][:, keep].sum(axis=0)
    edges = np.arange(0.0, omega.max() + bin_width, bin_width)
    layer = np.histogram(omega, edges, weights=share)[0] / (near.sum() * bin_width)
    bulk = np.histogram(omega, edges, weights=1.0 - share)[0] / ((~near).sum() * bin_width)
    norm = keep.sum() / active.size  # per particle: both integrate to the modes per particle
    links = contacts_per_particle(packing)[active]
    return {"omega": omega, "share": share, "layer_fraction": float(near.mean()), "edges": edges,
            "layer_vdos": layer / norm, "bulk_vdos": bulk / norm, "n_layer": int(near.sum()),
            "n_active": int(active.size), "pressure": packing.info["pressure"],
            "z": packing.info["z"], "n_wall_contacts": packing.info["n_wall_contacts"],
            "z_layer": float(links[near].mean()), "z_bulk": float(links[~near].mean())}


def contacts_per_particle(packing) -> np.ndarray:
    """(N,) each particle's contacts with non-rattlers and with the walls (0 for rattlers)."""
    found = geometry.find_contacts(packing.positions, packing.diameters, packing.cell)
    active = ~packing.rattler
    both = active[found.i] & active[found.j]
    count = np.bincount(found.i[both], minlength=packing.n) + np.bincount(found.j[both], minlength=packing.n)
    touch = walling.touching(packing.positions, packing.diameters, packing.walls, active)
    return (count + np.bincount(touch.particle, minlength=packing.n)) * active


def summary(name: str, shear: float, phi: float, packings: list, vdos, model: ContactModel) -> dict:
    """The numbers of one set of configurations ``packings`` (module docstring): pressure,
    sigma_xy and z (mean and spread over configurations), c_L and c_T (configurations x
    directions, :func:`angles`) and at x, y and the diagonals, ``vdos`` (a results.Vdos)."""
    theta, directions = angles()
    rows = []
    for packing in packings:
        sigma = mechanics.stress(packing)["stress"]
        stiffness, density = elastic_tensor(packing, model)
        c_l, c_t = speeds(stiffness, density, directions)
        rows.append({"pressure": float(np.trace(sigma) / packing.dim), "sigma_xy": float(sigma[0, 1]),
                     "z": float(packing.info["z"]), "c_L": c_l, "c_T": c_t})
    out = {"name": name, "shear": shear, "phi": phi, "count": len(packings), "n": packings[0].n, "vdos": vdos,
           "theta": theta,
           "omega_c": vdos.omega_c}
    for key in ("pressure", "sigma_xy", "z"):
        values = np.array([r[key] for r in rows])
        out[key], out[key + "_spread"] = float(values.mean()), float(values.std())
    for mode in ("L", "T"):
        table = np.array([r[f"c_{mode}"] for r in rows])  # (configurations, directions)
        out[f"c_{mode}_angle"] = table
        for label, degrees in DIRECTION_NAMES.items():
            at = int(round(degrees / 180.0 * DIRECTIONS))
            out[f"c_{mode}_{label}"] = float(table[:, at].mean())
            out[f"c_{mode}_{label}_spread"] = float(table[:, at].std())
        out[f"c_{mode}_aniso"] = float(np.mean((table.max(axis=1) - table.min(axis=1)) / table.mean(axis=1)))
    return out


DIRECTION_NAMES = {"x": 0.0, "y": 90.0, "45": 45.0, "135": 135.0}
"""The directions the tables name (degrees from x): along the shear (x), across it (y), and the
diagonals, the principal axes of a simple shear (135: where it compresses for a positive tilt)."""


def scene(path: str, model: ContactModel = ContactModel(rho=RHO)) -> dict:
    """One results file of configs/boxes.yaml (:func:`summary` of its configurations)."""
    with results.open_results(path) as f:
        stored = [results.packing(f, index) for index in range(len(f["packings"]))]
        vdos = results.vdos(f)[model.rho]
    packings = [configuration(s) for s in stored]
    shear = float(stored[0]["tilt"][0] / stored[0]["box"][0]) if stored[0]["tilt"].size else 0.0
    return summary(os.path.basename(path).removesuffix(".h5"), shear, float(np.mean([s["phi"] for s in stored])),
                   packings, vdos, model)


def sheared_scene(path: str, strain: float, model: ContactModel = ContactModel(rho=RHO),
                  bin_width: float = 0.05, save: str | None = None) -> dict:
    """The square configurations of one results file sheared quasi-statically to ``strain``
    (``shear.quasistatic``), their :func:`summary` with their vDOS from every eigenvalue
    (dense: ``references.dense_eigenvalues``, the same histogram as the pipeline's); with ``save``
    (a folder) the sheared packings are written there as a rotsound packing file
    ``packing_<name>.h5`` (``hdf5.save_packings``: configs/boxes_waves.yaml reads them)."""
    from petsc4py import PETSc

    from solver.references import dense_eigenvalues
    from solver.spectrum import modes

    with results.open_results(path) as f:
        stored = [results.packing(f, index) for index in range(len(f["packings"]))]
    phi = float(np.mean([s["phi"] for s in stored]))
    packings, omegas = [], []
    for s in stored:
        sheared = shear.quasistatic(configuration(s), strain)
        dm = dynmat.assemble(sheared, model, PETSc.COMM_SELF)
        try:
            lam = dense_eigenvalues(dm)
        finally:
            dm.destroy()
        omegas.append(np.sqrt(lam[lam > 1e-8]))
        packings.append(sheared)
    edges, density = modes.vdos(omegas, bin_width)
    top, spread = modes.cutoff(omegas)
    vdos = results.Vdos(edges, density, top, spread, len(omegas))
    name = os.path.basename(path).removesuffix(".h5").replace("_shear0", f"_quasistatic{strain:g}")
    if save is not None:
        hdf5.save_packings(os.path.join(save, f"packing_{name}.h5"), packings)
    return summary(name, strain, phi, packings, vdos, model)


def at_pressure(rows: list[dict], pressure: float, key: str) -> float:
    """``key`` of the square scenes ``rows`` interpolated linearly in log p to ``pressure``."""
    ordered = sorted(rows, key=lambda r: r["pressure"])
    return float(np.interp(np.log(pressure), np.log([r["pressure"] for r in ordered]), [r[key] for r in ordered]))


def comparison(square: list[dict], sheared: list[dict]) -> str:
    """Each sheared scene against the square scenes at its pressure (:func:`at_pressure`): the
    relative differences of omega_c and of c_L, c_T along each named direction."""
    lines = ["| scene | p (kn) | Δω_c | " + " | ".join(f"Δc_{m} {d}" for m in "LT" for d in DIRECTION_NAMES) + " |",
             "|---|---|---|" + "---|" * (2 * len(DIRECTION_NAMES))]
    for r in sheared:
        p = r["pressure"]
        cells = [f"{100 * (r['vdos'].omega_c / at_pressure(square, p, 'omega_c') - 1):+.1f} %"]
        for m in "LT":
            for d in DIRECTION_NAMES:
                cells.append(f"{100 * (r[f'c_{m}_{d}'] / at_pressure(square, p, f'c_{m}_{d}') - 1):+.1f} %")
        lines.append(f"| {r['name']} | {p:.2e} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + ("\n\nEach against the square cells' value at the same pressure, interpolated "
                               "linearly in log p between the square scenes (outside their range: the nearest).")


def shear_table(rows: list[dict]) -> str:
    """The Markdown table of the square, tilted and sheared scenes."""
    names = list(DIRECTION_NAMES)
    lines = ["| scene | γ | φ | p (kn) | σ_xy (kn) | z | ω_c | " + " | ".join(f"c_L {d}" for d in names) + " | "
             + " | ".join(f"c_T {d}" for d in names) + " | spread c_L | spread c_T |",
             "|---|---|---|---|---|---|---|" + "---|" * (2 * len(names) + 2)]
    for r in rows:
        speeds_ = [f"{r[f'c_{m}_{d}']:.4f}" for m in "LT" for d in names]
        lines.append(f"| {r['name']} | {r['shear']:.2f} | {r['phi']:.3f} | {r['pressure']:.3e} | "
                     f"{r['sigma_xy']:+.1e} ± {r['sigma_xy_spread']:.0e} | {r['z']:.3f} | {r['vdos'].omega_c:.3f} | "
                     + " | ".join(speeds_) + f" | {100 * r['c_L_aniso']:.1f} % | {100 * r['c_T_aniso']:.1f} % |")
    spread = max(max(r[f"c_{m}_{d}_spread"] for m in "LT" for d in names) for r in rows)
    return "\n".join(lines) + (f"\n\nMeans over each scene's configurations; the speeds' standard deviation between "
                               f"configurations is at most {spread:.4f}; the spread is (max − min)/mean of c(θ) "
                               f"over {DIRECTIONS} directions, per configuration, averaged; σ_xy ± its standard "
                               f"deviation (compressive stress positive: σ = (1/V) Σ r_c ⊗ f_c).")


def waves_scene(path: str, model: ContactModel = ContactModel(rho=RHO)) -> dict:
    """One results file of configs/boxes_waves.yaml: the direction of its standing waves (the
    reciprocal vector b_a of its cell, a its one ``waves.axes``), c_L and c_T of their fits at
    the smallest k (``results.fits``: configurations pooled) and the long-wave speeds along the
    same direction from each of its packings' matrix (:func:`elastic_tensor`, mean over them)."""
    with results.open_results(path) as f:
        scene_keys = yaml.safe_load(f.attrs["scene"])
        stored = [results.packing(f, index) for index in range(len(f["packings"]))]
        fits = results.fits(f)
    axis = "xyz".index(scene_keys["waves"]["axes"][0])
    direction = stored[0]["cell"].reciprocal()[axis]
    direction = direction / np.linalg.norm(direction)
    predicted = np.array([speeds(*elastic_tensor(configuration(s), model), direction[None, :]) for s in stored])
    pressure = np.mean([mechanics.stress(configuration(s))["pressure"] for s in stored])
    return {"name": os.path.basename(path).removesuffix(".h5"), "axis": "xyz"[axis], "pressure": float(pressure),
            "degrees": float(np.degrees(np.arctan2(direction[1], direction[0])) % 180.0),
            "k": float(fits[(model.rho, "L")]["k"][0]), "c_L": float(fits[(model.rho, "L")]["c"][0]),
            "c_T": float(fits[(model.rho, "TR")]["c"][0]), "long_L": float(predicted[:, 0].mean()),
            "long_T": float(predicted[:, 1].mean())}


def waves_table(rows: list[dict]) -> str:
    """The standing waves' speeds at the smallest k against the long-wave speeds along the same
    direction."""
    lines = ["| scene | along | direction (° from x) | p (kn) | k d0 | c_L waves | c_L long-wave | c_T waves | "
             "c_T long-wave |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['name']} | b_{r['axis']} | {r['degrees']:.1f} | {r['pressure']:.3e} | {r['k']:.3f} | "
                     f"{r['c_L']:.4f} | {r['long_L']:.4f} | {r['c_T']:.4f} | {r['long_T']:.4f} |")
    return "\n".join(lines) + ("\n\nWaves: the fits of C(k, t) at the smallest k, the configurations pooled; "
                               "long-wave: the Christoffel speeds of each packing's relaxed stiffness along the "
                               "same direction, averaged.")


def walls_scene(n: int, phi: float, seeds: list[int], model: ContactModel = ContactModel(rho=RHO)) -> dict:
    """Packings between walls (:func:`walled_packing`), one per seed, and their :func:`wall_layers`
    pooled: omega and share of every mode, the layers' local vDOS averaged over seeds."""
    parts = [wall_layers(walled_packing(n, phi, seed), model) for seed in seeds]
    edges = max((p["edges"] for p in parts), key=len)

    def padded(key):  # each seed's bins reach its own largest omega
        return np.mean([np.pad(p[key], (0, edges.size - p["edges"].size)) for p in parts], axis=0)

    return {"n": n, "phi": phi, "seeds": len(seeds), "omega": np.concatenate([p["omega"] for p in parts]),
            "share": np.concatenate([p["share"] / p["layer_fraction"] for p in parts]), "edges": edges,
            "layer_vdos": padded("layer_vdos"), "bulk_vdos": padded("bulk_vdos"),
            **{key: float(np.mean([p[key] for p in parts])) for key in
               ("layer_fraction", "n_layer", "n_active", "pressure", "z", "n_wall_contacts", "z_layer", "z_bulk")}}


WALL_BINS = np.arange(0.0, 5.0 + 1e-9, 0.25)
"""omega bins (1/t0) of the walls' table and figure."""


def walls_table(w: dict) -> str:
    """The layer's share of the modes' kinetic energy per omega bin, over its share of particles."""
    lines = ["| ω | modes | energy in the layer / layer's share of particles |", "|---|---|---|"]
    which = np.digitize(w["omega"], WALL_BINS) - 1
    for b in range(WALL_BINS.size - 1):
        inside = which == b
        if inside.any():
            lines.append(f"| {WALL_BINS[b]:.2f}–{WALL_BINS[b + 1]:.2f} | {inside.sum()} | "
                         f"{w['share'][inside].mean():.2f} |")
    return "\n".join(lines) + (f"\n\n{w['seeds']} packings of {w['n']} disks at φ = {w['phi']}, "
                               f"p = {w['pressure']:.2e}, "
                               f"z = {w['z']:.2f}, {w['n_wall_contacts']:.0f} wall contacts each; the layer (centres "
                               f"within {LAYER:g} d0 of a wall) holds {100 * w['layer_fraction']:.1f} % of the "
                               f"non-rattlers, with {w['z_layer']:.2f} contacts each (a wall's counted), the bulk's "
                               f"{w['z_bulk']:.2f}.")


def draw(square: list[dict], tilted: list[dict], sheared: list[dict], walled: dict | None) -> dict:
    """The three figures (module docstring), {file name without .png: figure}, open."""
    drawn = {}
    kinds = (("square", square, "C0", "o"), ("tilted cell, FIRE", tilted, "C1", "s"),
             ("sheared quasi-statically", sheared, "C2", "^"))
    middle = sorted(square, key=lambda r: r["phi"])[len(square) // 2]["phi"]
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for label, rows, colour, _ in kinds:
        for r in rows:
            if abs(r["phi"] - middle) < 1e-6:
                v = r["vdos"]
                centres = 0.5 * (v.edges[1:] + v.edges[:-1])
                g = np.where(v.density > 0, v.density, np.nan)
                text = rf"{label}, $\gamma$ = {r['shear']:g}, $p$ = {r['pressure']:.2e}"
                axes[0].plot(centres, g, color=colour, label=text)
                low = centres < 1.5
                axes[1].plot(centres[low], g[low] / centres[low], color=colour, label=text)
    disks = square[0]["n"]
    axes[0].set(xlabel=r"$\omega\,t_0$", ylabel=r"$g(\omega)\,t_0$",
                title=rf"vDOS, {disks} disks, $\phi$ = {middle:.2f}, $\rho$ = 1")
    axes[1].set(xlabel=r"$\omega\,t_0$", ylabel=r"$g(\omega)/\omega$ ($t_0^2$)", title="low frequencies")
    for ax in axes:
        legend(ax, fontsize=7)
    fig.tight_layout()
    drawn["boxes_vdos"] = fig

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    for label, rows, colour, marker in kinds:
        for r in rows:
            if abs(r["phi"] - middle) < 1e-6:
                degrees = np.degrees(r["theta"])
                axes[0].plot(degrees, r["c_L_angle"].mean(axis=0) / r["c_L_angle"].mean(), color=colour,
                             label=rf"$c_L$, {label}")
                axes[0].plot(degrees, r["c_T_angle"].mean(axis=0) / r["c_T_angle"].mean(), color=colour, ls="--",
                             label=rf"$c_T$, {label}")
        ordered = sorted(rows, key=lambda r: r["pressure"])
        p = [r["pressure"] for r in ordered]
        for mode, ax in (("L", axes[1]), ("T", axes[2])):
            ax.plot(p, [r[f"c_{mode}_x"] for r in ordered], marker + "-", color=colour, label=f"along $x$, {label}")
            ax.plot(p, [r[f"c_{mode}_135"] for r in ordered], marker + ":", color=colour, mfc="none",
                    label=rf"along 135$^\circ$, {label}")
    axes[0].set(xlabel=r"direction $\theta$ (degrees from $x$)", ylabel=r"$c(\theta)$ / its mean",
                title=rf"long-wave speeds, $\phi$ = {middle:.2f}")
    axes[0].set_xticks([0, 45, 90, 135, 180])
    axes[1].set(xlabel=r"pressure $p$ ($k_n$)", ylabel=r"$c_L$ ($d_0/t_0$)", title="longitudinal")
    axes[2].set(xlabel=r"pressure $p$ ($k_n$)", ylabel=r"$c_T$ ($d_0/t_0$)", title="transverse")
    for ax in axes:
        legend(ax, fontsize=7)
    fig.tight_layout()
    drawn["boxes_speeds"] = fig

    if walled is not None:
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
        which = np.digitize(walled["omega"], WALL_BINS) - 1
        centres = 0.5 * (WALL_BINS[1:] + WALL_BINS[:-1])
        ratio = np.array([walled["share"][which == b].mean() if np.any(which == b) else np.nan
                          for b in range(centres.size)])
        axes[0].plot(centres[np.isfinite(ratio)], ratio[np.isfinite(ratio)], "o-", color="C3",
                     label=rf"within {LAYER:g} $d_0$ of a wall")
        axes[0].axhline(1.0, color="0.5", lw=0.8, ls=":", label="evenly spread")
        axes[0].set(xlabel=r"$\omega\,t_0$", ylabel="layer's energy / its share of particles",
                    title=rf"{walled['n']} disks between walls, $\phi$ = {walled['phi']:.2f}")
        e = walled["edges"]
        mid = 0.5 * (e[1:] + e[:-1])
        axes[1].plot(mid, np.where(walled["layer_vdos"] > 0, walled["layer_vdos"], np.nan), color="C3",
                     label=rf"layer (within {LAYER:g} $d_0$)")
        axes[1].plot(mid, np.where(walled["bulk_vdos"] > 0, walled["bulk_vdos"], np.nan), color="C0", label="bulk")
        axes[1].set(xlabel=r"$\omega\,t_0$", ylabel=r"local $g(\omega)\,t_0$", title="local vDOS")
        for ax in axes:
            legend(ax, fontsize=7)
        fig.tight_layout()
        drawn["boxes_walls"] = fig
    return drawn


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="+", help="results files of configs/boxes.yaml")
    parser.add_argument("--figures", default="docs", help="folder for the PNGs (default docs)")
    parser.add_argument("--strain", type=float, default=0.3, help="quasistatic shear strain (default 0.3)")
    parser.add_argument("--save", default=None, help="folder for the quasi-statically sheared packings' files")
    parser.add_argument("--waves", nargs="*", default=[], help="results files of configs/boxes_waves.yaml")
    parser.add_argument("--walls-n", type=int, default=1024, help="disks between the walls (0: no walls part)")
    parser.add_argument("--walls-phi", type=float, default=0.87)
    parser.add_argument("--walls-seeds", type=int, default=3)
    args = parser.parse_args(argv)
    rows = [scene(path) for path in sorted(args.files)]
    square = [r for r in rows if r["shear"] == 0.0]
    tilted = [r for r in rows if r["shear"] != 0.0]
    sheared = [sheared_scene(path, args.strain, save=args.save) for path in sorted(args.files) if path.endswith("_shear0.h5")]
    print(shear_table(square + tilted + sheared), end="\n\n")
    print(comparison(square, tilted + sheared), end="\n\n")
    if args.waves:
        print(waves_table([waves_scene(path) for path in sorted(args.waves)]), end="\n\n")
    walled = walls_scene(args.walls_n, args.walls_phi, list(range(1, args.walls_seeds + 1))) if args.walls_n else None
    if walled is not None:
        print(walls_table(walled), end="\n\n")
    for name, fig in draw(square, tilted, sheared, walled).items():
        path = os.path.join(args.figures, f"{name}.png")
        fig.savefig(path, dpi=DPI)
        plt.close(fig)
        print(path)


if __name__ == "__main__":
    main()
