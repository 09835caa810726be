"""Small validators that turn bad values into one-sentence :class:`ConfigError`/`InputError`."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from acc_fusion.errors import ConfigError, InputError


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
    used = arr if where is None else arr[np.asarray(where, dtype=bool)]
    if finite and not np.all(np.isfinite(used)):
        raise InputError(f"{name} must be finite (no NaN or inf) where it is used")
    if nonnegative and np.any(used < 0):
        raise InputError(f"{name} must be >= 0, got a minimum of {float(np.min(used)):g}")
    return arr


def check_interval(name: str, value: object, *, lo_open: bool) -> tuple[float, float]:
    """Validate a ``(low, high)`` pair with ``0 <= low <= high < inf`` (``0 < low`` if open)."""
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise ConfigError(f"{name} must be a pair (low, high) of numbers, got {value!r}")
    low = check_range(f"{name}[0]", value[0], 0.0, math.inf, lo_open=lo_open, hi_open=True)
    high = check_range(f"{name}[1]", value[1], low, math.inf, hi_open=True)
    return low, high
