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

Alert classes, judged from truth
    The caller also flags, per step, the pairs in a *crash-relevant situation* in truth
    (:mod:`acc_fusion.metrics.alert_classes`: the driver must act now, whatever the rule under
    test says).  Flagged steps make a third kind of event, merged and matched with the same
    tolerance.  When a warning ends it gets one class:

    * **crash-relevant**: it matched a crash-relevant situation;
    * **nuisance**: otherwise, it matched an oracle threat (the rule fires on the true lead,
      but truth shows that nothing needed doing);
    * **sensing-false**: neither (with perfect sensing the rule would not have fired: noise,
      ghosts, a wrong target, a fault).

    A crash-relevant situation that matches no warning is *missed*; its *lead time* is its
    onset minus the onset of the first warning it matches.  The oracle's threats that met a
    crash-relevant situation are counted too (``threats_relevant``): how many of the rule's
    firings on truth needed any action.  The oracle-agreement figures (false alarms, misses)
    stay as they were: a *false alarm* is a warning that matched no oracle threat, whatever
    the situation.

Counting
    Every figure is counted when it becomes known: warnings and threats at their onset (and
    the TTC at warning over all warnings), detections and lead times when a threat first
    matches (the TTC of a matched warning when it first matches), false alarms and misses
    when an unmatched event stops being live, and the events still live when :meth:`finish`
    is called.  Call :meth:`finish` at the end of a run before reading the summary.

Warning classes are counted when the warning ends. Inactive pairs close their open intervals; an
event's tail still runs on time, so a pair that is inactive for less than :math:`\tau` can still
match across the gap. When a new vehicle takes a pair over (a slot of a traffic source),
:meth:`FCWMetrics.reset` settles the events of the vehicle before it, which must not match the
newcomer's across that gap. Pairs flagged ``collided`` count one collision per run of flagged
steps (whether or not active). Exposure (hours, km) and the per-step confusion matrix count
active pair-steps only.

Memory is constant: a few per-pair arrays, a fixed number of counters, and fixed-bin
histograms (:class:`acc_fusion.metrics.stats.Histogram`) for lead times and TTCs.

Per pair
    The same counts, the exposure and the sum of lead times are also kept per pair
    (:meth:`FCWMetrics.per_pair`), so that a batch of N independent Monte Carlo runs gives one
    row per run (:mod:`acc_fusion.sweep.run`).  They add up to the totals of :meth:`summary`.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.slots import PairState, pair_mask
from acc_fusion.core.validation import check_mask, check_range
from acc_fusion.metrics.event_kernels import _advance, _finish, _record, _usable
from acc_fusion.metrics.stats import Histogram
from acc_fusion.metrics.summary import (
    ALERT_CLASSES,
    CAUSE_CELLS,
    CAUSE_COUNTS,
    CAUSES,
    COUNTS,
    DISTRIBUTIONS,
    FCWSummary,
    event_rates,
)

#: Histogram bins [s]: lead time over [-60, 60) and TTC over [0, 60), 0.01 s wide.
LEAD_TIME_BINS = (-60.0, 60.0, 0.01)
TTC_BINS = (0.0, 60.0, 0.01)

#: Indices of the class and the causes that :meth:`FCWMetrics._count_causes` re-labels.
_SENSING_FALSE = ALERT_CLASSES.index("sensing_false")
_LEAD, _NOISE = CAUSES.index("lead"), CAUSES.index("noise")
#: Each of :data:`CAUSE_CELLS` as (class index, cause index).
_CAUSE_CELLS = tuple((ALERT_CLASSES.index(c), CAUSES.index(k)) for c, k in CAUSE_CELLS)


class EventState(PairState):
    """Per-pair state of one kind of event (warnings, threats or crash-relevant situations);
    see the module docstring.

    ``on``: the flag was set at the last step; ``live``, ``matched``, ``flagged``: the pair's
    current event (``flagged``: a warning or threat that met a crash-relevant situation);
    ``start``: its onset time; ``end``: the end of its last closed interval.  A step is
    :func:`_event_step`.
    """

    _PAIR_AXES = dict.fromkeys(("on", "live", "matched", "flagged", "start", "end"), 0)

    def __init__(self, n_pairs: int) -> None:
        self.on = np.zeros(n_pairs, dtype=bool)
        self.live = np.zeros(n_pairs, dtype=bool)
        self.matched = np.zeros(n_pairs, dtype=bool)
        self.flagged = np.zeros(n_pairs, dtype=bool)
        self.start = np.zeros(n_pairs)
        self.end = np.zeros(n_pairs)

    @property
    def arrays(self) -> tuple[np.ndarray, ...]:
        """``(on, live, matched, flagged, start, end)``, the arrays :func:`_record` advances."""
        return self.on, self.live, self.matched, self.flagged, self.start, self.end

    def advance(self, t: float, now: np.ndarray, horizon: float) -> tuple[np.ndarray, np.ndarray]:
        """Advance every pair to time ``t`` with the flags ``now (N,)`` (events end
        ``horizon`` seconds after their last interval, as :class:`FCWMetrics`'s with its
        ``tolerance``); returns the pairs whose event starts at ``t`` and those whose event
        ended."""
        new, ended = np.empty(self.live.size, dtype=bool), np.empty(self.live.size, dtype=bool)
        _advance(float(t), now, float(horizon), self.on, self.live, self.start, self.end, new,
                 ended)  # fmt: skip
        return new, ended

    def finish(self, pairs: np.ndarray | None = None) -> np.ndarray:
        """End the live events of ``pairs`` (a boolean mask; all by default); returns the
        pairs whose event ended (their ``matched`` and ``flagged`` say what it was)."""
        ended = np.empty(self.live.size, dtype=bool)
        _finish(pair_mask(pairs, self.live.size), self.on, self.live, ended)
        return ended


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
        "_onset_ttc": 0, "_collided": 0, "_warn_cause": 0, "_pair_counts": 1, "_pair_driven_s": 0,
        "_pair_distance_m": 0, "_pair_lead_time_s": 0, "_values": 1, "_pair_causes": 1,
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
        self._warnings = EventState(self.n_pairs)
        self._threats = EventState(self.n_pairs)
        self._relevant = EventState(self.n_pairs)
        self._onset_ttc = np.zeros(self.n_pairs)
        self._collided = np.zeros(self.n_pairs, dtype=bool)
        self._last_t = -math.inf
        self._counts = np.zeros(len(COUNTS), dtype=np.int64)  # in the order of COUNTS
        self._pair_counts = np.zeros((len(COUNTS), self.n_pairs), dtype=np.int64)
        self._pair_driven_s = np.zeros(self.n_pairs)
        self._pair_distance_m = np.zeros(self.n_pairs)
        self._pair_lead_time_s = np.zeros(self.n_pairs)
        self._driven_s = 0.0
        self._distance_m = 0.0
        self._confusion = np.zeros((3, 3), dtype=np.int64)
        self._lead_time = Histogram(*LEAD_TIME_BINS)
        self._relevant_lead_time = Histogram(*LEAD_TIME_BINS)
        self._ttc_matched = Histogram(*TTC_BINS)
        self._ttc_all = Histogram(*TTC_BINS)
        # One step's values: TTC at new warnings, at matched warnings, lead times, speeds,
        # lead times before crash-relevant situations.
        self._values = np.empty((5, self.n_pairs))
        # The cause of each pair's current warning (-1: none given) and the warnings by class
        # and cause; the rows of COUNTS that say which warnings started or ended with a class.
        self._warn_cause = np.full(self.n_pairs, -1, dtype=np.int64)
        self._by_cause = np.zeros((len(ALERT_CLASSES), len(CAUSES)), dtype=np.int64)
        self._pair_causes = np.zeros((len(ALERT_CLASSES), n_pairs, len(CAUSES)), np.int64)
        self._cause_rows = [COUNTS.index(c) for c in (*ALERT_CLASSES, "warnings")]
        self._causes_given = False

    def _resized(self, m: int) -> None:
        self.n_pairs = m
        self._warnings.resize(m)
        self._threats.resize(m)
        self._relevant.resize(m)

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
        return check_mask(name, value, self.n_pairs)

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
        relevant: np.ndarray | None = None,
        cause: np.ndarray | None = None,
    ) -> None:
        """Record one step at time ``t`` [s].

        Args:
            system, oracle: warning levels (N,) of the system and of the oracle.
            ttc: true time to collision (N,) [s], ``inf`` when not closing (any value for
                inactive pairs).
            speed: ego speed (N,) [m/s], for the distance driven.
            active: pairs driven this step; the others close their intervals.
            collided: pairs that collided at this step (default: none).
            relevant: pairs in a crash-relevant situation in truth at this step
                (:func:`acc_fusion.metrics.alert_classes.crash_relevant`; default: none).
            cause: (N,) index into :data:`CAUSES` of what the system warns on at this step,
                or -1 for none (read at a warning's onset; the warning's class is counted
                under it when it ends; never ``noise``, which the class gives); default: no
                causes.
        """
        t = self._check_time(t)
        n = self.n_pairs
        system, oracle, active = np.asarray(system), np.asarray(oracle), np.asarray(active)
        ttc, speed = np.asarray(ttc, dtype=float), np.asarray(speed, dtype=float)
        collided = np.zeros(n, dtype=bool) if collided is None else np.asarray(collided)
        relevant = np.zeros(n, dtype=bool) if relevant is None else np.asarray(relevant)
        if not (
            system.shape == oracle.shape == ttc.shape == speed.shape == (n,)
            and active.shape == collided.shape == relevant.shape == (n,)
            and system.dtype.kind in "iu"
            and oracle.dtype.kind in "iu"
            and active.dtype == collided.dtype == relevant.dtype == bool
            and _usable(system, oracle, ttc, speed, active)
        ):
            self._check(system, oracle, ttc, speed, active, collided, relevant)  # raises
        self._last_t = t
        if cause is not None:
            cause = np.asarray(cause)
            if (
                cause.shape != (n,)
                or cause.dtype.kind not in "iu"
                or ((cause < -1) | (cause >= len(CAUSES)) | (cause == _NOISE)).any()
            ):
                raise InputError(
                    f"cause must be an integer array of shape ({n},) of CAUSES indices, or -1 "
                    "for none (noise is given by a warning's class, not at its onset)"
                )
            self._causes_given = True
            before = self._pair_counts[self._cause_rows]

        values = self._values
        n_active, n_new, n_matched, n_lead, n_relevant = _record(
            t, system, oracle, ttc, speed, active, collided, relevant, self.warn_level,
            self._horizon, self.dt, *self._warnings.arrays, *self._threats.arrays,
            *self._relevant.arrays, self._onset_ttc, self._collided, self._counts,
            self._pair_counts, self._pair_driven_s, self._pair_distance_m,
            self._pair_lead_time_s, self._confusion, values,
        )  # fmt: skip
        self._ttc_all.add(values[0, :n_new])
        self._ttc_matched.add(values[1, :n_matched])
        self._lead_time.add(values[2, :n_lead])
        self._relevant_lead_time.add(values[4, :n_relevant])
        self._driven_s += n_active * self.dt
        self._distance_m += float(values[3, :n_active].sum()) * self.dt
        if cause is not None:
            delta = self._pair_counts[self._cause_rows] - before
            self._count_causes(delta[:-1] > 0)  # ended warnings, with their onset's cause
            started = delta[-1] > 0
            self._warn_cause[started] = cause[started]

    def _count_causes(self, ended: np.ndarray) -> None:
        """Count the warnings that ended with each class (``ended``: (classes, N) masks) under
        the cause recorded at their onset; a sensing-false one on the true lead under
        ``noise`` (:data:`CAUSES`)."""
        causes = self._by_cause.shape[1]
        for k, mask in enumerate(ended):
            pairs = np.flatnonzero(mask & (self._warn_cause >= 0))
            cause = self._warn_cause[pairs]
            if k == _SENSING_FALSE:
                cause = np.where(cause == _LEAD, _NOISE, cause)
            self._pair_causes[k, pairs, cause] += 1  # a pair ends one warning at a time
            self._by_cause[k] += np.bincount(cause, minlength=causes)

    def _check(self, system, oracle, ttc, speed, active, collided, relevant) -> None:
        """Raise the error of the first bad input of :meth:`update`."""
        self._levels("system", system)
        self._levels("oracle", oracle)
        self._mask("active", active)
        check_array("ttc", ttc, (self.n_pairs,), finite=False, nonnegative=True, where=active)
        if np.isnan(ttc[active]).any():
            raise InputError("ttc must be a number >= 0 or inf where active, got NaN")
        check_array("speed", speed, (self.n_pairs,), nonnegative=True, where=active)
        self._mask("collided", collided)
        self._mask("relevant", relevant)

    def _add(self, **events: np.ndarray) -> None:
        """Count the events of each kind (boolean masks over the pairs), in total and per pair."""
        for name, mask in events.items():
            i = COUNTS.index(name)
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
        self._settle(None)
        self._add(collisions=late)
        self._collided[:] = False
        self._last_t = -math.inf

    def reset(self, pairs: np.ndarray) -> None:
        """A new vehicle takes over ``pairs`` (a boolean mask, :attr:`SlotSource.reassigned`):
        end the events of the vehicle before it, whose tails could otherwise match the new
        vehicle's events within :math:`\\tau`.  Its unmatched warning or threat counts as a
        false alarm or a miss now (nothing can match it any more); the totals, the exposure
        and the per-pair sums carry on."""
        self._settle(self._mask("pairs", pairs))

    def _settle(self, pairs: np.ndarray | None) -> None:
        """End the live events of ``pairs`` (all if ``None``) and count what they were."""
        w, h, c = self._warnings, self._threats, self._relevant
        w_end, h_end, c_end = w.finish(pairs), h.finish(pairs), c.finish(pairs)
        classes = {
            "crash_relevant": w_end & w.flagged,
            "nuisance": w_end & ~w.flagged & w.matched,
            "sensing_false": w_end & ~w.flagged & ~w.matched,
        }
        self._add(
            false_alarms=w_end & ~w.matched,
            missed=h_end & ~h.matched,
            relevant_missed=c_end & ~c.matched,
            **classes,
        )
        self._count_causes(np.stack([classes[c] for c in ALERT_CLASSES]))

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
        if any(e.live.any() for e in (other._warnings, other._threats, other._relevant)):
            raise InputError("merge needs a finished instance: call finish(t) on it first")
        self._counts += other._counts
        self._driven_s += other._driven_s
        self._distance_m += other._distance_m
        self._confusion += other._confusion
        self._lead_time.merge(other._lead_time)
        self._relevant_lead_time.merge(other._relevant_lead_time)
        self._ttc_matched.merge(other._ttc_matched)
        self._ttc_all.merge(other._ttc_all)
        self._by_cause += other._by_cause
        self._causes_given |= other._causes_given

    def per_pair(self) -> dict[str, np.ndarray]:
        """Per-pair figures so far (complete after :meth:`finish`), arrays ``(N,)``.

        Keys: the event counts (``warnings``, ``false_alarms``, ``threats``, ``detected``,
        ``missed``, ``collisions``, the alert classes ``crash_relevant``, ``nuisance``,
        ``sensing_false``, the crash-relevant situations ``relevant``, ``relevant_detected``,
        ``relevant_missed`` and the oracle's threats that met one, ``threats_relevant``),
        ``hours`` and ``km`` of active exposure,
        ``lead_time_sum_s``, the sum of the lead times [s] of the pair's detected threats,
        and the nuisance and sensing-false warnings by cause (:data:`CAUSE_COUNTS`; zeros
        where no causes were given).
        """
        return {
            **{name: c.copy() for name, c in zip(COUNTS, self._pair_counts, strict=True)},
            **{
                name: self._pair_causes[k, :, j].copy()
                for name, (k, j) in zip(CAUSE_COUNTS, _CAUSE_CELLS, strict=True)
            },  # fmt: skip
            "hours": self._pair_driven_s / 3600.0,
            "km": self._pair_distance_m / 1000.0,
            "lead_time_sum_s": self._pair_lead_time_s.copy(),
        }

    def summary(self, confidence: float = 0.95) -> FCWSummary:
        """The metrics so far (complete after :meth:`finish`), intervals at ``confidence``."""
        count = dict(zip(COUNTS, self._counts.tolist(), strict=True))
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
            relevant_lead_time=self._relevant_lead_time.distribution(),
            ttc_at_warning=self._ttc_matched.distribution(),
            ttc_at_any_warning=self._ttc_all.distribution(),
            confusion=tuple(tuple(row) for row in self._confusion.tolist()),
            by_cause=(
                {
                    c: dict(zip(CAUSES, row, strict=True))
                    for c, row in zip(ALERT_CLASSES, self._by_cause.tolist(), strict=True)
                }
                if self._causes_given
                else None
            ),
            per_pair=self.per_pair(),
            histograms=copy.deepcopy(
                dict(
                    zip(
                        DISTRIBUTIONS,
                        (
                            self._lead_time,
                            self._relevant_lead_time,
                            self._ttc_matched,
                            self._ttc_all,
                        ),
                        strict=True,
                    )
                )
            ),  # fmt: skip
        )
