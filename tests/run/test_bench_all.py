"""scripts/benchmarks/bench_all.py finds every benchmark and cross-check by its ``BENCH`` declaration, and
BENCHMARKS.md is what their records and readings render to: a record or a reading changed, added
or removed without ``python -m scripts.benchmarks.bench_all --render-only`` fails here (the file names the
machine it was rendered on; that line is left out)."""

import pytest
from conftest import REPO

from scripts.benchmarks import bench_all

pytestmark = pytest.mark.serial_only  # reads files; nothing parallel


def test_every_benchmark_and_cross_check_declares_its_place_and_has_its_record():
    found = bench_all.benchmarks()
    modules = {path.stem for folder, pattern in bench_all.FOLDERS.items() for path in (REPO / folder).glob(pattern)}
    assert {bench["path"].stem for bench in found} == modules - {"bench_all"}
    assert len({bench["order"] for bench in found}) == len(found)
    for bench in found:
        for name in bench["also"] + [bench["record"]]:
            assert (bench["path"].parent / "records" / f"{name}.json").exists(), (bench["module"], name)


def test_benchmarks_md_is_its_records_and_readings_rendered():
    def lines(text):
        return [line for line in text.splitlines() if not line.startswith("Rendered on: ")]

    assert lines(bench_all.text(bench_all.benchmarks())) == lines((REPO / "BENCHMARKS.md").read_text())
