"""Figures from results files: which figures a results file gets (:func:`draw_results`, in memory;
:func:`plot_results` writes them beside it), the reproduction report's (:func:`report_figures`) and the vDOS of several files overlaid
(:func:`plot_vdos_compare`).  The figures themselves are drawn by one module per stage, from the
arrays ``io.results`` reads:

- ``common``: the Agg backend (set there, once), saving as PNG and PDF, particles and sections,
  rho labels, legends, log ticks;
- ``packing``: the configuration and its force network;
- ``spectrum``: vDOS, mode energies K and Q, participation ratio; the vDOS of several files;
- ``waves``: VAFs, S(k, omega), dispersion with the lattice model, the RT transition and band,
  phase speeds and attenuation;
- ``attenuation``: the Rayleigh-to-diffusive regimes of gamma(k);
- ``modes``: single modes and standing-wave snapshots on the particles;
- ``damped``: damped modes (sigma, Q, the damped vDOS);
- ``transport``: the diffusivity d(omega) of the modes;
- ``sweeps``: an amplitude sweep's departure from the linear omega and gamma, its loss and its
  contacts, with the thresholds predicted from the packing.

A stage module imports ``common`` only; this module imports the stage modules.  Never imports
petsc4py or mpi4py.  Not collective (rank 0 draws).
"""

from __future__ import annotations

import os

import numpy as np

from ..analysis import thresholds
from ..io import hdf5, results
from . import common
from .attenuation import plot_attenuation_regimes
from .damped import plot_damped_modes, plot_damped_vdos
from .modes import plot_mode_shapes, plot_wave_snapshots
from .packing import plot_force_network, plot_packing
from .spectrum import plot_energies, plot_participation, plot_vdos, plot_vdos_compare
from .transport import plot_diffusivity
from .sweeps import plot_sweeps, predictions
from .waves import (plot_bands, plot_dispersion, plot_dispersion_rt, plot_spectra, plot_speeds_attenuation,
                    plot_transition, plot_vafs)

__all__ = ["draw_results", "plot_results", "plot_vdos_compare", "report_figures"]


def plot_results(path: str) -> list[str]:
    """Write every figure the results file has data for (:func:`draw_results`) next to it, as PNG
    and PDF; return the paths."""
    figures = draw_results(path)
    try:
        return [written for stem, fig in figures.items() for written in common.save(fig, stem)]
    finally:  # the rest, when one cannot be written
        for fig in figures.values():
            common.plt.close(fig)


def draw_results(path: str) -> dict:
    """Every figure the results file at ``path`` has data for, drawn and not written: {stem (the
    path without .png/.pdf): matplotlib Figure}, open (``common.save`` writes and closes one)."""
    with common.kept() as figures:
        try:
            _draw_results(path)
        except BaseException:
            for fig in figures.values():
                common.plt.close(fig)
            raise
    return figures


def _draw_results(path: str) -> None:
    """Draw (``common.save``) every figure of the results file ``path``."""
    stem = os.path.splitext(path)[0]
    with results.open_results(path) as f:
        first = results.first_packing(f)
        read = None
        if first is not None:
            plot_packing(first, f"{stem}_packing")
            read = hdf5.read_packings(path, count=1, check_equilibrium=False, model=results.contact_model(f))[0]
            plot_force_network(read, f"{stem}_forces")
        _sweeps(results.sweeps(f), results.sweep_friction(f), read, f"{stem}_sweep")
        vdos = results.vdos(f)
        damped = results.damped_modes(f)
        plot_vdos(vdos, f"{stem}_vdos", damped=bool(damped))
        plot_energies(vdos, results.mode_energies(f), results.binned_energies(f), f"{stem}_energies")
        plot_diffusivity(results.diffusivity(f), f"{stem}_diffusivity")
        waves = results.waves(f)
        plot_vafs(waves, f"{stem}_vaf")
        plot_spectra(waves, f"{stem}_spectrum")
        fits, lattice_fit = results.fits(f), results.lattice(f)
        plot_dispersion(fits, f"{stem}_dispersion")
        plot_dispersion_rt(fits, lattice_fit, f"{stem}_dispersion_rt")
        plot_transition(fits, lattice_fit, waves, f"{stem}_transition")
        plot_bands(lattice_fit, results.bands(f), f"{stem}_bands")
        plot_speeds_attenuation(fits, f"{stem}_speeds_attenuation")
        dim = first["positions"].shape[1] if first is not None else 2
        plot_attenuation_regimes(fits, f"{stem}_attenuation", dim=dim)
        shapes = results.mode_shapes(f)
        per_mode_participation = results.participation(f)
        snapshots = results.wave_snapshots(f)
        pictured = {i: results.packing(f, i) for i in {g.packing for g in shapes} | {w.packing for w in snapshots}}
    plot_participation(per_mode_participation, shapes, f"{stem}_participation")
    plot_mode_shapes(pictured, shapes, stem)
    plot_wave_snapshots(pictured, snapshots, stem)
    if damped:
        plot_damped_modes(damped, f"{stem}_damped_modes")
        plot_damped_vdos(damped, float(np.diff(vdos[next(iter(vdos))].edges[:2])[0]), f"{stem}_damped_vdos")


def _sweeps(sweeps: dict, friction: float | None, packing, stem: str) -> list[str]:
    """An amplitude sweep's figures (``plot_sweeps``), with the thresholds predicted from the
    first ``packing``'s contacts (rho > 0: a tangential spring to slide) at the sweep's mu."""
    if not sweeps:
        return []
    predicted, contacts = {}, None
    if packing is not None and friction:
        for rho, mode in sweeps:
            if rho > 0:
                slacks = thresholds.slacks(packing, rho, friction)
                contacts = len(slacks.opening)
                predicted[(rho, mode)] = predictions(sweeps[(rho, mode)], slacks, mode, packing.dim)
    return plot_sweeps(sweeps, stem, contacts, predicted)


def report_figures(data, folder: str) -> list[tuple[str, str]]:
    """Draw the reproduction report's figures into ``folder`` from the files that ``data``
    (``analysis.claims.Data``, filled by ``report.gather``) names; return (caption, png path) pairs."""
    os.makedirs(folder, exist_ok=True)
    out: list[tuple[str, str]] = []

    def keep(caption, paths):
        pngs = [p for p in paths if p.endswith(".png")]
        out.extend((caption if len(pngs) == 1 else f"{caption} ({os.path.basename(p)})", p) for p in pngs)

    if data.vdos_file:
        keep("Fig. 1: vDOS for every rho (rho = 0 dotted), arrows at omega_c", plot_vdos(data.vdos, f"{folder}/fig1_vdos"))
    energies = data.energies_file.get(1.0) or data.energies_file.get(0.4)
    if energies:
        with results.open_results(energies) as f:
            keep("Fig. 6: K (blue dotted), Q (red) and g x 5e-3 (dashed), rho = 1 and 0.4",
                 plot_energies(results.vdos(f), results.mode_energies(f), results.binned_energies(f), f"{folder}/fig6_energies",
                               rhos=(1.0, 0.4)))
    if data.waves_file:
        fits, lattice_fit = data.fits, data.lattice
        rt = [rho for rho, mode in fits if mode == "RT"]
        transition = [min(rt, key=lambda r: abs(r - 0.2))] if rt else []
        with results.open_results(data.waves_file) as f:  # only the rho drawn: the runs are the bulk of a file
            waves = results.waves(f, rhos={0.0, 1.0, *transition})
        keep("Fig. 2: VAFs at k d0 nearest 0.38 pi", plot_vafs(waves, f"{folder}/fig2_vaf", rhos=(0.0, 1.0)))
        keep("Fig. 3: log10 S(k, omega), rho = 1", plot_spectra(waves, f"{folder}/fig3_spectrum", rhos=(1.0,)))
        keep("Fig. 4: RT dispersion with the lattice model", plot_dispersion_rt(fits, lattice_fit, f"{folder}/fig4_dispersion_rt"))
        keep("Fig. 5: the RT transition at rho = 0.2", plot_transition(fits, lattice_fit, waves, f"{folder}/fig5_transition"))
        omega_c = {rho: v[2] for rho, v in data.vdos.items()}
        keep("Fig. 7: RT band limits against rho", plot_bands(lattice_fit, data.bands, f"{folder}/fig7_bands", omega_c or None))
        keep("Figs. S2, S3: phase speeds and attenuation of L and TR", plot_speeds_attenuation(fits, f"{folder}/figS2_S3"))
    with_vdos = [(path, phi) for path, phi, _, what in data.sources if "vdos" in what]
    if len({round(phi, 4) for _, phi in with_vdos}) >= 2:
        keep("Fig. S1: vDOS at several phi", plot_vdos_compare([p for p, _ in with_vdos], f"{folder}/figS1_vdos_phi"))
    return out
