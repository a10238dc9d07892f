"""Typed classes from the core's plain values: a dataclass filled by its own type hints.

The core hands its result structs to Python as plain values (dicts, lists, numbers);
:func:`build` fills a dataclass from them field by field (by JSON key), lists item by item, a
``Union`` by its first fitting arm, null floats as NaN. A type that builds itself from its core
value (e.g. a columnar sequence, or a tagged union) is registered with :func:`register_builder`.
:class:`Record` is the base of the classes built so: ``obj["key"]`` and ``to_dict()`` give the
core's keys back (:func:`unbuild`).

It is its own module, not part of :mod:`robot_stiffness.results`, so that a command that
builds an identification does not import the diagnosis classes (a quarter of a command's
Python start-up).
"""

from __future__ import annotations

import dataclasses
import math
import typing
from typing import Any, Callable, Dict, List, Mapping, Optional, Union

import numpy as np

from ._equality import FieldEq

#: A JSON-ready value (what ``to_dict`` returns).
Json = Union[None, bool, int, float, str, List["Json"], Dict[str, "Json"]]

_SELF_BUILDING: Dict[object, Callable[[object], object]] = {}


def register_builder(tp: type, from_core: Callable[[object], object]) -> None:
    """Makes :func:`build` build ``tp`` with ``from_core(value)``."""
    _SELF_BUILDING[tp] = from_core


def value_of(f: "dataclasses.Field[object]", value: Mapping[str, object]) -> Optional[str]:
    """The key of ``f`` in ``value``: its JSON key, or the key earlier versions wrote it under
    (``former`` in its metadata: a result saved before a rename reads back); None if neither."""
    key = json_key(f)
    if key in value:
        return key
    former = f.metadata.get("former")
    return str(former) if former is not None and former in value else None


def json_key(f: "dataclasses.Field[object]") -> str:
    """The JSON key of a field (its name unless it is a Python keyword, e.g. ``lambda``)."""
    return str(f.metadata.get("key", f.name))


def field_names(cls: type) -> List[str]:
    """The names of a dataclass's fields."""
    return [f.name for f in dataclasses.fields(cls)]


_HINTS: Dict[type, Dict[str, object]] = {}


def hints(cls: type) -> Dict[str, object]:
    """A dataclass's resolved type hints (computed once per class)."""
    if cls not in _HINTS:
        _HINTS[cls] = typing.get_type_hints(cls)  # resolved in the class's own module
    return _HINTS[cls]


def fits(tp: object, value: object) -> bool:
    """Whether ``value`` (a core value) has the shape of type ``tp`` (for picking a Union arm)."""
    origin = typing.get_origin(tp)
    if dataclasses.is_dataclass(tp):
        required = {json_key(f) for f in dataclasses.fields(tp)
                    if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING}
        return isinstance(value, dict) and required <= set(value)
    if origin in (list, List):
        (item,) = typing.get_args(tp)
        return isinstance(value, list) and all(fits(item, v) for v in value[:1])
    if origin is tuple:
        return isinstance(value, (list, tuple)) and len(value) == len(typing.get_args(tp))
    if tp is float:
        return value is None or (isinstance(value, (int, float)) and not isinstance(value, bool))
    if tp in (int, str, bool):
        return isinstance(value, tp)
    return True


_FLAT: Dict[object, Optional[Callable[[Any], object]]] = {}


def float_or_nan(v: object) -> float:
    """A core float (``None`` for a non-finite value in JSON) as a float."""
    return math.nan if v is None else float(v)  # type: ignore[arg-type]


def flat_builder(tp: object) -> Optional[Callable[[Any], object]]:
    """For a dataclass whose fields are all ``int``, ``float``, ``str`` or ``bool``: a function
    that builds it from a core mapping as :func:`build` does, without the per-field dispatch
    (lists of such items are the long ones). ``None`` for any other type."""
    if tp not in _FLAT:
        builder: Optional[Callable[[Any], object]] = None
        if dataclasses.is_dataclass(tp) and isinstance(tp, type) and tp not in _SELF_BUILDING:
            types = hints(tp)
            convert: Dict[object, Optional[Callable[[Any], object]]] = {int: int, float: float_or_nan, str: None, bool: None}
            fields = dataclasses.fields(tp)
            if all(types[f.name] in convert for f in fields):
                plan = [(f.name, json_key(f), convert[types[f.name]]) for f in fields]
                cls: type = tp

                def build_flat(value: Any) -> object:
                    if not isinstance(value, dict):
                        raise TypeError(f"{cls.__name__} expects a mapping, got {type(value).__name__}")
                    return cls(**{name: (value[key] if conv is None else conv(value[key]))
                                  for name, key, conv in plan if key in value})

                builder = build_flat
        _FLAT[tp] = builder
    return _FLAT[tp]


def build(tp: object, value: object) -> object:
    """``value`` (plain core values) as type ``tp``: dataclasses field by field (by JSON key),
    lists item by item, a Union by its first fitting arm, null floats as NaN."""
    origin = typing.get_origin(tp)
    if origin is Union:
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if value is None and len(args) < len(typing.get_args(tp)):
            return None
        arm = next((a for a in args if fits(a, value)), args[0])
        return build(arm, value)
    if tp in _SELF_BUILDING:
        return _SELF_BUILDING[tp](value)
    if dataclasses.is_dataclass(tp) and isinstance(tp, type):
        if not isinstance(value, dict):
            raise TypeError(f"{tp.__name__} expects a mapping, got {type(value).__name__}")
        types = hints(tp)
        keys = {f.name: value_of(f, value) for f in dataclasses.fields(tp)}
        kwargs = {name: build(types[name], value[key]) for name, key in keys.items() if key is not None}
        return tp(**kwargs)
    if origin in (list, List):
        (item,) = typing.get_args(tp)
        flat = flat_builder(item)
        if flat is not None:  # e.g. per_pose: one entry per pose, 10⁵ of them in a large campaign
            return [flat(v) for v in value]  # type: ignore[attr-defined]
        return [build(item, v) for v in value]  # type: ignore[attr-defined]
    if origin is tuple:
        return tuple(build(a, v) for a, v in zip(typing.get_args(tp), value))  # type: ignore[call-overload]
    if tp is float:
        return math.nan if value is None else float(value)  # type: ignore[arg-type]
    if tp is int:
        return int(value)  # type: ignore[call-overload]
    return value


class Record(FieldEq):
    """Base of the classes :func:`build` fills: ``obj["key"]`` reads a field by its JSON key
    (the dict access of earlier versions keeps working), ``to_dict`` gives the JSON form, and
    ``==`` compares field by field with NaN equal to NaN (a result equals its pickled copy, or
    the same computation run elsewhere, even where a statistic is undefined)."""

    def __getitem__(self, key: str) -> object:
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            if json_key(f) == key:
                return getattr(self, f.name)
        raise KeyError(key)

    def get(self, key: str, default: object = None) -> object:
        """``self[key]``, or ``default`` when there is no such field or it is None."""
        try:
            value = self[key]
        except KeyError:
            return default
        return default if value is None else value

    def to_dict(self) -> Dict[str, Json]:
        """The JSON-ready form (NaN stays a float; the CLI writes it as null)."""
        out = unbuild(self, getattr(self, "model_kind", None))
        assert isinstance(out, dict)
        return out


def unbuild(obj: object, model: Optional[str]) -> Json:
    """The JSON-ready form of a built value, the inverse of :func:`build`: a dataclass by its
    fields' JSON keys (less those marked ``json: False``, those of the other ``model``, and
    those marked ``omit_none`` that are None), a columnar value by its ``records()``, arrays
    and tuples as lists."""
    records = getattr(obj, "records", None)
    if callable(records) and not isinstance(obj, type):  # a method, not a field of that name
        return list(records())
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out: Dict[str, Json] = {}
        for f in dataclasses.fields(obj):
            if f.metadata.get("json", True) is False:
                continue
            only = f.metadata.get("model")
            if only is not None and model is not None and only != model:
                continue
            value = getattr(obj, f.name)
            if value is None and f.metadata.get("omit_none"):
                continue
            out[json_key(f)] = unbuild(value, model)
        return out
    if isinstance(obj, (list, tuple)):
        return [unbuild(v, model) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()  # type: ignore[no-any-return]
    return obj  # type: ignore[return-value]
