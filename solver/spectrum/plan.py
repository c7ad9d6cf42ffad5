"""The spectrum stage's plan: how the spectra of a scene are computed, decided from the scene's
spectrum and modes sections, its model and its packings' facts (stored tangential forces,
dashpots, size), and refused before any compute if that cannot run.

:func:`resolve` is the one place ``spectrum.method: auto`` is decided (:func:`auto_method`: the
cheapest exact method that fits the matrix and what is asked), once from the scene alone and
again once the packings are read (a packing file may hold stored tangential forces).  The rules
refuse what a method cannot do: keys of the section that do not go together
(:func:`check_section`, :func:`check_modes`), a non-symmetric matrix (:func:`check_stressed`),
dashpots (:func:`check_damping`), a dense solver's size (``DENSE``, :func:`check_size`: each
method's ``chosen_solver`` picks dense or windows by size, dense takes up to the module's
``MAX_DOF``), a ``factor_ranks`` the run's layout cannot share (:func:`check_factor_ranks`).
What a unit computes with the plan's choices: ``unit``.

Each rule takes the sections it reads (``io.schema.SpectrumSpec``, ``ModesSpec``, ``ModelSpec``;
None: the scene has no such section) and raises InputError naming the keys.  Pure and not
collective: every rank that checks the same scene raises the same error.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import dataclasses

from ..errors import InputError
from ..model import dynmat
from ..model.rules import asymmetry
from . import nonhermitian, pep

METHODS = ("auto", "slicing", "counting", "kpm", "nonhermitian", "pep")
"""spectrum.method values (auto: :func:`auto_method`)."""
SOLVERS = ("auto", "dense", "windows")
"""spectrum.solver values, of the methods in ``DENSE`` (their ``chosen_solver``)."""
DENSE = {"nonhermitian": nonhermitian, "pep": pep}
"""spectrum.method -> its module, for the methods with a dense solver (``chosen_solver``, MAX_DOF)."""


def check_section(spec, where: str) -> None:
    """Refuse keys of the spectrum section ``spec`` that its method cannot take (auto: any that
    some method takes). Not collective."""
    if spec.method not in ("slicing", "pep", "auto") and spec.window:
        raise InputError(f"{where}method = {spec.method!r} gives the whole vDOS: {where}window needs method "
                         f"'slicing' (or 'pep', whose window is in the damped frequency)")
    if spec.method not in ("nonhermitian", "pep", "auto") and spec.solver != "auto":
        raise InputError(f"{where}solver = {spec.solver!r} chooses how methods nonhermitian and pep find every "
                         f"eigenvalue; method {spec.method!r} has no such choice: drop {where}solver or use method "
                         f"'nonhermitian' (or 'pep' with model.damping)")
    if spec.frequencies is not None and (spec.method not in ("pep", "auto") or spec.window):
        raise InputError(f"{where}frequencies = {spec.frequencies}: bands of damped modes, for method 'pep' without "
                         f"{where}window" + ("" if spec.method in ("pep", "auto") else f" (method is {spec.method!r})"))
    if spec.method not in ("counting", "auto") and spec.factor_ranks not in (1, "auto"):
        raise InputError(f"{where}factor_ranks = {spec.factor_ranks}: the ranks sharing each factorisation of method "
                         f"'counting'; method {spec.method!r} has none to share: drop {where}factor_ranks")
    if spec.method == "counting" and spec.energies:
        raise InputError(f"{where}method = 'counting' gives mode counts only: {where}energies needs method "
                         f"'slicing' (per mode) or 'kpm' (bin averages)")


def check_modes(modes, where: str) -> None:
    """Refuse a modes section ``modes`` that names no modes to keep. Not collective."""
    if modes.omega is None and not modes.localised:
        raise InputError(f"{where}omega is missing: give the target frequencies (1/t0) whose nearest modes to keep, "
                         f"e.g. {where}omega: [0.1, 1.0], or {where}localised")


def check_localised(spec, modes) -> None:
    """Refuse ``modes.localised`` without the per-mode participation of a slicing spectrum with
    energies (``spec``: the spectrum section, None: none). Not collective."""
    if modes is not None and modes.localised and (spec is None or spec.method != "slicing" or not spec.energies):
        raise InputError(f"modes.localised = {modes.localised}: the participation ratios of every mode come from "
                         f"the spectrum: give spectrum: {{energies: true}} (method slicing)"
                         + ("" if spec is None else f"; spectrum.method is {spec.method!r}, "
                                                    f"energies {spec.energies}"))


def check_stressed(spec, modes, why: str) -> None:
    """Refuse what needs a symmetric matrix on one that is not (``why``, a clause:
    ``model.rules.asymmetry``; docs/stressed_contacts.md sections 2 and 4): any spectrum method but
    nonhermitian and pep with the dense solver (slicing, counting and kpm rest on symmetry; pep's
    windows bound the damped modes only for a symmetric D), and mode shapes.  Not collective."""
    if spec is not None and spec.method == "pep" and spec.solver != "dense":
        raise InputError(f"spectrum.method = 'pep' with spectrum.solver = {spec.solver!r}: {why}, so the "
                         f"dynamical matrix is not symmetric and the windows' bounds on the damped modes do not hold: "
                         f"give spectrum.solver: dense (up to {pep.MAX_DOF} DOF)")
    if spec is not None and spec.method not in ("nonhermitian", "pep"):
        raise InputError(f"spectrum (method {spec.method}): {why}, so the dynamical matrix is not "
                         f"symmetric (the DEM code's tangential update has no energy, docs/stressed_contacts.md); "
                         f"slicing, counting and kpm need a symmetric matrix and would give a wrong vDOS: use "
                         f"spectrum.method: nonhermitian (every eigenvalue, complex ones counted as unstable)")
    if modes is not None:
        raise InputError(f"modes: {why}, so the dynamical matrix is not symmetric and its modes are not the "
                         f"orthogonal eigenvectors that modes keeps; drop the modes section for this packing")


def check_damping(spec, modes, dashpots: str) -> None:
    """With contact dashpots (``dashpots``: the keys that turn them on as the scene wrote them,
    ``ModelSpec.dashpot_keys``; "" for none), refuse a spectrum method but pep (the others solve
    the undamped problem) and mode shapes (undamped eigenvectors); without, refuse pep (no damped
    modes to find).  Not collective."""
    if dashpots and spec is not None and spec.method != "pep":
        raise InputError(f"spectrum.method = {spec.method!r} with {dashpots}: it solves the undamped "
                         f"problem; the damped modes (lambda^2 M + lambda C + D) x = 0 need spectrum.method: pep "
                         f"(or auto); the undamped vDOS of the same packing: drop {dashpots} from this scene")
    if dashpots and modes is not None:
        raise InputError(f"modes with {dashpots}: modes keeps the undamped eigenvectors of D, not the damped "
                         f"modes of (lambda^2 M + lambda C + D) x = 0; drop {dashpots} from this scene to see "
                         f"the undamped modes of the same packing")
    if not dashpots and spec is not None and spec.method == "pep":
        raise InputError("spectrum.method = 'pep': the damped modes need dashpots: give model.damping (gamma_n, "
                         "gamma_t) or model.restitution; without them every mode is undamped: use method slicing")


def auto_method(spec, model, which: str | None) -> tuple[str, str]:
    """What ``spectrum.method: auto`` means for the spectrum section ``spec`` under the model
    section ``model`` on packings carrying the stored tangential forces ``which`` says (a clause;
    None: none), and why: the cheapest exact method that fits the matrix and what is asked: pep
    with dashpots (the only one that takes them), nonhermitian on a non-symmetric matrix
    (``model.rules.asymmetry``), else counting when only counts are asked (no energies, no
    window), else slicing.  Not collective."""
    if model.damped:
        return "pep", "dashpots: the damped modes"
    why = asymmetry(model, which)
    if why is not None:
        return "nonhermitian", f"{why}, so the matrix is not symmetric"
    if spec.energies or spec.window:
        return "slicing", "per-mode energies asked" if spec.energies else "a window asked"
    return "counting", "only counts asked: no energies, no window"


def resolve(spec, model, which: str | None):
    """(section, line): the spectrum section ``spec`` (None: none) with ``method: auto`` replaced by
    :func:`auto_method`'s choice (``model``, ``which``: as there) and checked again
    (:func:`check_section`), and the log line saying what auto chose and why (None when the
    method was not auto; then ``spec`` itself).  Not collective."""
    if spec is None or spec.method != "auto":
        return spec, None
    method, reason = auto_method(spec, model, which)
    spec = dataclasses.replace(spec, method=method)
    check_section(spec, "spectrum.")
    return spec, f"spectrum.method auto -> {method} ({reason})"


def check_factor_ranks(spec, unit_ranks: int, source: str) -> None:
    """Refuse a ``factor_ranks`` of the spectrum section ``spec`` (None: no spectrum) that does not
    divide the ``unit_ranks`` ranks a unit is solved on (``source`` says where that number comes
    from).  Not collective."""
    if spec is not None and spec.factor_ranks != "auto" and unit_ranks % spec.factor_ranks:
        raise InputError(f"spectrum.factor_ranks = {spec.factor_ranks}: must divide the {unit_ranks} "
                         f"rank{'s' * (unit_ranks > 1)} each (rho, packing) unit is solved on ({source}): choose "
                         f"one of {[d for d in range(1, unit_ranks + 1) if unit_ranks % d == 0]}")


def check_size(spec, model, particles: int, dim: int, which: str) -> None:
    """InputError if ``particles`` in ``dim`` dimensions (``which``: the packing, for the message)
    make a matrix beyond the dense solver's size of ``spec.method`` (``DENSE``) at some rho of
    the model section ``model``, under the solver ``spec.solver`` picks (``chosen_solver``);
    nothing for another method or no spectrum (``spec`` None).  Not collective."""
    method = DENSE.get(spec.method) if spec is not None else None
    if method is None:
        return
    for rho in model.rho:
        size = particles * dynmat.dof_per_particle(dim, model.contact(rho))
        if method.chosen_solver(spec.solver, size) == "dense" and size > method.MAX_DOF:
            order = size if method is nonhermitian else 2 * size  # pep: the first-order matrix
            raise InputError(f"spectrum.solver = 'dense': the {which} packing's {particles} particles make "
                             f"{size} DOF at rho = {rho:g}, more than the {method.MAX_DOF} the dense solver of "
                             f"method {spec.method} takes (a full non-symmetric eigensolve of order "
                             f"{order} needs hours and {16 * order ** 2 / 2 ** 30:.0f} GiB); use spectrum.solver: "
                             f"windows or a smaller packing.n")


def pep_bands(spec) -> list[tuple[float, float]] | None:
    """The bands of omega_d a pep spectrum keeps: spectrum.window, or one band of half-width
    frequency_width about each of spectrum.frequencies (overlapping ones merged), or None."""
    if spec.window:
        return [tuple(spec.window)]
    if not spec.frequencies:
        return None
    bands = []
    for omega in sorted(spec.frequencies):
        lo, hi = max(omega - spec.frequency_width, 0.0), omega + spec.frequency_width
        if bands and lo <= bands[-1][1]:
            bands[-1] = (bands[-1][0], max(hi, bands[-1][1]))
        else:
            bands.append((lo, hi))
    return bands


def probe_seed(spec, seed: int, p_index: int) -> int | None:
    """The seed of the random probes of packing ``p_index``'s spectrum units, the scene's ``seed``
    plus ``p_index``, for kpm; None for the other methods, which draw nothing."""
    return seed + p_index if spec.method == "kpm" else None
