"""rotsound's benchmarks: what each stage costs, measured against the obvious alternatives, with
the JSON records BENCHMARKS.md is rendered from.  Not part of the installed package (pyproject
installs ``solver`` only); run from the repository's root, each as a module:

    python -m scripts.benchmarks.bench_kpm          # one benchmark: its record in scripts/benchmarks/records/kpm.json
    make bench                              # all of them, then BENCHMARKS.md (scripts/benchmarks/bench_all.py)
    python -m scripts.benchmarks.bench_all --render-only

- ``bench_<name>.py``: one benchmark; it declares ``BENCH`` (its place, arguments and record: see
  bench_all.py), writes ``records/<name>.json`` with ``benchlib.save`` and runs its cases in fresh
  processes of itself (``python -m``, often under ``mpirun``), each printing one JSON line;
- ``bench_<name>.md``: its reading, rendered under its table (``bench_paper_programme.md``, a
  reading with no benchmark, comes last);
- ``benchlib.py``: what they share (machine, timing, records, the cached packings of
  ``cache/bench_<N>.h5``);
- ``records/``: the committed records.

The cross-checks against other codes live beside them in ``crosschecks/`` and are rendered into
the same BENCHMARKS.md.  By-products (logs, progress files) go to ``results/bench/``, cached
packings and spectra to ``cache/``.
"""
