"""The scene's rules on its ``model`` section: what its keys ask together and what they ask of
the packings (their dimension, their friction, the DEM code that wrote their contact file), and
whether the dynamical matrix they make is symmetric (:func:`asymmetry`).

Each rule takes the sections it reads (``io.schema.ModelSpec``, ``PackingSpec``) and raises
InputError naming the keys.  Pure and not collective: every rank that checks the same sections
raises the same error.
"""

from __future__ import annotations

from ..errors import InputError

DEM_CONVENTIONS = {"liggghts-local": ("contact", "lammps"), "yade": ("contact", "yade"),
                   "mercury-fstat": ("contact", "lammps")}
"""contacts_format -> (model.lever, model.history) of the code that writes it (docs/stressed_contacts.md;
MercuryDPM's: its own waves converge to that matrix's, tests/io/test_mercury_waves.py)."""


def check_section(model, where: str) -> None:
    """Refuse keys of the model section ``model`` that do not go together: a coefficient of
    restitution beside the gamma_n it sets, or under a law where no single gamma_n gives it.
    Not collective."""
    if model.restitution is not None and (
            model.law != "harmonic" or (model.damping is not None and model.damping.gamma_n > 0.0)):
        raise InputError(f"{where}restitution = {model.restitution}: " + (
            f"it sets {where}damping.gamma_n, which is given too: give one of them" if model.law == "harmonic" else
            f"under {where}law = {model.law!r} the coefficient of restitution depends on the impact speed, so no "
            f"single gamma_n gives it: give {where}damping.gamma_n"))


def check_dimension(model, dim: int, source: str) -> None:
    """Refuse a twisting spring in ``dim`` < 3 dimensions (``source`` says where ``dim`` came from,
    as a clause: "packing.dim is 2"). Not collective."""
    if dim != 3 and model.rho_twist > 0.0:
        raise InputError(f"model.rho_twist = {model.rho_twist}: twisting resistance needs spheres in 3D, "
                         f"but {source} (in 2D a contact has no twist: set model.rho_twist to 0, or "
                         f"use spheres)")


def check_dem_convention(model, packing) -> None:
    """A LIGGGHTS, YADE or MercuryDPM contact file (``packing.contacts`` in ``packing.contacts_format``) whose
    stored forces the matrix keeps, read under another code's lever or history, would give that
    code's matrix of this packing, silently: InputError naming the keys to set.  Not collective."""
    if packing.contacts is None or model.stored_forces != "keep":
        return
    want = DEM_CONVENTIONS.get(packing.contacts_format)
    if want is None or (model.lever, model.history) == want:
        return
    raise InputError(f"packing.contacts_format = '{packing.contacts_format}' holds a packing integrated with "
                     f"the lever {want[0]} and {want[1]}'s history (docs/stressed_contacts.md), but model.lever = "
                     f"'{model.lever}' and model.history = '{model.history}': set model.lever: {want[0]} "
                     f"and model.history: {want[1]} (or model.stored_forces: drop for the unstressed matrix)")


def check_mobilised(model, packing) -> None:
    """Refuse ``model.mobilised: slide`` without the packings' friction coefficient. Not collective."""
    if model.mobilised == "slide" and packing.friction is None:
        raise InputError("model.mobilised = 'slide': which contacts are at the Coulomb limit needs their mu: give "
                         "packing.friction (with packing.contacts, or packing.engine: lammps)")


def asymmetry(model, which: str | None) -> str | None:
    """Why the dynamical matrix of the model section ``model`` is not symmetric, as a clause, or
    None: the stored tangential forces ``which`` says the packings carry (None: none) when
    ``model.stored_forces`` keeps them, or YADE's slip (``model.history: yade`` with a tangential
    spring; docs/stressed_contacts.md), or LAMMPS's pair granular's (``model.history: granular`` under
    the lever contact; docs/finite_amplitude.md). Not collective."""
    if which is not None and model.stored_forces == "keep":
        return which
    if model.history == "yade" and any(r > 0 for r in model.rho):
        return "model.history: yade takes YADE's tangential slip, which is not the transpose of its forces' action"
    if model.history == "granular" and model.lever != "radius" and any(r > 0 for r in model.rho):
        return ("model.history: granular takes the tangential slip at the radius while the torques act at "
                f"model.lever: {model.lever} (LAMMPS's pair granular), which is not symmetric")
    return None


def check_held(model, which: str | None) -> None:
    """Refuse rho = 0 when the matrix keeps the stored tangential forces ``which`` says the packings
    carry (None: none): the tangential springs hold them. Not collective."""
    if which is not None and model.stored_forces == "keep" and 0.0 in model.rho:
        raise InputError(f"model.rho contains 0: {which}, held by the tangential springs: every rho must be > 0")


def check_cohesion(cohesion, where: str) -> None:
    """Refuse a ``model.cohesion`` section (``where``: its key path prefix) whose bridges cannot be
    built: no surface tension, or not exactly one of volume and liquid_content (``capillary.Cohesion``
    says what is allowed).  Not collective."""
    if cohesion.surface_tension is None:
        raise InputError(f"{where}surface_tension is required: the liquid's surface tension in units of kn (> 0)")
    if (cohesion.volume is None) == (cohesion.liquid_content is None):
        raise InputError(f"{where}volume and {where}liquid_content: give exactly one (the volume of every bridge in "
                         f"d0^3, or the liquid each particle carries as a fraction of its volume); got "
                         f"{'both' if cohesion.volume is not None else 'neither'}")
    try:
        cohesion.cohesion()
    except ValueError as exc:
        raise InputError(f"{where.rstrip('.')}: {exc}") from None


def check_wet(model, packing, waves) -> None:
    """Refuse capillary bridges (``model.cohesion``) where rotsound cannot take them yet: packings
    made by LAMMPS (its engine has no bridges; rotsound's FIRE makes wet packings), a contact
    file other than LIGGGHTS's (it gives no bridged pairs), ``packing.relax`` (a dry re-minimisation) and LAMMPS's
    waves.  (The sliding branch needs the packings' mu, which only those give.)  Not collective."""
    if model.cohesion is None:
        return
    said = "model.cohesion (capillary bridges)"
    if packing.file is None and packing.engine == "lammps":
        raise InputError(f"{said} with packing.engine: lammps: LAMMPS's packing engine has no bridges; rotsound's "
                         f"FIRE (packing.engine: fire) makes wet packings")
    if packing.contacts is not None and packing.contacts_format != "liggghts-local":
        raise InputError(f"{said} with packing.contacts_format: {packing.contacts_format}: that contact file gives "
                         f"no bridged pairs apart, which a wet packing needs (docs/capillary_bridges.md); LIGGGHTS's "
                         f"(liggghts-local) lists them, and rotsound's HDF5 files hold them")
    if packing.relax:
        raise InputError(f"{said} with packing.relax: the relaxation is dry (frictionless FIRE without bridges); "
                         f"give the wet packing at rest")
    if waves is not None and waves.engine == "lammps":
        raise InputError(f"{said} with waves.engine: lammps: LAMMPS's waves have no bridges; use rotsound's "
                         f"linear waves (waves.engine: rotsound)")
