"""Command line of rotsound (also ``python -m solver``): run scenes, draw figures, write the
reproduction report; ``rotsound --help`` prints the usage (``_EPILOG``).

Bad input stops every rank with one message and exit code 2; a numerical failure (a time
integration that blew up) with one message and exit code 3; an unexpected error prints its
traceback and aborts all ranks (no rank is left waiting).

Each command imports the modules it runs when it runs (``pipeline`` and the solvers for ``run``,
matplotlib's figures for ``plot`` and ``report``, ASE and VTK for ``export``, VTK for ``render``), so that ``keys``,
``--help`` and a refused command line start in a fraction of a second and load no MPI.
"""

from __future__ import annotations

import argparse
import sys
import traceback

from . import __version__
from . import options, petscenv
from .errors import InputError, Interrupted, NumericalFailure
from .io import scenes, schema

EXIT_INPUT = 2
EXIT_NUMERICAL = 3  # a solve failed numerically on every rank (e.g. a wave run blew up); nothing written
EXIT_TERMINATED = 143  # 128 + SIGTERM, as a shell reports a job ended by SIGTERM


_DESCRIPTION = "rotsound: sound in disordered frictional disk packings (run scenes, plot, report, export, render)."
_EPILOG = """\
usage of each command:
  rotsound run SCENE.yaml [--set KEY.PATH=VALUE ...] [--fresh] [--group-size G] [-petsc_option value ...]
      a file of several YAML documents runs them in order, with one PETSc for all;
      under MPI: mpirun -n 4 rotsound run SCENE.yaml; mpirun -n 64 rotsound run SCENE.yaml
      --group-size 2 solves 32 (rho, packing) units at a time, each on 2 ranks
  rotsound plot RESULTS.h5|SCENE.yaml [MORE ...]
  rotsound report RESULTS.h5|SCENE.yaml [MORE ...] [--output REPRODUCTION.md] [--notes NOTES.md]
  rotsound export RESULTS.h5 --format extxyz|vtp|lammps-dump --output PATH [--packing i] [--rho R] [--mode j]
  xvfb-run -a rotsound render EXPORT.vtp --output PICTURE.png [--color FIELD] [--arrows FIELD] [--view z|iso]
      draws a vtp export with VTK (an X server: xvfb-run without a display)
  rotsound keys       the scene reference as a Markdown table
  rotsound --version  rotsound, PETSc and SLEPc versions

Words starting with a single '-' (after the scene) are PETSc/SLEPc options for 'run'; they win
over the scene's petsc: mapping.  The manual (make docs; its pages are docs/*.md) has the scene keys and the file formats.
"""


def _versions() -> str:
    """rotsound's version and those of the PETSc and SLEPc it would use, without starting MPI or
    PETSc: petsc4py and slepc4py are built with, and numbered as, the libraries they wrap, and
    importing the packages (not their PETSc/SLEPc modules) initialises nothing."""
    lines = [f"rotsound {__version__}"]
    try:
        petscenv.ensure_importable()
        import petsc4py
        import slepc4py

        lines += [f"PETSc {petsc4py.__version__} (petsc4py at {petsc4py.get_config()['PETSC_DIR']})",
                  f"SLEPc {slepc4py.__version__}",
                  f"MUMPS: {'Debian PT-Scotch build (SCOTCH ordering)' if petscenv.mumps_build() == 'ptscotch' else 'Debian build'}"]
    except ImportError as exc:
        lines.append(f"PETSc/SLEPc: not found ({exc})")
    return "\n".join(lines)


class _VersionAction(argparse.Action):
    """``--version``: print :func:`_versions` (computed only when asked) and exit 0."""

    def __init__(self, option_strings, dest, **kwargs):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        print(_versions())
        parser.exit()


class _ArgumentError(InputError):
    pass


class _Parser(argparse.ArgumentParser):
    """argparse that raises InputError (exit code 2, one message) instead of exiting."""

    def error(self, message):
        raise _ArgumentError(f"command line: {message} (see 'rotsound --help')")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="rotsound", description=_DESCRIPTION, epilog=_EPILOG,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action=_VersionAction, help="print rotsound, PETSc and SLEPc versions")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    run = sub.add_parser("run", help="run a scene under mpirun or serially")
    run.add_argument("scene", help="scene YAML file")
    run.add_argument("--set", action="append", default=[], metavar="KEY.PATH=VALUE",
                     help="override a scene key (value parsed as YAML); repeatable")
    run.add_argument("--fresh", action="store_true",
                     help="discard the output file and its finished units first (no resume)")
    run.add_argument("--group-size", metavar="G",
                     help="split the ranks into groups of G consecutive ranks, each solving its share of "
                          "the (rho, packing) units on its own (G divides the number of ranks; default: "
                          "one group of all ranks)")
    plot = sub.add_parser("plot", help="figures from a results file (PNG and PDF beside it)")
    plot.add_argument("results", nargs="+", help="results .h5 file(s), or scene(s) whose output to plot; "
                                                 "with several, also an overlay of their vDOS (Fig. S1)")
    report = sub.add_parser("report", help="the reproduction report: each claim of the paper against the "
                                           "results files (figures in <output folder>/reproduction/)")
    report.add_argument("results", nargs="+", help="results .h5 file(s) or scene(s): vDOS, waves, and any "
                                                   "phi != 0.9 vDOS for Fig. S1")
    report.add_argument("--output", default="REPRODUCTION.md", help="Markdown file to write")
    report.add_argument("--notes", help="Markdown file appended as the report's Notes section")
    export = sub.add_parser("export", help="a packing of a results file, and optionally one of its kept modes "
                                           "(animated), as a file OVITO and ParaView open")
    export.add_argument("results", help="results .h5 file")
    export.add_argument("--format", required=True, choices=None, metavar="{extxyz,vtp,lammps-dump}",
                        help="extxyz (ASE), vtp (VTK XML PolyData by VTK; one file per frame; a wet packing's "
                             "bridges also as NAME.bridges.vtp lines, both named by NAME.vtm) or lammps-dump")
    export.add_argument("--output", required=True,
                        help="file to write (vtp: NAME.vtp; with several frames NAME_0000.vtp, NAME_0001.vtp, ...)")
    export.add_argument("--packing", type=int, default=0, help="configuration index (default 0)")
    export.add_argument("--rho", type=float, help="rho of the mode (needed when modes were kept at several rho)")
    export.add_argument("--mode", type=int, help="index of a kept mode of that packing and rho (see the file's "
                                                 "modes/ group); without it, the packing alone")
    export.add_argument("--frames", type=int, default=12, help="phases of one period in the animation, the first "
                                                                  "the largest displacement (default 12)")
    export.add_argument("--amplitude", type=float, default=0.1,
                        help="largest displacement in the animation, d0 (default 0.1)")
    render = sub.add_parser("render", help="draw a vtp export with VTK, as ParaView shows it (a PNG; needs an X "
                                           "server: run under xvfb-run)")
    render.add_argument("vtp", help="a file of `rotsound export --format vtp`")
    render.add_argument("--output", required=True, help="PNG to write")
    render.add_argument("--color", default="rattler", help="point array for the colour (default rattler; a vector's "
                                                           "component as NAME_x, _y or _z)")
    render.add_argument("--arrows", help="vector point array drawn as arrows")
    render.add_argument("--arrow-length", type=float, default=3.0, help="longest arrow, d0 (default 3)")
    render.add_argument("--view", choices=("z", "iso"), default="z",
                        help="z: down the z axis, parallel projection (2D); iso: a 3D box from a corner (default z)")
    render.add_argument("--size", type=int, default=1200, help="image side, pixels (default 1200)")
    render.add_argument("--title", default="", help="text in the top-left corner")
    sub.add_parser("keys", help="print the scene key reference (Markdown)")
    return parser


def _group_size(text: str | None, ranks: int) -> int | None:
    """``--group-size`` as a divisor of ``ranks``, or None (one group of all ranks)."""
    if text is None:
        return None
    try:
        size = int(text)
    except ValueError:
        size, text = 0, repr(text)
    if size < 1 or ranks % size:
        divisors = ", ".join(str(d) for d in range(1, ranks + 1) if ranks % d == 0)
        raise InputError(f"command line: --group-size = {text}: must be a whole number that divides the "
                         f"number of ranks ({ranks}): one of {divisors}")
    return size


def _run(args, petsc_words, comm) -> None:
    group_size = _group_size(args.group_size, comm.size)
    todo = scenes.load(args.scene, args.set, comm)
    yaml_words = options.to_argv(options.flatten(todo[0].petsc))
    argv = yaml_words + petsc_words  # later words win: the command line beats the scene
    options.refuse_bare_solver_options(options.option_names(argv))
    petscenv.init(argv)
    from . import pipeline

    for index, scene in enumerate(todo):
        if len(todo) > 1:
            pipeline.say(comm, f"== scene {index + 1} of {len(todo)}: {scene.output}")
        pipeline.run(scene, comm, argv, fresh=args.fresh, group_size=group_size)


def _targets(names: list[str]) -> list[str]:
    """Results paths: each scene file is replaced by the outputs of its documents."""
    out = []
    for name in names:
        if name.endswith((".yaml", ".yml")):
            out += [scene.output for scene in scenes.build_all(name, scenes.read_documents(name))]
        else:
            out.append(name)
    return out


def _report(args) -> None:
    from . import report

    path, rows = report.write(_targets(args.results), args.output, args.notes)
    counts = {s: sum(r.status == s for r in rows) for s in ("PASS", "FAIL", "NOT MEASURED")}
    print(f"wrote {path}: {counts['PASS']} pass, {counts['FAIL']} fail, {counts['NOT MEASURED']} not measured")


def _plot(args) -> None:
    from . import plots

    targets = _targets(args.results)
    written = [path for target in targets for path in plots.plot_results(target)]
    if len(targets) > 1:
        import os

        written += plots.plot_vdos_compare(targets, os.path.splitext(targets[0])[0] + "_vdos_compare")
    for path in written:
        print(f"wrote {path}")


def _render(args) -> None:
    try:
        from .io import render
    except ImportError as exc:
        raise InputError(f"render needs VTK's Python module (Debian's python3-vtk9, which scripts/tools/setup.sh "
                         f"installs): {exc}") from None
    render.draw(args.vtp, args.output, args.color, args.arrows, args.arrow_length, args.view, args.size, args.title)
    print(f"wrote {args.output}")


def _launcher_rank() -> int:
    """This process's rank as mpirun/mpiexec announce it, for errors raised before MPI starts."""
    import os

    for var in ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK"):
        if var in os.environ:
            return int(os.environ[var])
    return 0


def main(argv: list[str] | None = None) -> int:
    words = sys.argv[1:] if argv is None else argv
    ours, petsc_words = options.split_argv(words)
    parser = _parser()
    comm = None
    try:
        args = parser.parse_args(ours)
        if petsc_words and args.command != "run":
            raise InputError(f"command line: PETSc options {petsc_words} only apply to 'run'")
        if args.command == "keys":
            print(schema.reference_markdown())
            return 0
        if args.command == "plot":
            _plot(args)
            return 0
        if args.command == "export":
            from .io import export

            written, what = export.export(args.results, args.format, args.output, args.packing, args.rho,
                                          args.mode, args.frames, args.amplitude)
            for path in written:
                print(f"wrote {path}")
            print(what)
            return 0
        if args.command == "render":
            _render(args)
            return 0
        if args.command == "report":
            _report(args)
            return 0
        from mpi4py import MPI

        comm = MPI.COMM_WORLD
        _run(args, petsc_words, comm)
        return 0
    except InputError as exc:
        if (comm.rank if comm is not None else _launcher_rank()) == 0:
            print(f"rotsound: error: {exc}", file=sys.stderr, flush=True)
        return EXIT_INPUT
    except NumericalFailure as exc:  # raised on every rank together: no rank is left waiting
        if comm.rank == 0:
            print(f"rotsound: error: {exc}", file=sys.stderr, flush=True)
        return EXIT_NUMERICAL
    except Interrupted:
        if comm.rank == 0:
            print("rotsound: stopped by SIGTERM after the unit in flight; finished units are kept: "
                  "run the same command again to resume", file=sys.stderr, flush=True)
        return EXIT_TERMINATED
    except Exception:  # noqa: BLE001 - anything else: report and take every rank down
        traceback.print_exc()
        sys.stderr.flush()
        if comm is not None and comm.size > 1:
            comm.Abort(1)
        return 1


if __name__ == "__main__":
    sys.exit(main())
