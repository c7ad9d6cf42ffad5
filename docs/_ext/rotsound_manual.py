"""A Sphinx extension for rotsound's manual: the scene key reference, generated from the schema.

A page that holds the line ``<!-- scene-keys -->`` gets, in its place, the table that
``rotsound keys`` prints (``solver.io.schema.reference_markdown``), every time the manual is built.
"""

MARKER = "<!-- scene-keys -->"


def fill(text: str) -> str:
    """``text`` with the key reference table in place of :data:`MARKER`."""
    from solver.io import schema

    return text.replace(MARKER, schema.reference_markdown())


def _source_read(app, docname, source):  # noqa: ARG001 - Sphinx's event signature
    source[0] = fill(source[0])


def setup(app):
    app.connect("source-read", _source_read)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
