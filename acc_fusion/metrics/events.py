r"""Streaming event-level metrics of a forward-collision-warning system against its oracle.

Every step the caller gives, for N pairs, the system's warning level and the *oracle's* (the
same warning rule evaluated on ground truth), as int8 arrays: 0 none, 1 caution, 2
imminent.  A pair *warns* at a step when it is active and ``system >= warn_level``; it is
*threatened* when it is active and ``oracle >= warn_level``.

Intervals and events
    An *interval* is a maximal run of steps with the flag set.  It starts at the time
    :math:`t_s` of its first step and ends at the time :math:`t_e` of the first step
    without the flag (the flag cleared, the pair inactive, or the run finished), so it
    covers :math:`[t_s, t_e)`.  The *gap* between two intervals is the time from the end of
    the earlier to the start of the later one (0 when they overlap).

    Intervals of the same kind whose gap is at most the tolerance :math:`\tau` are merged
    into one *event*: a *warning* (system) or a *threat* (oracle).  A warning that flickers
    off and on within :math:`\tau` is one warning, as the driver perceives it.  An event
    starts at the start of its first interval and is *live* while one of its intervals is
    open and until :math:`\tau` after the end of its last one; a new interval of the same
    kind that starts while the event is live extends it.

Matching
    A warning and a threat *match* when their gap is at most :math:`\tau`, that is, when
    both are live at the same step (both-live implies gap :math:`\le \tau`, and the later
    one's first step sees the earlier one still live, with a slack of :math:`10^{-6}\,dt`
    for the rounding of step times).

    * **False alarm**: a warning that matches no threat.
    * **Missed warning**: a threat that matches no warning; a **detected** threat matches
      at least one.
    * **Lead time** of a detected threat: its onset time minus the onset time of the first
      warning it matches (positive = the system warned earlier).  A warning that spans
      several threats gives each of them its lead time.
    * **TTC at warning**: the true time to collision at a warning's first step, over all
      warnings and, separately, over matched warnings.

    For intervals of the same kind separated by more than :math:`\tau` events are the
    intervals themselves, and these rules are exactly the definitions "a warning interval
    with no threat interval within :math:`\pm\tau`" and "a threat interval with no warning
    within :math:`\pm\tau`".  When several intervals fall within :math:`\tau` of each
    other they count as one event, and lead times and TTCs are taken at the onset of that
    event's first interval.

Counting
    Every figure is counted when it becomes known: warnings and threats at their onset (and
    the TTC at warning over all warnings), detections and lead times when a threat first
    matches (the TTC of a matched warning when it first matches), false alarms and misses
    when an unmatched event stops being live, and the events still live when :meth:`finish`
    is called.  Call :meth:`finish` at the end of a run before reading the summary.

Inactive pairs close their open intervals; an event's tail still runs on time, so a pair
that is inactive for less than :math:`\tau` can still match across the gap.  When a new
vehicle takes a pair over (a slot of a traffic source), :meth:`FCWMetrics.reset` settles the
events of the vehicle before it, which must not match the newcomer's across that gap.
Pairs flagged ``collided`` count one collision per run of flagged steps (whether or not
active).
Exposure (hours, km) and the per-step confusion matrix count active pair-steps only.

Memory is constant: a few per-pair arrays, a fixed number of counters, and fixed-bin
histograms (:class:`acc_fusion.metrics.stats.Histogram`) for lead times and TTCs.

Per pair
    The same counts, the exposure and the sum of lead times are also kept per pair
    (:meth:`FCWMetrics.per_pair`), so that a batch of N independent Monte Carlo runs gives one
    row per run (:mod:`acc_fusion.sweep.run`).  They add up to the totals of :meth:`summary`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.slots import PairState, pair_mask
from acc_fusion.core.validation import check_array, check_range
from acc_fusion.metrics.stats import Histogram
from acc_fusion.metrics.summary import FCWSummary, event_rates

#: Histogram bins [s]: lead time over [-60, 60) and TTC over [0, 60), 0.01 s wide.
LEAD_TIME_BINS = (-60.0, 60.0, 0.01)
TTC_BINS = (0.0, 60.0, 0.01)

_COUNTS = ("warnings", "false_alarms", "threats", "detected", "missed", "collisions")


class _Events(PairState):
    """Per-pair state of one kind of event (warnings or threats); see the module docstring.

    ``on``: the flag was set at the last step; ``live``, ``matched``: the pair's current
    event; ``start``: its onset time; ``end``: the end of its last closed interval.  A step
    is :func:`_event_step`.
    """

    _PAIR_AXES = dict.fromkeys(("on", "live", "matched", "start", "end"), 0)

    def __init__(self, n_pairs: int) -> None:
        self.on = np.zeros(n_pairs, dtype=bool)
        self.live = np.zeros(n_pairs, dtype=bool)
        self.matched = np.zeros(n_pairs, dtype=bool)
        self.start = np.zeros(n_pairs)
        self.end = np.zeros(n_pairs)

    @property
    def arrays(self) -> tuple[np.ndarray, ...]:
        """``(on, live, matched, start, end)``, what :func:`_event_step` advances."""
        return self.on, self.live, self.matched, self.start, self.end

    def finish(self, pairs: np.ndarray | None = None) -> np.ndarray:
        """End the events of ``pairs`` (a boolean mask; all by default); returns the pairs
        whose event was unmatched."""
        unmatched = np.empty(self.live.size, dtype=bool)
        _finish(pair_mask(pairs, self.live.size), self.on, self.live, self.matched, unmatched)
        return unmatched


class FCWMetrics(PairState):
    """Streaming false-alarm, miss, lead-time and TTC metrics over N pairs.

    Args:
        n_pairs: number of pairs N.
        dt: step length [s] (exposure counts ``dt`` per active pair-step).
        tolerance: :math:`\\tau` [s], the matching window (default 1 s).
        warn_level: the level that counts as a warning: 1 caution (default) or 2 imminent.

    Call :meth:`update` every step, :meth:`finish` at the end of a run, then
    :meth:`summary` (all pairs together) or :meth:`per_pair` (one value per pair).  After
    :meth:`finish` the instance can record another run (its time may start again);
    :meth:`merge` adds the counts of another finished instance to the totals.
    """

    _PAIR_AXES = {
        "_onset_ttc": 0, "_collided": 0, "_pair_counts": 1, "_pair_driven_s": 0,
        "_pair_distance_m": 0, "_pair_lead_time_s": 0, "_values": 1,
    }  # fmt: skip

    def __init__(self, n_pairs: int, dt: float, tolerance: float = 1.0, warn_level: int = 1):
        if isinstance(n_pairs, bool) or not isinstance(n_pairs, (int, np.integer)) or n_pairs < 1:
            raise ConfigError(f"n_pairs must be a whole number >= 1, got {n_pairs!r}")
        if warn_level not in (1, 2) or isinstance(warn_level, bool):
            raise ConfigError(f"warn_level must be 1 (caution) or 2 (imminent), got {warn_level!r}")
        self.n_pairs = int(n_pairs)
        self.dt = check_range("dt", dt, 0.0, math.inf, lo_open=True, hi_open=True)
        self.tolerance = check_range("tolerance", tolerance, 0.0, math.inf, hi_open=True)
        self.warn_level = int(warn_level)
        self._horizon = self.tolerance + 1e-6 * self.dt
        self._warnings = _Events(self.n_pairs)
        self._threats = _Events(self.n_pairs)
        self._onset_ttc = np.zeros(self.n_pairs)
        self._collided = np.zeros(self.n_pairs, dtype=bool)
        self._last_t = -math.inf
        self._counts = np.zeros(len(_COUNTS), dtype=np.int64)  # in the order of _COUNTS
        self._pair_counts = np.zeros((len(_COUNTS), self.n_pairs), dtype=np.int64)
        self._pair_driven_s = np.zeros(self.n_pairs)
        self._pair_distance_m = np.zeros(self.n_pairs)
        self._pair_lead_time_s = np.zeros(self.n_pairs)
        self._driven_s = 0.0
        self._distance_m = 0.0
        self._confusion = np.zeros((3, 3), dtype=np.int64)
        self._lead_time = Histogram(*LEAD_TIME_BINS)
        self._ttc_matched = Histogram(*TTC_BINS)
        self._ttc_all = Histogram(*TTC_BINS)
        # One step's values: TTC at new warnings, at matched warnings, lead times, speeds.
        self._values = np.empty((4, self.n_pairs))

    def _resized(self, m: int) -> None:
        self.n_pairs = m
        self._warnings.resize(m)
        self._threats.resize(m)

    def _levels(self, name: str, value: object) -> np.ndarray:
        arr = np.asarray(value)
        if arr.shape != (self.n_pairs,) or arr.dtype.kind not in "iu":
            raise InputError(
                f"{name} must be an integer array of shape ({self.n_pairs},), "
                f"got {arr.dtype} of shape {arr.shape}"
            )
        if arr.min() < 0 or arr.max() > 2:
            raise InputError(
                f"{name} must hold levels 0 (none), 1 (caution) or 2 (imminent), "
                f"got values in [{arr.min()}, {arr.max()}]"
            )
        return arr

    def _mask(self, name: str, value: object) -> np.ndarray:
        arr = np.asarray(value)
        if arr.shape != (self.n_pairs,) or arr.dtype != bool:
            raise InputError(
                f"{name} must be a boolean array of shape ({self.n_pairs},), "
                f"got {arr.dtype} of shape {arr.shape}"
            )
        return arr

    def _check_time(self, t: float) -> float:
        t = float(t)
        if not t > self._last_t or not math.isfinite(t):
            raise InputError(f"t must be finite and increase from step to step, got {t!r}")
        return t

    def update(
        self,
        t: float,
        system: np.ndarray,
        oracle: np.ndarray,
        ttc: np.ndarray,
        speed: np.ndarray,
        active: np.ndarray,
        collided: np.ndarray | None = None,
    ) -> None:
        """Record one step at time ``t`` [s].

        Args:
            system, oracle: warning levels (N,) of the system and of the oracle.
            ttc: true time to collision (N,) [s], ``inf`` when not closing (any value for
                inactive pairs).
            speed: ego speed (N,) [m/s], for the distance driven.
            active: pairs driven this step; the others close their intervals.
            collided: pairs that collided at this step (default: none).
        """
        t = self._check_time(t)
        n = self.n_pairs
        system, oracle, active = np.asarray(system), np.asarray(oracle), np.asarray(active)
        ttc, speed = np.asarray(ttc, dtype=float), np.asarray(speed, dtype=float)
        collided = np.zeros(n, dtype=bool) if collided is None else np.asarray(collided)
        if not (
            system.shape == oracle.shape == ttc.shape == speed.shape == (n,)
            and active.shape == collided.shape == (n,)
            and system.dtype.kind in "iu"
            and oracle.dtype.kind in "iu"
            and active.dtype == collided.dtype == bool
            and _usable(system, oracle, ttc, speed, active)
        ):
            self._check(system, oracle, ttc, speed, active, collided)  # raises
        self._last_t = t

        values = self._values
        n_active, n_new, n_matched, n_lead = _record(
            t, system, oracle, ttc, speed, active, collided, self.warn_level, self._horizon,
            self.dt, *self._warnings.arrays, *self._threats.arrays, self._onset_ttc,
            self._collided, self._counts, self._pair_counts, self._pair_driven_s,
            self._pair_distance_m, self._pair_lead_time_s, self._confusion, values,
        )  # fmt: skip
        self._ttc_all.add(values[0, :n_new])
        self._ttc_matched.add(values[1, :n_matched])
        self._lead_time.add(values[2, :n_lead])
        self._driven_s += n_active * self.dt
        self._distance_m += float(values[3, :n_active].sum()) * self.dt

    def _check(self, system, oracle, ttc, speed, active, collided) -> None:
        """Raise the error of the first bad input of :meth:`update`."""
        self._levels("system", system)
        self._levels("oracle", oracle)
        self._mask("active", active)
        check_array("ttc", ttc, (self.n_pairs,), finite=False, nonnegative=True, where=active)
        if np.isnan(ttc[active]).any():
            raise InputError("ttc must be a number >= 0 or inf where active, got NaN")
        check_array("speed", speed, (self.n_pairs,), nonnegative=True, where=active)
        self._mask("collided", collided)

    def _add(self, **events: np.ndarray) -> None:
        """Count the events of each kind (boolean masks over the pairs), in total and per pair."""
        for name, mask in events.items():
            i = _COUNTS.index(name)
            self._counts[i] += np.count_nonzero(mask)
            self._pair_counts[i] += mask

    def finish(self, t: float, collided: np.ndarray | None = None) -> None:
        """End the run at time ``t`` (>= the last step's time): resolve every open event.

        No interval can start after the run, so every live warning or threat is final:
        unmatched ones count as false alarms or misses now.  ``collided`` (N,) are the pairs
        collided at the end: a collision in the run's last step (which ends the run, so no
        :meth:`update` saw it) counts too.
        """
        if not float(t) >= self._last_t:
            raise InputError(f"t must not be before the last step's time, got {t!r}")
        late = (
            np.zeros(self.n_pairs, dtype=bool)
            if collided is None
            else self._mask("collided", collided) & ~self._collided
        )
        self._add(
            false_alarms=self._warnings.finish(), missed=self._threats.finish(), collisions=late
        )
        self._collided[:] = False
        self._last_t = -math.inf

    def reset(self, pairs: np.ndarray) -> None:
        """A new vehicle takes over ``pairs`` (a boolean mask, :attr:`SlotSource.reassigned`):
        end the events of the vehicle before it, whose tails could otherwise match the new
        vehicle's events within :math:`\\tau`.  Its unmatched warning or threat counts as a
        false alarm or a miss now (nothing can match it any more); the totals, the exposure
        and the per-pair sums carry on."""
        pairs = self._mask("pairs", pairs)
        self._add(false_alarms=self._warnings.finish(pairs), missed=self._threats.finish(pairs))

    def merge(self, other: FCWMetrics) -> None:
        """Add the counts, exposure and distributions of ``other`` (a finished instance).

        Only the totals are merged: :meth:`per_pair` keeps describing this instance's pairs.
        """
        if (other.warn_level, other.tolerance) != (self.warn_level, self.tolerance):
            raise InputError(
                "merge needs the same warn_level and tolerance, got "
                f"{other.warn_level} and {other.tolerance:g} s for "
                f"{self.warn_level} and {self.tolerance:g} s"
            )
        if other._warnings.live.any() or other._threats.live.any():
            raise InputError("merge needs a finished instance: call finish(t) on it first")
        self._counts += other._counts
        self._driven_s += other._driven_s
        self._distance_m += other._distance_m
        self._confusion += other._confusion
        self._lead_time.merge(other._lead_time)
        self._ttc_matched.merge(other._ttc_matched)
        self._ttc_all.merge(other._ttc_all)

    def per_pair(self) -> dict[str, np.ndarray]:
        """Per-pair figures so far (complete after :meth:`finish`), arrays ``(N,)``.

        Keys: the event counts (``warnings``, ``false_alarms``, ``threats``, ``detected``,
        ``missed``, ``collisions``), ``hours`` and ``km`` of active exposure, and
        ``lead_time_sum_s``, the sum of the lead times [s] of the pair's detected threats.
        """
        return {
            **{name: c.copy() for name, c in zip(_COUNTS, self._pair_counts, strict=True)},
            "hours": self._pair_driven_s / 3600.0,
            "km": self._pair_distance_m / 1000.0,
            "lead_time_sum_s": self._pair_lead_time_s.copy(),
        }

    def summary(self, confidence: float = 0.95) -> FCWSummary:
        """The metrics so far (complete after :meth:`finish`), intervals at ``confidence``."""
        count = dict(zip(_COUNTS, self._counts.tolist(), strict=True))
        hours = self._driven_s / 3600.0
        km = self._distance_m / 1000.0
        return FCWSummary(
            warn_level=self.warn_level,
            tolerance=self.tolerance,
            confidence=float(confidence),
            **count,
            hours=hours,
            km=km,
            **event_rates(count, hours, km, confidence),
            lead_time=self._lead_time.distribution(),
            ttc_at_warning=self._ttc_matched.distribution(),
            ttc_at_any_warning=self._ttc_all.distribution(),
            confusion=tuple(tuple(row) for row in self._confusion.tolist()),
            per_pair=self.per_pair(),
        )


@njit(cache=True)
def _usable(system, oracle, ttc, speed, active):  # pragma: no cover - compiled
    """True if the levels are 0, 1 or 2 and, where ``active``, ``ttc`` is a number >= 0 or inf
    and ``speed`` a finite number >= 0 (the checks of :meth:`FCWMetrics.update`)."""
    for i in range(active.size):
        if not (0 <= system[i] <= 2 and 0 <= oracle[i] <= 2):
            return False
        if active[i] and not (ttc[i] >= 0.0 and np.isfinite(speed[i]) and speed[i] >= 0.0):
            return False
    return True


@njit(cache=True)
def _finish(pairs, on, live, matched, unmatched):  # pragma: no cover - compiled
    """:meth:`_Events.finish` of the pairs in ``pairs (N,)``: their events end (not on, not
    live, in place); ``unmatched (N,)`` receives those whose live event was unmatched."""
    for i in range(pairs.size):
        unmatched[i] = pairs[i] and live[i] and not matched[i]
        if pairs[i]:
            on[i] = False
            live[i] = False


@njit(cache=True)
def _event_step(t, now, horizon, on, live, matched, start, end):  # pragma: no cover - compiled
    """Advance one pair's event of one kind (:class:`_Events`) to time ``t`` with the flag
    ``now``.

    Takes and returns the pair's ``(on, live, matched, start, end)``, preceded on return by
    whether a new event starts at ``t`` and whether an unmatched event stopped being live
    (its tail passed ``horizon`` after its last interval).
    """
    held = on and now
    if on and not now:
        end = t
    expired = live and not held and t - end > horizon
    unmatched = expired and not matched
    live = live and not expired
    new = now and not on and not live
    if new:
        live, matched, start = True, False, t
    return new, unmatched, now, live, matched, start, end


@njit(cache=True)
def _record(
    t, system, oracle, ttc, speed, active, collided, warn_level, horizon, dt,
    w_on, w_live, w_matched, w_start, w_end, h_on, h_live, h_matched, h_start, h_end,
    onset_ttc, was_collided, counts, pair_counts, pair_driven_s, pair_distance_m,
    pair_lead_time_s, confusion, values,
):  # pragma: no cover - compiled  # fmt: skip
    """One step of :meth:`FCWMetrics.update` on checked inputs, in place (``w_*``: the
    warnings, ``h_*``: the threats, as :class:`_Events`; counts in the order of ``_COUNTS``).

    Rows 0 to 3 of ``values`` receive, in the order of the pairs, the TTC at the new warnings,
    the onset TTC of the newly matched warnings, the lead times of the newly detected threats
    and the speeds of the active pairs; returns how many of each, the last being the number
    of active pairs.
    """
    n_new = n_matched = n_lead = n_active = 0
    for i in range(active.size):
        warns = active[i] and system[i] >= warn_level
        threatened = active[i] and oracle[i] >= warn_level
        warn_new, false_alarm, w_on[i], w_live[i], w_matched[i], w_start[i], w_end[i] = _event_step(
            t, warns, horizon, w_on[i], w_live[i], w_matched[i], w_start[i], w_end[i]
        )
        threat_new, missed, h_on[i], h_live[i], h_matched[i], h_start[i], h_end[i] = _event_step(
            t, threatened, horizon, h_on[i], h_live[i], h_matched[i], h_start[i], h_end[i]
        )
        if warn_new:
            onset_ttc[i] = ttc[i]
            values[0, n_new] = ttc[i]
            n_new += 1
        both = w_live[i] and h_live[i]
        warn_matched = both and not w_matched[i]
        detected = both and not h_matched[i]
        if both:
            w_matched[i] = True
            h_matched[i] = True
        if warn_matched:
            values[1, n_matched] = onset_ttc[i]
            n_matched += 1
        if detected:
            lead = h_start[i] - w_start[i]
            values[2, n_lead] = lead
            n_lead += 1
            pair_lead_time_s[i] += lead
        if active[i]:
            confusion[oracle[i], system[i]] += 1
            values[3, n_active] = speed[i]
            n_active += 1
            pair_driven_s[i] += dt
            pair_distance_m[i] += speed[i] * dt
        collision = collided[i] and not was_collided[i]
        was_collided[i] = collided[i]
        events = (warn_new, false_alarm, threat_new, detected, missed, collision)
        for k in range(len(events)):
            if events[k]:
                counts[k] += 1
                pair_counts[k, i] += 1
    return n_active, n_new, n_matched, n_lead
