"""Streaming FCW metrics: known counts on synthetic level sequences, and an offline reference."""

from __future__ import annotations

import json
import math
import pickle

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.metrics.events import FCWMetrics
from acc_fusion.metrics.stats import poisson_rate_interval

DT = 0.1


def levels(*patterns: str) -> np.ndarray:
    """(steps, N) int8 levels from one string per pair, e.g. ``"0012210"``."""
    return np.array([[int(c) for c in p] for p in patterns], dtype=np.int8).T


def at(n_steps: int, spans: dict[int, tuple[float, float]], level: int = 1) -> str:
    """A pattern of ``n_steps`` steps with ``level`` on over [start, end) seconds per span."""
    out = ["0"] * n_steps
    for start, end in spans.values():
        for k in range(round(start / DT), round(end / DT)):
            out[k] = str(level)
    return "".join(out)


def run(
    system,
    oracle,
    *,
    tolerance=1.0,
    warn_level=1,
    active=None,
    ttc=None,
    speed=None,
    collided=None,
    relevant=None,
    finish=True,
    metrics=None,
):
    """Feed (steps, N) arrays at t = k * DT and finish at the end of the last step."""
    steps, n = system.shape
    m = metrics or FCWMetrics(n, DT, tolerance=tolerance, warn_level=warn_level)
    for k in range(steps):
        m.update(
            k * DT,
            system[k],
            oracle[k],
            np.full(n, 5.0) if ttc is None else ttc[k],
            np.full(n, 20.0) if speed is None else speed[k],
            np.ones(n, bool) if active is None else active[k],
            None if collided is None else collided[k],
            None if relevant is None else relevant[k],
        )
    if finish:
        m.finish(steps * DT)
    return m


def counts(m: FCWMetrics) -> tuple[int, ...]:
    s = m.summary()
    return s.warnings, s.false_alarms, s.threats, s.detected, s.missed


def test_warning_without_threat_is_one_false_alarm():
    m = run(levels("0001110000000000"), levels("0" * 16))
    assert counts(m) == (1, 1, 0, 0, 0)


def test_threat_without_warning_is_one_miss():
    m = run(levels("0" * 16), levels("0001111000000000"))
    assert counts(m) == (0, 0, 1, 0, 1)


@pytest.mark.parametrize(
    "warning, threat, detected, lead",
    [
        ((1.0, 1.2), (1.5, 2.0), True, 0.5),  # 0.5 s before, short: gap 0.3 s
        ((1.0, 3.0), (1.5, 2.0), True, 0.5),  # 0.5 s before, lasting through the threat
        ((1.0, 1.2), (3.0, 3.5), False, None),  # 2 s before: gap 1.8 s > 1 s
        ((1.0, 1.2), (2.2, 2.5), True, 1.2),  # gap exactly the tolerance: matched
        ((1.0, 1.2), (2.3, 2.5), False, None),  # gap tolerance + dt
        ((1.3, 1.4), (1.0, 1.5), True, -0.3),  # late warning inside the threat
        ((2.5, 2.7), (1.0, 1.5), True, -1.5),  # late, gap exactly the tolerance
        ((2.6, 2.7), (1.0, 1.5), False, None),  # too late
        ((1.0, 1.5), (1.0, 1.5), True, 0.0),
    ],
)
def test_one_warning_one_threat(warning, threat, detected, lead):
    m = run(levels(at(40, {0: warning})), levels(at(40, {0: threat})))
    s = m.summary()
    if detected:
        assert counts(m) == (1, 0, 1, 1, 0)
        assert s.lead_time.mean == pytest.approx(lead, abs=1e-9)
        assert abs(s.lead_time.median - lead) <= 0.0100001
    else:
        assert counts(m) == (1, 1, 1, 0, 1)
        assert s.lead_time.count == 0 and math.isnan(s.lead_time.mean)


def test_flicker_within_tolerance_is_one_event_and_leads_from_its_first_onset():
    m = run(levels("0101010000000000000000000000"), levels("0" * 28))
    assert counts(m) == (1, 1, 0, 0, 0)
    # Separated by more than the tolerance: two events.
    m = run(levels("0100000000000000000000100000"), levels("0" * 28))
    assert counts(m) == (2, 2, 0, 0, 0)
    # Warning flicker from 0.1 s, threat at 1.0 s: one detected threat, lead 0.9 s.
    m = run(levels("0101010000000000000000000000"), levels("0000000000111000000000000000"))
    assert counts(m) == (1, 0, 1, 1, 0)
    assert m.summary().lead_time.mean == pytest.approx(0.9)


def test_one_warning_spanning_two_threats():
    m = run(levels(at(80, {0: (1.0, 6.0)})), levels(at(80, {0: (1.5, 2.0), 1: (4.0, 4.5)})))
    s = m.summary()
    assert counts(m) == (1, 0, 2, 2, 0)
    assert s.lead_time.mean == pytest.approx((0.5 + 3.0) / 2)
    assert (s.lead_time.p10, s.lead_time.p90) == pytest.approx((0.505, 3.005), abs=0.0051)


def test_several_pairs_at_once():
    system = levels(
        "00011100000000000000000000000000",  # false alarm
        "00000000000000000000000000000000",  # miss
        "00001111111000000000000000000000",  # detected, lead 0.2 s
        "00000000000011100000000000000000",  # detected late, lead -0.3 s
        "01100000000000000000000000011000",  # FA + detected (lead 0.1 s)
        "00000000000000000000000000000000",  # nothing
    )
    oracle = levels(
        "00000000000000000000000000000000",
        "00000000001111100000000000000000",
        "00000011100000000000000000000000",
        "00000000011111000000000000000000",
        "00000000000000000000000000001100",
        "00000000000000000000000000000000",
    )
    m = run(system, oracle)
    s = m.summary()
    assert counts(m) == (5, 2, 4, 3, 1)
    assert s.lead_time.mean == pytest.approx((0.2 - 0.3 + 0.1) / 3)
    assert s.false_alarm_ratio.value == pytest.approx(2 / 5)
    assert s.miss_rate.value == pytest.approx(1 / 4)


def test_intervals_open_at_finish():
    system = levels("000000000111", "000000000000", "000000001100")
    oracle = levels("000000000000", "000000000111", "000000000000")
    crash = np.zeros((12, 3), bool)
    crash[11, 0] = True
    m = run(system, oracle, collided=crash, finish=False)
    assert counts(m) == (2, 0, 1, 0, 0)  # onsets known, outcomes pending
    m.finish(12 * DT)
    assert counts(m) == (2, 2, 1, 0, 1)
    # Finishing resolves everything: the instance takes a new run from t = 0, in which a
    # warning and a collision at the first step are new ones.
    crash = np.zeros((12, 3), bool)
    crash[0, 0] = True
    run(
        levels("110000000000", "0" * 12, "0" * 12),
        levels(*["0" * 12] * 3),
        collided=crash,
        metrics=m,
    )
    assert counts(m) == (3, 3, 1, 0, 1)
    assert m.summary().collisions == 2


def test_inactive_steps():
    on = np.ones(20, bool)
    gap = on.copy()
    gap[5] = False  # one inactive step inside a warning
    system = levels("00111111100000000000")
    active = gap[:, None]
    m = run(system, levels("0" * 20), active=active)
    assert counts(m) == (1, 1, 0, 0, 0)  # gap dt <= tolerance: one event
    m = run(system, levels("0" * 20), active=active, tolerance=0.05)
    assert counts(m) == (2, 2, 0, 0, 0)  # tolerance below dt: two events
    s = m.summary()
    assert s.hours == pytest.approx(19 * DT / 3600)
    assert s.km == pytest.approx(19 * DT * 20.0 / 1000)
    # An inactive pair's levels, TTC and speed are ignored (NaN allowed).
    off = np.zeros((20, 1), bool)
    nan = np.full((20, 1), np.nan)
    m = run(levels("1" * 20), levels("2" * 20), active=off, ttc=nan, speed=nan)
    s = m.summary()
    assert counts(m) == (0, 0, 0, 0, 0) and s.hours == 0.0 and s.km == 0.0
    assert s.false_alarms_per_hour.hi == math.inf


def test_a_new_vehicle_in_a_pair_does_not_inherit_the_events_of_the_one_before():
    # Pair 0: the first vehicle warns at 0.2-0.5 s and leaves at 0.6 s; a new one takes the
    # slot at 0.7 s and is threatened from 0.8 s, within the tolerance of the old warning.
    # Pair 1 keeps its vehicle, warned and threatened together.
    system = levels("0011100000000000", "0011100000000000")
    oracle = levels("0000000011100000", "0011100000000000")
    active = np.ones((16, 2), bool)
    active[6, 0] = False  # the slot is empty for one step
    kept = run(system, oracle, active=active)
    assert counts(kept) == (2, 0, 2, 2, 0)  # without the reset the two vehicles match
    m = FCWMetrics(2, DT)
    run(system[:7], oracle[:7], active=active[:7], metrics=m, finish=False)
    m.reset(np.array([True, False]))  # the new vehicle's first step
    m.update(0.7, system[7], oracle[7], np.full(2, 5.0), np.full(2, 20.0), active[7])
    assert m.summary().false_alarms == 1  # the old warning: final, and unmatched
    for k in range(8, 16):
        m.update(k * DT, system[k], oracle[k], np.full(2, 5.0), np.full(2, 20.0), active[k])
    m.finish(1.6)
    assert counts(m) == (2, 1, 2, 1, 1)  # the new vehicle's threat is its own: missed
    assert m.per_pair()["false_alarms"].tolist() == [1, 0]
    assert m.summary().hours == kept.summary().hours  # the exposure carries on
    with pytest.raises(InputError, match="pairs must be a boolean array of shape"):
        m.reset(np.array([0, 1]))


def test_collisions_count_once_per_run_of_flags():
    flags = np.zeros((20, 3), bool)
    flags[4, 0] = True  # one pulse
    flags[6:10, 1] = True  # a flag held for 4 steps
    flags[3, 2] = flags[12, 2] = True  # two separate collisions
    m = run(levels(*["0" * 20] * 3), levels(*["0" * 20] * 3), collided=flags)
    assert m.summary().collisions == 4


def test_exposure_and_confusion(rng):
    steps, n = 300, 8
    system = rng.integers(0, 3, (steps, n)).astype(np.int8)
    oracle = rng.integers(0, 3, (steps, n)).astype(np.int8)
    active = rng.random((steps, n)) < 0.8
    speed = rng.uniform(0, 30, (steps, n))
    s = run(system, oracle, active=active, speed=speed).summary()
    expected = np.zeros((3, 3), int)
    np.add.at(expected, (oracle[active], system[active]), 1)
    assert np.array_equal(np.array(s.confusion), expected)
    assert s.hours == pytest.approx(active.sum() * DT / 3600)
    assert s.km == pytest.approx((speed * active).sum() * DT / 1000)


def test_warn_level_two_ignores_cautions():
    system = levels("0011110000000000000000", "0022220000000000000000")
    m = run(system, levels("0" * 22, "0" * 22), warn_level=2)
    assert counts(m) == (1, 1, 0, 0, 0)


def test_ttc_at_warning():
    inf = math.inf
    system = levels("0011000000000000000", "0000110000000000000", "0000000011000000000")
    oracle = levels("0001100000000000000", "0000000000000000000", "0000000000000000000")
    ttc = np.full((19, 3), 9.0)
    ttc[2, 0], ttc[4, 1], ttc[8, 2] = 2.5, inf, 8.0
    s = run(system, oracle, ttc=ttc).summary()
    assert (s.ttc_at_warning.count, s.ttc_at_warning.mean) == (1, pytest.approx(2.5))
    assert (s.ttc_at_any_warning.count, s.ttc_at_any_warning.finite) == (3, 2)
    assert s.ttc_at_any_warning.mean == pytest.approx((2.5 + 8.0) / 2)
    assert s.ttc_at_any_warning.p90 == inf


def random_levels(rng, steps, n, p_switch):
    """Telegraph-like level sequences: runs of random length, so intervals of all sizes."""
    switch = rng.random((steps, n)) < p_switch
    return (np.cumsum(switch, axis=0) % 2 * rng.integers(1, 3, (steps, n))).astype(np.int8)


def reference(system, oracle, active, ttc, warn_level, tolerance, relevant):
    """The definitions evaluated offline on whole sequences (events = merged intervals)."""

    def events(flag):
        out, start = [], None
        for k, f in enumerate(list(flag) + [False]):
            if f and start is None:
                start = k * DT
            elif not f and start is not None:
                if out and start - out[-1][1] <= tolerance + 1e-9:
                    out[-1][1] = k * DT
                else:
                    out.append([start, k * DT])
                start = None
        return out

    def gap(a, b):
        return max(0.0, a[0] - b[1], b[0] - a[1])

    names = "warnings false_alarms threats detected missed crash_relevant nuisance sensing_false"
    names += " relevant relevant_detected relevant_missed threats_relevant"
    result = dict.fromkeys(names.split(), 0)
    leads, relevant_leads, ttc_matched = [], [], []

    def near(a, b):
        return gap(a, b) <= tolerance + 1e-9

    for i in range(system.shape[1]):
        warns = events(active[:, i] & (system[:, i] >= warn_level))
        threats = events(active[:, i] & (oracle[:, i] >= warn_level))
        situations = events(active[:, i] & relevant[:, i])
        match = [[near(w, h) for h in threats] for w in warns]
        result["warnings"] += len(warns)
        result["threats"] += len(threats)
        result["relevant"] += len(situations)
        result["false_alarms"] += sum(not any(row) for row in match)
        for w, row in zip(warns, match, strict=True):
            kind = "nuisance" if any(row) else "sensing_false"
            result["crash_relevant" if any(near(w, c) for c in situations) else kind] += 1
        for j, h in enumerate(threats):
            hits = [w for w, row in zip(warns, match, strict=True) if row[j]]
            result["detected" if hits else "missed"] += 1
            result["threats_relevant"] += any(near(h, c) for c in situations)
            if hits:
                leads.append(h[0] - hits[0][0])
        for c in situations:
            hits = [w for w in warns if near(w, c)]
            result["relevant_detected" if hits else "relevant_missed"] += 1
            if hits:
                relevant_leads.append(c[0] - hits[0][0])
        ttc_matched += [
            ttc[round(w[0] / DT), i] for w, row in zip(warns, match, strict=True) if any(row)
        ]
    return result, leads, relevant_leads, ttc_matched


@pytest.mark.parametrize(
    "tolerance, warn_level, p_switch", [(1.0, 1, 0.08), (0.3, 1, 0.3), (0.0, 2, 0.2)]
)
def test_streaming_equals_offline_reference(rng, tolerance, warn_level, p_switch):
    steps, n = 400, 30
    system = random_levels(rng, steps, n, p_switch)
    oracle = random_levels(rng, steps, n, p_switch)
    active = rng.random((steps, n)) < 0.95
    ttc = rng.uniform(0.5, 10.0, (steps, n))
    relevant = random_levels(rng, steps, n, p_switch / 3) > 0
    s = run(
        system,
        oracle,
        active=active,
        ttc=ttc,
        relevant=relevant,
        tolerance=tolerance,
        warn_level=warn_level,
    ).summary()
    want, leads, relevant_leads, ttc_matched = reference(
        system, oracle, active, ttc, warn_level, tolerance, relevant
    )
    assert want["warnings"] > 20 and want["false_alarms"] > 0 and want["detected"] > 5
    assert min(want[k] for k in ("crash_relevant", "nuisance", "sensing_false")) > 0
    assert want["relevant_missed"] > 0 and want["threats_relevant"] > 0
    assert {k: getattr(s, k) for k in want} == want
    assert s.relevant_lead_time.count == len(relevant_leads)
    assert s.relevant_lead_time.mean == pytest.approx(np.mean(relevant_leads), abs=1e-9)
    assert s.lead_time.count == len(leads)
    assert s.lead_time.mean == pytest.approx(np.mean(leads), abs=1e-9)
    assert abs(s.lead_time.median - np.median(leads)) <= 2 * DT
    assert s.ttc_at_warning.count == len(ttc_matched)
    assert s.ttc_at_warning.mean == pytest.approx(np.mean(ttc_matched), rel=1e-12)


def test_merge_equals_one_instance(rng):
    steps, n, cut = 300, 40, 25
    system = random_levels(rng, steps, n, 0.1)
    oracle = random_levels(rng, steps, n, 0.1)
    active = rng.random((steps, n)) < 0.9
    speed = rng.uniform(0, 30, (steps, n))
    ttc = rng.uniform(0.5, 10.0, (steps, n))
    collided = rng.random((steps, n)) < 0.01
    relevant = rng.random((steps, n)) < 0.05
    arrays = (system, oracle, active, speed, ttc, collided, relevant)

    def part(sl):
        sy, orc, ac, sp, tt, co, re = (a[:, sl] for a in arrays)
        return run(sy, orc, active=ac, speed=sp, ttc=tt, collided=co, relevant=re)

    whole = part(slice(None)).summary().as_dict()
    merged = part(slice(0, cut))
    merged.merge(part(slice(cut, None)))
    got = merged.summary().as_dict()
    for key in ("hours", "km"):
        assert got.pop(key) == pytest.approx(whole.pop(key))
    for key in (
        "false_alarms_per_hour",
        "false_alarms_per_100km",
        "alerts_per_hour",
        "alerts_per_100km",
        "lead_time",
        "relevant_lead_time",
        "ttc_at_warning",
        "ttc_at_any_warning",
    ):
        assert got.pop(key) == pytest.approx(whole.pop(key))
    assert got == whole
    assert whole["warnings"] > 0 and whole["collisions"] > 0


def test_merge_needs_a_finished_compatible_instance():
    m = FCWMetrics(2, DT)
    with pytest.raises(InputError, match="same warn_level and tolerance"):
        m.merge(FCWMetrics(2, DT, tolerance=0.5))
    open_ = run(levels("0011"), levels("0000"), finish=False)
    with pytest.raises(InputError, match="finished instance"):
        m.merge(open_)


def state_nbytes(m: FCWMetrics) -> int:
    parts = [m, m._warnings, m._threats, m._lead_time, m._ttc_matched, m._ttc_all]
    return sum(v.nbytes for p in parts for v in vars(p).values() if isinstance(v, np.ndarray))


def test_memory_does_not_grow(rng):
    n = 50
    m = FCWMetrics(n, DT, tolerance=0.5)
    system = random_levels(rng, 10_000, n, 0.1)
    oracle = random_levels(rng, 10_000, n, 0.1)
    ttc, speed, active = np.full(n, 3.0), np.full(n, 20.0), np.ones(n, bool)
    sizes = []
    for k in range(10_000):
        m.update(k * DT, system[k], oracle[k], ttc, speed, active)
        if k in (99, 9_999):
            sizes.append((state_nbytes(m), len(pickle.dumps(m))))
    assert sizes[0][0] == sizes[1][0]
    assert abs(sizes[0][1] - sizes[1][1]) < 64  # a growing list would add kilobytes
    assert m.summary().warnings > 10_000


def test_false_alarm_rate_interval_and_summary_output():
    system = levels(at(600, {i: (5.0 * i + 1, 5.0 * i + 1.5) for i in range(10)}))
    m = run(system, levels("0" * 600))
    s = m.summary(confidence=0.9)
    assert s.false_alarms == 10
    assert s.hours == pytest.approx(60.0 / 3600) and s.km == pytest.approx(60.0 * 20.0 / 1000)
    fa_h, fa_km = s.false_alarms_per_hour, s.false_alarms_per_100km
    assert (fa_h.lo, fa_h.hi) == poisson_rate_interval(10, s.hours, 0.9)
    assert (fa_km.lo, fa_km.hi) == poisson_rate_interval(10, s.km / 100, 0.9)
    assert fa_h.value == pytest.approx(600.0)
    json.dumps(s.as_dict(), allow_nan=False)
    text = s.format()
    assert "false alarms / h      600 [" in text
    assert "10 false alarms" in text and "90 % intervals" in text


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(n_pairs=0), "n_pairs must be a whole number >= 1"),
        (dict(dt=0.0), r"dt must be in \(0, inf\)"),
        (dict(tolerance=-1.0), r"tolerance must be in \[0, inf\)"),
        (dict(warn_level=3), "warn_level must be 1 .caution. or 2 .imminent."),
    ],
)
def test_bad_config(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        FCWMetrics(**{"n_pairs": 2, "dt": DT, **kwargs})


def test_bad_update_input():
    m = FCWMetrics(2, DT)
    ok = dict(
        system=np.zeros(2, np.int8),
        oracle=np.zeros(2, np.int8),
        ttc=np.full(2, np.inf),
        speed=np.full(2, 10.0),
        active=np.ones(2, bool),
    )
    bad = [
        ({"system": np.zeros(3, np.int8)}, r"system must be an integer array of shape \(2,\)"),
        ({"oracle": np.zeros(2)}, "oracle must be an integer array"),
        ({"system": np.array([0, 3], np.int8)}, r"system must hold levels 0 .none., 1 .caution."),
        ({"ttc": np.array([1.0, np.nan])}, "ttc must be a number >= 0 or inf where active"),
        ({"ttc": np.array([1.0, -1.0])}, "ttc must be >= 0"),
        ({"speed": np.array([1.0, np.inf])}, "speed must be finite"),
        ({"active": np.ones(2)}, "active must be a boolean array"),
    ]
    for change, match in bad:
        with pytest.raises(InputError, match=match):
            m.update(0.0, **{**ok, **change})
    m.update(0.0, **ok)
    with pytest.raises(InputError, match="t must be finite and increase"):
        m.update(0.0, **ok)
    with pytest.raises(InputError, match="t must not be before"):
        m.finish(-1.0)
