"""The scripted 2-D scenes: each produces the situation it names, in truth."""

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError
from acc_fusion.truth.objects import ObjectKind
from acc_fusion.truth.scenes import SCENES, SceneConfig, SceneSource


def _frames(scene, runs=8, seed=3):
    src = SceneSource(SceneConfig(scene=scene, runs=runs), seed=seed)
    frames = []
    while not src.done:
        frames.append(src.frame())
        src.advance()
    return src, frames


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_every_scene_runs_without_a_crash_of_its_attentive_ego(scene):
    src, frames = _frames(scene)
    assert len(frames) == src.n_steps
    assert not src.collided.any()
    assert all(f.valid.any(axis=1).all() for f in frames)  # guardrail posts at least


def test_the_lead_frame_gap_is_the_lead_x_on_a_straight_road():
    _, frames = _frames("lead_brakes")
    f = frames[100]
    rows = np.arange(f.n_egos)
    np.testing.assert_allclose(f.lead_frame().gap, f.x[rows, f.lead])
    assert (f.lead_frame().leader_id == 0).all()


def test_the_lead_brakes_to_a_stop():
    _, frames = _frames("lead_brakes")
    lead = frames[-1].lead_frame()
    assert (lead.lead_speed == 0).mean() > 0.5
    assert (np.array([f.lead_frame().lead_accel.min() for f in frames]) <= -4.0).any()


def _min_offset_from_straight_path(frames, actor, lo=30.0):
    """The smallest |y| of ``actor`` while it is more than ``lo`` m ahead."""
    best = np.full(frames[0].n_egos, np.inf)
    for f in frames:
        ahead = f.valid[:, actor] & (f.x[:, actor] > lo)
        best = np.where(ahead, np.minimum(best, np.abs(f.y[:, actor])), best)
    return best


def test_before_the_curve_the_adjacent_car_lies_on_the_straight_path_but_not_in_the_lane():
    _, frames = _frames("curve_adjacent")
    assert (_min_offset_from_straight_path(frames, 0) < 1.0).all()
    assert all((f.lane[:, 0] == -1).all() and (f.lead == -1).all() for f in frames)


def test_before_the_curve_the_parked_car_lies_on_the_straight_path():
    _, frames = _frames("parked_curve")
    assert (_min_offset_from_straight_path(frames, 0) < 1.5).all()
    assert (frames[0].kind[:, 0] == ObjectKind.PARKED).all()
    assert all((f.lead == -1).all() for f in frames)


def test_the_cut_out_reveals_a_stopped_car():
    _, frames = _frames("cut_out")
    assert (frames[0].lead == 0).all()
    assert (frames[-1].lead == 1).all()
    assert (frames[-1].lead_frame().lead_speed == 0).all()


def test_the_cut_in_becomes_the_lead():
    _, frames = _frames("cut_in")
    assert (frames[0].lead == -1).all()
    assert (frames[-1].lead == 0).all()


def test_the_crest_lowers_the_gantry_toward_the_boresight():
    _, frames = _frames("gantry_crest")
    clearance = frames[-1].elevation[:, 0]
    far = frames[0].elevation[:, 0]
    assert (far < clearance - 1.0).all()


def test_a_scene_is_reproducible_from_its_seed():
    _, a = _frames("cut_in", seed=5)
    _, b = _frames("cut_in", seed=5)
    np.testing.assert_array_equal(a[50].x, b[50].x)
    np.testing.assert_array_equal(a[50].ego_yaw_rate, b[50].ego_yaw_rate)


def test_a_driver_brake_request_overrides_the_idm_where_it_is_harder():
    config = SceneConfig(scene="gantry_crest", runs=2, dt=0.05)
    idm, braked = SceneSource(config, 0), SceneSource(config, 0)
    v0 = idm.frame().ego_speed
    idm.advance()
    braked.advance(np.array([0.0, 6.0]))
    assert braked.frame().ego_speed[0] == idm.frame().ego_speed[0]
    assert braked.frame().ego_speed[1] == pytest.approx(v0[1] - 6.0 * 0.05)


def test_a_bad_scene_or_run_count_is_one_error():
    with pytest.raises(ConfigError, match="scene must be one of"):
        SceneConfig(scene="tunnel")
    with pytest.raises(ConfigError, match="runs"):
        SceneConfig(runs=0)
