"""Scripted manoeuvres: exact kinematics, collisions, leader changes, reproducibility, errors;
and the protocols' FCW requirements."""

from __future__ import annotations

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.units import KMH, MPH, G
from acc_fusion.metrics.protocols import REQUIREMENTS, requirement
from acc_fusion.truth.manoeuvre_params import (
    OVERLAP_OFFSET,
    RANDOM_RANGES,
    SLOTS,
    CCRbParams,
    LVSParams,
)
from acc_fusion.truth.manoeuvres import SCENARIOS, STANDARD
from acc_fusion.truth.scripted import ScenarioSource, make_scenario, random_suite


def run(src: ScenarioSource, brake=None):
    """Step ``src`` to the end; returns the frames (the first included)."""
    frames = [src.frame()]
    while not src.done:
        frames.append(src.advance(None if brake is None else brake(frames[-1])))
    return frames


def test_registry_names():
    required = {"nhtsa_lvs", "nhtsa_lvd", "nhtsa_lvm", "ccrs", "ccrm", "ccrb"}
    required |= {"cut_in", "cut_out", "stop_and_go", "following"}
    assert required == set(STANDARD) and set(SCENARIOS) == required | {"random"}


def test_lvd_kinematics_are_exact():
    src = make_scenario("nhtsa_lvd", 1)  # both at 45 mph, 30 m; POV brakes at 0.3 g from t = 3 s
    v, a = 45 * MPH, 0.3 * G
    for _ in range(100):  # 5 s: 2 s of braking
        src.advance()
    state = src.state()
    assert state.t == pytest.approx(5.0, abs=1e-12)
    assert state.lead_speed[0] == pytest.approx(v - 2 * a, abs=1e-9)
    assert state.lead_position[0] == pytest.approx(30 + 5 * v - 0.5 * a * 4, abs=1e-9)
    assert state.ego_position[0] == pytest.approx(5 * v, abs=1e-9)
    assert state.lead_accel[0] == pytest.approx(-a, abs=1e-12)
    # bumper to bumper: the gap is the lead's rear minus the ego's front
    assert state.gap[0] == pytest.approx(state.lead_position[0] - state.ego_position[0])
    assert src.frame().gap[0] == state.gap[0]


def test_a_braking_lead_stops_exactly_and_stays_stopped():
    src = make_scenario("nhtsa_lvd", 1, headway=200.0, duration=15.0)  # the ego never gets there
    v, a = 45 * MPH, 0.3 * G
    states = []
    while not src.done:
        src.advance()
        states.append(src.state())
    speeds = np.array([s.lead_speed[0] for s in states])
    assert speeds.min() == 0.0 and np.all(np.diff(speeds) <= 0)
    stopped = speeds == 0.0
    assert stopped.sum() > 50 and np.all(stopped[np.argmax(stopped) :])
    stop = 200 + 3 * v + v * v / (2 * a)  # braking distance after 3 s at speed
    assert states[-1].lead_position[0] == pytest.approx(stop, abs=1e-9)
    assert states[-1].lead_accel[0] == 0.0 and not src.collided[0]


def test_lvs_without_braking_collides_at_full_speed():
    src = make_scenario("nhtsa_lvs", 3)
    frames = run(src)
    assert src.collided.all()
    np.testing.assert_allclose(src.collision_speed, 45 * MPH, atol=1e-9)  # 72.4 km/h
    np.testing.assert_allclose(src.end_time, 6.0, atol=1e-9)  # initial TTC 6 s
    assert frames[-1].gap[0] == 0.0 and frames[-1].ego_speed[0] == 0.0
    assert not src.active.any()
    # after the end the run is frozen and has no leader, and frames stay valid
    frozen = src.advance()
    assert (frozen.leader_id == -1).all() and np.all(frozen.ego_speed == 0)


def test_ccrm_collision_speed_is_the_speed_difference():
    src = make_scenario("ccrm", 2, vut_speed=(50 * KMH, 80 * KMH))
    run(src)
    np.testing.assert_allclose(src.collision_speed, [30 * KMH, 60 * KMH], atol=1e-9)


def test_early_braking_avoids_the_collision_and_ends_the_run():
    src = make_scenario("nhtsa_lvs", 1)  # gap 120.7 m at 20.1 m/s
    frames = run(src, brake=lambda f: np.array([6.0]) if f.t >= 1.0 else None)
    assert not src.collided[0] and np.isnan(src.collision_speed[0])
    last = frames[-1]
    assert last.ego_speed[0] == 0.0 and last.gap[0] > 0  # stopped short: the run is resolved
    assert src.end_time[0] == pytest.approx(1.0 + 45 * MPH / 6.0, abs=0.05 + 1e-9)


def test_tuple_parameters_spread_runs_over_the_grid():
    src = make_scenario("ccrb", 4)  # default: the protocol's 2x2 matrix
    np.testing.assert_array_equal(src.run_params["headway"], [12, 12, 40, 40])
    np.testing.assert_array_equal(src.run_params["gvt_decel"], [2, 6, 2, 6])
    np.testing.assert_allclose(src.frame().gap, [12, 12, 40, 40])
    assert make_scenario("ccrb", 1, headway=40.0, gvt_decel=6.0).run_params["headway"][0] == 40


def test_cut_in_gives_a_new_leader_id():
    src = make_scenario("cut_in", 1)  # far lead (id 1) at 80 m, merging car (id 2)
    frames = run(src)
    ids = np.array([f.leader_id[0] for f in frames])
    change = int(np.flatnonzero(np.diff(ids))[0]) + 1
    assert ids[0] == 1 and ids[change] == 2
    assert 0 < frames[change].lateral_offset[0] < OVERLAP_OFFSET
    assert frames[change].gap[0] < frames[change - 1].gap[0]
    assert src.collided[0]  # a slower car merged 15 m ahead and nobody braked


def test_cut_out_threat_disappears_before_a_collision():
    src = make_scenario("cut_out", 2, revealed_gap=(100.0, float("inf")))
    frames = run(src)
    assert frames[0].range_rate[0] < 0  # closing on the lead at first
    ids = np.array([f.leader_id for f in frames])
    change = int(np.flatnonzero(np.diff(ids[:, 0]))[0]) + 1
    assert frames[change - 1].gap[0] > 0  # the lead left before the ego reached it
    assert ids[change].tolist() == [2, -1]  # the revealed vehicle, or nobody
    assert frames[change].range_rate[0] == pytest.approx(0.0, abs=1e-12)
    assert not src.collided.any()


def test_cut_out_can_reveal_a_stopped_vehicle():
    src = make_scenario("cut_out", 1, lead_speed=80 * KMH, revealed_speed=0.0)
    run(src)
    assert src.collided[0] and src.collision_speed[0] == pytest.approx(80 * KMH)


@pytest.mark.parametrize("name", ["following", "stop_and_go"])
def test_car_following_never_collides(name):
    src = make_scenario(name, 50, seed=4, duration=30.0)
    frames = run(src)
    assert not src.collided.any()
    gaps = np.array([f.gap for f in frames])
    assert np.all(gaps > 1.0) and np.all(np.array([f.ego_speed for f in frames]) >= 0)
    lead = np.array([f.lead_speed for f in frames])
    if name == "stop_and_go":
        assert np.all(lead.min(axis=0) == 0) and np.all(lead.max(axis=0) > 5)
    else:
        closing = np.array([-f.range_rate for f in frames])
        assert np.all(gaps / np.maximum(closing, 1e-9) > 10)  # no threat at all


def test_random_suite_is_reproducible_and_covers_every_type():
    a, b = random_suite(300, seed=11), random_suite(300, seed=11)
    assert set(a.kind) == set(STANDARD)
    np.testing.assert_array_equal(a.kind, b.kind)
    for _ in range(60):
        fa, fb = a.advance(), b.advance()
        for name in ("gap", "lead_speed", "ego_speed", "ego_accel", "leader_id"):
            np.testing.assert_array_equal(getattr(fa, name), getattr(fb, name))
    assert not np.array_equal(random_suite(300, seed=12).kind, a.kind)


def test_closed_loop_actions_do_not_touch_other_runs():
    a, b = random_suite(40, seed=5), random_suite(40, seed=5)
    brake = np.zeros(40)
    brake[0] = 3.0
    for _ in range(80):
        fa, fb = a.advance(brake), b.advance()
    np.testing.assert_array_equal(fa.gap[1:], fb.gap[1:])
    assert fa.ego_speed[0] < fb.ego_speed[0] or not a.active[0]


def test_random_draws_stay_in_their_documented_ranges():
    src = random_suite(400, seed=2)
    for kind, ranges in RANDOM_RANGES.items():
        rows = src.kind == kind
        for name, (lo, hi, _, _) in ranges.items():
            values = src.run_params[name][rows]
            assert np.all((values >= lo) & (values <= hi)), (kind, name)
        assert f"{kind} " in random_suite.__doc__


def test_bad_input_names_the_field_and_the_allowed_values():
    with pytest.raises(ConfigError, match="scenario must be one of .*'ccrs'.*got 'ccrx'"):
        make_scenario("ccrx", 2)
    with pytest.raises(ConfigError, match=r"ccrs.vut_speed must be in \(0, 70\], got -3"):
        make_scenario("ccrs", 2, vut_speed=-3.0)
    with pytest.raises(ConfigError, match=r"ccrb.headway must be in \(0, 1000\]"):
        CCRbParams(headway=(12.0, 0.0))
    with pytest.raises(ConfigError, match="ccrm.vut_speed must exceed ccrm.gvt_speed"):
        make_scenario("ccrm", 1, vut_speed=10 * KMH)
    with pytest.raises(
        ConfigError, match="unknown key ccrs.'speed' in ccrs; allowed keys: vut_speed"
    ):
        make_scenario("ccrs", 1, speed=10.0)
    with pytest.raises(ConfigError, match="n_runs must be an integer >= 1"):
        ScenarioSource("ccrs", 0)
    with pytest.raises(ConfigError, match=r"dt must be in \(0, 1\]"):
        ScenarioSource("ccrs", 1, dt=0.0)
    with pytest.raises(ConfigError, match="params of 'ccrs' must be a CCRsParams"):
        ScenarioSource("ccrs", 1, params=LVSParams())
    with pytest.raises(ConfigError, match="random.kinds must be one of"):
        make_scenario("random", 2, kinds=("ccrs", "lvs"))
    src = make_scenario("ccrs", 2)
    with pytest.raises(InputError, match="ego_brake must be >= 0"):
        src.advance(np.array([1.0, -2.0]))
    with pytest.raises(InputError, match=r"ego_brake must have shape \(2,\)"):
        src.advance(np.zeros(3))
    src.advance(np.array([np.nan, 0.0]))  # NaN = no request


FRAME_FIELDS = ("gap", "lead_speed", "lead_accel", "ego_speed", "ego_accel", "lateral_offset")


def brake_when_close(frame):
    """A deterministic closed-loop driver: 5 m/s² when the gap is below 15 m."""
    return np.where((frame.leader_id >= 0) & (frame.gap < 15.0), 5.0, np.nan)


def assert_restarted_runs_follow(src, fresh, ref, mask, brake=brake_when_close, rows=None):
    """Step ``src`` (just restarted in ``mask``), ``fresh`` and ``ref`` (never restarted) to the
    end with the same driver: ``src``'s rows in ``mask`` must follow ``fresh``'s ``rows``
    (default: all; leader ids offset by ``SLOTS`` per restart), the others ``ref``."""
    rows = np.arange(fresh.n_runs) if rows is None else rows
    offset = SLOTS * (src.generation[mask] - fresh.generation[rows])
    k0 = int(round(src.t / src.dt))
    frames = {"src": [], "fresh": [], "ref": []}
    fs, ff, fr = src.frame(), fresh.frame(), ref.frame()
    for step in range(src.n_steps - k0 + 1):
        assert fs.t == pytest.approx((k0 + step) * src.dt, abs=1e-9)
        np.testing.assert_allclose(src.run_time[mask], step * src.dt, atol=1e-9)
        for key, frame, source in (("src", fs, src), ("fresh", ff, fresh), ("ref", fr, ref)):
            values = [getattr(frame, name) for name in (*FRAME_FIELDS, "leader_id")]
            frames[key].append(np.stack([*values, source.active]))
        b = brake(fs)
        b_fresh = np.full(fresh.n_runs, np.nan)
        b_fresh[rows] = b[mask]
        fs, ff, fr = src.advance(b), fresh.advance(b_fresh), ref.advance(b)
        assert not src.reassigned.any()
    assert src.done and not fresh.active[rows].any() and ref.done
    got, want, other = (np.array(frames[key]) for key in ("src", "fresh", "ref"))
    want = want[:, :, rows]
    ids = want[:, -2]
    want[:, -2] = np.where(ids >= 0, ids + offset, -1)
    np.testing.assert_allclose(got[:, :, mask], want, atol=1e-9, rtol=0)
    np.testing.assert_array_equal(got[:, :, ~mask], other[:, :, ~mask])
    for name in ("end_time", "collided", "collision_speed"):
        np.testing.assert_array_equal(getattr(src, name)[mask], getattr(fresh, name)[rows])
        np.testing.assert_array_equal(getattr(src, name)[~mask], getattr(ref, name)[~mask])


def test_restart_reproduces_a_fresh_source_and_leaves_the_other_runs_alone():
    n, k0, dt = 40, 37, 0.1
    a, b = random_suite(n, 3, dt), random_suite(n, 3, dt)  # b: never restarted
    for _ in range(k0):
        a.advance(brake_when_close(a.frame())), b.advance(brake_when_close(b.frame()))
    mask = np.zeros(n, dtype=bool)
    mask[[1, 5, 17, 30, 31, 39]] = True
    kind_before = a.kind
    a.restart(mask, seed=9)
    fresh = ScenarioSource("random", int(mask.sum()), dt, 9)  # the same draws
    assert kind_before is not a.kind and np.array_equal(kind_before, b.kind)
    np.testing.assert_array_equal(a.kind[mask], fresh.kind)
    np.testing.assert_array_equal(a.kind[~mask], b.kind[~mask])
    for name, column in a.run_params.items():
        np.testing.assert_array_equal(column[mask], fresh.run_params.get(name, np.nan))
        np.testing.assert_array_equal(column[~mask], b.run_params.get(name, np.nan)[~mask])
    np.testing.assert_array_equal(a.duration[mask], fresh.duration)
    np.testing.assert_array_equal(a.reassigned, mask)
    np.testing.assert_allclose(a.t0, np.where(mask, k0 * dt, 0.0), atol=1e-12)
    np.testing.assert_array_equal(a.generation, mask.astype(int))
    steps = np.ceil(b.duration[~mask] / dt - 1e-9).astype(int).max()
    assert a.n_steps == max(steps, k0 + fresh.n_steps)
    assert_restarted_runs_follow(a, fresh, b, mask)
    assert a.collided.any() and not a.collided.all()  # both endings were exercised


def test_runs_drawn_ahead_start_as_a_fresh_source_runs_them_again_and_again():
    """``start`` with a block of ``draw`` n: the masked runs follow the block's rows; a second
    start writes into the source's own script (its arrays) and still reproduces them."""
    n, dt = 30, 0.1
    a, b = random_suite(n, 4, dt), random_suite(n, 4, dt)
    block, fresh = a.draw(12, 5), ScenarioSource("random", 12, dt, 5)
    first, second = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    first[[0, 3, 4, 20]], second[[3, 7, 29]] = True, True
    for k in range(20):
        if k == 10:
            for src in (a, b):
                src.start(first, block.take(slice(0, 4)))
        a.advance(brake_when_close(a.frame())), b.advance(brake_when_close(b.frame()))
    duration = a.duration
    a.start(second, block.take(np.array([9, 4, 6])))
    assert a.duration is not duration and np.array_equal(duration, b.duration)
    np.testing.assert_array_equal(a.kind[second], fresh.kind[[9, 4, 6]])
    assert_restarted_runs_follow(a, fresh, b, second, rows=np.array([9, 4, 6]))
    with pytest.raises(InputError, match="draws must hold 3 runs"):
        a.start(second, block.take(slice(0, 2)))


def test_restart_can_bring_in_kinds_and_segments_the_source_did_not_have():
    kinds = ("ccrs", "stop_and_go")
    a, b = (make_scenario("random", 2, 11, kinds=kinds, duration=20.0) for _ in range(2))  # ccrs
    for _ in range(5):
        a.advance(), b.advance()
    mask = np.array([False, True])
    a.restart(mask, seed=0)
    fresh = make_scenario("random", 1, 0, kinds=kinds, duration=20.0)  # a stop_and_go run
    assert list(b.kind) == ["ccrs", "ccrs"] and list(a.kind) == ["ccrs", "stop_and_go"]
    assert np.isnan(a.run_params["vut_speed"][1]) and np.isnan(a.run_params["cruise_speed"][0])
    assert a.run_params["cruise_speed"][1] == fresh.run_params["cruise_speed"][0]
    assert_restarted_runs_follow(a, fresh, b, mask)


def test_restarting_ended_runs_makes_them_active_again():
    src = make_scenario("nhtsa_lvs", 3)  # every run hits the stopped POV at 6 s
    run(src)
    assert src.done and src.collided.all()
    mask = np.array([True, False, True])
    src.restart(mask, seed=None)
    assert not src.done
    np.testing.assert_array_equal(src.active, mask)
    np.testing.assert_array_equal(src.collided, ~mask)
    np.testing.assert_array_equal(np.isnan(src.collision_speed), mask)
    np.testing.assert_array_equal(src.end_time, [np.inf, 6.0, np.inf])
    frame = src.frame()  # run 1 shows its final (collision) frame once more
    np.testing.assert_array_equal(frame.leader_id, [1 + SLOTS, 1, 1 + SLOTS])
    np.testing.assert_allclose(frame.gap[mask], 6 * 45 * MPH, atol=1e-9)  # initial TTC 6 s
    np.testing.assert_allclose(frame.ego_speed, [45 * MPH, 0.0, 45 * MPH], atol=1e-12)
    assert src.n_steps == 120 + 320  # restarted at step 120; the runs last 16 s
    assert src.advance().leader_id[1] == -1  # frozen
    run(src)
    assert src.collided.all() and src.t == pytest.approx(12.0)
    np.testing.assert_allclose(src.end_time, 6.0, atol=1e-9)  # run time
    np.testing.assert_allclose(src.t0 + src.end_time, [12.0, 6.0, 12.0], atol=1e-9)
    np.testing.assert_allclose(src.collision_speed, 45 * MPH, atol=1e-9)
    src.restart(np.array([True, False, False]), seed=None)  # ids stay unique per run
    assert src.frame().leader_id[0] == 1 + 2 * SLOTS
    np.testing.assert_array_equal(src.generation, [2, 0, 1])


def test_a_run_that_ended_by_braking_restarts_without_the_old_brake():
    src = make_scenario("nhtsa_lvd", 2)  # the POV brakes at 3 s
    run(src, brake=lambda f: np.full(2, 8.0) if f.t >= 3.5 else None)
    assert src.done and not src.collided.any()  # the braking drivers resolved the threat
    src.restart(np.array([True, False]), seed=None)
    assert src.frame().ego_accel[0] == 0.0  # no brake request carried over
    fresh = make_scenario("nhtsa_lvd", 1)
    run(src), run(fresh)  # no driver now: a scripted run ends only at the collision
    assert src.collided[0] and src.end_time[0] == fresh.end_time[0] > 3.0


def test_restart_takes_the_grid_points_of_a_fresh_source():
    src = make_scenario("ccrb", 4)  # headway x decel: (12, 2), (12, 6), (40, 2), (40, 6)
    for _ in range(10):
        src.advance()
    src.restart(np.array([False, False, True, True]), seed=0)  # a fresh 2-run source: 12 m
    np.testing.assert_array_equal(src.run_params["headway"], [12, 12, 12, 12])
    np.testing.assert_array_equal(src.run_params["gvt_decel"], [2, 6, 2, 6])
    np.testing.assert_allclose(src.frame().gap[2:], 12.0, atol=1e-12)


def test_restart_with_an_empty_mask_is_a_no_op():
    a, b = random_suite(10, seed=4), random_suite(10, seed=4)
    for _ in range(20):
        a.advance(), b.advance()
    rng = np.random.default_rng(5)
    before = rng.bit_generator.state
    a.restart(np.zeros(10, dtype=bool), rng)
    assert rng.bit_generator.state == before  # nothing drawn
    assert not a.reassigned.any() and a.n_steps == b.n_steps
    for _ in range(30):
        fa, fb = a.advance(), b.advance()
        for name in (*FRAME_FIELDS, "leader_id"):
            np.testing.assert_array_equal(getattr(fa, name), getattr(fb, name))
    np.testing.assert_array_equal(a.end_time, b.end_time)


def test_restart_rejects_a_bad_mask():
    src = make_scenario("ccrs", 3)
    with pytest.raises(InputError, match=r"mask must have shape \(3,\), got \(4,\)"):
        src.restart(np.zeros(4, dtype=bool), seed=0)
    with pytest.raises(InputError, match=r"mask must have shape \(3,\), got \(1, 3\)"):
        src.restart(np.zeros((1, 3), dtype=bool), seed=0)
    with pytest.raises(InputError, match="mask must be a boolean array, got dtype int64"):
        src.restart(np.array([0, 1, 2]), seed=0)


def test_every_protocol_manoeuvre_with_an_fcw_test_has_a_requirement():
    # Euro NCAP tests the FCW in CCRs only; CCRm and CCRb are AEB-only (no FCW requirement).
    assert set(REQUIREMENTS) == {"nhtsa_lvs", "nhtsa_lvd", "nhtsa_lvm", "ccrs"}
    assert [requirement(n).required_ttc for n in ("nhtsa_lvs", "nhtsa_lvd", "nhtsa_lvm")] == [
        2.1,
        2.4,
        2.0,
    ]
    assert not requirement("ccrs").verified
    with pytest.raises(ConfigError, match="scenario must be one of .*got 'ccrb'"):
        requirement("ccrb")
    with pytest.raises(ConfigError, match="scenario must be one of .*'nhtsa_lvs'.*got 'following'"):
        requirement("following")


def test_pass_rule_is_five_of_seven_and_no_warning_fails():
    lvs = requirement("nhtsa_lvs")
    five = np.array([2.5, 2.2, 2.1, 3.0, 2.4, 2.0, np.nan])
    assert lvs.passes(five)
    assert not lvs.passes(np.where(np.arange(7) == 0, np.nan, five))  # 4 of 7
    np.testing.assert_array_equal(lvs.trial_passes([2.1, 2.09, np.nan]), [True, False, False])
    assert lvs.pass_probability(1.0) == 1.0 and lvs.pass_probability(0.0) == 0.0
    assert lvs.pass_probability(0.5) == pytest.approx(29 / 128)
    with pytest.raises(InputError, match="must hold the 7 trials of nhtsa_lvs, got 3"):
        lvs.passes([3.0, 3.0, 3.0])


def test_move_is_advance_without_the_frame():
    """``move`` then ``frame`` is ``advance``: the frame is built when first asked for."""
    a, b = random_suite(40, 4, 0.1), random_suite(40, 4, 0.1)
    for _ in range(30):
        brake = brake_when_close(a.frame())
        frame = a.advance(brake)
        assert b.move(brake) is None
        built = b.frame()
        for name in ("ego_speed", "ego_accel", "gap", "lead_speed", "lead_accel", "leader_id"):
            assert np.array_equal(getattr(frame, name), getattr(built, name), equal_nan=True)
        assert built.t == frame.t and b.frame() is built
