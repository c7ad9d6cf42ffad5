"""rotsound against other codes: standing waves integrated by LAMMPS and YADE themselves on the
packings and starts rotsound uses, against rotsound's exact C(k, t) (docs/validation.md).  Not
part of the installed package; run from the repository's root, each as a module:

    python -m scripts.crosschecks.crosscheck_lammps     # its record in scripts/crosschecks/records/crosscheck.json

- ``crosscheck_<name>.py``: one cross-check; it declares ``BENCH`` (scripts/benchmarks/bench_all.py runs
  it with ``make bench`` and renders its table into BENCHMARKS.md);
- ``crosscheck_<name>.md``: its reading, rendered under its table;
- ``harness.py``: what they share (LAMMPS on rotsound's packing and start, the pooling of C(k, t),
  their options, table columns and records); the exact references are the package's
  (``solver.references``), which the tests use too;
- ``yade_referee.py``: the YADE half of crosscheck_yade, run by YADE's launcher, never imported;
- ``records/``: the committed records.

Smaller copies of the LAMMPS cross-checks run in the tests (tests/run/test_crosscheck_*.py, which
import the harness and the cross-checks from here).
"""
