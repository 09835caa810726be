"""Working on the occupied slots only: the pipeline's stages shrink to a prefix of the pairs.

A traffic source (SUMO) gives every equipped vehicle a slot of a fixed capacity (1024 by
default) and fills the lowest free slot first, so the vehicles on the network occupy a prefix
of the slots, far shorter than the capacity while the network fills or empties.  Every stage
of the pipeline costs in proportion to the pairs it holds, so
:func:`acc_fusion.sim.closed_loop.simulate`
lets the stages work on that prefix only (:class:`Extent` decides its length) and
:meth:`PairState.resize` moves the state of the slots beyond it aside, unchanged, until the
prefix grows over them again.

This changes no result: a slot beyond the prefix has been empty for at least one step (so
the metrics have closed its events), every stage resets a slot's state when a new vehicle
takes it (``forget``/``reset``), and the random draws are made for the whole capacity and
cut to the prefix, so every slot sees the same draws with or without the prefix (the tests
hold the two runs equal).
"""

from __future__ import annotations

import hashlib
from typing import ClassVar

import numpy as np
from numba import njit

from acc_fusion.core.errors import ConfigError, InputError

#: Slots by which the prefix grows or shrinks (each resize copies every stage's state once).
QUANTUM = 64


class PairState:
    """A stage whose per-pair arrays can shrink to the first m pairs and grow back.

    A subclass names its per-pair array attributes in ``_PAIR_AXES`` (attribute → axis of
    the pair index; an attribute that is ``None`` is skipped) and extends :meth:`_resized` to
    set its pair count and resize its parts.  The state of the pairs beyond m is parked, not
    dropped: growing back restores it as it was.
    """

    _PAIR_AXES: ClassVar[dict[str, int]] = {}

    def resize(self, m: int) -> None:
        """Hold the first ``m`` pairs (``1 <= m <=`` the pairs the stage was built for).

        A held array that changes size is a new C-contiguous array (the kernels' layout); a
        parked tail may be a view of an older one (which it keeps in memory), so that growing
        copies only the pairs that come back."""
        parked = self.__dict__.setdefault("_parked", {})
        for name, axis in self._PAIR_AXES.items():
            held = getattr(self, name)
            if held is None:
                continue
            now, rest = held.shape[axis], parked.get(name)
            total = now + (0 if rest is None else rest.shape[axis])
            if not 1 <= m <= total:
                raise ConfigError(f"{type(self).__name__} can hold 1 to {total} pairs, got {m}")
            if m >= now:
                head = (
                    np.concatenate((held, _span(rest, 0, m - now, axis)), axis) if m > now else held
                )
                tail = rest if m == now else _span(rest, m - now, None, axis)
            else:
                head = np.array(_span(held, 0, m, axis), order="C")
                kept = _span(held, m, None, axis)
                tail = kept if rest is None else np.concatenate((kept, rest), axis)
            setattr(self, name, head)
            if tail is not None:
                parked[name] = tail
        self._resized(m)

    def _resized(self, m: int) -> None:
        """Set the pair count to ``m`` and resize the stage's parts (subclasses extend it)."""


def _span(a: np.ndarray, start: int, stop: int | None, axis: int) -> np.ndarray:
    """The view of ``a`` from ``start`` to ``stop`` along ``axis``."""
    return a[(slice(None),) * axis + (slice(start, stop),)]


def pair_mask(pairs, n: int) -> np.ndarray:
    """``pairs`` (a boolean mask ``(n,)`` or indices; ``None``: every pair) as a boolean
    mask ``(n,)``; numpy checks the mask's length and the indices' range."""
    if pairs is None:
        return np.ones(n, dtype=bool)
    mask = np.zeros(n, dtype=bool)
    mask[np.asarray(pairs)] = True
    return mask


def unit_key(name: str) -> int:
    """A stable 63-bit integer key of a unit's name (e.g. a SUMO vehicle id): the same in
    every process and run, unlike ``hash`` (BLAKE2b of the UTF-8 name)."""
    digest = hashlib.blake2b(str(name).encode(), digest_size=8).digest()
    return int.from_bytes(digest, "little") >> 1


def resize_all(stages, m: int) -> None:
    """:meth:`PairState.resize` every stage of ``stages`` to ``m`` pairs."""
    for stage in stages:
        stage.resize(m)


class Extent:
    """The length of the prefix of slots the pipeline works on, step by step.

    It covers every slot active now or at the previous step (a slot that empties is seen
    empty once, so the metrics close its events), rounded up to a multiple of ``quantum``;
    it grows at once and shrinks only by at least two quanta (no resizing back and forth
    when the traffic hovers around a boundary).
    """

    def __init__(self, capacity: int, quantum: int = QUANTUM) -> None:
        self.capacity, self.quantum = int(capacity), int(quantum)
        self.size = self.capacity
        self._last = 0  # one past the highest slot active at the previous step

    def fit(self, active: np.ndarray) -> int:
        """The prefix length for a step whose active slots are ``active (capacity,)``."""
        occupied = np.flatnonzero(active)
        top = int(occupied[-1]) + 1 if occupied.size else 0
        need = max(top, self._last, 1)
        self._last = top
        q = self.quantum
        fitted = min(self.capacity, -(-need // q) * q)
        if fitted > self.size or fitted < self.size - q:
            self.size = fitted
        return self.size

    def fit_stages(self, active: np.ndarray, stages) -> int:
        """:meth:`fit` the prefix to ``active`` and :func:`resize_all` ``stages`` when its
        length changes; the length."""
        size = self.size
        if self.fit(active) != size:
            resize_all(stages, self.size)
        return self.size


class PairPool:
    """Dense pair indices for the live keys of a sparse key space.

    The 2-D world has E·F object slots (F per ego) of which a few are used at a time; its
    estimators need one pair per *used* slot only.  The pool gives each live key (a slot) a
    pair index for as long as it stays live, the lowest free index first, so the pairs in use
    stay a short prefix that an :class:`Extent` can cut the estimators to.

    Attributes:
        pair_of: ``(K,)`` each key's pair, -1 for none.
        key_of: ``(P,)`` each pair's key, -1 for a free pair.
    """

    def __init__(self, n_keys: int, n_pairs: int) -> None:
        self.pair_of = np.full(int(n_keys), -1, np.int64)
        self.key_of = np.full(int(n_pairs), -1, np.int64)

    @property
    def used(self) -> np.ndarray:
        """``(P,)`` the pairs that hold a key."""
        return self.key_of >= 0

    def release(self, keys: np.ndarray) -> np.ndarray:
        """Free the pairs of ``keys`` (a boolean mask ``(K,)``); the freed pairs ``(P,)``."""
        pairs = self.pair_of[keys]
        pairs = pairs[pairs >= 0]
        self.key_of[pairs] = -1
        self.pair_of[keys] = -1
        return pair_mask(pairs, self.key_of.size)

    def update(self, live: np.ndarray) -> np.ndarray:
        """Hold exactly the keys in ``live`` (a boolean mask over the first ``len(live)``
        keys; the keys beyond it are not live): free the pairs of the keys that left, give
        each new key the lowest free pair.  Returns the freed pairs ``(P,)`` (a pair freed
        and taken again in this call is among them)."""
        live = np.asarray(live, dtype=bool)
        if live.ndim != 1 or live.size > self.pair_of.size:
            raise InputError(f"live must be a mask of at most {self.pair_of.size} keys")
        if np.count_nonzero(live) > self.key_of.size:
            raise ConfigError(f"the pool of {self.key_of.size} pairs is full")
        freed = np.zeros(self.key_of.size, dtype=bool)
        _hold(live, self.pair_of, self.key_of, freed)
        return freed


@njit(cache=True)
def _hold(live, pair_of, key_of, freed):  # pragma: no cover - compiled
    """:meth:`PairPool.update` in place, in one pass over the keys to free and one to
    take: the keys that left give their pair back (marked in ``freed``), then each new key,
    in ascending order, takes the lowest free pair."""
    for k in range(pair_of.size):
        p = pair_of[k]
        if p >= 0 and not (k < live.size and live[k]):
            key_of[p], pair_of[k], freed[p] = -1, -1, True
    free = 0
    for k in range(live.size):
        if live[k] and pair_of[k] < 0:
            while key_of[free] >= 0:
                free += 1
            key_of[free], pair_of[k] = k, free
