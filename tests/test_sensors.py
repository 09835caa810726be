"""Tests of the sensor models (acc_fusion.sensors.sensor) and the fault injection
(acc_fusion.sensors.faults)."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.sensors.faults import FAULT_KINDS, Fault
from acc_fusion.sensors.sensor import InfraredSensor, RadarSensor, Sensor
from acc_fusion.sensors.spec import infrared_spec, radar_spec
from acc_fusion.truth.frame import TruthFrame

DT = 0.05
EGO = 25.0
LEAD = 20.0


def frame(t, n, gap=50.0, *, leader=True, lateral=0.0, ego_speed=EGO):
    """A frame of ``n`` pairs; scalars broadcast, ``leader`` may be a bool array."""
    gap = np.broadcast_to(np.asarray(gap, dtype=float), (n,)).copy()
    has = np.broadcast_to(np.asarray(leader, dtype=bool), (n,))
    gap[~has] = np.nan
    return TruthFrame(
        t=t,
        ego_speed=np.full(n, ego_speed),
        ego_accel=np.zeros(n),
        gap=gap,
        lead_speed=np.where(has, LEAD, np.nan),
        lead_accel=np.where(has, 0.0, np.nan),
        leader_id=np.where(has, np.arange(n), -1),
        lateral_offset=np.broadcast_to(np.asarray(lateral, dtype=float), (n,)).copy(),
    )


def run(sensor, n, steps, **kw):
    """Measurements of ``steps`` frames, times accumulated as a simulator would (t += DT)."""
    out, t = [], 0.0
    for _ in range(steps):
        out.append(sensor.measure(frame(t, n, **kw)))
        t += DT
    return out


def sure(spec_fn=radar_spec, **kw):
    """A spec that always detects a visible target."""
    return spec_fn(detection_prob=1.0, **kw)


# --- specs and defaults ------------------------------------------------------------------


def test_default_specs_are_documented_values():
    radar, ir = radar_spec(), infrared_spec()
    assert (radar.name, radar.rate_hz, ir.name, ir.rate_hz) == ("radar", 20.0, "infrared", 10.0)
    assert radar.range_std_quadratic == 0.0
    # Stein et al. 2003: q = sigma_px / (f_px H) with f ~ 686 px, H = 1.2 m, sigma = 1 px.
    assert ir.range_std_quadratic == pytest.approx(1.21e-3, rel=0.01)
    assert ir.range_noise_std(np.array([0.0, 90.0])) == pytest.approx([0.3, 0.3 + 9.84], rel=0.01)
    assert radar_spec(range_std=0.5).range_std == 0.5


def test_spec_fields_from_config_types_are_normalised():
    spec = radar_spec(rate_hz=20, ghost_range=[10, 30])
    assert isinstance(spec.rate_hz, float)
    assert spec.ghost_range == (10.0, 30.0)


def test_subclasses_use_their_default_spec():
    assert RadarSensor().spec == radar_spec()
    assert InfraredSensor().spec == infrared_spec()
    custom = radar_spec(max_range=150.0)
    assert RadarSensor(custom).spec is custom


# --- noise, limits, detection ------------------------------------------------------------


def test_radar_noise_std_and_declared_covariance():
    n = 40_000
    m = RadarSensor(sure(), seed=1).measure(frame(0.0, n, gap=60.0))
    assert m.valid.all() and m.z.shape == (n, 2) and m.r.shape == (n, 2, 2)
    err = m.z - [60.0, LEAD - EGO]
    # Sample std of n normals has relative std 1/sqrt(2n) = 0.35 %; allow 2 %.
    assert err.std(axis=0) == pytest.approx([0.25, 0.12], rel=0.02)
    assert np.all(np.abs(err.mean(axis=0)) < 4 * np.array([0.25, 0.12]) / math.sqrt(n))
    np.testing.assert_allclose(m.r, np.broadcast_to(np.diag([0.25**2, 0.12**2]), (n, 2, 2)))


def test_infrared_range_noise_grows_with_range():
    n = 30_000
    gaps = np.repeat([10.0, 50.0, 90.0], n // 3)
    spec = sure(infrared_spec)
    m = InfraredSensor(spec, seed=2).measure(frame(0.0, n, gap=gaps))
    err = (m.z[:, 0] - gaps).reshape(3, -1)
    expected = spec.range_noise_std(np.array([10.0, 50.0, 90.0]))
    assert err.std(axis=1) == pytest.approx(expected, rel=0.03)
    assert np.all(np.diff(err.std(axis=1)) > 0)
    assert m.z[:, 1].std() == pytest.approx(0.5, rel=0.03)
    # Declared R follows the *measured* range: the sensor does not know the truth.
    np.testing.assert_allclose(m.r[:, 0, 0], spec.range_noise_std(m.z[:, 0]) ** 2)


def test_range_and_fov_limits():
    half = math.radians(15.0)  # radar: 30 deg full FOV
    gap = np.array([0.4, 0.6, 249.0, 251.0, 50.0, 50.0, 50.0])
    lateral = np.array(
        [
            0.0,
            0.0,
            0.0,
            0.0,
            50 * math.tan(half - 0.01),
            50 * math.tan(half + 0.01),
            -50 * math.tan(half + 0.01),
        ]
    )
    m = RadarSensor(sure(), seed=3).measure(frame(0.0, 7, gap=gap, lateral=lateral))
    np.testing.assert_array_equal(m.valid, [False, True, True, False, True, False, False])
    assert np.isnan(m.z[~m.valid]).all()
    np.testing.assert_array_equal(m.r[~m.valid], np.broadcast_to(np.eye(2), (4, 2, 2)))


def test_detection_probability():
    n = 40_000
    m = RadarSensor(seed=4).measure(frame(0.0, n))
    p = 0.98
    assert abs(m.valid.mean() - p) < 4 * math.sqrt(p * (1 - p) / n)
    m0 = RadarSensor(radar_spec(detection_prob=0.0), seed=4).measure(frame(0.0, n))
    assert not m0.valid.any()


def test_no_leader_no_report():
    leader = np.array([True, False, True, False])
    m = RadarSensor(sure(), seed=5).measure(frame(0.0, 4, leader=leader))
    np.testing.assert_array_equal(m.valid, leader)
    assert np.isnan(m.z[~leader]).all() and not m.ghost.any()


# --- timing ------------------------------------------------------------------------------


def test_asynchronous_rates_at_20hz_step():
    radar = run(RadarSensor(sure(), seed=6), 3, 20)
    ir = run(InfraredSensor(sure(infrared_spec), seed=6), 3, 20)
    assert all(m.valid.all() for m in radar)
    np.testing.assert_array_equal([m.valid.all() for m in ir], [k % 2 == 0 for k in range(20)])
    assert not any(m.valid.any() for m in ir[1::2])
    assert [m.t for m in ir] == pytest.approx([k * DT for k in range(20)])


def test_phase_offsets_the_sample_times():
    ir = run(InfraredSensor(sure(infrared_spec, phase=0.05), seed=7), 2, 10)
    np.testing.assert_array_equal([m.valid.all() for m in ir], [k % 2 == 1 for k in range(10)])


def test_coarse_step_reports_once_per_frame():
    radar = RadarSensor(sure(), seed=8)  # 20 Hz sampled by 0.1 s frames
    assert all(radar.measure(frame(0.1 * k, 2)).valid.all() for k in range(5))


# --- randomness ---------------------------------------------------------------------------


def test_same_seed_same_measurements_and_reset():
    spec = radar_spec(ghost_rate=1.0)
    faults = [Fault("spikes", 0.2, magnitude=5.0, probability=0.5)]
    leader = np.arange(50) % 3 > 0

    def record(sensor):
        return run(sensor, 50, 10, leader=leader)

    def assert_same(ms_a, ms_b):
        for ma, mb in zip(ms_a, ms_b, strict=True):
            for name in ("z", "r", "valid", "ghost"):
                np.testing.assert_array_equal(getattr(ma, name), getattr(mb, name))

    a = record(Sensor(spec, faults, seed=9))
    sensor = Sensor(spec, faults, seed=9)
    assert_same(record(sensor), a)
    sensor.reset(seed=9)
    assert_same(record(sensor), a)
    sensor.reset()  # no seed: the streams continue, fresh noise
    assert not np.array_equal(record(sensor)[0].z, a[0].z, equal_nan=True)
    other = record(Sensor(spec, faults, seed=10))
    assert not np.array_equal(other[0].z, a[0].z, equal_nan=True)


def test_one_pairs_visibility_does_not_change_other_pairs_noise():
    n = 6
    visible = run(RadarSensor(seed=11), n, 5)
    leader = np.array([False, True, True, True, True, True])
    hidden = run(RadarSensor(seed=11), n, 5, leader=leader, gap=[300.0, 50, 50, 50, 50, 50])
    for mv, mh in zip(visible, hidden, strict=True):
        assert not mh.valid[0]
        np.testing.assert_array_equal(mv.z[1:], mh.z[1:])


def test_generator_seed_is_accepted():
    m = RadarSensor(seed=np.random.default_rng(12)).measure(frame(0.0, 3))
    assert m.z.shape == (3, 2)


# --- faults -------------------------------------------------------------------------------

WINDOW = (0.3, 0.6)  # frames 6..11 at DT = 0.05


def in_window(m):
    return WINDOW[0] <= m.t + 1e-12 < WINDOW[1]


def nominal_and_faulty(fault, n=2000, steps=16, spec=None):
    spec = spec or sure()
    return run(Sensor(spec, seed=13), n, steps), run(Sensor(spec, [fault], seed=13), n, steps)


def test_dropout():
    clean, faulty = nominal_and_faulty(Fault("dropout", *WINDOW))
    for mc, mf in zip(clean, faulty, strict=True):
        if in_window(mf):
            assert not mf.valid.any() and np.isnan(mf.z).all()
        else:
            np.testing.assert_array_equal(mf.z, mc.z)


def test_stuck_repeats_last_report_before_start():
    clean, faulty = nominal_and_faulty(Fault("stuck", *WINDOW))
    before = faulty[5]  # last frame before 0.3 s
    for mc, mf in zip(clean, faulty, strict=True):
        if in_window(mf):
            assert mf.valid.all()
            np.testing.assert_array_equal(mf.z, before.z)
            np.testing.assert_array_equal(mf.r, before.r)
        else:
            np.testing.assert_array_equal(mf.z, mc.z)


def test_stuck_holds_each_pairs_last_valid_report():
    leader = np.arange(300) % 4 > 0  # every fourth pair never has a target
    spec = radar_spec(detection_prob=0.5)  # many pairs miss the frame just before start
    ms = run(Sensor(spec, [Fault("stuck", *WINDOW)], seed=14), 300, 10, leader=leader)
    last = np.full((300, 2), np.nan)
    for m in ms[:6]:
        last[m.valid] = m.z[m.valid]
    assert (~ms[5].valid & leader).any()
    for m in ms[6:]:
        np.testing.assert_array_equal(m.valid, ~np.isnan(last[:, 0]))
        np.testing.assert_array_equal(m.z, last)


def test_bias():
    clean, faulty = nominal_and_faulty(Fault("bias", *WINDOW, magnitude=3.0, rate_magnitude=-1.0))
    for mc, mf in zip(clean, faulty, strict=True):
        offset = [3.0, -1.0] if in_window(mf) else [0.0, 0.0]
        np.testing.assert_allclose(mf.z - mc.z, np.broadcast_to(offset, mc.z.shape), atol=1e-12)


def test_spikes():
    fault = Fault("spikes", *WINDOW, magnitude=10.0, rate_magnitude=2.0, probability=0.3)
    clean, faulty = nominal_and_faulty(fault)
    hits = []
    for mc, mf in zip(clean, faulty, strict=True):
        d = mf.z - mc.z
        if not in_window(mf):
            np.testing.assert_array_equal(d, 0.0)
            continue
        hit = d[:, 0] != 0
        assert np.all((np.abs(d[hit, 0]) >= 10.0) & (np.abs(d[hit, 0]) <= 20.0))
        assert np.all((np.abs(d[hit, 1]) >= 2.0) & (np.abs(d[hit, 1]) <= 4.0))
        assert np.all(d[~hit] == 0.0)
        hits.append(hit)
    hits = np.concatenate(hits)
    assert abs(hits.mean() - 0.3) < 4 * math.sqrt(0.3 * 0.7 / hits.size)
    signs = np.sign(
        np.concatenate([(mf.z - mc.z)[:, 0] for mc, mf in zip(clean, faulty, strict=True)])
    )
    assert abs((signs > 0).sum() - (signs < 0).sum()) < 4 * math.sqrt(hits.sum())


def test_noise_burst_inflates_noise_but_not_declared_r():
    clean, faulty = nominal_and_faulty(Fault("noise_burst", *WINDOW, magnitude=4.0), n=20_000)
    for mc, mf in zip(clean, faulty, strict=True):
        np.testing.assert_array_equal(mf.r[:, 1, 1], mc.r[:, 1, 1])
        np.testing.assert_allclose(mf.r[:, 0, 0], 0.25**2)
        if in_window(mf):
            err = mf.z - [50.0, LEAD - EGO]
            assert err.std(axis=0) == pytest.approx([1.0, 0.48], rel=0.03)
        else:
            np.testing.assert_array_equal(mf.z, mc.z)


def test_fault_window_is_half_open():
    fault = Fault("dropout", 1.0, 2.0)
    assert [fault.active(t) for t in (0.99, 1.0, 1.99, 2.0)] == [False, True, True, False]
    assert Fault("bias", 0.0).active(1e9)


# --- clutter ------------------------------------------------------------------------------


def ghost_spec(**kw):
    return sure(**{"ghost_rate": 1.0, "ghost_duration": (0.5, 2.0), **kw})


def test_ghosts_appear_without_leader_and_close_at_ego_speed():
    n = 2000
    # Spawned at 100..120 m, a ghost stays in view for its whole life (<= 2 s at 25 m/s).
    ms = run(Sensor(ghost_spec(ghost_range=(100.0, 120.0)), seed=15), n, 80, leader=False)
    ghost = np.array([m.ghost for m in ms])
    np.testing.assert_array_equal(ghost, [m.valid for m in ms])  # no leader: only ghosts
    # One ghost slot per pair: busy fraction lambda*D/(1+lambda*D) = 1.25/2.25 (M/G/1/1).
    assert ghost[40:].mean() == pytest.approx(1.25 / 2.25, abs=0.025)
    rates = np.concatenate([m.z[m.ghost, 1] for m in ms])
    assert rates.mean() == pytest.approx(-EGO, abs=0.01)
    assert rates.std() == pytest.approx(0.12, rel=0.05)
    # A stationary object's range falls by ego_speed * dt per frame.
    steps = np.concatenate(
        [(b.z[:, 0] - a.z[:, 0])[a.ghost & b.ghost] for a, b in zip(ms[:-1], ms[1:], strict=True)]
    )
    assert np.median(steps) == pytest.approx(-EGO * DT, abs=0.02)
    ranges = np.concatenate([m.z[m.ghost, 0] for m in ms])
    assert ranges.max() < 121.5 and ranges.min() > 100.0 - 2.0 * EGO - 1.5


def test_ghost_replaces_target_only_when_closer():
    # Ghosts spawn at 60..120 m and live <= 1 s at 25 m/s: they never come closer than 35 m.
    spec = ghost_spec(ghost_range=(60.0, 120.0), ghost_duration=(0.5, 1.0))
    near = run(Sensor(spec, seed=16), 500, 40, gap=30.0)
    assert all(m.valid.all() and not m.ghost.any() for m in near)
    far = run(Sensor(spec, seed=16), 500, 40, gap=200.0)
    assert any(m.ghost.any() for m in far)
    for m in far:
        assert np.all(m.z[m.ghost, 0] < 125.0)
        assert np.all(np.abs(m.z[~m.ghost, 0] - 200.0) < 2.0)


def test_ghosts_off_by_default():
    assert not any(m.ghost.any() for m in run(RadarSensor(seed=17), 500, 40, leader=False))


# --- bad input ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("override", "field"),
    [
        ({"range_std": -0.1}, "radar.range_std"),
        ({"range_std": 0.0}, "radar.range_std"),
        ({"range_std_quadratic": -1e-3}, "radar.range_std_quadratic"),
        ({"range_rate_std": float("nan")}, "radar.range_rate_std"),
        ({"rate_hz": 0.0}, "radar.rate_hz"),
        ({"min_range": -1.0}, "radar.min_range"),
        ({"min_range": 300.0}, "radar.max_range"),
        ({"max_range": float("inf")}, "radar.max_range"),
        ({"fov_deg": 0.0}, "radar.fov_deg"),
        ({"fov_deg": 400.0}, "radar.fov_deg"),
        ({"detection_prob": 1.5}, "radar.detection_prob"),
        ({"phase": -0.1}, "radar.phase"),
        ({"ghost_rate": -1.0}, "radar.ghost_rate"),
        ({"ghost_range": (50.0, 10.0)}, "radar.ghost_range[1]"),
        ({"ghost_range": (-5.0, 10.0)}, "radar.ghost_range[0]"),
        ({"ghost_range": 30.0}, "radar.ghost_range"),
        ({"ghost_duration": (0.0, 1.0)}, "radar.ghost_duration[0]"),
        ({"range_std": "big"}, "radar.range_std"),
        ({"colour": "red"}, "'colour'"),
    ],
)
def test_bad_spec_raises_config_error_naming_the_field(override, field):
    with pytest.raises(ConfigError) as err:
        radar_spec(**override)
    assert field in str(err.value) and "\n" not in str(err.value)


def test_bad_sensor_name():
    with pytest.raises(ConfigError, match="name"):
        radar_spec(name="")


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"kind": "melt", "start": 0.0}, "fault.kind"),
        ({"kind": "bias", "start": -1.0}, "fault.start"),
        ({"kind": "bias", "start": 2.0, "end": 2.0}, "fault.end"),
        ({"kind": "bias", "start": 0.0, "magnitude": float("inf")}, "fault.magnitude"),
        ({"kind": "spikes", "start": 0.0, "magnitude": -1.0}, "fault.magnitude"),
        ({"kind": "spikes", "start": 0.0, "rate_magnitude": -1.0}, "fault.rate_magnitude"),
        ({"kind": "spikes", "start": 0.0, "probability": 1.5}, "fault.probability"),
        ({"kind": "noise_burst", "start": 0.0, "magnitude": 0.5}, "fault.magnitude"),
    ],
)
def test_bad_fault_raises_config_error_naming_the_field(kwargs, field):
    with pytest.raises(ConfigError) as err:
        Fault(**kwargs)
    assert field in str(err.value) and "\n" not in str(err.value)


def test_unknown_fault_kind_lists_the_kinds():
    with pytest.raises(ConfigError) as err:
        Fault("melt", 0.0)
    assert all(kind in str(err.value) for kind in FAULT_KINDS)


def test_bad_sensor_arguments():
    with pytest.raises(ConfigError, match="spec"):
        Sensor({"name": "radar"})
    with pytest.raises(ConfigError, match=r"radar\.faults\[0\]"):
        RadarSensor(faults=["dropout"])
    with pytest.raises(ConfigError, match="seed"):
        RadarSensor(seed=-1)


def test_bad_frames_raise_input_error():
    radar = RadarSensor(seed=18)
    radar.measure(frame(0.0, 4))
    with pytest.raises(InputError, match="pairs"):
        radar.measure(frame(0.05, 5))
    with pytest.raises(InputError, match="frame.t"):
        radar.measure(frame(0.0, 4))
    with pytest.raises(InputError, match="TruthFrame"):
        radar.measure({"t": 0.1})
    radar.reset()
    assert radar.measure(frame(0.0, 5)).z.shape == (5, 2)


# --- speed --------------------------------------------------------------------------------


def test_measure_is_vectorised_over_pairs():
    n = 10_000
    radar = RadarSensor(radar_spec(ghost_rate=0.2), [Fault("bias", 0.0, magnitude=1.0)], seed=19)
    frames = [frame(k * DT, n) for k in range(20)]
    start = time.perf_counter()
    for f in frames:
        radar.measure(f)
    per_call = (time.perf_counter() - start) / len(frames)
    assert per_call < 0.01  # about 1 ms here; a Python loop over 10k pairs takes far longer


@pytest.mark.parametrize("lateral", [False, True])
def test_one_pass_kernel_equals_observe_then_emit(lateral):
    from acc_fusion.sensors.kernels import _emit, _observe, _observe_emit

    rng = np.random.default_rng(1)
    n = 300
    gap = rng.uniform(-5.0, 200.0, n)
    leader = np.where(rng.random(n) < 0.8, 1, -1)
    ego, lead = rng.uniform(0.0, 30.0, n), rng.uniform(0.0, 30.0, n)
    bearing = rng.normal(0.0, 0.5, n) if lateral else None
    ghost_range, ghost_life = rng.uniform(0.0, 150.0, n), rng.uniform(-1.0, 1.0, n)
    u, e = rng.random(n), rng.standard_normal((2, n))
    spec = radar_spec()
    observe_params = (
        spec.min_range, spec.max_range, math.radians(spec.fov_deg) / 2, spec.detection_prob,
        spec.range_std, spec.range_std_quadratic, spec.range_rate_std,
    )  # fmt: skip
    emit_params = (spec.range_std, spec.range_std_quadratic, spec.range_rate_std**2)
    truth = (gap, leader, ego, lead, bearing, ghost_range, ghost_life, u, e, observe_params)
    held = [rng.normal(size=(2, n)), rng.random(n) < 0.5, rng.random(n) < 0.5]
    clean, noise = np.empty((2, n)), np.empty((2, n))
    seen, ghost = np.empty(n, dtype=bool), np.empty(n, dtype=bool)
    _observe(*truth, clean, noise, seen, ghost)
    outs = [np.empty((2, n)), np.empty((2, 2, n)), np.empty(n, bool), np.empty(n, bool)]
    held_ref = [h.copy() for h in held]
    _emit(clean + noise, seen, ghost, *held_ref, emit_params, *outs)
    one = [np.empty_like(o) for o in outs]
    _observe_emit(*truth, *held, emit_params, *one)
    for a, b in zip([*outs, *held_ref], [*one, *held], strict=True):
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
