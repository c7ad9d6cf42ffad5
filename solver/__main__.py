"""Command line: ``python -m solver {run,plot,keys} ...`` (also installed as ``rotsound``).

    rotsound run SCENE.yaml [--set key.path=value ...] [--fresh] [-petsc_option value ...]
        (a file of several YAML documents runs them in order, one PETSc for all)
    rotsound plot RESULTS.h5|SCENE.yaml [MORE.h5 ...]
    rotsound report RESULTS.h5|SCENE.yaml [MORE ...] [--output REPRODUCTION.md]
    rotsound keys                      # the scene reference as a Markdown table

Words starting with a single '-' are PETSc/SLEPc options (they win over the scene's
``petsc:`` mapping).  Bad input stops every rank with one message and exit code 2; an
unexpected error prints its traceback and aborts all ranks (no rank is left waiting).
"""

from __future__ import annotations

import argparse
import sys
import traceback

from .io import schema as config
from . import options as petscopts
from .errors import InputError, Interrupted

EXIT_INPUT = 2
EXIT_TERMINATED = 143  # 128 + SIGTERM, as a shell reports a job ended by SIGTERM


class _ArgumentError(InputError):
    pass


class _Parser(argparse.ArgumentParser):
    """argparse that raises InputError (exit code 2, one message) instead of exiting."""

    def error(self, message):
        raise _ArgumentError(f"command line: {message} (see 'rotsound --help')")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="rotsound", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    run = sub.add_parser("run", help="run a scene under mpirun or serially")
    run.add_argument("scene", help="scene YAML file")
    run.add_argument("--set", action="append", default=[], metavar="KEY.PATH=VALUE",
                     help="override a scene key (value parsed as YAML); repeatable")
    run.add_argument("--fresh", action="store_true",
                     help="discard the output file and its finished units first (no resume)")
    plot = sub.add_parser("plot", help="figures from a results file (PNG and PDF beside it)")
    plot.add_argument("results", nargs="+", help="results .h5 file(s), or scene(s) whose output to plot; "
                                                 "with several, also an overlay of their vDOS (Fig. S1)")
    report = sub.add_parser("report", help="the reproduction report: each claim of the paper against the "
                                           "results files (figures in <output folder>/reproduction/)")
    report.add_argument("results", nargs="+", help="results .h5 file(s) or scene(s): vDOS, waves, and any "
                                                   "phi != 0.9 vDOS for Fig. S1")
    report.add_argument("--output", default="REPRODUCTION.md", help="Markdown file to write")
    report.add_argument("--notes", help="Markdown file appended as the report's Notes section")
    sub.add_parser("keys", help="print the scene key reference (Markdown)")
    return parser


def load_scenes(path: str, assignments: list[str], comm) -> list[config.Scene]:
    """Read on rank 0, broadcast, validate everywhere (same error on every rank). Collective.

    A file of several YAML documents is several scenes run in order; ``--set`` applies to each."""
    docs, error = None, None
    if comm.rank == 0:
        try:
            docs = config.read_documents(path)
            for raw in docs:
                for assignment in assignments:
                    config.set_key(raw, assignment)
        except InputError as exc:
            error = exc
    docs, error = comm.bcast((docs, error), root=0)
    if error is not None:
        raise error
    return config.build_all(path, docs)


def _run(args, petsc_words, comm) -> None:
    from . import petscenv

    scenes = load_scenes(args.scene, args.set, comm)
    yaml_words = petscopts.to_argv(petscopts.flatten(scenes[0].petsc))
    argv = yaml_words + petsc_words  # later words win: the command line beats the scene
    petscenv.init(argv)
    from . import pipeline

    for index, scene in enumerate(scenes):
        if len(scenes) > 1:
            pipeline.say(comm, f"== scene {index + 1} of {len(scenes)}: {scene.output}")
        pipeline.run(scene, comm, argv, fresh=args.fresh)


def _targets(names: list[str]) -> list[str]:
    """Results paths: each scene file is replaced by the outputs of its documents."""
    out = []
    for name in names:
        if name.endswith((".yaml", ".yml")):
            out += [scene.output for scene in config.build_all(name, config.read_documents(name))]
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


def _launcher_rank() -> int:
    """This process's rank as mpirun/mpiexec announce it, for errors raised before MPI starts."""
    import os

    for var in ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK"):
        if var in os.environ:
            return int(os.environ[var])
    return 0


def main(argv: list[str] | None = None) -> int:
    words = sys.argv[1:] if argv is None else argv
    ours, petsc_words = petscopts.split_argv(words)
    parser = _parser()
    comm = None
    try:
        args = parser.parse_args(ours)
        if petsc_words and args.command != "run":
            raise InputError(f"command line: PETSc options {petsc_words} only apply to 'run'")
        if args.command == "keys":
            print("| key | default | meaning |\n|---|---|---|")
            for key, default, doc in config.reference():
                print(f"| `{key}` | `{default}` | {doc} |")
            return 0
        if args.command == "plot":
            _plot(args)
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
