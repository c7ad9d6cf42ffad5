"""Sphinx configuration of rotsound's manual (``make docs``: HTML in docs/_build/html).

Pages are Markdown (MyST).  Two parts are generated from the code at every build, so that they
cannot drift from it (``_ext/rotsound_manual.py``): the scene key reference, from the schema, and
the API pages of the results readers, from their docstrings (autodoc)."""

import pathlib
import sys

HERE = pathlib.Path(__file__).parent
sys.path[:0] = [str(HERE / "_ext"), str(HERE.parent)]

project = "rotsound"
author = "the rotsound developers"
extensions = ["myst_parser", "sphinx.ext.autodoc", "rotsound_manual"]
source_suffix = {".md": "markdown"}
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3
html_theme = "furo"
html_title = "rotsound"
exclude_patterns = ["_build", "reproduction_notes.md"]  # appended to REPRODUCTION.md by rotsound report --notes
autodoc_mock_imports = ["petsc4py", "slepc4py", "mpi4py"]
suppress_warnings = ["myst.header"]
