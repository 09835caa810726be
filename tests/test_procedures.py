"""The test-track procedures as 2-D scenes (:mod:`acc_fusion.truth.procedures`) and what they
need of :mod:`acc_fusion.truth.scenes`: the cruising SV, the POV's deceleration ramp, contact
with an offset POV, runs that end one by one, the trench plate."""

import math

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.units import KMH, G
from acc_fusion.metrics.summary import CAUSES
from acc_fusion.sim.world import alert_cause
from acc_fusion.truth.objects import STATIONARY_KINDS, ObjectKind
from acc_fusion.truth.procedures import (
    L0_TTC,
    PASS_THROUGH_SPACING,
    REST_TIME,
    RUN_IN,
    ProcedureSource,
    TestPoint,
    decelerating_lead,
    fmvss127_points,
    pass_through_point,
    plate_point,
    procedure_scene,
    slower_lead,
    start_gap,
    stopped_lead,
)
from acc_fusion.truth.scenes import SIGNATURES, Actors, SceneConfig, SceneSource, _actors

DT = 0.05


def _run(points, brake=None):
    """Run ``points`` to the end with the constant brake requests ``brake (N,)`` (``None``:
    none); returns the source and every frame."""
    src = ProcedureSource(points, DT)
    frames = []
    while not src.done:
        frames.append(src.frame())
        src.advance(brake)
    return src, frames


def test_a_stopped_lead_without_braking_is_hit_at_the_sv_speed():
    v = 50 * KMH
    src, frames = _run([stopped_lead(v)])
    assert src.collided[0] and not src.active[0]
    assert src.collision_speed[0] == pytest.approx(v, rel=1e-9)
    moving = [f.ego_speed[0] for f in frames]
    assert np.all(np.asarray(moving) == v)  # the robot driver holds the test speed
    # it ended at contact, well before its duration
    assert src.t == pytest.approx(RUN_IN + L0_TTC, abs=DT)


def test_a_strong_enough_brake_request_stops_the_sv_short():
    v = 50 * KMH
    src, frames = _run([stopped_lead(v)], brake=np.array([6.0]))
    assert not src.collided[0] and math.isnan(src.collision_speed[0])
    assert not src.active[0] and src.done
    # stopped in v / 6 s, then REST_TIME at rest ends the run
    assert src.t == pytest.approx(v / 6.0 + REST_TIME, abs=2 * DT)
    assert frames[-1].ego_speed[0] == 0.0
    assert frames[-1].lead[0] == 0 and frames[-1].x[0, 0] > 5.0


def test_a_cruising_sv_keeps_its_speed_when_the_request_ends():
    src = ProcedureSource([stopped_lead(80 * KMH)], DT)
    for k in range(40):
        src.advance(np.array([3.0 if k < 20 else 0.0]))
    speed = src.frame().ego_speed[0]
    assert speed == pytest.approx(80 * KMH - 3.0 * 20 * DT)
    src.advance()
    assert src.frame().ego_speed[0] == speed


def test_the_decelerating_pov_reaches_its_deceleration_within_the_rise_time():
    decel, rise = 0.5 * G, 1.0
    point = decelerating_lead(80 * KMH, 40.0, decel, rise=rise)
    src = ProcedureSource([point], DT)
    accel = {}
    while not src.done:
        f = src.frame()
        accel[round(f.t / DT)] = f.accel[0, 0]
        src.advance()  # the SV reaches the POV only after the ramp
    onset = round(point.pov_brake_time / DT)
    assert accel[onset] == 0.0
    assert accel[onset + round(rise / 2 / DT)] == pytest.approx(-decel / 2)
    assert accel[onset + round(rise / DT)] == pytest.approx(-decel)
    assert accel[onset + round(rise / DT) + 10] == pytest.approx(-decel)
    assert rise <= 1.5  # FMVSS 127: reached within 1.5 s


def test_the_ramp_kinematics_are_continuous_and_stop_where_expected():
    v0, decel, rise, tb = 22.0, 4.0, 1.5, 2.0
    act = _actors(1, [{"kind": 0, "s0": 10.0, "v0": v0, "brake_time": tb,
                       "brake_decel": decel, "brake_rise": rise}])  # fmt: skip
    t = np.linspace(0.0, 12.0, 2401)
    s, v, a = (np.array([act.centre(x)[i][0, 0] for x in t]) for i in range(3))
    np.testing.assert_allclose(np.gradient(s, t), v, atol=1e-2)
    np.testing.assert_allclose(np.gradient(v, t)[(t > tb + 0.01) & (v > 0.1)],
                               a[(t > tb + 0.01) & (v > 0.1)], atol=1e-2)  # fmt: skip
    stop = v0 / decel + rise / 2
    stop_s = (
        10.0
        + v0 * tb
        + v0 * rise
        - decel * rise**2 / 6
        + (v0 - decel * rise / 2) * (stop - rise)
        - decel * (stop - rise) ** 2 / 2
    )
    assert v[t >= tb + stop + 1e-9].max() == 0.0 and a[t >= tb + stop + 1e-9].max() == 0.0
    assert s[-1] == pytest.approx(stop_s)


def test_a_rise_of_zero_is_exactly_the_step():
    specs = [{"kind": 0, "s0": 30.0, "v0": 25.0, "brake_time": 1.0, "brake_decel": 6.0}]
    step = _actors(3, specs)
    none = Actors(**{k: getattr(step, k) for k in Actors.__dataclass_fields__
                     if k not in ("brake_rise", "present")})  # fmt: skip
    mixed = _actors(3, [{**specs[0], "brake_rise": np.array([0.0, 1.0, 0.0])}])
    for t in (0.0, 1.0, 1.37, 3.0, 9.0):
        a, b, c = step.centre(t), none.centre(t), mixed.centre(t)
        for x, y, z in zip(a, b, c, strict=True):
            np.testing.assert_array_equal(x, y)
            np.testing.assert_array_equal(x[[0, 2]], z[[0, 2]])


@pytest.mark.parametrize("overlap, side", [(-0.5, 1.0), (0.5, -1.0), (-0.75, 1.0)])
def test_an_offset_pov_is_the_in_path_lead_and_its_contact_counts(overlap, side):
    v = 40 * KMH
    point = stopped_lead(v, overlap=overlap)
    src, frames = _run([point])
    offset = (1 - abs(overlap)) * 1.8
    assert point.lateral_offset == pytest.approx(side * offset)
    assert frames[0].y[0, 0] == pytest.approx(side * offset)
    assert all(f.lead[0] == 0 for f in frames if f.valid[0, 0])
    assert src.collided[0] and src.collision_speed[0] == pytest.approx(v)


def test_a_pov_beside_the_sv_body_is_neither_lead_nor_contact():
    src, frames = _run([stopped_lead(40 * KMH, overlap=0.0)])  # offset by a whole width
    assert not src.collided.any()
    assert all(f.lead[0] == -1 for f in frames)


def test_the_plate_and_the_pass_through_povs_are_never_hit_nor_the_lead():
    points = [plate_point(), pass_through_point()]
    src, frames = _run(points)
    assert not src.collided.any() and np.isnan(src.collision_speed).all()
    assert all((f.lead == -1).all() for f in frames)
    assert not src.active.any() and src.done
    # every run lasted its duration: the SV drove over the plate and between the POVs
    assert src.t == pytest.approx(max(p.duration for p in points), abs=DT)
    first = frames[0]
    assert first.kind[0, 0] == ObjectKind.PLATE
    assert first.height[0, 0] == 0.025 and first.elevation[0, 0] == 0.0
    assert (first.width[0, 0], first.length[0, 0]) == (2.4, 3.7)
    assert first.lane[0, 0] == 0 and first.y[0, 0] == 0.0
    assert not first.valid[0, 1]  # the plate's run has no second POV
    y = first.y[1, :2]
    assert (first.kind[1, :2] == ObjectKind.VEHICLE).all() and first.valid[1, :2].all()
    inner = y.max() - y.min() - first.width[1, 0]
    assert inner == pytest.approx(PASS_THROUGH_SPACING) and abs(inner - 4.5) <= 0.1
    assert sorted(first.lane[1, :2]) == [-1, 1]


def test_the_plate_is_a_stationary_kind_with_a_signature():
    assert ObjectKind.PLATE in STATIONARY_KINDS
    length, width, height, rcs, contrast = SIGNATURES[ObjectKind.PLATE]
    assert (length, width, height) == (3.7, 2.4, 0.025)
    assert rcs < SIGNATURES[ObjectKind.VEHICLE][3] and contrast == 0.5
    frame = ProcedureSource([plate_point()], DT).frame()
    cause = alert_cause(frame, np.array([0]), np.array([-1]))
    assert CAUSES[int(cause[0])] == "stationary"


@pytest.mark.parametrize("point", [stopped_lead(30 * KMH), stopped_lead(80 * KMH),
                                   slower_lead(60 * KMH), slower_lead(100 * KMH)])  # fmt: skip
def test_the_ttc_at_l0_is_five_seconds(point):
    src = ProcedureSource([point], DT)
    assert src.l0_time[0] == pytest.approx(RUN_IN)
    for _ in range(round(RUN_IN / DT)):
        src.advance()
    f = src.frame()
    assert f.t == pytest.approx(point.l0_time)
    assert f.x[0, 0] / -f.vx[0, 0] == pytest.approx(L0_TTC)
    assert point.gap == pytest.approx(start_gap(point.sv_speed, point.pov_speed))


def test_runs_end_one_by_one_and_the_batch_goes_on():
    points = [stopped_lead(80 * KMH), plate_point(), stopped_lead(20 * KMH, overlap=-0.5)]
    src = ProcedureSource(points, DT)
    assert src.n_steps == round(max(p.duration for p in points) / DT)
    ended = {}
    while not src.done:
        src.frame()
        src.advance()
        for i in np.flatnonzero(~src.active):
            ended.setdefault(int(i), src.t)
    assert src.collided.tolist() == [True, False, True]
    # both stopped leads are hit at the end of their TTC, the plate run lasts its duration
    assert ended[0] == pytest.approx(RUN_IN + L0_TTC, abs=DT)
    assert ended[2] == pytest.approx(RUN_IN + L0_TTC, abs=DT)
    assert ended[1] == pytest.approx(points[1].duration, abs=DT)
    last = src.frame()
    assert (last.lead == -1).all()  # ended runs have no lead


def test_the_fmvss127_matrix():
    points = fmvss127_points()
    kinds = [p.kind for p in points]
    assert kinds.count("plate") == kinds.count("pass_through") == 1
    stopped = [p for p in points if p.kind == "stopped"]
    speeds = sorted(round(p.sv_speed / KMH) for p in stopped if not p.manual_brake)
    assert speeds == list(range(10, 81, 10))
    manual = sorted(round(p.sv_speed / KMH) for p in stopped if p.manual_brake)
    assert manual == [70, 80, 90, 100]
    slower = [p for p in points if p.kind == "slower"]
    assert {round(p.pov_speed / KMH) for p in slower} == {20}
    assert sorted(round(p.sv_speed / KMH) for p in slower if not p.manual_brake) == [
        40, 50, 60, 70, 80]  # fmt: skip
    decel = [p for p in points if p.kind == "decelerating"]
    assert {round(p.sv_speed / KMH) for p in decel} == {50, 80}
    assert all(p.sv_speed == p.pov_speed and 12 <= p.gap <= 40 for p in decel)
    assert {round(p.pov_decel / G, 2) for p in decel} == {0.3, 0.5}
    assert all(0 < p.pov_decel_rise <= 1.5 for p in decel)
    assert {p.manual_brake for p in decel} == {False, True}
    false_activation = [p for p in points if p.kind in ("plate", "pass_through")]
    assert all(p.sv_speed == pytest.approx(80 * KMH) for p in false_activation)
    assert all(p.label.startswith("FMVSS 127 S") for p in points)
    np.testing.assert_allclose([p.l0_time for p in points], RUN_IN)


def test_a_ncap_ccrb_point_runs():
    # Euro NCAP CCRb: both at 50 km/h, the target braking at 6 m/s² 12 m ahead
    point = decelerating_lead(50 * KMH, 12.0, 6.0, rise=0.0, run_in=2.0)
    src, _ = _run([point])
    assert src.collided[0] and 0.0 < src.collision_speed[0] < 50 * KMH


@pytest.mark.parametrize(
    "kwargs, word",
    [
        ({"sv_speed": -1.0, "pov_speed": 0.0, "gap": 50.0}, "sv_speed"),
        ({"sv_speed": 10.0, "pov_speed": 0.0, "gap": 50.0, "overlap": 1.5}, "overlap"),
        ({"sv_speed": 10.0, "pov_speed": 0.0, "gap": 50.0, "overlap": -1.01}, "overlap"),
        ({"sv_speed": 10.0, "pov_speed": 0.0, "gap": -5.0}, "gap"),
        ({"sv_speed": 10.0, "pov_speed": 12.0, "gap": 50.0, "kind": "slower"}, "pov_speed"),
        ({"sv_speed": 10.0, "pov_speed": 5.0, "gap": 50.0}, "pov_speed"),
        (
            {"sv_speed": 10.0, "pov_speed": 10.0, "gap": 20.0, "kind": "decelerating"},
            "decelerating",
        ),  # fmt: skip
        ({"sv_speed": 10.0, "pov_speed": 0.0, "gap": 50.0, "kind": "tunnel"}, "kind"),
        ({"sv_speed": 10.0, "pov_speed": 0.0, "gap": 50.0, "pov_decel": -2.0}, "pov_decel"),
        ({"sv_speed": 10.0, "pov_speed": 0.0, "gap": 50.0, "duration": 0.0}, "duration"),
        (
            {
                "sv_speed": 22.0,
                "pov_speed": 0.0,
                "gap": 50.0,
                "kind": "pass_through",
                "overlap": 0.5,
            },
            "overlap",
        ),  # fmt: skip
    ],
)
def test_bad_test_points_are_one_sentence_config_errors(kwargs, word):
    with pytest.raises(ConfigError, match=word) as err:
        TestPoint(**kwargs)
    assert "\n" not in str(err.value)


def test_bad_point_lists_and_steps_are_config_errors():
    with pytest.raises(ConfigError, match="points"):
        procedure_scene([])
    with pytest.raises(ConfigError, match="points"):
        ProcedureSource([stopped_lead(10.0), "stopped"])
    with pytest.raises(ConfigError, match="dt"):
        ProcedureSource([stopped_lead(10.0)], dt=0.0)


def test_a_procedure_scene_is_a_cruising_scene_with_padded_slots():
    points = [stopped_lead(60 * KMH), pass_through_point()]
    scene = procedure_scene(points)
    assert (scene.ego_model, scene.lead_rule) == ("cruise", "overlap")
    assert scene.duration == max(p.duration for p in points)
    assert scene.actors.present[:, :2].tolist() == [[True, False], [True, True]]
    assert (scene.ego_speed == [60 * KMH, 80 * KMH]).all()


def test_existing_scenes_are_unchanged():
    # values of the code before the procedures were added (cut_in, 4 runs, seed 1, 100 steps)
    src = SceneSource(SceneConfig("cut_in", 4), 1)
    for _ in range(100):
        src.advance()
    f = src.frame()
    np.testing.assert_allclose(
        f.ego_speed, [20.06440848, 20.33661226, 17.63897141, 20.31112635], rtol=1e-8
    )
    np.testing.assert_allclose(
        f.x[:, 0], [16.71433632, 21.71414367, 7.79821215, 20.40118138], rtol=1e-8
    )
    assert (f.lead == 0).all()
    # the IDM ego still follows (it slowed behind the slower car that cut in) and every run
    # stays active for the whole scene
    assert (f.ego_speed < 25.0).all() and src.active.all()
    assert np.isnan(src.collision_speed).all() and src.scene.ego_model == "idm"
