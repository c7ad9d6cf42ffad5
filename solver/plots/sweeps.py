"""Figures of an amplitude sweep (``waves.engine: lammps`` with a list of amplitudes; issue 46,
docs/finite_amplitude.md): how far omega(k) and gamma(k) move from their values at the sweep's
smallest amplitude as A grows, the loss Q^-1 = 2 gamma / omega, and the contacts that slide and
open, with the crossover measured (``results.crossover``) and the thresholds
predicted from the packing (``thresholds.affine_amplitudes``, ``predicted_crossover``).

Never imports petsc4py or mpi4py.  Not collective.  Units: A in d0/t0, omega and gamma in 1/t0.
"""

from __future__ import annotations

import numpy as np

from ..analysis import thresholds
from ..io import results
from ..waves import excitation
from .common import legend, log_ticks, plt, rho_label, save, series_colour


def predictions(sweep, slacks, mode: str, dim: int) -> dict[str, float]:
    """The predicted thresholds of one (rho, mode) sweep on a packing's contact ``slacks``
    (``thresholds.Slacks``) for its first run's strain at its smallest k, with the phase speed
    omega/k of the sweep's smallest amplitude there: the first contact to open and to slide and
    the crossover A* (the affine modulus 2 % down), {label: amplitude}; {} for RT and R or a
    failed linear fit."""
    if mode not in thresholds.STRAIN_MODES or not np.isfinite(sweep.omega[0, 0]):
        return {}
    strain = thresholds.unit_strain(mode, *excitation.runs(mode, dim)[0], dim)
    speed = float(sweep.omega[0, 0] / sweep.k[0])
    a_open, a_slide = thresholds.affine_amplitudes(slacks, strain, speed)
    return {"first opens (affine)": float(a_open.min()), "first slides (affine)": float(a_slide.min()),
            "A* predicted (affine)": thresholds.predicted_crossover(slacks, strain, speed)}


def plot_sweeps(sweeps: dict, stem: str, contacts: int | None = None, predicted: dict | None = None) -> list[str]:
    """One figure per (rho, mode) of ``sweeps`` (``results.sweeps``): (a) |omega/omega_0 - 1| and
    |gamma/gamma_0 - 1| against A, a line per k, the 1 % level and the measured A* of each; (b)
    Q^-1 = 2 gamma / omega; (c) the most contacts sliding and opened at once, as a share of the
    packing's ``contacts`` when given; the ``predicted`` {(rho, mode): {label: A}} thresholds as
    vertical lines in (a) and (c), named in the legend of each.  Returns the files written."""
    written = []
    for (rho, mode), sweep in sorted(sweeps.items()):
        fig, axes = plt.subplots(1, 3, figsize=(15, 5), sharex=True)
        a = sweep.amplitude
        colors = [series_colour(kk, sweep.k.size) for kk in range(sweep.k.size)]
        starred, stars = False, results.crossover(sweep)
        for kk, (k, color) in enumerate(zip(sweep.k, colors)):
            for value, star, style, name in ((sweep.omega, stars.omega[kk], "o-", r"\omega"),
                                             (sweep.gamma, stars.gamma[kk], "s--", r"\gamma")):
                departure = np.abs(value[:, kk] / value[0, kk] - 1.0)
                shown = departure > 0
                axes[0].loglog(a[shown], departure[shown], style, ms=3, lw=0.8, color=color,
                               label=rf"${name}$, $k d_0$ = {k:.3f}")
                if np.isfinite(star) and star > 0:
                    axes[0].plot([star], [0.01], "*", ms=9, color=color, mec="k", mew=0.4,
                                 label=None if starred else r"measured $A^*$ (1 % and 2$\sigma$ out)")
                    starred = True
            q_inverse = 2.0 * sweep.gamma[:, kk] / sweep.omega[:, kk]
            shown = q_inverse > 0  # a failed fit's (NaN) or a negative one: not on log axes
            axes[1].loglog(a[shown], q_inverse[shown], "o-", ms=3, lw=0.8, color=color, label=rf"$k d_0$ = {k:.3f}")
        axes[0].axhline(0.01, color="k", lw=0.6, alpha=0.5, label="1 % level")
        share = 1.0 / contacts if contacts else 1.0
        for series, style, name in ((sweep.sliding, "o-", "sliding"), (sweep.opened, "s--", "opened")):
            most = series.max(axis=1) * share
            axes[2].loglog(a[most > 0], most[most > 0], style, ms=3, lw=0.8, label=f"most {name} at once")
        for label, value in (predicted or {}).get((rho, mode), {}).items():
            if np.isfinite(value):
                for ax in (axes[0], axes[2]):
                    ax.axvline(value, lw=0.8, ls=":" if "first" in label else "-", alpha=0.7,
                               color="C3" if "open" in label else ("C2" if "slide" in label else "k"), label=label)
        axes[0].set(xlabel=r"$A$ ($d_0/t_0$)", ylabel="departure from the smallest $A$",
                    title=f"{mode}, {rho_label(rho)}: softening and extra attenuation")
        axes[1].set(xlabel=r"$A$ ($d_0/t_0$)", ylabel=r"$Q^{-1} = 2\gamma/\omega$", title="loss")
        axes[2].set(xlabel=r"$A$ ($d_0/t_0$)", ylabel="share of the contacts" if contacts else "contacts",
                    title="contacts at the Coulomb limit and opened")
        for ax in axes:
            log_ticks(ax.xaxis)
            legend(ax)
        fig.tight_layout()
        written += save(fig, f"{stem}_{mode}_rho{rho:g}")
    return written
