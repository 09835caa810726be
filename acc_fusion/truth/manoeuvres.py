r"""The standard FCW/AEB test manoeuvres as speed programs of the ego and up to two other
vehicles (plans), built batched over N runs, and the randomised Monte Carlo suite.

Manoeuvres (:data:`SCENARIOS`)
    =============  ==========================================================================
    name           manoeuvre (default parameters; all overridable, see the params classes)
    =============  ==========================================================================
    nhtsa_lvs      NHTSA FCW test 1, lead vehicle stopped: SV at 45 mph (72.4 km/h) toward a
                   stopped POV
    nhtsa_lvd      NHTSA FCW test 2, lead vehicle decelerating: SV and POV at 45 mph, 30 m
                   apart, the POV brakes at 0.3 g to a stop
    nhtsa_lvm      NHTSA FCW test 3, lead vehicle moving: SV at 45 mph, POV at 20 mph
    ccrs           Euro NCAP Car-to-Car Rear stationary: VUT (10-80 km/h; 50) toward a
                   stationary GVT
    ccrm           Euro NCAP Car-to-Car Rear moving: VUT (30-80 km/h; 50) toward a GVT at
                   20 km/h
    ccrb           Euro NCAP Car-to-Car Rear braking: VUT and GVT at 50 km/h, headway 12 or
                   40 m, the GVT brakes at 2 or 6 m/s² (default: the 2x2 matrix)
    cut_in         a slower vehicle changes into the ego lane at a short gap
    cut_out        the ego follows (and closes on) a lead that changes lane before a collision
                   would happen, revealing the vehicle ahead of it (moving, stopped or none)
    stop_and_go    urban queue: the lead alternately brakes to a stop and pulls away; the ego
                   follows it with the Intelligent Driver Model
    following      steady car following at a safe time headway with mild lead speed
                   fluctuations: no threat, pure false-alarm exposure
    random         Monte Carlo mixture of the above (:func:`random_suite`)
    =============  ==========================================================================

    Sources: NHTSA, *Forward Collision Warning System Confirmation Test*, Office of Vehicle
    Safety, February 2013 (tests 1-3: LVS, LVD, LVM; the set-ups above are the widely cited
    ones, the primary text was not readable here); Euro NCAP, *Test Protocol - AEB Car-to-Car
    systems* (v3.0.2, July 2019; v4.x, 2022-2023): CCRm at 30-80 km/h toward 20 km/h, CCRb at
    50 km/h with 12/40 m and 2/6 m/s², and CCRs toward a stationary target are checked against
    BeamNG's implementation of v3.0.2 (``BeamNG/BeamNG_NCAP_Tests``,
    ``src/beamng_ncap/scenarios.py``, which tests CCRs at 10-50 km/h, the AEB speeds); the
    10-80 km/h span of CCRs (AEB plus FCW speeds) is not verified.  That implementation starts
    the measured test at a TTC of 4 s; the scripts start earlier (``initial_ttc`` = 6 s, or a
    steady phase of ``brake_time`` before the lead brakes) so that a tracker has converged and
    a warning earlier than 4 s can be seen.  Parameters are named as in the protocols (SV/POV
    for NHTSA, VUT/GVT for Euro NCAP), in SI units.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from functools import partial
from typing import Any

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_choice
from acc_fusion.truth.manoeuvre_params import (
    FOLLOWING_DURATION,
    IDM,
    LANE_WIDTH,
    RANDOM_RANGES,
    SETTLE_TIME,
    SLOTS,
    VEHICLE_LENGTH,
    CCRbParams,
    CCRmParams,
    CCRsParams,
    CutInParams,
    CutOutParams,
    FollowingParams,
    LVDParams,
    LVMParams,
    LVSParams,
    ScenarioParams,
    StopAndGoParams,
)


@dataclass(frozen=True)
class _Plan:
    """The script of N runs (S = :data:`SLOTS` other vehicles, K speed segments each)."""

    ego_speed: np.ndarray  # (N,) initial ego speed
    idm: np.ndarray  # (N,) bool: the ego follows the IDM
    time_headway: np.ndarray  # (N,) IDM T [s] (NaN where not IDM)
    desired_speed: np.ndarray  # (N,) IDM v0 [m/s] (NaN where not IDM)
    duration: np.ndarray  # (N,) [s]
    present: np.ndarray  # (N, S) bool
    position: np.ndarray  # (N, S) rear bumper, ego front bumper at 0 [m]
    speed: np.ndarray  # (N, S) [m/s]
    seg_t: np.ndarray  # (N, S, K) segment start [s]
    seg_v: np.ndarray  # (N, S, K) target speed [m/s]
    seg_rate: np.ndarray  # (N, S, K) |acceleration| [m/s²]
    lateral: np.ndarray  # (N, S, 4) lane change: start [s], from [m], to [m], duration [s]


_PLAN_FIELDS = tuple(f.name for f in fields(_Plan))  # the names of _Plan's fields


@dataclass(frozen=True)
class _Vehicle:
    """One other vehicle of a kind's runs: initial gap (inf: absent), speed, speed events."""

    gap: np.ndarray
    speed: np.ndarray
    events: tuple[tuple[np.ndarray, np.ndarray, np.ndarray], ...] = ()  # (t, target, rate)
    lateral: tuple[Any, Any, Any, Any] = (0.0, 0.0, 0.0, 1.0)


@dataclass(frozen=True)
class Draws:
    """``n_runs`` runs of a scenario drawn, not yet started (:meth:`ScenarioSource.draw
    <acc_fusion.truth.scripted.ScenarioSource.draw>`): script, parameters' names and values
    ``(P, n)`` (NaN where a field does not apply to a run's kind), kinds."""

    plan: _Plan
    names: tuple[str, ...]
    params: np.ndarray
    kind: np.ndarray

    @classmethod
    def of(cls, plan: _Plan, runs: dict[str, np.ndarray], kind: np.ndarray) -> Draws:
        """The draws of a manoeuvre's build: its plan, ``{field: (n,) array}`` and kinds."""
        values = np.array([*runs.values()], float).reshape(len(runs), kind.shape[0])
        return cls(plan, tuple(runs), values, kind)

    @property
    def n_runs(self) -> int:
        return int(self.kind.shape[0])

    def take(self, rows: slice | np.ndarray) -> Draws:
        """The runs ``rows`` of these (a slice or an index array)."""
        plan = _Plan(**{name: getattr(self.plan, name)[rows] for name in _PLAN_FIELDS})
        return Draws(plan, self.names, self.params[:, rows], self.kind[rows])

    def table(self) -> RunParams:
        """Their parameters as the :class:`RunParams` of a source (its own array)."""
        return RunParams(self.names, self.params)


class RunParams:
    """The parameters of N runs, ``(P, N)`` under their names (NaN where a field does not
    apply to a run's kind), which the runs started later overwrite: in place, or in a new
    array where a field is new or :meth:`columns` lent the array out."""

    def __init__(self, names: tuple[str, ...], values: np.ndarray) -> None:
        self.names, self.values, self._lent = names, values, False

    def columns(self) -> dict[str, np.ndarray]:
        """``{field: (N,) array}``: views that runs started later leave as they are."""
        self._lent = True
        return dict(zip(self.names, self.values, strict=True))

    def start(self, idx: np.ndarray, draws: Draws) -> None:
        """Write the parameters of ``draws`` into the runs ``idx`` (NaN in a field they lack)."""
        names, values, same = self.names, self.values, draws.names == self.names
        if not same or self._lent:
            names = (*names, *(f for f in draws.names if f not in names))
            values = np.full((len(names), values.shape[1]), np.nan)
            values[: len(self.names)] = self.values
        if same:
            values[:, idx] = draws.params
        else:
            values[:, idx] = np.nan
            values[np.ix_([names.index(f) for f in draws.names], idx)] = draws.params
        self.names, self.values, self._lent = names, values, False


def _plan(ego_speed, vehicles, duration, horizon, idm=None) -> _Plan:
    """Stack the vehicles into a :class:`_Plan`; ``idm`` = (time headway, desired speed)."""
    n = ego_speed.shape[0]
    slots = list(vehicles) + [_Vehicle(np.full(n, np.inf), np.zeros(n))] * (SLOTS - len(vehicles))
    programs = []
    for v in slots:
        columns = [(np.zeros(n), v.speed, np.zeros(n)), *v.events]
        programs.append([np.column_stack([c[i] for c in columns]) for i in range(3)])
    k = max(p[0].shape[1] for p in programs)

    def stack(i: int, fill: float) -> np.ndarray:
        return np.stack([_pad_segments(p[i], k, fill) for p in programs], axis=1)

    present = np.stack([np.isfinite(v.gap) for v in slots], axis=1)
    t_headway, v_desired = (np.full(n, np.nan),) * 2 if idm is None else idm
    return _Plan(
        ego_speed=ego_speed,
        idm=np.full(n, idm is not None),
        time_headway=t_headway,
        desired_speed=v_desired,
        duration=duration if horizon is None else np.full(n, horizon),
        present=present,
        position=np.where(present, np.stack([v.gap for v in slots], axis=1), 0.0),
        speed=np.stack([v.speed for v in slots], axis=1),
        seg_t=stack(0, np.inf),
        seg_v=stack(1, 0.0),
        seg_rate=stack(2, 0.0),
        lateral=np.stack(
            [np.column_stack([np.broadcast_to(x, (n,)) for x in v.lateral]) for v in slots], axis=1
        ),
    )


def _pad_segments(a: np.ndarray, k: int, fill: float) -> np.ndarray:
    """Pad the segment axis (last) of ``a`` to ``k`` entries with ``fill`` (``np.pad``'s
    result without its general machinery, a fifth of an episode's restart); ``a`` itself if
    it has ``k``."""
    if a.shape[-1] == k:
        return a
    out = np.full((*a.shape[:-1], k), fill, dtype=a.dtype)
    out[..., : a.shape[-1]] = a
    return out


def _cycles(start, phases, horizon):
    """Segments repeating ``phases`` [(duration, target, rate), ...] from ``start`` on."""
    durations = np.stack([p[0] for p in phases], axis=-1)  # (n, P)
    period = durations.sum(axis=-1)
    count = int(np.ceil(np.max((horizon - start) / period))) + 1
    offsets = np.cumsum(durations, axis=-1) - durations
    t = (
        start[:, None, None]
        + np.arange(count)[None, :, None] * period[:, None, None]
        + offsets[:, None, :]
    )
    shape = t.shape
    targets = np.broadcast_to(np.stack([p[1] for p in phases], -1)[:, None, :], shape)
    rates = np.broadcast_to(np.stack([p[2] for p in phases], -1)[:, None, :], shape)
    n = start.shape[0]
    return t.reshape(n, -1), targets.reshape(n, -1), rates.reshape(n, -1)


def _approach(ego_speed, lead_speed, initial_ttc, horizon) -> _Plan:
    """Constant-speed ego toward a slower constant-speed lead, starting at ``initial_ttc``."""
    lead = _Vehicle(initial_ttc * (ego_speed - lead_speed), lead_speed)
    return _plan(ego_speed, [lead], initial_ttc + SETTLE_TIME, horizon)


def _closing(ego_speed, lead_speed, ego_field: str, lead_field: str) -> None:
    """Reject a lead that is not slower than the subject vehicle."""
    if np.any(ego_speed <= lead_speed):
        raise ConfigError(
            f"{ego_field} must exceed {lead_field} (the subject vehicle must close in), "
            f"got {ego_speed[ego_speed <= lead_speed][0]:g} <= "
            f"{lead_speed[ego_speed <= lead_speed][0]:g} m/s"
        )


def _braking_lead(speed, headway, decel, brake_time, horizon) -> _Plan:
    """Ego and lead at ``speed``; the lead brakes to a stop at ``brake_time``."""
    lead = _Vehicle(headway, speed, events=((brake_time, np.zeros_like(speed), decel),))
    return _plan(speed, [lead], brake_time + speed / decel + SETTLE_TIME, horizon)


def _lvs(p, rng, horizon):
    return _approach(p["sv_speed"], np.zeros_like(p["sv_speed"]), p["initial_ttc"], horizon)


def _lvd(p, rng, horizon):
    return _braking_lead(p["speed"], p["headway"], p["pov_decel"], p["brake_time"], horizon)


def _lvm(p, rng, horizon):
    _closing(p["sv_speed"], p["pov_speed"], "nhtsa_lvm.sv_speed", "nhtsa_lvm.pov_speed")
    return _approach(p["sv_speed"], p["pov_speed"], p["initial_ttc"], horizon)


def _ccrs(p, rng, horizon):
    return _approach(p["vut_speed"], np.zeros_like(p["vut_speed"]), p["initial_ttc"], horizon)


def _ccrm(p, rng, horizon):
    _closing(p["vut_speed"], p["gvt_speed"], "ccrm.vut_speed", "ccrm.gvt_speed")
    return _approach(p["vut_speed"], p["gvt_speed"], p["initial_ttc"], horizon)


def _ccrb(p, rng, horizon):
    return _braking_lead(p["speed"], p["headway"], p["gvt_decel"], p["brake_time"], horizon)


def _cut_in(p, rng, horizon):
    v, vc, gap = p["ego_speed"], p["cut_in_speed"], p["cut_in_gap"]
    if np.any(p["lead_gap"] <= gap + VEHICLE_LENGTH):
        raise ConfigError(
            f"cut_in.lead_gap must exceed cut_in.cut_in_gap + {VEHICLE_LENGTH:g} m (the far "
            "lead is ahead of the merging vehicle)"
        )
    t_end = p["lane_change_time"] + p["lane_change_duration"]
    far = _Vehicle(p["lead_gap"], v)
    lane_change = (p["lane_change_time"], LANE_WIDTH, 0.0, p["lane_change_duration"])
    cutter = _Vehicle(gap + (v - vc) * t_end, vc, lateral=lane_change)
    return _plan(v, [far, cutter], t_end + 2 * SETTLE_TIME, horizon)


def _cut_out(p, rng, horizon):
    v, vl, vr = p["ego_speed"], p["lead_speed"], p["revealed_speed"]
    t_end = p["lane_change_time"] + p["lane_change_duration"]
    revealed_start = p["revealed_gap"] + (v - vr) * t_end
    lead_front = p["lead_gap"] + VEHICLE_LENGTH
    if np.any(
        (lead_front >= revealed_start) | (lead_front - (v - vl) * t_end >= p["revealed_gap"])
    ):
        raise ConfigError(
            "cut_out.revealed_gap must keep the revealed vehicle ahead of the lead until the "
            "lead's lane change ends"
        )
    lane_change = (p["lane_change_time"], 0.0, LANE_WIDTH, p["lane_change_duration"])
    lead = _Vehicle(p["lead_gap"], vl, lateral=lane_change)
    return _plan(v, [lead, _Vehicle(revealed_start, vr)], t_end + 2 * SETTLE_TIME, horizon)


def _idm_gap(lead_speed, top_speed, p, label: str) -> np.ndarray:
    """IDM equilibrium gap behind a lead at ``lead_speed``; the ego must want to go faster."""
    if np.any(p["ego_desired_speed"] <= top_speed):
        raise ConfigError(f"{label}.ego_desired_speed must exceed the lead's highest speed")
    return IDM.equilibrium_gap(lead_speed, p["time_headway"], p["ego_desired_speed"])


def _following_duration(shape, horizon) -> np.ndarray:
    return np.full(shape, FOLLOWING_DURATION if horizon is None else horizon)


def _stop_and_go(p, rng, horizon):
    vc, b, a = p["cruise_speed"], p["lead_decel"], p["lead_accel"]
    gap = _idm_gap(vc, vc, p, "stop_and_go")
    duration = _following_duration(vc.shape, horizon)
    first_stop = rng.uniform(0.0, 1.0, vc.shape) * p["cruise_time"]
    phases = [(vc / b + p["stop_time"], np.zeros_like(vc), b), (vc / a + p["cruise_time"], vc, a)]
    lead = _Vehicle(gap, vc, events=(_cycles(first_stop, phases, duration),))
    return _plan(vc, [lead], duration, horizon, idm=(p["time_headway"], p["ego_desired_speed"]))


def _following(p, rng, horizon):
    v, amp, rate = p["lead_speed"], p["speed_amplitude"], p["fluctuation_accel"]
    gap = _idm_gap(v, v + amp, p, "following")
    duration = _following_duration(v.shape, horizon)
    half = p["fluctuation_period"] / 2
    delay = rng.uniform(0.0, 1.0, v.shape) * half
    swing = _cycles(delay, [(half, v + amp, rate), (half, v - amp, rate)], duration)
    lead = _Vehicle(gap, v, events=(swing,))
    return _plan(v, [lead], duration, horizon, idm=(p["time_headway"], p["ego_desired_speed"]))


#: The standard manoeuvres: name -> (parameters class, per-run builder).
_BUILDERS: dict[str, tuple[type[ScenarioParams], Callable[..., _Plan]]] = {
    "nhtsa_lvs": (LVSParams, _lvs),
    "nhtsa_lvd": (LVDParams, _lvd),
    "nhtsa_lvm": (LVMParams, _lvm),
    "ccrs": (CCRsParams, _ccrs),
    "ccrm": (CCRmParams, _ccrm),
    "ccrb": (CCRbParams, _ccrb),
    "cut_in": (CutInParams, _cut_in),
    "cut_out": (CutOutParams, _cut_out),
    "stop_and_go": (StopAndGoParams, _stop_and_go),
    "following": (FollowingParams, _following),
}


#: Names of the standard (non-random) manoeuvres.
STANDARD: tuple[str, ...] = tuple(_BUILDERS)


@dataclass(frozen=True)
class RandomSuiteParams:
    """Parameters of the ``random`` mixture (:func:`random_suite`).

    Attributes:
        kinds: the manoeuvres to mix, each drawn with equal probability (a name listed twice is
            drawn twice as often); default: all of :data:`STANDARD`.
    """

    kinds: tuple[str, ...] = STANDARD

    def __post_init__(self) -> None:
        kinds = (self.kinds,) if isinstance(self.kinds, str) else tuple(self.kinds)
        if not kinds:
            raise ConfigError("random.kinds must name at least one of " + ", ".join(STANDARD))
        for kind in kinds:
            check_choice("random.kinds", kind, STANDARD)
        object.__setattr__(self, "kinds", kinds)


@dataclass(frozen=True)
class Manoeuvre:
    """A registry entry: its parameters class and ``build(params, n, rng, horizon)``."""

    params: type
    build: Callable[..., tuple[_Plan, dict[str, np.ndarray], np.ndarray]]


def _build_one(name: str, params: ScenarioParams, n: int, rng, horizon):
    runs = params.grid(n)
    return _BUILDERS[name][1](runs, rng, horizon), runs, np.full(n, name)


def _build_random(params: RandomSuiteParams, n: int, rng, horizon):
    kinds = np.asarray(params.kinds)[rng.integers(len(params.kinds), size=n)]
    parts, runs = [], {}
    for name, (cls, build) in _BUILDERS.items():
        ranges = RANDOM_RANGES[name]
        drawn = {f: rng.uniform(lo, hi, size=n) for f, (lo, hi, _, _) in ranges.items()}
        idx = np.flatnonzero(kinds == name)
        if idx.size:
            p = {**cls().grid(idx.size), **{f: a[idx] for f, a in drawn.items()}}
            parts.append((idx, build(p, rng, horizon)))
            for f, a in p.items():
                runs.setdefault(f, np.full(n, np.nan))[idx] = a
    return _merge(parts, n), runs, kinds


def _merge(parts: list[tuple[np.ndarray, _Plan]], n: int) -> _Plan:
    """One plan from the plans of disjoint sets of runs (speed programs padded to equal K)."""
    k = max(plan.seg_t.shape[-1] for _, plan in parts)
    merged = {}
    for name in _PLAN_FIELDS:
        arrays = [_padded(name, getattr(plan, name), k) for _, plan in parts]
        out = np.empty((n, *arrays[0].shape[1:]), dtype=arrays[0].dtype)
        for (idx, _), a in zip(parts, arrays, strict=True):
            out[idx] = a
        merged[name] = out
    return _Plan(**merged)


def _merge_into(plan: _Plan, idx: np.ndarray, sub: _Plan) -> _Plan | None:
    """``plan`` with its runs ``idx`` replaced by ``sub``'s, written into ``plan``'s arrays
    (which must be its own) except ``duration`` (a new array: it is handed out); ``None``
    when ``sub``'s speed programs are longer than ``plan``'s or a dtype would change."""
    k = plan.seg_t.shape[-1]
    pairs = [(name, getattr(plan, name), getattr(sub, name)) for name in _PLAN_FIELDS]
    if sub.seg_t.shape[-1] > k or any(np.result_type(a, b) != a.dtype for _, a, b in pairs):
        return None
    for name, a, b in pairs:
        if name != "duration":
            a[idx] = _padded(name, b, k)
    duration = plan.duration.copy()
    duration[idx] = sub.duration
    return replace(plan, duration=duration)


def _padded(name: str, a: np.ndarray, k: int) -> np.ndarray:
    """Field ``name`` of a plan with its speed programs padded to ``k`` segments (segments
    that never start: at ``inf``, to speed 0 at rate 0)."""
    if not name.startswith("seg_"):
        return a
    return _pad_segments(a, k, np.inf if name == "seg_t" else 0.0)


#: Registry of the manoeuvres: name -> :class:`Manoeuvre`.
SCENARIOS: dict[str, Manoeuvre] = {
    **{name: Manoeuvre(cls, partial(_build_one, name)) for name, (cls, _) in _BUILDERS.items()},
    "random": Manoeuvre(RandomSuiteParams, _build_random),
}


def _ranges_table() -> str:
    """The RST table of :data:`RANDOM_RANGES` appended to :func:`random_suite`'s docstring."""
    rows = [("type", "parameter", "range", "unit", "why")]
    for kind, ranges in RANDOM_RANGES.items():
        for field_name, (lo, hi, unit, why) in ranges.items():
            rows.append((kind, field_name, f"{lo:.4g} - {hi:.4g}", unit, why))
    widths = [max(len(r[i]) for r in rows) for i in range(5)]
    rule = "    " + "  ".join("=" * w for w in widths)
    lines = [
        "    " + "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
        for r in rows
    ]
    return "\n".join([rule, lines[0], rule, *lines[1:], rule, ""])
