"""A Sphinx extension for rotsound's manual: the scene key reference, generated from the schema,
and a check that every page rendered.

A page that holds the line ``<!-- scene-keys -->`` gets, in its place, the table that
``rotsound keys`` prints (``solver.io.schema.reference_markdown``), every time the manual is built.

When the HTML is written, every page is scanned for reStructuredText that reached the reader as
text (an autodoc directive parsed as Markdown prints ``.. py:class::`` and ``:func:`open_results```
verbatim) and for named-tuple fields left with Python's stand-in docstring "Alias for field number
N"; any hit fails the build (:class:`RawMarkupError`, naming page, line and text), with or
without ``-W``.
"""

import pathlib
import re
from html import unescape

from sphinx.errors import SphinxError

MARKER = "<!-- scene-keys -->"

RAW = re.compile(r"\.\. (?:py:|auto)[a-z]*::|:(?:func|class|meth|attr|data|mod|exc|obj):|Alias for field number \d+")
"""Text that only shows in a page when reStructuredText was not rendered."""


class RawMarkupError(SphinxError):
    category = "Unrendered reStructuredText in the built manual"


def fill(text: str) -> str:
    """``text`` with the key reference table in place of :data:`MARKER`."""
    from solver.io import schema

    return text.replace(MARKER, schema.reference_markdown())


def raw_markup(html: str) -> list[tuple[int, str]]:
    """[(line number, the line's visible text)] of the lines of one written page that show
    :data:`RAW` in prose or in a code block (an indented directive body lands in one); inline
    code (``<code>``, a Markdown backtick span) may quote markup."""
    prose = re.sub(r"<code\b.*?</code>", lambda m: "\n" * m.group().count("\n"), html, flags=re.S)
    found = []
    for number, (line, outside_code) in enumerate(zip(html.splitlines(), prose.splitlines()), start=1):
        if RAW.search(unescape(re.sub(r"<[^>]*>", "", outside_code))):
            found.append((number, unescape(re.sub(r"<[^>]*>", "", line)).strip()))
    return found


def _source_read(app, docname, source):  # noqa: ARG001 - Sphinx's event signature
    source[0] = fill(source[0])


def _build_finished(app, exception):
    if exception is not None or app.builder.format != "html":
        return
    outdir = pathlib.Path(app.outdir)
    hits = [f"{page.relative_to(outdir)}:{number}: {text}"
            for page in sorted(outdir.glob("**/*.html")) if "_sources" not in page.parts
            for number, text in raw_markup(page.read_text(encoding="utf-8"))]
    if hits:
        raise RawMarkupError(f"{len(hits)} line(s) show markup as text (a directive parsed as Markdown needs a "
                             "```{eval-rst} block; a named-tuple field needs a #: comment):\n  " +
                             "\n  ".join(hits[:20]) + ("\n  ..." if len(hits) > 20 else ""))


def setup(app):
    app.connect("source-read", _source_read)
    app.connect("build-finished", _build_finished)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
