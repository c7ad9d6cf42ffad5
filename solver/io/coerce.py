"""The coercion engine of the scene schema: a YAML mapping validated into the declared dataclasses
(``schema``) key by key -- unknown keys refused with the nearest allowed one, each value coerced to
its field's kind (YAML's spellings of numbers included) and checked against its field's range --
and then by the rules across keys (``scene_rules``).  Pure and deterministic (no MPI, no PETSc):
every rank that builds the same mapping raises the same :class:`~solver.errors.InputError`.
"""

from __future__ import annotations

import dataclasses
import difflib

from ..errors import InputError
from . import scene_rules


def _type_name(kind) -> str:
    return {int: "an integer", float: "a number", str: "a string", dict: "a mapping",
            "floats": "a number or a list of numbers", "number_or_list": "a number or a list of numbers", "paths": "a path or a list of paths",
            bool: "true or false", "window": "a list [omega_lo, omega_hi]", "strs": "a list of names",
            "ints": "a list of integers", "floats_list": "a list of numbers",
            "cache": "auto, a folder path, or off", "ranks": "auto or a whole number",
            "walls": "a list of walls, each a mapping {axis: x, y or z, position: a number}"}.get(
        kind, "a mapping")


def _coerce(value, kind, where):
    """Convert a YAML value to ``kind`` or raise InputError naming ``where``."""
    def fail():
        raise InputError(f"{where} = {value!r}: must be {_type_name(kind)}")

    if kind is int:
        if isinstance(value, bool):
            fail()
        if isinstance(value, int):
            return value
        try:  # 2e6 (a string to PyYAML) or 2.0e6 is the integer 2000000
            number = float(value) if isinstance(value, (float, str)) else None
        except ValueError:
            number = None
        if number is None or not number.is_integer():
            fail()
        return int(number)
    if kind is float:
        if isinstance(value, bool):
            fail()
        if isinstance(value, str):  # PyYAML reads 1e-6 (no dot) as a string
            try:
                return float(value)
            except ValueError:
                fail()
        if not isinstance(value, (int, float)):
            fail()
        return float(value)
    if kind == "ranks":
        if value == "auto":
            return value
        try:
            return _coerce(value, int, where)
        except InputError:
            fail()
    if kind == "cache" and value is False:  # YAML reads a bare off/no/false as False
        return "off"
    if kind in (str, "cache"):
        if not isinstance(value, str) or not value:
            fail()
        return value
    if kind in (dict, bool):
        if not isinstance(value, kind):
            fail()
        return value
    if kind in ("strs", "ints", "floats_list"):
        if not isinstance(value, list):
            fail()
        item = {"strs": str, "ints": int, "floats_list": float}[kind]
        return [_coerce(v, item, where) for v in value]
    if kind == "window":  # numbers, including PyYAML's strings such as 1e1
        if not isinstance(value, list) or any(isinstance(v, bool) for v in value):
            fail()
        return [_coerce(v, float, where) for v in value]
    if kind == "floats":
        items = value if isinstance(value, list) else [value]
        if not items:
            raise InputError(f"{where} = []: must not be empty")
        return [_coerce(v, float, where) for v in items]
    if kind == "number_or_list":  # a number stays one; a list (a sweep) stays a list
        if not isinstance(value, list):
            return _coerce(value, float, where)
        if not value:
            raise InputError(f"{where} = []: must not be empty")
        return [_coerce(v, float, where) for v in value]
    if kind == "walls":  # [{axis: z, position: 0.0}, ...]
        if not isinstance(value, list):
            fail()
        walls = []
        for index, wall in enumerate(value):
            if not isinstance(wall, dict) or set(map(str, wall)) != {"axis", "position"}:
                raise InputError(f"{where}[{index}] = {wall!r}: each wall is a mapping with the keys axis and "
                                 f"position, e.g. {{axis: z, position: 0.0}}")
            if wall["axis"] not in ("x", "y", "z"):
                raise InputError(f"{where}[{index}].axis = {wall['axis']!r}: must be x, y or z")
            walls.append({"axis": wall["axis"], "position": _coerce(wall["position"], float, f"{where}[{index}].position")})
        return walls
    if kind == "paths":
        items = value if isinstance(value, list) else [value]
        if not items or not all(isinstance(v, str) and v for v in items):
            fail()
        return value
    raise AssertionError(kind)


def build(cls, raw, where: str = ""):
    """Validate mapping ``raw`` into dataclass ``cls`` (a section of ``schema``, or ``schema.Scene``):
    every key coerced to its kind and checked against its field's range, nested sections built
    likewise, then the rules across keys (``scene_rules.check``); ``where`` is the key path prefix.
    InputError names the key.  Not collective."""
    raw = {} if raw is None else raw
    if not isinstance(raw, dict):
        raise InputError(f"{where.rstrip('.') or 'scene'} = {raw!r}: must be a mapping")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(map(str, raw)) - set(fields))
    if unknown:
        near = difflib.get_close_matches(unknown[0], fields, n=1)
        hint = f"did you mean {where}{near[0]}? " if near else ""
        raise InputError(f"unknown key {where}{unknown[0]}: {hint}allowed keys in "
                         f"{where.rstrip('.') or 'the scene'} are {', '.join(fields)}")
    values = {}
    for name, f in fields.items():
        kind, check = f.metadata["kind"], f.metadata["check"]
        key = f"{where}{name}"
        if dataclasses.is_dataclass(kind):
            values[name] = build(kind, raw.get(name), key + ".")
            continue
        if isinstance(kind, tuple):  # optional section: present (even empty) means "compute it"
            if name in raw and raw[name] is not None:
                values[name] = build(kind[1], raw[name], key + ".")
            continue
        if name not in raw or raw[name] is None:
            continue
        value = _coerce(raw[name], kind, key)
        for item in (value if isinstance(value, list) and kind in ("floats", "number_or_list") else [value]):
            problem = check(item) if check else None
            if problem:
                raise InputError(f"{key} = {raw[name]!r}: {problem}")
        values[name] = value
    obj = cls(**values)
    scene_rules.check(obj, where, frozenset(str(key) for key, value in raw.items() if value is not None))
    return obj
