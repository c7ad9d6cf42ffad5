"""The scene's rules across its keys: each section's own (:func:`check`, called by ``coerce.build``
on every section it builds) and the scene's across sections (:func:`check_scene`), each stage's
rules taken from that stage (``packing.rules``, ``model.rules``, ``spectrum.plan``,
``waves.rules``) and called here in a fixed order: of several problems, the first one met is the
one reported.  A scene is checked as it is built (a bad scene is refused before any compute),
again with the run's layout before any packing is made (:func:`check_run`), and once more with
its packings (:func:`check_packings`), which may decide ``spectrum.method: auto``.

Not collective: every rank that checks the same scene (and packings) raises the same InputError.
"""

from __future__ import annotations

import dataclasses

from ..errors import InputError
from ..model import rules as model_rules
from ..packing import rules as packing_rules
from ..model import dynmat
from ..spectrum import plan as spectrum_plan
from ..transport import rules as transport_rules
from ..waves import rules as waves_rules
from .schema import CohesionSpec, ModelSpec, ModesSpec, PackingSpec, Scene, SpectrumSpec, TransportSpec, WavesSpec

SECTION_RULES = {PackingSpec: packing_rules.check_section, ModelSpec: model_rules.check_section,
                 CohesionSpec: model_rules.check_cohesion,
                 SpectrumSpec: spectrum_plan.check_section, ModesSpec: spectrum_plan.check_modes,
                 TransportSpec: transport_rules.check_section, WavesSpec: waves_rules.check_section}
"""Section class -> its rule across its own keys, ``rule(section, where)``."""
GIVEN_RULES = {TransportSpec: transport_rules.check_given}
"""Section class -> its rule on which keys the scene wrote, ``rule(section, given, where)``."""


def check(obj, where: str, given: frozenset = frozenset()) -> None:
    """Refuse a section (``where``: its key path prefix; ``given``: the keys the scene wrote in it,
    null values left out) or a whole :class:`Scene` that ``coerce.build`` has just built; a scene's
    ``spectrum.method: auto`` is checked as the scene alone resolves it and kept (its packings may
    decide it: :func:`check_packings`).  Not collective."""
    if isinstance(obj, Scene):
        resolve(obj, packing_rules.stored_forces_source(obj.packing))
        return
    rule = SECTION_RULES.get(type(obj))
    if rule is not None:
        rule(obj, where)
    if type(obj) in GIVEN_RULES:
        GIVEN_RULES[type(obj)](obj, given, where)


def resolve(scene: Scene, which: str | None) -> tuple[Scene, str | None]:
    """``scene`` with ``spectrum.method: auto`` replaced by the plan's choice (``spectrum.plan.resolve``)
    on packings carrying the stored tangential forces ``which`` says (None: none), and the log line
    saying so (None when the method was not auto); InputError if the scene cannot run so
    (:func:`check_scene`).  Not collective: the same on every rank given the same ``which``."""
    spectrum, said = spectrum_plan.resolve(scene.spectrum, scene.model, which)
    if said is not None:
        scene = dataclasses.replace(scene, spectrum=spectrum)
    check_scene(scene)
    return scene, said


def check_scene(scene: Scene) -> None:
    """The rules across the sections of ``scene``, in order: mode shapes picked from the spectrum,
    a generated packing's dimension, a contact file's DEM convention, friction for mobilised
    contacts, capillary bridges where they cannot go, what packing.friction is for, the waves' LAMMPS engine, a non-symmetric matrix (of
    the stored forces the scene alone gives), dashpots, the output's name.  Not collective."""
    spectrum_plan.check_localised(scene.spectrum, scene.modes)
    if scene.packing.file is None:
        check_dimension(scene, scene.packing.dim, f"packing.dim is {scene.packing.dim}")
    model_rules.check_dem_convention(scene.model, scene.packing)
    model_rules.check_mobilised(scene.model, scene.packing)
    model_rules.check_wet(scene.model, scene.packing, scene.waves)
    packing_rules.check_friction(scene.packing, scene.waves)
    waves_rules.check_engine(scene.waves, scene.packing, scene.model)
    check_stressed(scene, packing_rules.stored_forces_source(scene.packing))
    spectrum_plan.check_damping(scene.spectrum, scene.modes, scene.model.dashpot_keys)
    waves_rules.check_damping(scene.waves, scene.model.dashpot_keys)
    transport_rules.check_scene(scene.transport, scene.spectrum, scene.model.dashpot_keys)
    if not scene.output.endswith((".h5", ".hdf5")):
        raise InputError(f"output = {scene.output!r}: must end in .h5 or .hdf5")


def check_dimension(scene: Scene, dim: int, source: str) -> None:
    """Raise InputError if ``scene`` asks in ``dim`` dimensions for what exists only in 3D: a
    twisting spring, waves along z, the twist wave R.  ``source`` says where ``dim`` came from, as
    a clause ("packing.dim is 2", "packing.file F holds disks"). Not collective."""
    model_rules.check_dimension(scene.model, dim, source)
    waves_rules.check_dimension(scene.waves, dim, source)


def check_stressed(scene: Scene, which: str | None) -> None:
    """Raise InputError if stressed packings (``which`` says whose stored tangential forces; None:
    none) or YADE's slip (``model.history: yade``) make a matrix that is not symmetric
    (``model.rules.asymmetry``) for what needs a symmetric one: the spectrum's and the modes'
    (``spectrum.plan.check_stressed``), the diffusivity's, the waves' spectral path, and, for stored forces the matrix
    keeps, rho = 0.  Not collective."""
    why = model_rules.asymmetry(scene.model, which)
    if why is None:
        return
    spectrum_plan.check_stressed(scene.spectrum, scene.modes, why)
    transport_rules.check_stressed(scene.transport, why)
    waves_rules.check_stressed(scene.waves, why)
    model_rules.check_held(scene.model, which)


def check_run(asked: Scene, unit_ranks: int, source: str) -> Scene:
    """``asked`` as the scene alone resolves ``spectrum.method: auto``, refused before any packing
    is made if its spectrum cannot run on the ``unit_ranks`` ranks of a unit (``source`` says where
    that number comes from) or on the generated packings' size (the dense solvers', the
    diffusivity's scratch).  Not collective."""
    scene = resolve(asked, packing_rules.stored_forces_source(asked.packing))[0]
    spectrum_plan.check_factor_ranks(scene.spectrum, unit_ranks, source)
    if scene.packing.file is None:
        spectrum_plan.check_size(scene.spectrum, scene.model, scene.packing.n, scene.packing.dim, "generated")
        _check_scratch(scene, scene.packing.n, scene.packing.dim, "the generated packings")
    return scene


def _check_scratch(scene: Scene, particles: int, dim: int, which: str) -> None:
    """``transport.rules.check_scratch`` at every rho of ``scene`` for ``particles`` non-rattlers in
    ``dim`` dimensions (``which``: the packing, for the message). Not collective."""
    for rho in scene.model.rho:
        dof = particles * dynmat.dof_per_particle(dim, scene.model.contact(rho))
        transport_rules.check_scratch(scene.transport, dof, f"{which} at rho = {rho:g}")


def check_packings(asked: Scene, packings: list) -> tuple[Scene, str | None]:
    """Refuse a scene its packings cannot run, before any compute: a file's dimension, stored
    tangential forces with what needs a symmetric matrix, the waves' k in each box, the dense
    solvers' size, the diffusivity's scratch, stored forces LAMMPS's waves cannot take.  Return the scene ``asked`` with ``spectrum.method: auto`` resolved for these
    packings (:func:`resolve`) and the line that says what auto chose (None if nothing).  Not
    collective: the same on every rank."""
    if asked.packing.file is not None:  # generated packings were checked with the scene
        check_dimension(asked, packings[0].dim, f"packing.file {asked.packing.file} holds disks "
                                                f"(positions (N, 2))")
    stressed = [i for i, p in enumerate(packings) if p.stressed]
    which = f"configuration(s) {', '.join(map(str, stressed[:5]))} carry stored tangential forces" if stressed \
        else None
    scene, chosen = resolve(asked, which or packing_rules.stored_forces_source(asked.packing))
    check_stressed(scene, which)
    waves_rules.check_history(scene.waves, scene.model, packings)
    waves_rules.check_boxes(scene.waves, packings)
    for index, p in enumerate(packings):
        spectrum_plan.check_size(scene.spectrum, scene.model, int((~p.rattler).sum()), p.dim, f"packing {index}")
        _check_scratch(scene, int((~p.rattler).sum()), p.dim, f"packing {index}")
    return scene, chosen
