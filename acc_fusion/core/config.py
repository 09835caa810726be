"""Typed configuration: dataclasses built from TOML/YAML mappings with clear errors.

Every configurable component of acc_fusion is a frozen dataclass whose ``__post_init__``
validates its fields (see :mod:`acc_fusion.core.validation`).  :func:`from_mapping` builds such a
dataclass (recursively) from a plain mapping, rejecting unknown keys with the list of allowed
ones, and :func:`load_mapping` reads TOML (``tomllib``) or YAML (``yaml.safe_load``).
"""

from __future__ import annotations

import dataclasses
import re
import sys
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TypeVar

import yaml

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.paths import existing_file

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

T = TypeVar("T")


class _YamlLoader(yaml.SafeLoader):
    """PyYAML's safe loader, reading ``1e-3`` as a number as YAML 1.2 does (YAML 1.1, which
    PyYAML follows, needs ``1.0e-3`` and reads ``1e-3`` as a string)."""


_YamlLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)


#: The largest config or spec file read [bytes]: a config is a page of settings, and a
#: larger file is a mistake (a data file given as a config), read no further.
MAX_FILE_BYTES = 1 << 20
#: The deepest nesting of tables and lists in a config, and the most values it holds: deeper
#: or larger structures (or YAML aliases that expand into them) are refused before any work.
MAX_DEPTH = 32
MAX_VALUES = 100_000


def load_yaml(text: str, where: str = "the YAML text") -> Any:
    """One YAML document, safely (numbers in exponent form without a dot included); a syntax
    error, or a document nested deeper than :data:`MAX_DEPTH` or holding more than
    :data:`MAX_VALUES` values, is one :class:`ConfigError` naming ``where`` (and the line and
    column)."""
    return _parsed(text, "yaml", where)


def _parsed(text: str, fmt: str, where: str) -> Any:
    """``text`` parsed as ``fmt`` (``"yaml"`` or ``"toml"``) and checked by :func:`_bounded`;
    its syntax errors as one :class:`ConfigError` with line and column."""
    try:
        if fmt == "toml":
            data = tomllib.loads(text)
        else:
            data = yaml.load(text, Loader=_YamlLoader)  # noqa: S506 (a SafeLoader subclass)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise ConfigError(f"{where} is not valid YAML{at}: {exc.problem or exc.context}") from None
    except yaml.YAMLError as exc:  # a character YAML does not allow: its first line says which
        problem = " ".join(str(exc).splitlines()[0].split())
        raise ConfigError(f"{where} is not valid YAML: {problem}") from None
    except tomllib.TOMLDecodeError as exc:
        problem, _, at = str(exc).partition(" (at ")
        at = f" at {at.rstrip(')')}" if at else ""
        raise ConfigError(f"{where} is not valid TOML{at}: {problem}") from None
    except RecursionError:
        raise ConfigError(f"{where} nests deeper than {MAX_DEPTH} levels") from None
    _bounded(data, where)
    return data


def _bounded(data: Any, where: str) -> None:
    """A :class:`ConfigError` if ``data`` nests tables and lists deeper than :data:`MAX_DEPTH`
    or holds more than :data:`MAX_VALUES` values (shared YAML aliases counted each time)."""
    todo = [(data, 0)]
    count = 0
    while todo:
        value, depth = todo.pop()
        count += 1
        if depth > MAX_DEPTH:
            raise ConfigError(f"{where} nests deeper than {MAX_DEPTH} levels")
        if count > MAX_VALUES:
            raise ConfigError(f"{where} holds more than {MAX_VALUES} values")
        if isinstance(value, Mapping):
            todo.extend((v, depth + 1) for v in value.values())
        elif isinstance(value, (list, tuple)):
            todo.extend((v, depth + 1) for v in value)


def load_mapping(path: str | Path) -> dict[str, Any]:
    """Read a TOML (``.toml``) or YAML (``.yaml``/``.yml``) file into a dict: one
    :class:`ConfigError` naming the file (and the line and column of a syntax error) if it is
    missing, not a regular file, over :data:`MAX_FILE_BYTES`, not UTF-8, not valid, or not a
    mapping."""
    p = existing_file(path, "config file")
    where = f"config file {str(p)!r}"
    suffix = p.suffix.lower()
    if suffix not in (".toml", ".yaml", ".yml"):
        raise ConfigError(f"{where} must end in .toml, .yaml or .yml")
    try:
        with p.open("rb") as fh:
            raw = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise ConfigError(f"{where} cannot be read: {exc.strerror}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise ConfigError(f"{where} is larger than {MAX_FILE_BYTES >> 20} MiB")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(f"{where} is not UTF-8 text") from None
    data = _parsed(text, "toml" if suffix == ".toml" else "yaml", where)
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(f"{where} must hold a mapping at the top level")
    return data


def from_mapping(cls: type[T], data: Mapping[str, Any] | None, prefix: str = "") -> T:
    """Build dataclass ``cls`` from ``data``; nested dataclass fields are built recursively.

    Unknown keys, and missing keys of fields without a default, raise :class:`ConfigError`
    naming the key (its dotted path) and listing the allowed or required ones.
    """
    if data is not None and not isinstance(data, Mapping):
        where = prefix.rstrip(".") or cls.__name__
        raise ConfigError(f"{where} must be a table/mapping, got {data!r}")
    data = dict(data or {})
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        where = prefix.rstrip(".") or cls.__name__
        raise ConfigError(
            f"unknown key {prefix}{unknown[0]!r} in {where}; allowed keys: {', '.join(fields)}"
        )
    required = [
        name
        for name, f in fields.items()
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
    ]
    lacking = [name for name in required if name not in data]
    if lacking:
        where = prefix.rstrip(".") or cls.__name__
        raise ConfigError(
            f"{where} needs the key {lacking[0]!r} (required keys: {', '.join(required)})"
        )
    hints = typing.get_type_hints(cls)
    kwargs = {}
    for name, value in data.items():
        kwargs[name] = _convert(hints[name], value, f"{prefix}{name}")
    return cls(**kwargs)


_SCALARS = {bool: "true or false", int: "a whole number", float: "a number", str: "a string"}


def _type_error(name: str, expected: str, value: Any) -> ConfigError:
    return ConfigError(f"{name} must be {expected}, got {value!r}")


def _convert(tp: Any, value: Any, name: str) -> Any:
    """``value`` checked against the declared type ``tp`` (nested dataclasses built), so that a
    wrong type is a :class:`ConfigError` naming the key, never a ``TypeError`` later."""
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if tp in _SCALARS:
        ok = (
            isinstance(value, bool)
            if tp is bool
            else isinstance(value, tp)
            and not isinstance(value, bool)
            or (tp is float and isinstance(value, int) and not isinstance(value, bool))
        )
        if not ok:
            raise _type_error(name, _SCALARS[tp], value)
        return float(value) if tp is float else value
    if tp is dict or origin is dict:
        if not isinstance(value, Mapping):
            raise _type_error(name, "a table/mapping", value)
        return value
    if origin is typing.Literal:
        if value not in args:
            raise _type_error(name, "one of " + ", ".join(map(repr, args)), value)
        return value
    if dataclasses.is_dataclass(tp):
        if isinstance(value, tp):
            return value
        if not isinstance(value, Mapping):
            raise ConfigError(f"{name} must be a table/mapping, got {value!r}")
        return from_mapping(tp, value, prefix=f"{name}.")
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        if len(inner) == 1:
            return _convert(inner[0], value, name)
        for option in inner:  # the first type the value has
            try:
                return _convert(option, value, name)
            except ConfigError:
                continue
        raise _type_error(name, " or ".join(_describe(a) for a in args), value)
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise _type_error(name, "a list", value)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(args[0], v, f"{name}[{i}]") for i, v in enumerate(value))
        if args and len(args) != len(value):
            raise _type_error(name, f"a list of {len(args)} values", value)
        if args:
            return tuple(
                _convert(a, v, f"{name}[{i}]")
                for i, (a, v) in enumerate(zip(args, value, strict=True))
            )
        return tuple(value)
    return value


def _describe(tp: Any) -> str:
    if tp is type(None):
        return "null"
    if tp in _SCALARS:
        return _SCALARS[tp]
    if typing.get_origin(tp) is tuple:
        return "a list"
    if dataclasses.is_dataclass(tp) or tp is dict or typing.get_origin(tp) is dict:
        return "a table/mapping"
    return getattr(tp, "__name__", str(tp))
