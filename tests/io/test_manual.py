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


def test_raw_markup_is_found_in_a_written_page():
    """What an autodoc directive parsed as Markdown wrote into docs/results.md's page (before
    ```{eval-rst}): each line is found, a rendered page's are not, nor markup quoted as inline code."""
    raw = ("<p>.. py:module:: solver.io.results</p>\n<p><code>x</code> is read.</p>\n"
           "<p><span>:func:</span><code class=\"docutils\">open_results</code> is the one door</p>\n"
           "<div><pre><span></span>  Alias for field number 2\n</pre></div>\n")
    assert [number for number, _ in rotsound_manual.raw_markup(raw)] == [1, 3, 4]
    rendered = ("<dt class=\"sig\"><span class=\"pre\">solver.io.results.open_results</span></dt>\n"
                "<dd><p>(B+1,) 1/t0, the bins&#8217; edges; see <a href=\"#\">open_results()</a></p></dd>\n"
                "<p>a page quoting <code class=\"docutils\"><span>:func:</span></code> in backticks</p>\n")
    assert rotsound_manual.raw_markup(rendered) == []
