"""Small validators that turn bad values into one-sentence :class:`ConfigError`/`InputError`."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import fields
from typing import TypeVar

import numpy as np
from numba import njit

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


def check_array(
    name: str,
    value: object,
    shape: tuple[int | None, ...] | None = None,
    *,
    finite: bool = True,
    nonnegative: bool = False,
    where: np.ndarray | None = None,
) -> np.ndarray:
    """Validate a float array: shape (``None`` = any length), finiteness, sign.

    ``where`` restricts the finiteness/sign checks to the entries that are used (for example
    only the pairs that have a lead vehicle); the others may hold NaN.
    """
    arr = np.asarray(value, dtype=float)
    if shape is not None:
        ok = arr.ndim == len(shape) and all(
            s is None or s == a for s, a in zip(shape, arr.shape, strict=False)
        )
        if not ok:
            dims = ["N" if s is None else str(s) for s in shape]
            want = "(" + ", ".join(dims) + ("," if len(dims) == 1 else "") + ")"
            raise InputError(f"{name} must have shape {want}, got {arr.shape}")
    if not (finite or nonnegative) or arr.size == 0:
        return arr
    mask = _ALL if where is None else np.asarray(where, dtype=bool)
    if mask.size != 1 and mask.shape != arr.shape[: mask.ndim]:
        raise InputError(
            f"{name}: the mask of used entries has shape {mask.shape}, not {arr.shape}"
        )
    rows = arr.reshape(1, -1) if mask.size == 1 else arr.reshape(mask.size, -1)
    bad = _scan(rows, mask.reshape(-1), finite, nonnegative)
    if bad == _NON_FINITE:
        raise InputError(f"{name} must be finite (no NaN or inf) where it is used")
    if bad == _NEGATIVE:
        used = arr if where is None else arr[mask]
        raise InputError(f"{name} must be >= 0, got a minimum of {float(np.nanmin(used)):g}")
    return arr


_ALL = np.ones(1, dtype=bool)
_NON_FINITE, _NEGATIVE = 1, 2


@njit(cache=True)
def _scan(rows, mask, finite, nonnegative):  # pragma: no cover - compiled
    """0 if the used rows (``mask``, or every row when ``mask`` has one entry) are valid, else
    :data:`_NON_FINITE` (any non-finite value) or :data:`_NEGATIVE` (a negative value)."""
    every = mask.size == 1 and mask[0]
    negative = False
    for i in range(rows.shape[0]):
        if not (every or mask[i]):
            continue
        for j in range(rows.shape[1]):
            v = rows[i, j]
            if finite and not np.isfinite(v):
                return _NON_FINITE
            if nonnegative and v < 0:
                negative = True
    return _NEGATIVE if negative else 0


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
