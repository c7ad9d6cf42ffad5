"""The scene schema: the declarations of a scene's keys, as frozen dataclasses.

Every field carries its documentation, default and allowed range in ``metadata``; the manual's
key reference is printed from the same source (``rotsound keys``, :func:`reference`).  A mapping is
validated into these classes by ``coerce.build``, key by key, then by the rules across keys
(``scene_rules``, which takes each stage's rules from that stage).  Validation is pure (no MPI,
no PETSc) and deterministic, so every rank that validates the same mapping raises the same
:class:`~solver.errors.InputError`.  Reading scene files, ``--set`` and the rules across the
documents of a file are in ``scenes``.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass, field

import yaml

from ..capillary import COHESION_LAWS, Cohesion
from ..contact_law import (HISTORIES, LAWS, LEVERS, MOBILISED, RESTITUTION_RULE, STORED_FORCES, ContactModel,
                           restitution_damping)
from ..packing.jammed import MIN_N
from ..packing.rules import stored_forces_source
from ..spectrum import nonhermitian, pep
from ..spectrum import plan as spectrum_plan
from ..transport.rules import METHOD_KEYS as TRANSPORT_METHOD_KEYS, METHODS as TRANSPORT_METHODS
from ..waves import schedule


def _f(default, doc, check=None, kind=None):
    """Field with documentation ``doc``; ``check(value) -> str | None`` says what is allowed."""
    meta = {"doc": doc, "check": check, "kind": kind}
    if isinstance(default, (list, dict)):
        return field(default_factory=lambda: copy.deepcopy(default), metadata=meta)  # never shared
    return field(default=default, metadata=meta)


def _one_of(values, null: bool = False):
    """Check: the value is one of ``values`` (or null, when ``null``: the checks see only non-null values)."""
    allowed = ", ".join(values) + (", or null" if null else "")
    return lambda v: None if v in values else f"must be one of {allowed}"


def _range(lo=None, hi=None, lo_open=False, hi_open=False):
    def check(v):
        bad = (lo is not None and (v < lo or (lo_open and v == lo))) or \
              (hi is not None and (v > hi or (hi_open and v == hi)))
        if bad or (isinstance(v, float) and not math.isfinite(v)):
            left = "(" if lo_open else "["
            right = ")" if hi_open else "]"
            return f"must be in {left}{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}{right}"
        return None
    return check


def _factor_ranks(v):
    """Check of ``spectrum.factor_ranks``: auto or a whole number >= 1."""
    return None if v == "auto" else _range(1, 10**6)(v)


def _even_n(v):
    if v < MIN_N or v % 2:
        return f"must be an even integer >= {MIN_N} (50:50 mixture; in 2D that also makes the box exceed two diameters)"
    return None


@dataclass(frozen=True)
class PackingSpec:
    """Section ``packing``: how configurations are made or where they are read from."""

    n: int | None = _f(None, f"number of particles N, disks or spheres (even, >= {MIN_N}; in 3D the box must also "
                             "exceed two large diameters); required unless `file` is given", _even_n, int)
    phi: float | None = _f(None, "area (2D) or volume (3D) fraction phi, in (0, 1); required unless `file` is given",
                           _range(0.0, 1.0, True, True), float)
    dim: int = _f(2, "dimension of generated packings: 2 (disks in a square box) or 3 (spheres in a cubic box); "
                     "a packing file's positions give its own", lambda v: None if v in (2, 3) else "must be 2 or 3",
                  int)
    count: int | None = _f(None, "number of independent configurations; default 1 when "
                                 "generating, all of the file's with `file`", _range(1, 100000), int)
    file: str | list[str] | None = _f(None, "packing file, or a list of files: rotsound's HDF5 layout, a LAMMPS or "
                                            "LIGGGHTS data file or text dump (atom_style sphere), a YADE text "
                                            "export, or a MercuryDPM .data file (see the manual, "
                                            "docs/packing_files.md)", None, "paths")
    format: str | None = _f(None, "format of packing.file: rotsound, lammps-data, lammps-dump, yade or mercury "
                                  "(MercuryDPM's 3D .data file); null: detected from each file's content",
                            _one_of(("rotsound", "lammps-data", "lammps-dump", "yade", "mercury"), null=True), str)
    force_tol: float = _f(1e-6, "FIRE stops when the largest net force per particle, divided by m, is below "
                                "force_tol (kn d0/m)",
                          _range(0.0, 1e-2, True), float)
    max_steps: int = _f(2_000_000, "FIRE step limit per configuration", _range(1), int)
    engine: str = _f("fire", "minimiser of generated packings: fire (rotsound's, one configuration per rank) or "
                             "lammps (LAMMPS's FIRE on all ranks, one configuration after another: the same start "
                             "and criterion, a different but equally valid minimum; needs scripts/tools/setup_dem.sh)",
                     _one_of(("fire", "lammps")), str)
    contacts: str | list[str] | None = _f(None, "with `file`: the contact file(s), one per packing file, holding "
                                                "every contact's stored tangential force (a LAMMPS 'dump local' of "
                                                "index, patom1 patom2, pair/local p1 p2 p3; see the manual, "
                                                "docs/stressed_packings.md): the packing is analysed as the DEM code left it, on its "
                                                "tangential forces (docs/stressed_contacts.md)", None, "paths")
    contacts_format: str = _f("lammps-local", "format of packing.contacts: lammps-local (LAMMPS dump local: index, "
                                              "patom1 patom2, pair/local p1 p2 p3) or liggghts-local (LIGGGHTS dump "
                                              "local of compute pair/gran/local pos id force force_tangential; read "
                                              "it with model.lever: contact) or yade (the table id1 id2 shearForce "
                                              "normalForce a YADE script writes, see the manual, docs/stressed_packings.md; read it with "
                                              "model.lever: contact and model.history: yade) or mercury-fstat "
                                              "(MercuryDPM's .fstat; read it with model.lever: contact)",
                              _one_of(("lammps-local", "liggghts-local", "yade", "mercury-fstat")), str)
    friction: float | None = _f(None, "Coulomb coefficient mu. With engine: lammps, generated packings are "
                                      "frictional, as a DEM code leaves them: squeezed from 0.75 phi to phi in "
                                      "LAMMPS (gran/hooke/history or gran/hertz/history, kt = 2/7 kn, damped) until "
                                      "every force and torque is below force_tol, with their stored tangential "
                                      "forces (friction: 0 is the same protocol without friction: no stored "
                                      "forces, a symmetric matrix). With `contacts`: the mu the file's packing was "
                                      "made with; a stored "
                                      "force above mu f_n is refused, those at mu f_n are counted as mobilised. "
                                      "null: frictionless packings, or mu unknown", _range(0.0, 1e4), float)
    pressure: float | None = _f(None, "with friction and engine: lammps: the pressure (kn in 2D, kn/d0 in 3D; "
                                      "the virial's, rotsound's `pressure`) at which LAMMPS holds the packing: "
                                      "after the squeeze to phi, fix press/berendsen moves the box until the "
                                      "packing is at rest at this pressure (to 1e-3), then it settles in that box; "
                                      "phi is then where the squeeze ends and the packing's own phi is reported. "
                                      "null: the squeeze's box is kept", _range(0.0, 1e2, True), float)
    shear: float = _f(0.0, "generated packings with engine: fire: the shear strain gamma of their periodic cell, its "
                           "tilt xy over its side L (LAMMPS's xy = gamma L; xz = yz = 0): the packing made at shear 0 "
                           "is sheared quasi-statically to gamma at fixed volume (steps of shear_step, each an affine "
                           "shear of particles and cell, then FIRE to rest), so it carries a shear stress sigma_xy "
                           "(docs/dem_packings.md). Between -0.5 and 0.5, LAMMPS's limit; 0: the square or cubic box",
                      _range(-0.5, 0.5), float)
    shear_step: float = _f(0.01, "with shear: the strain step of the quasistatic shear (the last step shorter when it "
                                 "does not divide shear); smaller steps follow the path more closely at more FIRE runs",
                           _range(0.0, 0.05, lo_open=True), float)
    walls: list[dict] | None = _f(None, "with `file`: flat immovable walls, a list of {axis: x, y or z, position: p}, p in "
                                        "the packing file's units and coordinates (as LAMMPS's fix wall/gran xplane/"
                                        "yplane/zplane takes them), on axes the file does not make periodic; each faces "
                                        "the side its particles are on. null: a LAMMPS file's f (fm, fs) bounds imply "
                                        "walls at its box bounds; other axes have none (docs/walls.md)", None, "walls")
    wall_contacts: str | list[str] | None = _f(None, "with `file`: the wall contact file(s), one per packing file: one line "
                                                     "per particle-wall contact, 'id wall fx fy fz' (the particle's id, "
                                                     "the wall's index from 0, the force on it from the wall in the "
                                                     "file's units), '#' comments; the tangential parts are the contacts' "
                                                     "stored forces (docs/walls.md)", None, "paths")
    gravity: list[float] | None = _f(None, "with `file`: the body force per unit mass, a vector of D numbers in the packing "
                                           "file's units (LAMMPS's fix gravity as a vector: force = mass g); it enters "
                                           "the rest check, not the stiffness; it must point against a wall "
                                           "(docs/walls.md)", lambda v: None if len(v) in (2, 3) and all(map(math.isfinite, v))
                                     else "must be a list of 2 or 3 finite numbers", "floats_list")
    relax: bool = _f(False, "with `file`: re-minimise each configuration frictionlessly with FIRE (to force_tol) "
                            "before the matrix is built, for packings made with friction, which balance only "
                            "with their tangential forces (they are refused otherwise); this moves the particles",
                     None, bool)


@dataclass(frozen=True)
class DampingSpec:
    """Section ``model.damping``: the contact dashpots (docs/damping.md)."""

    gamma_n: float = _f(0.0, "normal dashpot rate (1/t0) in LAMMPS's gran/*/history convention: force "
                             "-m_eff gamma_n v_n, m_eff = m_i m_j/(m_i + m_j) (times sqrt(a' xi) under hertz)",
                        _range(0.0, 1e6), float)
    gamma_t: float = _f(0.0, "tangential dashpot rate (1/t0): force -m_eff gamma_t v_t on the relative "
                             "tangential velocity of the contact point (rotations included)",
                        _range(0.0, 1e6), float)


@dataclass(frozen=True)
class CohesionSpec:
    """Section ``model.cohesion``: capillary bridges (docs/capillary_bridges.md)."""

    law: str = _f("willett", "the bridge's force law: willett (Willett et al. 2000, MercuryDPM's closed form) or "
                             "soulie (Soulie et al. 2006, as LIGGGHTS's cohesion easo/capillary/viscous evaluates it)",
                  _one_of(COHESION_LAWS), str)
    surface_tension: float = _f(None, "the liquid's surface tension gamma in units of kn (harmonic: gamma/kn; hertz: "
                                      "gamma/(kn d0)); > 0, required",
                                _range(0.0, 1e6, True), float)
    contact_angle: float = _f(0.0, "contact angle theta (radians), in [0, pi/2)", _range(0.0, math.pi / 2, False, True),
                              float)
    volume: float | None = _f(None, "the volume V of every bridge (d0^3); or give liquid_content",
                              _range(0.0, 1e3, True), float)
    liquid_content: float | None = _f(None, "LIGGGHTS's surface liquid content: the liquid a particle carries as a "
                                            "fraction of its volume (4/3) pi R^3; each bridge takes a share of both "
                                            "particles' (docs/capillary_bridges.md); or give volume",
                                      _range(0.0, 1e3, True), float)

    def cohesion(self) -> Cohesion:
        """The bridges' law (``capillary.Cohesion``, which refuses what it cannot build: ValueError;
        ``model.rules.check_cohesion`` turns that into the scene's InputError)."""
        return Cohesion(self.law, self.surface_tension, self.contact_angle, self.volume or 0.0,
                        self.liquid_content or 0.0)


@dataclass(frozen=True)
class ModelSpec:
    """Section ``model``: contact law parameters (kn = 1)."""

    rho: list[float] = _f([1.0], "stiffness ratio kt/kn: a number or a list, each >= 0",
                          _range(0.0, 1e6), "floats")
    rho_roll: float = _f(0.0, "rolling stiffness ratio kr/kn (2D and 3D), the same for every rho; >= 0",
                         _range(0.0, 1e6), float)
    rho_twist: float = _f(0.0, "twisting stiffness ratio ko/kn, the same for every rho; >= 0; 3D only",
                          _range(0.0, 1e6), float)
    law: str = _f("harmonic", "contact law: harmonic (kn xi, the paper's) or hertz (kn sqrt(a' xi) xi, a' = "
                              "R_i R_j/(R_i + R_j), with every spring scaled by sqrt(a' xi) at the reference, as "
                              "LAMMPS's gran/hertz/history); generated packings are minimised under the same normal "
                              "law, and a file must be in equilibrium under it",
                  _one_of(LAWS), str)
    masses: str = _f("equal", "equal: m = 1 for every particle (the paper's); density: the masses the packing "
                              "file holds, else m proportional to d^D; both scaled to a mean of 1. The inertia "
                              "is m d^2/8 (disk) or m d^2/10 (sphere)",
                     _one_of(("equal", "density")), str)

    mobilised: str = _f("stick", "stressed packings: how a contact at the Coulomb limit (|f_t| = mu f_n, needs "
                                 "packing.friction) responds: stick (the stick stiffness, LAMMPS's for unloading "
                                 "increments) or slide (no tangential stiffness along the slip, LAMMPS's for loading "
                                 "ones; docs/stressed_contacts.md)",
                        _one_of(MOBILISED), str)

    lever: str = _f("radius", "where a contact's tangential force acts, for the slip of the contact point and "
                              "the torques: radius (R from each centre, LAMMPS's gran/*/history and rotsound's own "
                              "packings) or contact (R - xi/2, the middle of the overlap, as LIGGGHTS and YADE); a "
                              "wall contact's too (docs/walls.md); a stressed packing balances its torques only "
                              "with the lever it was made with",
                    _one_of(LEVERS), str)

    stored_forces: str = _f("keep", "stressed packings: keep their stored tangential forces in the matrix "
                                    "(non-symmetric, as the DEM code integrates them), or drop them: unstressed "
                                    "springs on the same packing, symmetric, for comparison (the packing is then not "
                                    "at rest under the matrix's forces)",
                            _one_of(STORED_FORCES), str)

    history: str = _f("lammps", "stressed packings: the DEM code's update of a stored tangential force, which the "
                                "matrix linearises: lammps (projected onto the tangent plane as the contact turns: "
                                "LAMMPS's gran/*/history, LIGGGHTS, rotsound's own packings) or yade (YADE's ScGeom: "
                                "also turned about the normal by the pair's mean spin; the two differ in 3D only) or "
                                "granular (LAMMPS's pair granular, which waves.engine: lammps runs with rolling and "
                                "twisting springs: projected as lammps, the slip taken at the radius while the "
                                "torques act at model.lever)",
                      _one_of(HISTORIES), str)

    damping: DampingSpec | None = _f(None, "contact dashpots (docs/damping.md); absent or null: none. Damped "
                                           "waves run by waves.method: exponential (exact) or a first-order "
                                           "waves.integrator (rk, theta, ...); damped modes by spectrum.method pep",
                                     None, ("optional", DampingSpec))

    restitution: float | None = _f(None, "normal coefficient of restitution e of a binary collision of two "
                                         "particles of the mean mass, instead of model.damping.gamma_n: gamma_n = "
                                         "2 omega_0 (-ln e) / sqrt(pi^2 + ln^2 e), omega_0 = sqrt(2 kn / m) "
                                         "(docs/damping.md section 5; harmonic law only: under hertz e depends on "
                                         "the impact speed). null: none",
                                   _range(0.0, 1.0, True), float)

    cohesion: CohesionSpec | None = _f(None, "capillary bridges in the contact law (docs/capillary_bridges.md): "
                                             "each pulls a pair together while it touches and across a gap up to "
                                             "the rupture distance; generated packings are wet from the start, and "
                                             "a packing file must give its bridged pairs apart. Absent or null: dry",
                                       None, ("optional", CohesionSpec))

    def contact(self, rho: float) -> ContactModel:
        """The contact model of this section at tangential ratio ``rho`` (one of ``self.rho``)."""
        return ContactModel(rho, self.rho_roll, self.rho_twist, self.law, self.mobilised, self.lever,
                            self.stored_forces, self.history, *self.dashpots, cohesion=self.bridges)

    @property
    def bridges(self) -> Cohesion | None:
        """The capillary bridges' law, or None (dry)."""
        return None if self.cohesion is None else self.cohesion.cohesion()

    @property
    def at_rest(self) -> ContactModel:
        """What the packings are checked under: the normal law, the lever and the bridges
        (``ContactModel.at_rest``)."""
        return ContactModel(law=self.law, lever=self.lever, cohesion=self.bridges)

    @property
    def dashpots(self) -> tuple[float, float]:
        """(gamma_n, gamma_t) (1/t0): ``damping``'s, gamma_n from ``restitution`` when that is given."""
        gamma_n, gamma_t = (0.0, 0.0) if self.damping is None else (self.damping.gamma_n, self.damping.gamma_t)
        if self.restitution is not None:
            gamma_n = restitution_damping(self.restitution)
        return gamma_n, gamma_t

    @property
    def dashpot_record(self) -> dict:
        """gamma_n, gamma_t (1/t0) and ``gamma_n_from``: model.damping, or model.restitution e with
        the rule that derived gamma_n from it (``RESTITUTION_RULE``); for the log and the results file."""
        gamma_n, gamma_t = self.dashpots
        origin = "model.damping" if self.restitution is None else \
            f"model.restitution e = {self.restitution!r}: {RESTITUTION_RULE}"
        return {"gamma_n": gamma_n, "gamma_t": gamma_t, "gamma_n_from": origin}

    @property
    def damped(self) -> bool:
        """Whether a dashpot is on."""
        return any(gamma > 0.0 for gamma in self.dashpots)

    @property
    def dashpot_keys(self) -> str:
        """The keys that turn a dashpot on, as the scene wrote them, for messages: "model.damping",
        "model.restitution" or both joined by "and"; "" when none is on."""
        by_restitution = self.restitution is not None and restitution_damping(self.restitution) > 0.0
        by_damping = self.damping is not None and max(self.damping.gamma_n, self.damping.gamma_t) > 0.0
        return " and ".join(key for key, on in (("model.restitution", by_restitution), ("model.damping", by_damping))
                            if on)


def _window(v):
    if len(v) != 2 or not 0.0 <= v[0] < v[1] or not all(math.isfinite(x) for x in v):
        return "must be [omega_lo, omega_hi] with 0 <= omega_lo < omega_hi (units 1/t0), or null"
    return None


def _frequencies(v):
    if not v or not all(math.isfinite(x) and x > 0.0 for x in v):
        return "must be a non-empty list of frequencies > 0 (1/t0), or null"
    return None


def _times(v):
    if not v or not all(math.isfinite(x) and x >= 0.0 for x in v):
        return "must be a non-empty list of times >= 0 (t0), or null"
    return None


@dataclass(frozen=True)
class SpectrumSpec:
    """Section ``spectrum`` (absent: no eigensolve; ``{}``: full spectrum with defaults)."""

    window: list[float] | None = _f(None, "[omega_lo, omega_hi] in 1/t0 for one band, or null for "
                                          "the full spectrum", _window, "window")
    energies: bool = _f(False, "also compute per-mode K, Q and participation ratio (needs eigenvectors); "
                               "with kpm: bin averages of K and Q (twice the probes' cost)", None, bool)
    bin_width: float = _f(0.05, "vDOS bin width in 1/t0", _range(0.0, 10.0, True), float)
    tol: float = _f(1e-12, "SLEPc relative tolerance (-spectrum_eps_tol wins)", _range(0.0, 1e-2, True), float)
    zero_tol: float = _f(1e-4, "modes with omega below this (1/t0) are zero modes", _range(0.0, 1.0, True),
                         float)
    max_window_modes: int = _f(2000, "eigenpairs kept in memory at once (slicing window size)",
                               _range(10, 10**7), int)
    method: str = _f("auto", "auto: pep with model.damping, else nonhermitian on a non-symmetric matrix (stored "
                             "tangential forces, of packing.contacts or a packing file's own, or model.history: "
                             "yade; chosen once the packings are read, and logged), else counting when only counts "
                             "are asked (no energies, no window), else slicing; slicing: exact eigenvalues (SLEPc spectrum slicing); counting: the exact "
                                "vDOS from Sylvester inertias at the bin edges (no eigenvalues: vDOS, omega_c, mode "
                                "counts); kpm: stochastic vDOS (Chebyshev moments, no factorisation; vDOS, omega_c "
                                "and, with energies, binned K and Q); nonhermitian: every eigenvalue omega^2 of a "
                                "matrix that need not be symmetric (a stressed packing's), complex ones counted as "
                                "unstable (no window; with energies: K, Q of the stable modes), by spectrum.solver; "
                                "pep: every damped mode lambda = -sigma + i omega_d of (lambda^2 M + lambda C + D) x = 0 "
                                "with model.damping (window: omega_d in [lo, hi); with energies: K, Q of each), by "
                                "spectrum.solver",
                     _one_of(spectrum_plan.METHODS), str)
    solver: str = _f("auto", f"nonhermitian and pep only: dense (LAPACK on rank 0, time ~ DOF^3: nonhermitian up to "
                             f"{nonhermitian.MAX_DOF} DOF, auto up to {nonhermitian.AUTO_DENSE_DOF}; pep on the 2 DOF "
                             f"first-order matrix, up to {pep.MAX_DOF}, auto up to {pep.AUTO_DENSE_DOF}) or windows "
                             "(SLEPc shift-and-invert windows, checked complete by the count and the trace moments; "
                             "any size)",
                     _one_of(spectrum_plan.SOLVERS), str)
    frequencies: list[float] | None = _f(None, "pep only: the damped modes with omega_d within frequency_width of "
                                               "one of these frequencies (1/t0; e.g. the waves' omega(k), for "
                                               "analysis.loss), each band marched on its own; null: every mode (or "
                                               "the window)", _frequencies, "floats_list")
    frequency_width: float = _f(0.05, "pep with frequencies: the half-width of each band (1/t0)",
                                _range(0.0, 10.0, True), float)
    probes: int = _f(16, "kpm: random probe vectors", _range(1, 10**5), int)
    moments: int = _f(0, "kpm: Chebyshev moments; 0 chooses them so the smearing at omega = 1/t0 is "
                         "half a bin", _range(0, 10**6), int)
    factor_ranks: int | str = _f("auto", "counting: ranks that share each factorisation (MUMPS on their "
                                         "sub-communicator; must divide the ranks of a unit, mpirun -n or "
                                         "--group-size). 1: a sequential factor per rank, the fastest while one fits "
                                         "in a rank's memory; more: memory per rank falls as 1/factor_ranks; auto: "
                                         "the fewest ranks whose shared factor fits in half the memory available to "
                                         "a rank (MUMPS's own estimate). The counts are the same integers on any "
                                         "layout", _factor_ranks, "ranks")


@dataclass(frozen=True)
class ModesSpec:
    """Section ``modes`` (absent: no mode shapes): whole eigenvectors near chosen frequencies, for
    pictures (``rotsound plot``) and exports (``rotsound export``); spectrum/shapes.py."""

    omega: list[float] | None = _f(None, "target frequencies (1/t0): the modes nearest each are kept whole "
                                         "(give omega, localised or both)", _frequencies, "floats_list")
    count: int = _f(1, "modes kept per target frequency (nearest in omega^2; zero modes left out)",
                    _range(1, 100), int)
    tol: float = _f(1e-10, "SLEPc relative tolerance of the shift-and-invert solve (-modes_eps_tol wins)",
                    _range(0.0, 1e-2, True), float)
    localised: int = _f(0, "also keep the n modes of lowest and the n of highest participation ratio of each "
                            "(rho, packing), from its spectrum (needs spectrum.energies, method slicing)",
                        _range(0, 100), int)


WAVE_MODES = ("L", "TR", "RT", "R")


def _axes(v):
    if not v or len(set(v)) != len(v) or any(a not in ("x", "y", "z") for a in v):
        return "must be a non-empty list of distinct axes from x, y, z, or null"
    return None


def _modes(v):
    bad = [m for m in v if m not in WAVE_MODES]
    if not v or bad or len(set(v)) != len(v):
        return "must be a non-empty list of distinct modes from L, TR, RT, R (R: 3D only)"
    return None


def _positive_ints(v):
    if not v or any(x < 1 for x in v):
        return "must be a non-empty list of integers >= 1 (k = 2 pi n / L)"
    return None


def _kd0(v):
    if not v or any(not (0.0 < x <= 2 * math.pi) for x in v):
        return "must be a non-empty list of k d0 values in (0, 2 pi]"
    return None


@dataclass(frozen=True)
class WavesSpec:
    """Section ``waves`` (absent: no standing waves)."""

    modes: list[str] = _f(["L", "TR", "RT"], "modes to excite, from L, TR, RT (paper's Table 1) and R "
                                             "(angular velocity along k, the twist mode; 3D only)", _modes,
                          "strs")
    n: list[int] | None = _f(None, "wave numbers as integers n, k = 2 pi n / L (give n or kd0)",
                             _positive_ints, "ints")
    kd0: list[float] | None = _f(None, "wave numbers as k d0; each is moved to the nearest allowed "
                                       "2 pi n / L (reported)", _kd0, "floats_list")
    axes: list[str] | None = _f(None, "axes along which k runs, from x, y, z (z in 3D only); null: every axis. The "
                                      "runs along them are pooled, so in a box whose sides differ their allowed k "
                                      "must agree to 1 %. In a tilted (sheared) cell axis a means k along the "
                                      "reciprocal vector b_a, L its height across a (docs/waves_theory.md)",
                                _axes, "strs")
    amplitude: float | list[float] = _f(1e-3, "initial velocity amplitude A (d0/t0, or 1/t0 for RT); with "
                                               "engine: lammps a list is a sweep, one unit per amplitude",
                                        _range(0.0, 1.0, True), "number_or_list")
    dt: float = _f(0.02, "time step (t0); refused at or above the scheme's stability limit (-waves_ts_dt wins)", _range(0.0, 10.0, True),
                   float)
    t_end: float = _f(100.0, "run length (t0) (-waves_ts_max_time wins)", _range(0.0, 1e7, True), float)
    sample_every: int = _f(5, "steps between samples of the Fourier components", _range(1, 10**6), int)
    integrator: str = _f("verlet", f"time integrator: {', '.join(schedule.INTEGRATORS)} (-waves_ts_type wins: "
                                   "any PETSc TS type; python is verlet)", _one_of(schedule.INTEGRATORS), str)
    method: str = _f("ts", "ts: integrate with PETSc TS; spectral: no time stepping (samples every dt x "
                           "sample_every, r_i(0) phase only, symmetric matrices): Lanczos on the matrix, or with "
                           "model.damping the Chebyshev-Bessel series of exp(tJ); "
                           "exponential: exp(h J) of the first-order system from sample to sample by SLEPc MFN "
                           "(exact to tol, any matrix: the exact path for stressed packings)",
                     _one_of(schedule.METHODS), str)
    engine: str = _f("rotsound", "rotsound: the linear waves of the dynamical matrix (waves.method); lammps: LAMMPS "
                                 "integrates the packing itself with its full contact law at waves.amplitude, from "
                                 "the packing held at rest: Coulomb mu = packing.friction, contacts that open and "
                                 "form, its velocity Verlet at waves.dt; the unit also keeps its contacts' series "
                                 "(docs/finite_amplitude.md)", _one_of(schedule.ENGINES), str)
    contacts_every: int | None = _f(None, "engine: lammps: samples between records of the contacts' series (the "
                                          "Fourier components are kept every sample); null: 10. A record costs "
                                          "more than ten of LAMMPS's steps (BENCHMARKS)", _range(1, 10**6), int)
    rolling_friction: float | None = _f(None, "engine: lammps with model.history: granular: the rolling springs' "
                                              "Coulomb limit mu_roll (|f_r| <= mu_roll |f_n|; LAMMPS's rolling sds); "
                                              "null: 1e4, no limit (docs/finite_amplitude.md section 7)",
                                        _range(0.0, 1e4, True), float)
    twisting_friction: float | None = _f(None, "engine: lammps with model.history: granular: the twisting springs' "
                                               "Coulomb limit mu_twist in d0 (|torque| <= mu_twist |f_n|; LAMMPS's "
                                               "twisting sds); null: 1e4, no limit", _range(0.0, 1e4, True), float)
    snapshots: list[float] | None = _f(None, "times (t0, up to t_end) at which the whole velocity field of the "
                                             "mode's first run at the smallest k is kept, for pictures (method "
                                             "spectral without dashpots); null: none", _times, "floats_list")
    tol: float = _f(1e-8, "spectral: relative accuracy of z(t) (Lanczos error estimate; with dashpots the "
                          "series' error bound, relative to |X(0)|); exponential: the "
                          "error bound of the samples, relative to |X(0)| (each MFN solve to tol / samples)",
                    _range(0.0, 1e-2, True), float)


    @property
    def sweep(self) -> list[float] | None:
        """The amplitudes of a sweep (``amplitude`` given as a list), else None."""
        return self.amplitude if isinstance(self.amplitude, list) else None


@dataclass(frozen=True)
class TransportSpec:
    """Section ``transport`` (absent: no diffusivity): how far each mode carries energy, the
    Allen-Feldman diffusivity d(omega) (docs/diffusivity.md; the stage ``solver/transport``)."""

    eta: float | None = _f(None, "exact (required there): half-width (1/t0) of the Lorentzian that broadens "
                                 "delta(omega_n - omega_m) in the Allen-Feldman sum; a few mean level spacings "
                                 "1/(M g(omega)) of the M modes (docs/diffusivity.md: the choice of eta)",
                           _range(0.0, 1e3, True), float)
    method: str = _f("exact", "exact: every mode's d_n from its eigenvector (spectrum slicing in blocks of "
                              "`block` modes, vectors in scratch files of the units folder: n M float64 in all); "
                              "kpm: d(omega) per bin, no eigenvectors (Chebyshev moments with random probes, "
                              "MatMult only; the sum broadened by the bin, with a standard error per bin; "
                              "docs/diffusivity_trace.md)",
                     _one_of(TRANSPORT_METHODS), str)
    bin_width: float | None = _f(None, "width (1/t0) of the omega bins of d(omega), the mean d of the modes in each "
                                       "bin; null: spectrum.bin_width (the vDOS's bins), 0.05 without a spectrum "
                                       "section", _range(0.0, 10.0, True), float)
    omega_top: float | None = _f(None, "exact: the low-frequency window (1/t0): slice and sum only the modes up to "
                                       "omega_top + 20 eta, and report d(omega) for those up to omega_top, in the bins "
                                       "wholly below it; null: every mode (docs/diffusivity.md, section 5)",
                                 _range(0.0, 1e3, True), float)
    zero_tol: float = _f(1e-4, "modes with omega at or below this (1/t0) are zero modes and carry no energy "
                               "(left out of both sums, as the spectrum leaves them out)",
                         _range(0.0, 1.0, True), float)
    tol: float = _f(1e-12, "exact: SLEPc relative tolerance of the slicing windows (-transport_eps_tol wins)",
                    _range(0.0, 1e-2, True), float)
    block: int = _f(1000, "exact: modes per slicing window and per block of the double sum; memory per rank "
                          "~ (2 + D) n block / ranks float64", _range(10, 10**6), int)
    max_scratch_gib: float = _f(64.0, "exact: refuse, before any compute, a packing whose eigenvectors (8 n M "
                                      "bytes, written to the units folder) exceed this many GiB",
                                _range(0.0, 1e6, True), float)
    probes: int = _f(16, "kpm: random probe vectors (>= 2: their spread gives the standard error d_err, which "
                         "falls as 1/sqrt(probes))", _range(2, 10**5), int)
    moments: int = _f(0, "kpm: Chebyshev moments; 0 chooses them so that Jackson's smearing at omega = 1/t0 is "
                         "about half a bin", _range(0, 10**6), int)


@dataclass(frozen=True)
class AnalysisSpec:
    """Section ``analysis``: how waves results are fitted (post-processing; not part of the digest,
    so changing it reuses every finished unit)."""

    decay_window: float = _f(3.0, "fit exp(-gamma t) cos(omega t) to C(k, t) for t <= decay_window / gamma "
                                  "(C decayed to about e^-3)", _range(0.5, 50.0), float)
    lattice_kd0_max: float = _f(math.pi / 2, "joint fit of the lattice model's a_r, l (RT) and a_t (TR) "
                                             "uses k d0 <= this (the long-wave part)",
                                _range(0.0, 2 * math.pi, True), float)
    power_law_kd0_max: float = _f(1.0, "gamma ~ k^p is fitted for k d0 <= this, over the k whose decay "
                                       "the run resolves (gamma t_end >= 1)", _range(0.0, 2 * math.pi, True),
                                  float)


@dataclass(frozen=True)
class Scene:
    """A whole run."""

    output: str = _f("results/scene.h5", "results file (HDF5); its folder is created", None, str)
    seed: int = _f(0, "seed of every random draw (configuration i uses SeedSequence([seed, i]))",
                   _range(0, 2**63 - 1), int)
    packing: PackingSpec = _f(None, "see packing.*", None, PackingSpec)
    model: ModelSpec = _f(None, "see model.*", None, ModelSpec)
    spectrum: SpectrumSpec | None = _f(None, "see spectrum.*; absent or null: no eigensolve", None,
                                       ("optional", SpectrumSpec))
    waves: WavesSpec | None = _f(None, "see waves.*; absent or null: no standing waves", None,
                                 ("optional", WavesSpec))
    modes: ModesSpec | None = _f(None, "see modes.*; absent or null: no mode shapes", None,
                                 ("optional", ModesSpec))
    transport: TransportSpec | None = _f(None, "see transport.*; absent or null: no diffusivity", None,
                                         ("optional", TransportSpec))
    petsc: dict = _f({}, "PETSc/SLEPc options database entries; nested keys join with '_' "
                         "(-spectrum_eps_*, -waves_ts_*, -log_view, ...: see the option prefixes); the command line wins", None, dict)
    analysis: AnalysisSpec = _f(None, "see analysis.*; applies when the scene has waves", None, AnalysisSpec)
    cache: str = _f("auto", "shared unit cache: `auto` = a `cache` folder beside `output`, a folder path, or "
                            "`off` (or false); packings, matrix summaries, spectra and waves are reused from it "
                            "by content", None, "cache")

    def digest(self) -> str:
        """Stable hash of what the scene asks for (not ``output``, not ``analysis``, which only
        post-processes units, not ``cache``, not ``petsc``: the options acting on a unit are part
        of that unit's own content key, so changing them recomputes just those units, whether they
        come from this block or the command line).  Only values that differ from their defaults
        count (:func:`_explicit`), so a key added in a later version, at its default, leaves the
        digest of an unfinished run, and its resume, alone.  ``spectrum.factor_ranks`` says how
        the ranks share the work, not what is computed: left out too, so that a run is resumed
        with another layout (say, after running out of memory with a factor per rank).
        ``spectrum.method: auto`` counts as the method the scene alone gives it
        (``spectrum.plan.resolve`` before the packings are read): a packing file's stored forces,
        like the rest of its content, leave the digest alone."""
        spectrum = spectrum_plan.resolve(self.spectrum, self.model, stored_forces_source(self.packing))[0]
        data = _explicit(dataclasses.replace(self, spectrum=spectrum))
        for name in ("output", "analysis", "cache", "petsc"):
            data.pop(name, None)
        if isinstance(data.get("spectrum"), dict):
            data["spectrum"].pop("factor_ranks", None)
        return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:16]

    def to_yaml(self) -> str:
        """The validated scene with all defaults filled in, as YAML, less the keys of the transport
        method not in use (they do nothing, and a scene that writes them is refused): it reads back
        as the same scene."""
        data = dataclasses.asdict(self)
        if self.transport is not None:
            for method, keys in TRANSPORT_METHOD_KEYS.items():
                for key in keys if method != self.transport.method else ():
                    del data["transport"][key]
        return yaml.safe_dump(data, sort_keys=False)


def _explicit(section) -> dict:
    """The fields of a scene ``section`` that differ from their defaults, nested sections as
    mappings of theirs; an optional section (spectrum, waves) counts when present, even empty."""
    out = {}
    for f in dataclasses.fields(section):
        value = getattr(section, f.name)
        if dataclasses.is_dataclass(value):
            nested = _explicit(value)
            if nested or isinstance(f.metadata["kind"], tuple):
                out[f.name] = nested
            continue
        default = f.default_factory() if f.default is dataclasses.MISSING else f.default
        if value != default:
            out[f.name] = value
    return out


def reference(cls=Scene, where: str = "") -> list[tuple[str, str, str]]:
    """(key, default, description) rows of every scene key."""
    rows = []
    for f in dataclasses.fields(cls):
        kind = f.metadata["kind"]
        if isinstance(kind, tuple):
            kind = kind[1]
        if dataclasses.is_dataclass(kind):
            rows.extend(reference(kind, f"{where}{f.name}."))
            continue
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        rows.append((f"{where}{f.name}", json.dumps(default), f.metadata["doc"]))
    return rows


def reference_markdown() -> str:
    """The scene key reference as a Markdown table (``rotsound keys``, and the manual's scenes page)."""
    lines = ["| key | default | meaning |", "|---|---|---|"]
    lines += [f"| `{key}` | `{default}` | {doc.replace('|', chr(92) + '|')} |" for key, default, doc in reference()]
    return "\n".join(lines)
