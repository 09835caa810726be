"""What a config dataclass tree says about itself: fields, types, units, defaults, origins.

Every configurable part of acc_fusion is a frozen dataclass whose docstring documents each
field in an ``Attributes:`` section, with its unit in square brackets (``dt: simulation step
[s].``).  That docstring is the single place a field is described: this module reads it to

* write a JSON Schema of a config tree (:func:`json_schema`, ``acc-fusion config schema``), so
  editors validate TOML/YAML config files and complete their keys;
* list a resolved config with units and where each value comes from (:func:`describe`,
  ``acc-fusion config show``): the class that declares the default, or the config file;
* check dotted paths (``fusion.filter.jerk_std``) used by the CLI's ``--set`` and the sweeps'
  axes against the tree (:func:`field_at`).
"""

from __future__ import annotations

import copy
import dataclasses
import re
import types
import typing
from collections.abc import Mapping
from dataclasses import MISSING
from typing import Any

from acc_fusion.core.errors import ConfigError

#: JSON Schema dialect of :func:`json_schema`.
SCHEMA_DIALECT = "https://json-schema.org/draft/2020-12/schema"

_ENTRY = re.compile(r"^(\s+)([A-Za-z_][\w, ]*):\s*(.*)$")
_UNIT = re.compile(r"\[([^\[\]]{1,12})\]")


@dataclasses.dataclass(frozen=True)
class FieldInfo:
    """One field of a config dataclass.

    Attributes:
        path: dotted path from the root config (``fusion.filter.jerk_std``).
        name: the field's name.
        type: its declared type (a typing object).
        default: its default value (``None`` when it has none).
        owner: ``module.Class`` that declares the field (where its default comes from).
        doc: its description from the owner's ``Attributes:`` docstring section.
        unit: the unit in square brackets in that description, or ``""``.
        derived_from: the field of the root config this one is derived from (its dataclass
            field's ``metadata["derived_from"]``), or ``""``.
    """

    path: str
    name: str
    type: Any
    default: Any
    owner: str
    doc: str
    unit: str
    derived_from: str = ""


def field_docs(cls: type) -> dict[str, str]:
    """The ``Attributes:`` section of ``cls``'s docstring as ``{field: description}``.

    An entry may name several fields (``radar, infrared: ...``); continuation lines are joined.
    """
    doc = cls.__doc__ or ""
    lines = doc.split("\n")
    try:
        start = next(i for i, line in enumerate(lines) if line.strip() == "Attributes:")
    except StopIteration:
        return {}
    out: dict[str, str] = {}
    names: list[str] = []
    indent = None
    for line in lines[start + 1 :]:
        if not line.strip():
            continue
        m = _ENTRY.match(line)
        if m and (indent is None or len(m.group(1)) == indent):
            indent = len(m.group(1))
            names = [n.strip() for n in m.group(2).split(",")]
            for n in names:
                out[n] = m.group(3).strip()
        elif indent is not None and len(line) - len(line.lstrip()) > indent:
            for n in names:
                sep = "" if out[n].endswith("-") else " "
                out[n] = f"{out[n]}{sep}{line.strip()}"
        else:
            break
    return out


def unit_of(doc: str) -> str:
    """The first bracketed unit of a field description (``"[m/s²]"`` → ``"m/s²"``), or ``""``."""
    m = _UNIT.search(doc)
    return m.group(1) if m else ""


def _default(f: dataclasses.Field) -> Any:
    if f.default is not MISSING:
        return f.default
    if f.default_factory is not MISSING:
        return f.default_factory()
    return None


def _dataclass_of(tp: Any) -> type | None:
    """The dataclass inside ``tp`` (itself, or ``X | None``), else ``None``."""
    if dataclasses.is_dataclass(tp) and isinstance(tp, type):
        return tp
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        inner = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(inner) == 1:
            return _dataclass_of(inner[0])
    return None


def fields(cls: type, prefix: str = "") -> list[FieldInfo]:
    """Every field of the config tree rooted at ``cls``, depth first, nested ones dotted."""
    hints = typing.get_type_hints(cls)
    docs = field_docs(cls)
    out = []
    for f in dataclasses.fields(cls):
        if not f.init or f.name.startswith("_"):
            continue
        doc = docs.get(f.name, "")
        path = f"{prefix}{f.name}"
        out.append(
            FieldInfo(
                path,
                f.name,
                hints[f.name],
                _default(f),
                _owner(cls, f.name),
                doc,
                unit_of(doc),
                f.metadata.get("derived_from", ""),
            )
        )
        inner = _dataclass_of(hints[f.name])
        if inner is not None:
            out += fields(inner, prefix=f"{path}.")
    return out


def _owner(cls: type, name: str) -> str:
    for base in cls.__mro__:
        if name in getattr(base, "__annotations__", {}):
            return f"{base.__module__}.{base.__qualname__}"
    return f"{cls.__module__}.{cls.__qualname__}"  # pragma: no cover - fields are annotated


def field_at(cls: type, path: str) -> FieldInfo:
    """The field at dotted ``path`` in the tree of ``cls``, or the leaf field (a mapping such as
    ``warning.params``) that ``path`` lies below; a :class:`ConfigError` naming the closest
    level's allowed keys if there is none."""
    by_path = {f.path: f for f in fields(cls)}
    if path in by_path:
        return by_path[path]
    parts = path.split(".")
    for n in range(len(parts) - 1, 0, -1):
        prefix = ".".join(parts[:n])
        if prefix in by_path and not any(p.startswith(prefix + ".") for p in by_path):
            return by_path[prefix]
    parent = path.rpartition(".")[0]
    keys = sorted(
        f.name for f in by_path.values() if f.path.rpartition(".")[0] == parent
    ) or sorted(f.name for f in by_path.values() if "." not in f.path)
    raise ConfigError(f"unknown config key {path!r}; allowed at that level: {', '.join(keys)}")


def _json_value(x: Any) -> Any:
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return {f.name: _json_value(getattr(x, f.name)) for f in dataclasses.fields(x) if f.init}
    if isinstance(x, Mapping):
        return {str(k): _json_value(v) for k, v in x.items()}
    if isinstance(x, (tuple, list)):
        return [_json_value(v) for v in x]
    if isinstance(x, float) and x != x:  # NaN has no JSON form
        return None
    return x


def _type_schema(tp: Any) -> dict:
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if tp is bool:
        return {"type": "boolean"}
    if tp is int:
        return {"type": "integer"}
    if tp is float:
        return {"type": "number"}
    if tp is str:
        return {"type": "string"}
    if tp is dict or origin is dict or tp is object or tp is Any:
        return {"type": "object"} if tp is not object and tp is not Any else {}
    if origin is typing.Literal:
        return {"enum": list(args)}
    if origin in (typing.Union, types.UnionType):
        return {"anyOf": [_type_schema(a) for a in args]}
    if tp is type(None):
        return {"type": "null"}
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return {"type": "array", "items": _type_schema(args[0])}
        return {
            "type": "array",
            "prefixItems": [_type_schema(a) for a in args],
            "minItems": len(args),
            "maxItems": len(args),
        }
    if dataclasses.is_dataclass(tp):
        return _object_schema(tp)
    return {}


def _object_schema(cls: type) -> dict:
    hints = typing.get_type_hints(cls)
    docs = field_docs(cls)
    props = {}
    for f in dataclasses.fields(cls):
        if not f.init or f.name.startswith("_"):
            continue
        schema = dict(_type_schema(hints[f.name]))
        if docs.get(f.name):
            schema["description"] = docs[f.name]
        default = _default(f)
        schema["default"] = _json_value(default)
        props[f.name] = schema
    return {
        "type": "object",
        "title": cls.__qualname__,
        "description": (cls.__doc__ or "").strip().split("\n")[0],
        "properties": props,
        "additionalProperties": False,
    }


def json_schema(cls: type, title: str | None = None) -> dict:
    """A JSON Schema (draft 2020-12) of config files for the dataclass tree of ``cls``."""
    schema = _object_schema(cls)
    schema["$schema"] = SCHEMA_DIALECT
    if title:
        schema["title"] = title
    return schema


def describe(config: Any, given: Mapping[str, Any] | None = None, source: str = "") -> list[dict]:
    """The resolved config as rows ``{key, value, unit, origin, doc}``, leaves only.

    ``given`` is the mapping the user supplied (a config file's content, or flags as dotted
    keys): a key found in it has origin ``source``; any other value is its class's default.
    """
    given_paths = set(_flatten(given or {}))
    rows = []
    for f in fields(type(config)):
        if _dataclass_of(f.type) is not None and _get(config, f.path) is not None:
            continue
        value = _get(config, f.path)
        supplied = f.path in given_paths or any(p.startswith(f"{f.path}.") for p in given_paths)
        rows.append(
            {
                "key": f.path,
                "value": _json_value(value),
                "unit": f.unit,
                "origin": (
                    f"derived from {f.derived_from}"
                    if f.derived_from
                    else source
                    if supplied
                    else f"default: {f.owner}"
                ),
                "doc": f.doc,
            }
        )
    return rows


def _get(obj: Any, path: str) -> Any:
    for part in path.split("."):
        obj = getattr(obj, part)
    return obj


def _flatten(data: Mapping[str, Any], prefix: str = "") -> list[str]:
    out = []
    for k, v in data.items():
        key = f"{prefix}{k}"
        out.append(key)
        if isinstance(v, Mapping):
            out += _flatten(v, f"{key}.")
    return out


def set_path(data: dict, dotted: str, value: object) -> None:
    """Set ``data[a][b][c] = value`` for ``dotted = "a.b.c"``; the tables on the way are copied
    (or created), so a mapping shared with other configs is never changed, and so is ``value``."""
    *parents, leaf = dotted.split(".")
    for part in parents:
        inner = data.get(part)
        data[part] = inner = dict(inner) if isinstance(inner, Mapping) else {}
        data = inner
    data[leaf] = copy.deepcopy(value)
