"""Checking input arrays: shape, dtype, finite and non-negative values, in one compiled pass
(:func:`check_array`), so that a bad array is one :class:`~acc_fusion.core.errors.InputError`
naming it.  Apart from :mod:`acc_fusion.core.validation` because of its numba kernel, which the
config checks (and so the command line's parsers) do without."""

from __future__ import annotations

import numpy as np
from numba import njit

from acc_fusion.core.errors import InputError


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


@njit(cache=True)
def all_finite(x):  # pragma: no cover - compiled
    """True if every entry of the flat array ``x`` is finite (a kernel's shortcut past
    :func:`check_array` for inputs that are usually good)."""
    for i in range(x.size):
        if not np.isfinite(x[i]):
            return False
    return True
