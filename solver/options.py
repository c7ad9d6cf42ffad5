"""The scene's ``petsc:`` mapping and the PETSc options database.

Flattening follows PETSc's own YAML reader: nested keys join with ``_``; ``null`` is a flag
without value, booleans become true/false, lists are comma-joined.  YAML options are put in
front of the command-line options when PETSc is initialised, so the command line wins and
options read at initialisation (``-log_view``, ``-malloc_debug``) work from YAML too.
Each solver object has its own options prefix (``PREFIXES``): ``-spectrum_eps_*``,
``-waves_ts_*``, ...; rotsound never writes into the options database (defaults are set on the
objects in code, then ``setFromOptions``), and what each object used is read back from it
(``eps_settings``, ``ts_settings``).  Unused options: petsc4py 3.18 cannot ask PETSc which
options were queried (no ``PetscOptionsUsed`` binding; PETSc's own report, ``-options_left``,
comes only at PetscFinalize), so ``unused`` judges by prefix: an option is used when it belongs
to an object of a stage the scene runs, or is one of PETSc's process-wide options.
"""

from __future__ import annotations

from typing import Any

from .errors import InputError


def flatten(mapping: dict, prefix: str = "") -> dict[str, str | None]:
    """``{'eps': {'tol': 1e-9}}`` -> ``{'eps_tol': '1e-09'}``; None values are flags."""
    flat: dict[str, str | None] = {}
    for key, value in mapping.items():
        name = f"{prefix}{str(key).lstrip('-')}"
        if isinstance(value, dict):
            flat.update(flatten(value, name + "_"))
        elif value is None:
            flat[name] = None
        elif isinstance(value, bool):
            flat[name] = "true" if value else "false"
        elif isinstance(value, (list, tuple)):
            flat[name] = ",".join(str(v) for v in value)
        elif isinstance(value, (int, float, str)):
            flat[name] = str(value)
        else:
            raise InputError(f"petsc.{name} = {value!r}: must be a number, string, bool, list or null")
    return flat


def to_argv(flat: dict[str, str | None]) -> list[str]:
    """Options as argv words: ``['-eps_tol', '1e-09', '-log_view']``."""
    argv: list[str] = []
    for name, value in flat.items():
        argv.append(f"-{name}")
        if value is not None:
            argv.append(value)
    return argv


def split_argv(argv: list[str]) -> tuple[list[str], list[str]]:
    """Split a command line into (ours, PETSc's): PETSc options start with one '-' and a letter.

    A PETSc option's value is the next word unless that word is itself an option.
    """
    ours: list[str] = []
    petsc: list[str] = []
    expect_value = False
    for word in argv:
        is_option = word.startswith("-") and not word.startswith("--") and len(word) > 1 and word[1].isalpha()
        if is_option:
            petsc.append(word)
            expect_value = True
        elif expect_value and not word.startswith("--"):
            petsc.append(word)
            expect_value = False
        else:
            ours.append(word)
            expect_value = False
    return ours, petsc


PREFIXES = {
    "spectrum_": "the spectrum-slicing EPS (-spectrum_eps_*, -spectrum_st_*, -spectrum_st_mat_mumps_icntl_*)",
    "inertia_": "the Sylvester-inertia factorisations that place windows and count modes "
                "(-inertia_pc_factor_mat_solver_type, -inertia_mat_mumps_icntl_*)",
    "nonhermitian_": "the shift-and-invert window EPS of spectrum.method nonhermitian with solver windows "
                     "(-nonhermitian_eps_nev, -nonhermitian_eps_ncv, -nonhermitian_st_pc_factor_mat_solver_type)",
    "pep_": "the window EPS of spectrum.method pep with solver windows (-pep_eps_nev, -pep_eps_ncv, -pep_eps_tol)",
    "pep_shift_": "the complex-shift factorisation of each pep window (-pep_shift_pc_factor_mat_solver_type, "
                  "-pep_shift_mat_mumps_icntl_*)",
    "modes_": "the shift-and-invert EPS of the modes section (-modes_eps_tol, -modes_eps_ncv, "
              "-modes_st_pc_factor_mat_solver_type, -modes_st_mat_mumps_icntl_*)",
    "transport_": "the spectrum-slicing window EPS of transport.method exact (-transport_eps_tol, "
                  "-transport_st_mat_mumps_icntl_*)",
    "wmax_": "the Lanczos EPS for the largest eigenfrequency (-wmax_eps_*)",
    "waves_": "the standing-wave TS and its SNES/KSP (-waves_ts_*, -waves_ksp_*), or the MFN of waves.method "
              "exponential (-waves_mfn_*)",
}
"""Options prefix of each solver object -> what it configures (the manual, docs/running.md)."""

STAGE_PREFIXES = {
    ("spectra", "slicing"): ("spectrum_", "inertia_", "wmax_"),
    ("spectra", "counting"): ("inertia_", "wmax_"),
    ("spectra", "kpm"): ("wmax_",),
    ("spectra", "nonhermitian"): ("nonhermitian_", "inertia_"),
    ("spectra", "pep"): ("pep_", "wmax_"),
    ("modes", "shapes"): ("modes_",),
    ("transport", "exact"): ("transport_", "inertia_", "wmax_"),
    ("transport", "kpm"): ("wmax_",),
    ("waves", "ts"): ("waves_", "wmax_"),
    ("waves", "spectral"): ("wmax_",),
    ("waves", "exponential"): ("waves_", "wmax_"),
}
"""(stage, method) -> prefixes of the options that can change that stage's units."""


def acting_on(argv: list[str], stage: str, method: str) -> dict[str, str | None]:
    """The options in argv words (name without '-' -> value or None) that act on ``stage``
    computed with ``method``: those with one of its prefixes. Not collective."""
    prefixes = STAGE_PREFIXES.get((stage, method), ())
    found: dict[str, str | None] = {}
    for index, word in enumerate(argv):
        if word.startswith("-") and len(word) > 1 and word[1].isalpha():
            value = argv[index + 1] if index + 1 < len(argv) and not (
                argv[index + 1].startswith("-") and len(argv[index + 1]) > 1 and argv[index + 1][1].isalpha()) else None
            if word[1:].startswith(prefixes):
                found[word[1:]] = value  # a later word wins, as in PETSc
    return dict(sorted(found.items()))


def option_names(argv: list[str]) -> list[str]:
    """Names (without '-') of the options in argv words."""
    return [w[1:] for w in argv if w.startswith("-") and len(w) > 1 and w[1].isalpha()]


GLOBAL_OPTIONS = frozenset((
    "help", "version", "options_left", "options_view", "options_monitor", "options_monitor_cancel",
    "options_file", "options_file_yaml", "options_string_yaml", "skip_petscrc",
    "log_view", "log_view_memory", "log_view_gpu_time", "log_all", "log_trace", "log_exclude", "log_sync",
    "log_mpe", "log_perfstubs", "log_summary", "malloc_debug", "malloc_dump", "malloc_view",
    "malloc_view_threshold", "malloc_test", "malloc_requested_size", "malloc_coalesce", "memory_view",
    "objects_dump", "info", "info_exclude", "on_error_abort", "on_error_mpiabort", "on_error_attach_debugger",
    "fp_trap", "no_signal_handler", "check_pointer_intensity", "checkstack", "start_in_debugger",
    "stop_for_debugger", "debugger_ranks", "debugger_pause", "display", "citations", "history",
    "use_gpu_aware_mpi"))
"""PETSc's process-wide options (read at initialisation or finalisation, by no solver object)."""

_OBJECT_WORDS = {  # leading word of an unprefixed solver option -> prefixes that take it
    "eps_": ("spectrum_", "wmax_", "modes_", "transport_"), "st_": ("spectrum_", "wmax_", "modes_", "transport_"),
    "bv_": ("spectrum_", "wmax_", "modes_", "transport_"), "ds_": ("spectrum_", "wmax_", "modes_", "transport_"),
    "rg_": ("spectrum_", "wmax_", "modes_", "transport_"), "fn_": ("spectrum_", "wmax_", "waves_"),
    "ts_": ("waves_",), "mfn_": ("waves_",), "snes_": ("waves_",), "ksp_": ("waves_",), "pc_": ("inertia_", "waves_"),
    "mat_mumps_": ("spectrum_st_", "inertia_", "modes_st_", "transport_st_"),
}


def refuse_bare_solver_options(names: list[str]) -> None:
    """Raise InputError for the first solver option given without an object's prefix
    (``-ts_dt``, ``-eps_tol``, ``-ksp_type``...): every solver object of rotsound has its own
    prefix (``PREFIXES``), so such an option would act on nothing and the run would silently use
    other settings.  Called on the scene's block and the command line before any work. Not
    collective (every rank sees the same words)."""
    for name in names:
        word = next((w for w in _OBJECT_WORDS if name.startswith(w)), None)
        if word is not None:
            hint = " or ".join(f"-{t}{name}" for t in _OBJECT_WORDS[word])
            raise InputError(f"PETSc option -{name}: acts on no solver, because each of rotsound's solver "
                             f"objects has its own options prefix; did you mean {hint}? (the manual, "
                             f"docs/running.md: PETSc options and their prefixes)")


def unused(names: list[str], stages: list[tuple[str, str]]) -> list[str]:
    """Those of ``names`` (options without '-') that no object of ``stages`` ((stage, method)
    pairs, as in ``STAGE_PREFIXES``) reads and that are not PETSc process-wide options: a prefix
    of a stage the scene does not run, or no prefix of ours at all.  (Solver options without a
    prefix never get here: :func:`refuse_bare_solver_options` stops the run first.)  A
    misspelling after a valid prefix (``-spectrum_eps_tpye``) is not detected here:
    ``-options_left`` makes PETSc list every option it never queried, at exit.  Not collective.
    """
    in_use = tuple(p for stage in stages for p in STAGE_PREFIXES.get(stage, ()))
    return [name for name in names if name not in GLOBAL_OPTIONS and not (in_use and name.startswith(in_use))]


def _which_name(eps) -> str:
    from slepc4py import SLEPc

    names = {v: k for k, v in vars(SLEPc.EPS.Which).items() if k.isupper()}
    return names.get(eps.getWhichEigenpairs(), str(eps.getWhichEigenpairs())).lower()


def pc_settings(pc) -> dict:
    """Type of a PETSc PC and, for a factorisation, the package that factorises and (MUMPS, once
    factorised) its build (``petscenv.mumps_build``), ICNTL 13 and 24, the ordering it used
    (INFOG 7: 3 SCOTCH, 4 PORD, 2 AMF, 0 AMD, 6 QAMD), and the block low-rank settings ICNTL 35
    (0: off) and CNTL 7 (the dropping parameter), read back from the object. Not collective."""
    from petsc4py import PETSc

    from . import petscenv

    out = {"pc_type": pc.getType()}
    if out["pc_type"] in ("cholesky", "lu"):
        out["factor_package"] = pc.getFactorSolverType()
        if out["factor_package"] == "mumps":
            try:  # the factor matrix exists once the PC is set up
                factor = pc.getFactorMatrix()
                out["mumps_icntl"] = {"13": factor.getMumpsIcntl(13), "24": factor.getMumpsIcntl(24)}
                out["mumps_build"], out["mumps_ordering_infog7"] = petscenv.mumps_build(), factor.getMumpsInfog(7)
                out["mumps_blr"] = {"icntl_35": factor.getMumpsIcntl(35), "cntl_7": factor.getMumpsCntl(7)}
            except PETSc.Error:  # not set up yet: no ICNTL to report
                pass
    return out


def ksp_settings(ksp) -> dict:
    """KSP type and tolerances with its PC (:func:`pc_settings`). Not collective."""
    rtol, atol, _, max_it = ksp.getTolerances()
    return {"ksp_type": ksp.getType(), "ksp_rtol": rtol, "ksp_atol": atol, "ksp_max_it": max_it,
            **pc_settings(ksp.getPC())}


def eps_settings(eps) -> dict:
    """What a configured SLEPc EPS uses, read back from it: prefix, type, tolerance, iteration
    limit, which eigenvalues, ST type; for spectrum slicing also the partitions and the KSP/PC of
    the internal solver that factorises (SLEPc's child EPS). Not collective."""
    from slepc4py import SLEPc

    tol, max_it = eps.getTolerances()
    st = eps.getST()
    out = {"prefix": eps.getOptionsPrefix(), "eps_type": eps.getType(), "tol": tol, "max_it": max_it,
           "which": _which_name(eps), "st_type": st.getType()}
    if eps.getWhichEigenpairs() == SLEPc.EPS.Which.ALL and eps.getType() == SLEPc.EPS.Type.KRYLOVSCHUR:
        out["partitions"] = eps.getKrylovSchurPartitions()
        out.update(ksp_settings(eps.getKrylovSchurKSP()))
    elif st.getType() != SLEPc.ST.Type.SHIFT:
        out.update(ksp_settings(st.getKSP()))
    return out


_EXPLICIT_TS = ("euler", "rk", "ssp", "python")


def ts_adapt_type(ts) -> str:
    """The TSAdapt type of a TS on ``PETSc.COMM_SELF``, read from the TS's own view (petsc4py
    3.18 has no TSAdapt binding). Not collective."""
    import os
    import tempfile

    from petsc4py import PETSc

    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "ts.txt")
        viewer = PETSc.Viewer().createASCII(path, comm=PETSc.COMM_SELF)
        ts.view(viewer)
        viewer.destroy()
        with open(path, encoding="utf-8") as view:
            lines = [line.strip() for line in view]
    found = [lines[i + 1] for i, line in enumerate(lines[:-1]) if line.startswith("TSAdapt Object")]
    if not found or not found[0].startswith("type:"):
        raise RuntimeError(f"no TSAdapt type in the view of TS {ts.getType()}")
    return found[0].split(":", 1)[1].strip()


def ts_settings(ts) -> dict:
    """What a configured PETSc TS uses, read back from it: prefix, type (and RK variant or theta),
    step, final time, step limit; for implicit types the SNES and KSP/PC.  (The adaptivity:
    :func:`ts_adapt_type`.) Not collective."""
    kind = ts.getType()
    out = {"prefix": ts.getOptionsPrefix(), "ts_type": kind, "dt": ts.getTimeStep(),
           "max_time": ts.getMaxTime(), "max_steps": ts.getMaxSteps()}
    if kind == "rk":
        out["rk_type"] = ts.getRKType()
    elif kind in ("theta", "cn", "beuler"):
        out["theta"], out["theta_endpoint"] = ts.getTheta(), bool(ts.getThetaEndpoint())
    if kind not in _EXPLICIT_TS:
        snes = ts.getSNES()
        out["snes_type"] = snes.getType()
        out.update(ksp_settings(snes.getKSP()))
    return out


def mfn_settings(mfn) -> dict:
    """What a configured SLEPc MFN uses, read back from it: prefix, type, tolerance, iteration
    limit, Krylov dimension, and its function's type and scale (alpha, beta: f(x) = beta
    exp(alpha x)). Not collective."""
    tol, max_it = mfn.getTolerances()
    fn = mfn.getFN()
    return {"prefix": mfn.getOptionsPrefix(), "mfn_type": mfn.getType(), "mfn_tol": tol, "mfn_max_it": max_it,
            "mfn_ncv": mfn.getDimensions(), "fn_type": fn.getType(), "fn_scale": tuple(fn.getScale())}


def snapshot() -> dict[str, Any]:
    """All options now in the database (name -> value), for provenance."""
    from petsc4py import PETSc

    return dict(PETSc.Options().getAll())


def restore(before: dict[str, Any]) -> None:
    """Put PETSc's options database back as ``before`` (a :func:`snapshot`): the options that
    ``solver.__main__.main`` run in-process put there (a scene's ``petsc:`` block, a command line's
    words) must not reach what runs after it in the same process (the next bad-input row of the
    tests and of scripts/tools/render_bad_inputs.py).  Not collective (each process has its database)."""
    from petsc4py import PETSc

    database = PETSc.Options()
    now = database.getAll()
    for name in now:
        if name not in before:
            database.delValue(f"-{name}")
    for name, value in before.items():
        if now.get(name) != value:
            database.setValue(f"-{name}", value)
