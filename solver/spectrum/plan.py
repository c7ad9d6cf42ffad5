"""The spectrum stage's plan: how the spectra of a scene are computed, decided from the scene's
spectrum section, its model and its packings' facts, and refused before any compute if that
cannot run.

The dense solvers (``DENSE``: nonhermitian and pep, ``spectrum.solver``) take matrices up to their
module's ``MAX_DOF``: :func:`check_size` refuses a packing beyond it, under the solver each
method's ``chosen_solver`` picks for that size, before any matrix is assembled.
:func:`check_factor_ranks` refuses a ``spectrum.factor_ranks`` the run's layout cannot share.
What a unit computes with the plan's choices: ``unit``.  Not collective: the same verdict on
every rank.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

from ..errors import InputError
from ..model import dynmat
from . import nonhermitian, pep

DENSE = {"nonhermitian": nonhermitian, "pep": pep}
"""spectrum.method -> its module, for the methods with a dense solver (``chosen_solver``, MAX_DOF)."""


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
