"""Scene files: YAML reading, ``--set`` overrides and the rules that span the documents of a file.

A scene file holds one YAML document per scene (``---`` separates scenes that run one after
another); each document is validated by ``coerce.build`` into a :class:`~solver.io.schema.Scene`.
Errors are :class:`~solver.errors.InputError` naming the file (and the document when there are
several).  No PETSc; only :func:`load` communicates (on the communicator it is given).
"""

from __future__ import annotations

import os

import yaml

from .. import parallel
from ..errors import InputError
from .coerce import build
from .schema import Scene


def set_key(raw: dict, assignment: str) -> None:
    """Apply one ``--set key.path=value`` (value parsed as YAML) to ``raw`` in place. Not collective."""
    if "=" not in assignment:
        raise InputError(f"--set {assignment!r}: must look like key.path=value")
    path, text = assignment.split("=", 1)
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise InputError(f"--set {assignment!r}: value is not valid YAML ({exc})") from None
    node = raw
    keys = path.split(".")
    for key in keys[:-1]:
        node = node.setdefault(key, {})
        if not isinstance(node, dict):
            raise InputError(f"--set {assignment!r}: {key} is not a mapping")
    node[keys[-1]] = value


def read_documents(path: str) -> list[dict]:
    """Read a scene file into one mapping per YAML document; errors name the file and document.
    Not collective."""
    if not os.path.isfile(path):
        raise InputError(f"scene file {path}: not found")
    try:
        with open(path, encoding="utf-8") as stream:
            docs = list(yaml.safe_load_all(stream))
    except yaml.YAMLError as exc:
        raise InputError(f"scene file {path}: invalid YAML: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"scene file {path}: cannot read: {exc}") from None
    docs = [{} if d is None else d for d in docs] or [{}]
    for index, raw in enumerate(docs):
        if not isinstance(raw, dict):
            where = f", document {index + 1}" if len(docs) > 1 else ""
            raise InputError(f"scene file {path}{where}: top level must be a mapping of keys")
    return docs


def build_all(path: str, docs: list[dict]) -> list[Scene]:
    """Validate every document of ``path``; the rules that span documents: distinct outputs, and
    PETSc options only in the first (they configure the one PETSc of the whole run). Not collective."""
    scenes = []
    for index, raw in enumerate(docs):
        try:
            scenes.append(build(Scene, raw))
        except InputError as exc:
            if len(docs) == 1:
                raise
            raise InputError(f"scene file {path}, document {index + 1}: {exc}") from None
        if index and scenes[-1].petsc:
            raise InputError(f"scene file {path}, document {index + 1}: petsc options configure the whole "
                             f"run; give them in the first document only")
    outputs = [s.output for s in scenes]
    for out in outputs:
        if outputs.count(out) > 1:
            raise InputError(f"scene file {path}: two documents write output {out!r}; each needs its own")
    return scenes


def load(path: str, assignments: list[str], comm) -> list[Scene]:
    """The scenes of file ``path`` with the ``--set`` ``assignments`` applied to each document:
    read on rank 0 of ``comm`` (an mpi4py communicator), broadcast, validated on every rank (the
    same InputError on every rank). Collective on ``comm``; any error reading the file, of any
    type, is raised on every rank (``parallel.owner_compute``)."""
    def read(_):
        docs = read_documents(path)
        for raw in docs:
            for assignment in assignments:
                set_key(raw, assignment)
        return docs

    return build_all(path, parallel.owner_compute(comm, [0], read)[0])
