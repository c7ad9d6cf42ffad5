"""The scene's rules on its ``transport`` section: its own keys (eta given; keys of another
method written), what the rest of the scene must give (a symmetric, undamped matrix; the bins of the
vDOS) and what the packings must fit (the exact route's scratch vectors).

Each rule takes the transport section (``io.schema.TransportSpec``; None: the scene has none, and
the rule passes) and raises InputError naming the keys.  Why a stressed or damped scene is
refused: the Allen-Feldman diffusivity (docs/diffusivity.md) is built on the harmonic energy
H = p^T p / 2 + q^T A q / 2 with A symmetric, whose current is conserved mode by mode; a matrix
with stored tangential forces is not symmetric (no energy, no orthogonal modes), and with
dashpots the energy is not conserved and the modes are damped.  Pure and not collective: every
rank raises the same error.  Units: omega and eta in 1/t0.
"""

from __future__ import annotations

from ..errors import InputError

METHODS = ("exact", "kpm")
"""transport.method values: exact, every mode's d_n from its eigenvector (``allen_feldman``);
kpm, d(omega) per bin from Chebyshev moments with random probes (``kpm_diffusivity``)."""
DEFAULT_BIN_WIDTH = 0.05
"""Bins of d(omega) (1/t0) without a spectrum section: the spectrum's default bin width."""
METHOD_KEYS = {"exact": ("tol", "block", "max_scratch_gib", "omega_top"), "kpm": ("probes", "moments")}
"""Keys of each method: written with another method, they would do nothing (refused: :func:`check_given`)."""


def check_section(spec, where: str) -> None:
    """Refuse a transport section ``spec`` of method exact without eta, or of method kpm with one
    (kpm broadens the sum by the bin: docs/diffusivity_trace.md).  Not collective."""
    if spec.method == "exact" and spec.eta is None:
        raise InputError(f"{where}eta is missing: give the Lorentzian half-width (1/t0) that broadens the "
                         f"Allen-Feldman sum, a few mean level spacings, e.g. {where}eta: 0.05 "
                         f"(docs/diffusivity.md: the choice of eta)")
    if spec.method == "kpm" and spec.eta is not None:
        raise InputError(f"{where}eta = {spec.eta!r}: method 'kpm' broadens the Allen-Feldman sum by the bin "
                         f"(a box of width {where}bin_width), not by a Lorentzian: drop {where}eta and choose the "
                         f"bins (docs/diffusivity_trace.md)")


def check_given(spec, given, where: str) -> None:
    """Refuse a transport section ``spec`` whose scene wrote (``given``: the section's keys in the
    scene, null values left out) a key of the other method, even at its default.  Not collective."""
    for method, keys in METHOD_KEYS.items():
        written = [key for key in keys if method != spec.method and key in given]
        if written:
            raise InputError(f"{where}{written[0]} = {getattr(spec, written[0])!r} is a key of method {method!r}; "
                             f"{where}method is {spec.method!r}: drop it")


def bin_width(spec, spectrum) -> float:
    """Width (1/t0) of the omega bins of d(omega): ``spec.bin_width``, else the spectrum section's
    (``spectrum``, None: none), else :data:`DEFAULT_BIN_WIDTH`. Not collective."""
    if spec.bin_width is not None:
        return spec.bin_width
    return spectrum.bin_width if spectrum is not None else DEFAULT_BIN_WIDTH


def check_scene(spec, spectrum, dashpots: str) -> None:
    """Refuse a transport section ``spec`` whose d(omega) bins differ from the vDOS's
    (``spectrum``: the spectrum section, None: none), whose ``omega_top`` lies below the first
    bin's top, or on a scene with dashpots (``dashpots``: the
    keys that turn them on, ``ModelSpec.dashpot_keys``; "": none).  Not collective."""
    if spec is None:
        return
    if spectrum is not None and spec.bin_width is not None and spec.bin_width != spectrum.bin_width:
        raise InputError(f"transport.bin_width = {spec.bin_width} differs from spectrum.bin_width = "
                         f"{spectrum.bin_width}: d(omega) is kept on the vDOS's bins; drop transport.bin_width "
                         f"(or give both the same)")
    if spec.omega_top is not None and spec.omega_top < bin_width(spec, spectrum):
        raise InputError(f"transport.omega_top = {spec.omega_top:g} is below the first bin's top edge "
                         f"{bin_width(spec, spectrum):g} (the bin width): d(omega) is reported only in the bins wholly "
                         f"below omega_top, and there would be none; raise transport.omega_top or narrow the bins")
    if dashpots:
        raise InputError(f"transport with {dashpots}: the Allen-Feldman diffusivity is that of the undamped "
                         f"modes of a conserved harmonic energy; with dashpots the energy decays and the modes are "
                         f"damped; drop {dashpots} from this scene for the diffusivity of the same packing "
                         f"(the dashpots' attenuation is measured by waves and spectrum.method pep)")


def check_stressed(spec, why: str) -> None:
    """Refuse a transport section ``spec`` on a matrix that is not symmetric (``why``, a clause:
    ``model.rules.asymmetry``). Not collective."""
    if spec is not None:
        raise InputError(f"transport: {why}, so the dynamical matrix is not symmetric: it has no conserved "
                         f"harmonic energy and no orthogonal modes, on which the Allen-Feldman diffusivity is "
                         f"built (docs/diffusivity.md); use model.stored_forces: drop for the unstressed springs "
                         f"of the same packing, or drop the transport section")


def check_scratch(spec, dof: int, which: str) -> None:
    """Refuse method exact on a matrix of ``dof`` DOF whose eigenvectors (8 dof^2 bytes at most)
    exceed ``spec.max_scratch_gib`` (``which``: the packing and rho, for the message).  Not
    collective."""
    if spec is None or spec.method != "exact":
        return
    need = 8.0 * dof * dof / 2**30
    if need > spec.max_scratch_gib:
        raise InputError(f"transport.method = 'exact' on {which}: its {dof} DOF have up to {dof} modes, whose "
                         f"eigenvectors take {need:.0f} GiB of scratch files in the units folder, more than "
                         f"transport.max_scratch_gib = {spec.max_scratch_gib:g}; raise it if the disk holds them "
                         f"(time grows as DOF^3), or use a smaller packing")
