"""The manual's generated parts (docs/_ext/rotsound_manual.py): the scenes page gets the key
reference from the schema at every build, so it lists every key with its default and no copy of
the table can go stale in the page's source.  (.ci/run builds the whole manual with warnings as
errors.)"""

import importlib.util

import pytest
from conftest import REPO

from solver.io import schema

pytestmark = pytest.mark.serial_only  # reads files; nothing parallel

_spec = importlib.util.spec_from_file_location("rotsound_manual", REPO / "docs" / "_ext" / "rotsound_manual.py")
rotsound_manual = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rotsound_manual)


def test_scenes_page_holds_the_schema_reference():
    source = (REPO / "docs" / "scenes.md").read_text()
    assert source.count(rotsound_manual.MARKER) == 1
    assert "| `output` |" not in source, "a hand-written key table in docs/scenes.md would drift"
    built = rotsound_manual.fill(source)
    rows = schema.reference()
    assert len(rows) > 40
    for key, default, _ in rows:
        assert f"| `{key}` | `{default}` |" in built, key
    assert built.index("| `output` |") < built.index("| `cache` |")  # in the schema's order
