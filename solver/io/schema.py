"""The scene schema: run descriptions as frozen, validated dataclasses.

Every field carries its documentation, default and allowed range in ``metadata``; the README
reference is printed from the same source (``rotsound keys``, :func:`reference`).  Validation is
pure (no MPI, no PETSc) and deterministic, so every rank that validates the same mapping raises
the same :class:`~solver.errors.InputError`.  Reading scene files, ``--set`` and the rules across
the documents of a file are in ``scenes``.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

import copy
import dataclasses
import difflib
import hashlib
import json
import math
from dataclasses import dataclass, field

import yaml

from ..contact_law import (HISTORIES, LAWS, LEVERS, MOBILISED, RESTITUTION_RULE, STORED_FORCES, ContactModel,
                           restitution_damping)
from ..errors import InputError
from ..waves.schedule import SECOND_ORDER


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
    if v < 16 or v % 2:
        return "must be an even integer >= 16 (50:50 mixture; in 2D that also makes the box exceed two diameters)"
    return None


@dataclass(frozen=True)
class PackingSpec:
    """Section ``packing``: how configurations are made or where they are read from."""

    n: int | None = _f(None, "number of particles N, disks or spheres (even, >= 16; in 3D the box must also "
                             "exceed two large diameters); required unless `file` is given", _even_n, int)
    phi: float | None = _f(None, "area (2D) or volume (3D) fraction phi, in (0, 1); required unless `file` is given",
                           _range(0.0, 1.0, True, True), float)
    dim: int = _f(2, "dimension of generated packings: 2 (disks in a square box) or 3 (spheres in a cubic box); "
                     "a packing file's positions give its own", lambda v: None if v in (2, 3) else "must be 2 or 3",
                  int)
    count: int | None = _f(None, "number of independent configurations; default 1 when "
                                 "generating, all of the file's with `file`", _range(1, 100000), int)
    file: str | list[str] | None = _f(None, "packing file, or a list of files: rotsound's HDF5 layout, a LAMMPS or "
                                            "LIGGGHTS data file or text dump (atom_style sphere), or a YADE text "
                                            "export (see README)", None, "paths")
    format: str | None = _f(None, "format of packing.file: rotsound, lammps-data, lammps-dump or yade; null: "
                                  "detected from each file's content",
                            _one_of(("rotsound", "lammps-data", "lammps-dump", "yade"), null=True), str)
    force_tol: float = _f(1e-6, "FIRE stops when the largest net force per particle, divided by m, is below "
                                "force_tol (kn d0/m)",
                          _range(0.0, 1e-2, True), float)
    max_steps: int = _f(2_000_000, "FIRE step limit per configuration", _range(1), int)
    engine: str = _f("fire", "minimiser of generated packings: fire (rotsound's, one configuration per rank) or "
                             "lammps (LAMMPS's FIRE on all ranks, one configuration after another: the same start "
                             "and criterion, a different but equally valid minimum; needs scripts/setup_dem.sh)",
                     _one_of(("fire", "lammps")), str)
    contacts: str | list[str] | None = _f(None, "with `file`: the contact file(s), one per packing file, holding "
                                                "every contact's stored tangential force (a LAMMPS 'dump local' of "
                                                "index, patom1 patom2, pair/local p1 p2 p3; see README, Stressed "
                                                "packings): the packing is analysed as the DEM code left it, on its "
                                                "tangential forces (docs/stressed_contacts.md)", None, "paths")
    contacts_format: str = _f("lammps-local", "format of packing.contacts: lammps-local (LAMMPS dump local: index, "
                                              "patom1 patom2, pair/local p1 p2 p3) or liggghts-local (LIGGGHTS dump "
                                              "local of compute pair/gran/local pos id force force_tangential; read "
                                              "it with model.lever: contact) or yade (the table id1 id2 shearForce "
                                              "normalForce a YADE script writes, see README; read it with "
                                              "model.lever: contact and model.history: yade)",
                              _one_of(("lammps-local", "liggghts-local", "yade")), str)
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
                              "stressed packing balances its torques only with the lever it was made with",
                    _one_of(LEVERS), str)

    stored_forces: str = _f("keep", "stressed packings: keep their stored tangential forces in the matrix "
                                    "(non-symmetric, as the DEM code integrates them), or drop them: unstressed "
                                    "springs on the same packing, symmetric, for comparison (the packing is then not "
                                    "at rest under the matrix's forces)",
                            _one_of(STORED_FORCES), str)

    history: str = _f("lammps", "stressed packings: the DEM code's update of a stored tangential force, which the "
                                "matrix linearises: lammps (projected onto the tangent plane as the contact turns: "
                                "LAMMPS's gran/*/history, LIGGGHTS, rotsound's own packings) or yade (YADE's ScGeom: "
                                "also turned about the normal by the pair's mean spin); the two differ in 3D only",
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

    def contact(self, rho: float) -> ContactModel:
        """The contact model of this section at tangential ratio ``rho`` (one of ``self.rho``)."""
        return ContactModel(rho, self.rho_roll, self.rho_twist, self.law, self.mobilised, self.lever,
                            self.stored_forces, self.history, *self.dashpots)

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


METHODS = ("auto", "slicing", "counting", "kpm", "nonhermitian", "pep")
SOLVERS = ("auto", "dense", "windows")  # spectrum.solver (nonhermitian, pep): spectrum/nonhermitian.py, pep.py


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
                     _one_of(METHODS), str)
    solver: str = _f("auto", "nonhermitian and pep only: dense (LAPACK on rank 0, time ~ DOF^3: nonhermitian up to "
                             "20000 DOF, auto up to 3000; pep on the 2 DOF first-order matrix, up to 8000, auto up to "
                             "4000) or windows (SLEPc shift-and-invert windows, checked complete by the count and the "
                             "trace moments; any size)",
                     _one_of(SOLVERS), str)
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


INTEGRATORS = ("verlet", "alpha2", "rk", "theta", "cn", "beuler", "ssp")
WAVE_METHODS = ("ts", "spectral", "exponential")  # waves.method: waves/schedule.py


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
                                      "must agree to 1 %", _axes, "strs")
    amplitude: float = _f(1e-3, "initial velocity amplitude A (d0/t0, or 1/t0 for RT)",
                          _range(0.0, 1.0, True), float)
    dt: float = _f(0.02, "time step (t0); refused at or above the scheme's stability limit (-waves_ts_dt wins)", _range(0.0, 10.0, True),
                   float)
    t_end: float = _f(100.0, "run length (t0) (-waves_ts_max_time wins)", _range(0.0, 1e7, True), float)
    sample_every: int = _f(5, "steps between samples of the Fourier components", _range(1, 10**6), int)
    integrator: str = _f("verlet", f"time integrator: {', '.join(INTEGRATORS)} (-waves_ts_type wins: "
                                   "any PETSc TS type; python is verlet)", _one_of(INTEGRATORS), str)
    method: str = _f("ts", "ts: integrate with PETSc TS; spectral: no time stepping (samples every dt x "
                           "sample_every, r_i(0) phase only, symmetric matrices): Lanczos on the matrix, or with "
                           "model.damping the Chebyshev-Bessel series of exp(tJ); "
                           "exponential: exp(h J) of the first-order system from sample to sample by SLEPc MFN "
                           "(exact to tol, any matrix: the exact path for stressed packings)",
                     _one_of(WAVE_METHODS), str)
    snapshots: list[float] | None = _f(None, "times (t0, up to t_end) at which the whole velocity field of the "
                                             "mode's first run at the smallest k is kept, for pictures (method "
                                             "spectral without dashpots); null: none", _times, "floats_list")
    tol: float = _f(1e-8, "spectral: relative accuracy of z(t) (Lanczos error estimate; with dashpots the "
                          "series' error bound, relative to |X(0)|); exponential: the "
                          "error bound of the samples, relative to |X(0)| (each MFN solve to tol / samples)",
                    _range(0.0, 1e-2, True), float)


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
        (:func:`resolve_method` before the packings are read): a packing file's stored forces,
        like the rest of its content, leave the digest alone."""
        data = _explicit(resolve_method(self, stored_forces_source(self))[0])
        for name in ("output", "analysis", "cache", "petsc"):
            data.pop(name, None)
        if isinstance(data.get("spectrum"), dict):
            data["spectrum"].pop("factor_ranks", None)
        return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:16]

    def to_yaml(self) -> str:
        """The validated scene with all defaults filled in, as YAML."""
        return yaml.safe_dump(dataclasses.asdict(self), sort_keys=False)


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


def _type_name(kind) -> str:
    return {int: "an integer", float: "a number", str: "a string", dict: "a mapping",
            "floats": "a number or a list of numbers", "paths": "a path or a list of paths",
            bool: "true or false", "window": "a list [omega_lo, omega_hi]", "strs": "a list of names",
            "ints": "a list of integers", "floats_list": "a list of numbers",
            "cache": "auto, a folder path, or off", "ranks": "auto or a whole number"}.get(
        kind, "a mapping")


def _coerce(value, kind, where):
    """Convert a YAML value to ``kind`` or raise InputError naming ``where``."""
    def fail():
        raise InputError(f"{where} = {value!r}: must be {_type_name(kind)}")

    if kind is int:
        if isinstance(value, bool):
            fail()
        if isinstance(value, int):
            return value
        try:  # 2e6 (a string to PyYAML) or 2.0e6 is the integer 2000000
            number = float(value) if isinstance(value, (float, str)) else None
        except ValueError:
            number = None
        if number is None or not number.is_integer():
            fail()
        return int(number)
    if kind is float:
        if isinstance(value, bool):
            fail()
        if isinstance(value, str):  # PyYAML reads 1e-6 (no dot) as a string
            try:
                return float(value)
            except ValueError:
                fail()
        if not isinstance(value, (int, float)):
            fail()
        return float(value)
    if kind == "ranks":
        if value == "auto":
            return value
        try:
            return _coerce(value, int, where)
        except InputError:
            fail()
    if kind == "cache" and value is False:  # YAML reads a bare off/no/false as False
        return "off"
    if kind in (str, "cache"):
        if not isinstance(value, str) or not value:
            fail()
        return value
    if kind in (dict, bool):
        if not isinstance(value, kind):
            fail()
        return value
    if kind in ("strs", "ints", "floats_list"):
        if not isinstance(value, list):
            fail()
        item = {"strs": str, "ints": int, "floats_list": float}[kind]
        return [_coerce(v, item, where) for v in value]
    if kind == "window":  # numbers, including PyYAML's strings such as 1e1
        if not isinstance(value, list) or any(isinstance(v, bool) for v in value):
            fail()
        return [_coerce(v, float, where) for v in value]
    if kind == "floats":
        items = value if isinstance(value, list) else [value]
        if not items:
            raise InputError(f"{where} = []: must not be empty")
        return [_coerce(v, float, where) for v in items]
    if kind == "paths":
        items = value if isinstance(value, list) else [value]
        if not items or not all(isinstance(v, str) and v for v in items):
            fail()
        return value
    raise AssertionError(kind)


def build(cls, raw, where: str = ""):
    """Validate mapping ``raw`` into dataclass ``cls``; ``where`` is the key path prefix."""
    raw = {} if raw is None else raw
    if not isinstance(raw, dict):
        raise InputError(f"{where.rstrip('.') or 'scene'} = {raw!r}: must be a mapping")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(map(str, raw)) - set(fields))
    if unknown:
        near = difflib.get_close_matches(unknown[0], fields, n=1)
        hint = f"did you mean {where}{near[0]}? " if near else ""
        raise InputError(f"unknown key {where}{unknown[0]}: {hint}allowed keys in "
                         f"{where.rstrip('.') or 'the scene'} are {', '.join(fields)}")
    values = {}
    for name, f in fields.items():
        kind, check = f.metadata["kind"], f.metadata["check"]
        key = f"{where}{name}"
        if dataclasses.is_dataclass(kind):
            values[name] = build(kind, raw.get(name), key + ".")
            continue
        if isinstance(kind, tuple):  # optional section: present (even empty) means "compute it"
            if name in raw and raw[name] is not None:
                values[name] = build(kind[1], raw[name], key + ".")
            continue
        if name not in raw or raw[name] is None:
            continue
        value = _coerce(raw[name], kind, key)
        for item in (value if isinstance(value, list) and kind == "floats" else [value]):
            problem = check(item) if check else None
            if problem:
                raise InputError(f"{key} = {raw[name]!r}: {problem}")
        values[name] = value
    obj = cls(**values)
    if isinstance(obj, Scene):  # spectrum.method auto is kept: the packings may decide it (pipeline.run)
        resolve_method(obj, stored_forces_source(obj))
    else:
        _cross_check(obj, where)
    return obj


def auto_method(scene: Scene, which: str | None) -> tuple[str, str]:
    """What ``spectrum.method: auto`` means for ``scene`` on packings carrying the stored tangential
    forces ``which`` says (None: none), and why: the cheapest exact method that fits the matrix and
    what is asked: pep with dashpots (the only one that takes them), nonhermitian on a non-symmetric
    matrix (:func:`asymmetry`), else counting when only counts are asked (no energies, no window),
    else slicing."""
    if scene.model.damped:
        return "pep", "dashpots: the damped modes"
    why = asymmetry(scene, which)
    if why is not None:
        return "nonhermitian", f"{why}, so the matrix is not symmetric"
    if scene.spectrum.energies or scene.spectrum.window:
        return "slicing", "per-mode energies asked" if scene.spectrum.energies else "a window asked"
    return "counting", "only counts asked: no energies, no window"


def resolve_method(scene: Scene, which: str | None) -> tuple[Scene, str | None]:
    """``scene`` with ``spectrum.method: auto`` replaced by :func:`auto_method`'s choice on packings
    carrying the stored tangential forces ``which`` says (None: none), and the log line saying so
    (None when the method was not auto); InputError if the scene cannot run so.  Not collective:
    the same on every rank given the same ``which``."""
    said = None
    if scene.spectrum is not None and scene.spectrum.method == "auto":
        method, why = auto_method(scene, which)
        scene = dataclasses.replace(scene, spectrum=dataclasses.replace(scene.spectrum, method=method))
        _cross_check(scene.spectrum, "spectrum.")
        said = f"spectrum.method auto -> {method} ({why})"
    _cross_check(scene, "")
    return scene, said


def stored_forces_source(scene: Scene) -> str | None:
    """Whose stored tangential forces the scene alone gives its packings, as a clause for messages;
    None when it gives none (a packing file's own, in its ``tangential`` group, are known once it
    is read). Not collective."""
    if scene.packing.contacts is not None:
        return "packing.contacts gives the packings stored tangential forces"
    if scene.packing.file is None and scene.packing.friction:
        return (f"packing.friction = {scene.packing.friction} makes frictional packings that stand on stored "
                f"tangential forces")
    return None


def asymmetry(scene: Scene, which: str | None) -> str | None:
    """Why the dynamical matrix of ``scene`` is not symmetric, as a clause, or None: the stored
    tangential forces ``which`` says the packings carry (None: none) when ``model.stored_forces``
    keeps them, or YADE's slip (``model.history: yade`` with a tangential spring;
    docs/stressed_contacts.md). Not collective."""
    if which is not None and scene.model.stored_forces == "keep":
        return which
    if scene.model.history == "yade" and any(r > 0 for r in scene.model.rho):
        return "model.history: yade takes YADE's tangential slip, which is not the transpose of its forces' action"
    return None


DEM_CONVENTIONS = {"liggghts-local": ("contact", "lammps"), "yade": ("contact", "yade")}
"""contacts_format -> (model.lever, model.history) of the code that writes it (docs/stressed_contacts.md)."""


def _check_dem_convention(scene) -> None:
    """A LIGGGHTS or YADE contact file read under another code's lever or history would give that
    code's matrix of this packing, silently: InputError naming the keys to set.  Not collective."""
    want = DEM_CONVENTIONS.get(scene.packing.contacts_format)
    if want is None or (scene.model.lever, scene.model.history) == want:
        return
    raise InputError(f"packing.contacts_format = '{scene.packing.contacts_format}' holds a packing integrated with "
                     f"the lever {want[0]} and {want[1]}'s history (docs/stressed_contacts.md), but model.lever = "
                     f"'{scene.model.lever}' and model.history = '{scene.model.history}': set model.lever: {want[0]} "
                     f"and model.history: {want[1]} (or model.stored_forces: drop for the unstressed matrix)")


def _cross_check(obj, where):
    if isinstance(obj, PackingSpec) and obj.contacts is not None and (obj.file is None or obj.relax):
        raise InputError(f"{where}contacts: the stored tangential forces of packing.file's packings; they need "
                         f"packing.file" + (" and cannot go with packing.relax, which re-minimises without them"
                                            if obj.relax else ""))
    if isinstance(obj, PackingSpec) and obj.friction is not None and obj.contacts is None and (
            obj.file is not None or obj.engine != "lammps"):
        raise InputError(f"{where}friction = {obj.friction}: the Coulomb mu of a frictional packing, made by LAMMPS "
                         f"(generated packings with packing.engine: lammps) or read with its contact file "
                         f"(packing.file with packing.contacts); give one of these")
    if isinstance(obj, PackingSpec) and obj.pressure is not None and (obj.friction is None or obj.file is not None):
        raise InputError(f"{where}pressure = {obj.pressure}: the pressure at which LAMMPS holds a frictional packing "
                         f"it makes: needs packing.friction with packing.engine: lammps and no packing.file (for a "
                         f"frictionless one in the same protocol, give friction: 0)")
    if isinstance(obj, PackingSpec) and obj.file is None:
        for name in ("n", "phi"):
            if getattr(obj, name) is None:
                raise InputError(f"{where}{name} is missing: give packing.n and packing.phi, "
                                 f"or packing.file")
        if obj.relax:
            raise InputError(f"{where}relax = true re-minimises the packings of packing.file; generated "
                             f"packings are minimised already: give packing.file or drop packing.relax")
    if isinstance(obj, SpectrumSpec) and obj.method not in ("slicing", "pep", "auto") and obj.window:
        raise InputError(f"{where}method = {obj.method!r} gives the whole vDOS: {where}window needs method "
                         f"'slicing' (or 'pep', whose window is in the damped frequency)")
    if isinstance(obj, SpectrumSpec) and obj.method not in ("nonhermitian", "pep", "auto") and obj.solver != "auto":
        raise InputError(f"{where}solver = {obj.solver!r} chooses how methods nonhermitian and pep find every "
                         f"eigenvalue; method {obj.method!r} has no such choice: drop {where}solver or use method "
                         f"'nonhermitian' (or 'pep' with model.damping)")
    if isinstance(obj, SpectrumSpec) and obj.frequencies is not None and (obj.method not in ("pep", "auto") or obj.window):
        raise InputError(f"{where}frequencies = {obj.frequencies}: bands of damped modes, for method 'pep' without "
                         f"{where}window" + ("" if obj.method in ("pep", "auto") else f" (method is {obj.method!r})"))
    if isinstance(obj, SpectrumSpec) and obj.method not in ("counting", "auto") and obj.factor_ranks not in (1, "auto"):
        raise InputError(f"{where}factor_ranks = {obj.factor_ranks}: the ranks sharing each factorisation of method "
                         f"'counting'; method {obj.method!r} has none to share: drop {where}factor_ranks")
    if isinstance(obj, SpectrumSpec) and obj.method == "counting" and obj.energies:
        raise InputError(f"{where}method = 'counting' gives mode counts only: {where}energies needs method "
                         f"'slicing' (per mode) or 'kpm' (bin averages)")
    if isinstance(obj, ModesSpec) and obj.omega is None and not obj.localised:
        raise InputError(f"{where}omega is missing: give the target frequencies (1/t0) whose nearest modes to keep, "
                         f"e.g. {where}omega: [0.1, 1.0], or {where}localised")
    if isinstance(obj, Scene) and obj.modes is not None and obj.modes.localised and (
            obj.spectrum is None or obj.spectrum.method != "slicing" or not obj.spectrum.energies):
        raise InputError(f"modes.localised = {obj.modes.localised}: the participation ratios of every mode come from "
                         f"the spectrum: give spectrum: {{energies: true}} (method slicing)"
                         + ("" if obj.spectrum is None else f"; spectrum.method is {obj.spectrum.method!r}, "
                                                            f"energies {obj.spectrum.energies}"))
    if isinstance(obj, WavesSpec) and (obj.n is None) == (obj.kd0 is None):
        raise InputError(f"{where}n / {where}kd0: give exactly one of them (the wave numbers)")
    if isinstance(obj, WavesSpec) and obj.snapshots is not None and (
            obj.method != "spectral" or max(obj.snapshots) > obj.t_end):
        raise InputError(f"{where}snapshots = {obj.snapshots}: velocity fields of the spectral path, at times up to "
                         f"{where}t_end = {obj.t_end}" + ("" if obj.method == "spectral" else
                                                          f"; {where}method is {obj.method!r}: use spectral"))
    if isinstance(obj, WavesSpec) and obj.sample_every * obj.dt > obj.t_end / 4:
        raise InputError(f"{where}sample_every = {obj.sample_every}: with dt = {obj.dt} that leaves "
                         f"fewer than 4 samples in t_end = {obj.t_end}")
    if isinstance(obj, Scene) and obj.packing.file is None:
        check_dimension(obj, obj.packing.dim, f"packing.dim is {obj.packing.dim}")
    if isinstance(obj, Scene) and obj.packing.contacts is not None and obj.model.stored_forces == "keep":
        _check_dem_convention(obj)
    if isinstance(obj, Scene) and obj.model.mobilised == "slide" and obj.packing.friction is None:
        raise InputError("model.mobilised = 'slide': which contacts are at the Coulomb limit needs their mu: give "
                         "packing.friction (with packing.contacts, or packing.engine: lammps)")
    if isinstance(obj, Scene):
        check_stressed(obj, stored_forces_source(obj))
    if isinstance(obj, ModelSpec) and obj.restitution is not None and (
            obj.law != "harmonic" or (obj.damping is not None and obj.damping.gamma_n > 0.0)):
        raise InputError(f"{where}restitution = {obj.restitution}: " + (
            f"it sets {where}damping.gamma_n, which is given too: give one of them" if obj.law == "harmonic" else
            f"under {where}law = {obj.law!r} the coefficient of restitution depends on the impact speed, so no "
            f"single gamma_n gives it: give {where}damping.gamma_n"))
    if isinstance(obj, Scene) and obj.model.damped:
        check_damped(obj)
    if isinstance(obj, Scene) and obj.spectrum is not None and obj.spectrum.method == "pep" and not obj.model.damped:
        raise InputError("spectrum.method = 'pep': the damped modes need dashpots: give model.damping (gamma_n, "
                         "gamma_t) or model.restitution; without them every mode is undamped: use method slicing")
    if isinstance(obj, Scene) and not obj.output.endswith((".h5", ".hdf5")):
        raise InputError(f"output = {obj.output!r}: must end in .h5 or .hdf5")


def check_dimension(scene: Scene, dim: int, source: str) -> None:
    """Raise InputError if ``scene`` asks in ``dim`` dimensions for what exists only in 3D: a
    twisting spring, the twist wave R.  ``source`` says where ``dim`` came from, as a clause
    ("packing.dim is 2", "packing.file F holds disks"). Not collective."""
    if dim == 3:
        return
    if scene.model.rho_twist > 0.0:
        raise InputError(f"model.rho_twist = {scene.model.rho_twist}: twisting resistance needs spheres in 3D, "
                         f"but {source} (in 2D a contact has no twist: set model.rho_twist to 0, or "
                         f"use spheres)")
    if scene.waves is not None and scene.waves.axes is not None and "z" in scene.waves.axes:
        raise InputError(f"waves.axes = {scene.waves.axes}: axis z needs 3D, but {source}")
    if scene.waves is not None and "R" in scene.waves.modes:
        raise InputError(f"waves.modes = {scene.waves.modes}: mode R (angular velocity along k) needs 3D, but "
                         f"{source}: in 2D the only rotation is about z (use RT, or spheres)")


def check_stressed(scene: Scene, which: str | None) -> None:
    """Raise InputError if stressed packings (``which`` says whose stored tangential forces; None:
    none) or YADE's slip (``model.history: yade``, docs/stressed_contacts.md) meet what
    needs a symmetric matrix (docs/stressed_contacts.md sections 2 and 4): ``modes``, any ``spectrum`` method
    but nonhermitian (slicing, counting and kpm rest on symmetry), ``waves.method: spectral``, or,
    for stored forces, rho = 0 (the tangential spring holds them); stored forces count for nothing
    when ``model.stored_forces`` drops them.  Not collective."""
    model = scene.model
    held = which if model.stored_forces == "keep" else None
    which = asymmetry(scene, which)
    if which is None:
        return
    if scene.spectrum is not None and scene.spectrum.method == "pep" and scene.spectrum.solver != "dense":
        raise InputError(f"spectrum.method = 'pep' with spectrum.solver = {scene.spectrum.solver!r}: {which}, so the "
                         f"dynamical matrix is not symmetric and the windows' bounds on the damped modes do not hold: "
                         f"give spectrum.solver: dense (up to 8000 DOF)")
    if scene.spectrum is not None and scene.spectrum.method not in ("nonhermitian", "pep"):
        raise InputError(f"spectrum (method {scene.spectrum.method}): {which}, so the dynamical matrix is not "
                         f"symmetric (the DEM code's tangential update has no energy, docs/stressed_contacts.md); "
                         f"slicing, counting and kpm need a symmetric matrix and would give a wrong vDOS: use "
                         f"spectrum.method: nonhermitian (every eigenvalue, complex ones counted as unstable)")
    if scene.modes is not None:
        raise InputError(f"modes: {which}, so the dynamical matrix is not symmetric and its modes are not the "
                         f"orthogonal eigenvectors that modes keeps; drop the modes section for this packing")
    if scene.waves is not None and scene.waves.method == "spectral":
        raise InputError(f"waves.method = 'spectral': {which}, so the matrix is not symmetric and has no "
                         f"orthogonal eigendecomposition: use waves.method: exponential (exact) or ts")
    if held is not None and 0.0 in model.rho:
        raise InputError(f"model.rho contains 0: {which}, held by the tangential springs: every rho must be > 0")


def check_damped(scene: Scene) -> None:
    """Raise InputError if a scene with contact dashpots (``model.damping``) asks for what cannot
    take them: a spectrum method but pep (the others solve the undamped problem), mode shapes (undamped
    eigenvectors), or a second-order
    integrator (verlet, alpha2: their force has no velocity term). Not collective."""
    if scene.spectrum is not None and scene.spectrum.method != "pep":
        raise InputError(f"spectrum.method = {scene.spectrum.method!r} with model.damping: it solves the undamped "
                         f"problem; the damped modes (lambda^2 M + lambda C + D) x = 0 need spectrum.method: pep "
                         f"(or auto); the undamped vDOS of the same packing: drop model.damping from this scene")
    if scene.modes is not None:
        raise InputError("modes with model.damping: modes keeps the undamped eigenvectors of D, not the damped "
                         "modes of (lambda^2 M + lambda C + D) x = 0; drop model.damping from this scene to see "
                         "the undamped modes of the same packing")
    if scene.waves is not None and scene.waves.snapshots is not None:
        raise InputError("waves.snapshots with model.damping: the snapshots come from the undamped Lanczos path; drop "
                         "waves.snapshots, or model.damping to see the undamped wave")
    if scene.waves is not None and scene.waves.method == "ts" and scene.waves.integrator in SECOND_ORDER:
        raise InputError(f"waves.integrator = {scene.waves.integrator!r} with model.damping: it integrates "
                         f"M u'' = -D u and has no velocity-dependent force; use waves.method: spectral or "
                         f"exponential (exact), or waves.integrator: rk (or theta, cn, beuler) on the first-order system")


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
