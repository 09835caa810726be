"""Small validators that turn bad values into one-sentence :class:`ConfigError`/`InputError`."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import fields
from typing import TypeVar

import numpy as np

from acc_fusion.core.errors import ConfigError, InputError

T = TypeVar("T")


def check_range(
    name: str,
    value: float,
    lo: float = -math.inf,
    hi: float = math.inf,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
) -> float:
    """Return ``value`` as a float if it lies in the interval, else raise :class:`ConfigError`.

    >>> check_range("radar.range_std", 0.25, 0.0, lo_open=True)
    0.25
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{name} must be a number, got {value!r}") from None
    bad_lo = v <= lo if lo_open else v < lo
    bad_hi = v >= hi if hi_open else v > hi
    if math.isnan(v) or bad_lo or bad_hi:
        left = "(" if lo_open else "["
        right = ")" if hi_open else "]"
        raise ConfigError(f"{name} must be in {left}{lo:g}, {hi:g}{right}, got {value!r}")
    return v


def check_choice(name: str, value: str, choices: Iterable[str]) -> str:
    """Return ``value`` if it is in ``choices``, else raise :class:`ConfigError` listing them."""
    options = tuple(choices)
    if value not in options:
        raise ConfigError(f"{name} must be one of {', '.join(map(repr, options))}, got {value!r}")
    return value


def check_mask(name: str, value: object, n: int) -> np.ndarray:
    """``value`` as a boolean array of shape ``(n,)``; anything else is an
    :class:`~acc_fusion.core.errors.InputError` naming ``name``."""
    arr = np.asarray(value)
    if arr.shape != (n,) or arr.dtype != bool:
        raise InputError(
            f"{name} must be a boolean array of shape ({n},), got {arr.dtype} {arr.shape}"
        )
    return arr


def broadcast(name: str, value: object, shape: tuple[int, ...], dtype) -> np.ndarray:
    """``value`` as an array of ``dtype`` broadcast to ``shape`` (itself when it already is
    one, else a read-only view), or a one-sentence
    :class:`~acc_fusion.core.errors.InputError` naming ``name``."""
    if isinstance(value, np.ndarray) and value.shape == shape and value.dtype == dtype:
        return value
    try:
        return np.broadcast_to(np.asarray(value, dtype=dtype), shape)
    except ValueError:
        raise InputError(f"{name} must have shape {shape}, got {np.shape(value)}") from None


def check_interval(name: str, value: object, *, lo_open: bool) -> tuple[float, float]:
    """Validate a ``(low, high)`` pair with ``0 <= low <= high < inf`` (``0 < low`` if open)."""
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise ConfigError(f"{name} must be a pair (low, high) of numbers, got {value!r}")
    low = check_range(f"{name}[0]", value[0], 0.0, math.inf, lo_open=lo_open, hi_open=True)
    high = check_range(f"{name}[1]", value[1], low, math.inf, hi_open=True)
    return low, high


def unchecked(cls: type[T], values: dict[str, object]) -> T:
    """An instance of the frozen dataclass ``cls`` holding ``values`` (one per field) as they
    are, without its ``__post_init__`` checks: for the frames a source builds from its own
    arrays at every step (``from_arrays`` of the frames); an
    :class:`~acc_fusion.core.errors.InputError` if a field is missing or unknown."""
    names = [f.name for f in fields(cls)]
    if sorted(values) != sorted(names):
        raise InputError(f"{cls.__name__} needs exactly the fields {', '.join(names)}")
    obj = object.__new__(cls)
    for name in names:
        object.__setattr__(obj, name, values[name])
    return obj
