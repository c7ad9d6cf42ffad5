"""The scene's rules on its ``packing`` section: what its keys ask together (a contact file needs
its packing file, friction and pressure need the protocol that uses them (or, for friction,
the waves' LAMMPS engine), shear needs rotsound's FIRE, generated packings
need N and phi), and which stored tangential forces the section alone gives its packings.

Each rule takes the section (``io.schema.PackingSpec``) and raises InputError naming the keys;
``where`` is the section's key path prefix (``packing.``).  Pure and not collective: every rank
that checks the same section raises the same error.
"""

from __future__ import annotations

from ..errors import InputError


def check_section(spec, where: str) -> None:
    """Refuse keys of the packing section ``spec`` that do not go together. Not collective."""
    if spec.contacts is not None and (spec.file is None or spec.relax):
        raise InputError(f"{where}contacts: the stored tangential forces of packing.file's packings; they need "
                         f"packing.file" + (" and cannot go with packing.relax, which re-minimises without them"
                                            if spec.relax else ""))
    walled = [name for name in ("walls", "wall_contacts", "gravity") if getattr(spec, name) is not None]
    if walled and (spec.file is None or spec.relax):
        raise InputError(f"{where}{walled[0]}: walls and gravity belong to a packing read from packing.file (generated "
                         f"packings are periodic and weightless)" + (", and cannot go with packing.relax, whose FIRE "
                                                                     "knows neither" if spec.relax else ""))
    if spec.pressure is not None and (spec.friction is None or spec.file is not None):
        raise InputError(f"{where}pressure = {spec.pressure}: the pressure at which LAMMPS holds a frictional packing "
                         f"it makes: needs packing.friction with packing.engine: lammps and no packing.file (for a "
                         f"frictionless one in the same protocol, give friction: 0)")
    if spec.shear and (spec.file is not None or spec.engine != "fire"):
        raise InputError(f"{where}shear = {spec.shear}: the shear of a packing rotsound's FIRE generates "
                         f"(packing.engine: fire, no packing.file); a packing file's cell carries its own tilt")
    if spec.file is None:
        for name in ("n", "phi"):
            if getattr(spec, name) is None:
                raise InputError(f"{where}{name} is missing: give packing.n and packing.phi, "
                                 f"or packing.file")
        if spec.relax:
            raise InputError(f"{where}relax = true re-minimises the packings of packing.file; generated "
                             f"packings are minimised already: give packing.file or drop packing.relax")


def check_friction(spec, waves) -> None:
    """Refuse ``packing.friction`` where nothing uses it: it is the Coulomb mu of a frictional
    packing made by LAMMPS (``engine: lammps``), of one read with its contact file
    (``contacts``), or of the contacts the waves' LAMMPS engine moves (``waves.engine: lammps``).
    Not collective."""
    engine = waves is not None and waves.engine == "lammps"
    if spec.friction is not None and spec.contacts is None and not engine and (spec.file is not None
                                                                               or spec.engine != "lammps"):
        raise InputError(f"packing.friction = {spec.friction}: the Coulomb mu of a frictional packing, made by LAMMPS "
                         f"(generated packings with packing.engine: lammps), read with its contact file "
                         f"(packing.file with packing.contacts), or of the contacts LAMMPS moves in finite-amplitude "
                         f"waves (waves.engine: lammps); give one of these")


def stored_forces_source(spec) -> str | None:
    """Whose stored tangential forces the packing section ``spec`` alone gives its packings, as a
    clause for messages; None when it gives none (a packing file's own, in its ``tangential``
    group, are known once it is read). Not collective."""
    if spec.contacts is not None:
        return "packing.contacts gives the packings stored tangential forces"
    if spec.file is None and spec.engine == "lammps" and spec.friction:
        return (f"packing.friction = {spec.friction} makes frictional packings that stand on stored "
                f"tangential forces")
    return None
