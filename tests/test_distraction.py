"""Eyes-off-road episodes: the driver holds, looks back, reacts; a warning cuts an episode
short; the draws are reproducible per slot; the crash benefit is paired by vehicle."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from acc_fusion.cli.main import main
from acc_fusion.core.errors import ConfigError
from acc_fusion.metrics.benefit import paired_benefit
from acc_fusion.truth.distraction import DistractionConfig
from acc_fusion.truth.driver import Driver, DriverConfig
from acc_fusion.truth.frame import TruthFrame
from acc_fusion.truth.scripted import make_scenario

DT = 0.1


def frame(t, n, range_rate=-5.0):
    return TruthFrame(
        t=t,
        ego_speed=np.full(n, 20.0),
        ego_accel=np.zeros(n),
        gap=np.full(n, 30.0),
        lead_speed=np.full(n, 20.0 + range_rate),
        lead_accel=np.zeros(n),
        leader_id=np.ones(n, dtype=np.int64),
    )


def distracted(n=4, rate=3600.0, seed=0, **durations):
    cfg = DriverConfig(distraction=DistractionConfig(rate=rate, **durations))
    return Driver(n, cfg, seed=seed)


def run(driver, warn_at=None, steps=200, range_rate=-5.0):
    """Step the driver; return per step (eyes_off, holding, brake) of run 0."""
    n, rows = driver.n_runs, []
    for k in range(steps):
        t = k * DT
        level = np.full(n, 2 if warn_at is not None and t >= warn_at else 0)
        brake = driver.step(level, frame(t, n, range_rate))
        rows.append((driver.eyes_off[0], driver.holding[0], brake[0]))
    return np.array(rows, dtype=float)


def test_an_episode_holds_then_the_driver_looks_back_and_reacts():
    d = distracted(duration_median=2.0, duration_log_sd=0.0)
    rows = run(d)
    off = np.flatnonzero(rows[:, 0])
    start, end = off[0], off[0] + int(round(2.0 / DT))
    assert rows[start:end, 0].all() and not rows[end, 0]  # 2 s eyes off, exactly
    assert rows[start:end, 1].all() and (rows[start:end, 2] == 0).all()  # held, no braking
    react = end + int(round(d.reaction_time[0] / DT + 0.5 - 1e-9))
    assert rows[end:react, 1].all() and (rows[end : react - 1, 2] == 0).all()
    brakes = np.flatnonzero(rows[:, 2] > 0)
    assert brakes[0] == pytest.approx(end + d.reaction_time[0] / DT, abs=1.0)
    assert rows[brakes[0], 2] == d.deceleration[0]


def test_a_driver_not_closing_on_his_lead_is_handed_back_after_his_reaction():
    d = distracted(rate=360.0, duration_median=1.0, duration_log_sd=0.0)
    rows = run(d, range_rate=+1.0, steps=600)
    assert (rows[:, 2] == 0).all()  # nothing to brake for
    first = np.flatnonzero(rows[:, 1])[0]
    held = np.flatnonzero(rows[first:, 1] == 0)[0]  # back to his car-following model
    assert held * DT == pytest.approx(1.0 + d.reaction_time[0], abs=2 * DT)


def test_a_warning_during_an_episode_ends_it_after_the_reaction_time():
    long = dict(duration_median=5.9, duration_log_sd=0.0)
    natural = run(distracted(**long))
    start = np.flatnonzero(natural[:, 0])[0] * DT
    d = distracted(**long)
    warned = run(d, warn_at=start + 0.5)
    brake_natural = np.flatnonzero(natural[:, 2] > 0)[0] * DT
    brake_warned = np.flatnonzero(warned[:, 2] > 0)[0] * DT
    assert brake_warned == pytest.approx(start + 0.5 + d.reaction_time[0], abs=1.5 * DT)
    assert brake_warned < brake_natural - 4.0
    assert not warned[np.flatnonzero(warned[:, 2] > 0)[0], 0]  # eyes back on the road


def test_the_episodes_follow_their_distributions_and_each_slot_its_own_draws():
    d = distracted(n=200, rate=120.0, seed=4)
    rows, durations, starts = [], [], 0
    for k in range(6000):  # 10 minutes, every driver idle and not closing
        d.step(np.zeros(200), frame(k * DT, 200, range_rate=+1.0))
        rows.append(d.eyes_off)
    eyes = np.array(rows)
    starts = (eyes[1:] & ~eyes[:-1]).sum()
    for col in eyes.T:  # the lengths of the completed episodes
        edges = np.flatnonzero(np.diff(col.astype(int)))
        durations += list(np.diff(edges)[::2] * DT) if col[0] == 0 else []
    hours_attentive = (~eyes).sum() * DT / 3600
    assert starts / hours_attentive == pytest.approx(120.0, rel=0.15)  # rate per attentive hour
    assert np.median(durations) == pytest.approx(1.2, rel=0.1)
    assert np.mean(np.array(durations) > 2.0) == pytest.approx(0.15, abs=0.04)
    # Slot 0's episodes do not depend on the other slots (pairing of FCW off and on).
    alone = distracted(n=1, rate=120.0, seed=4)
    for k in range(6000):
        alone.step(np.zeros(1), frame(k * DT, 1, range_rate=+1.0))
        assert alone.eyes_off[0] == eyes[k, 0]


@pytest.mark.parametrize(
    "fields, match",
    [
        ({"rate": -1.0}, "driver.distraction.rate"),
        ({"rate": float("nan")}, "driver.distraction.rate"),
        ({"duration_median": 0.0}, "duration_median"),
        ({"duration_range": (2.0, 1.0)}, "duration_range"),
    ],
)
def test_bad_distraction_settings_are_one_line_errors(fields, match):
    with pytest.raises(ConfigError, match=match):
        DistractionConfig(**fields)


def test_a_held_scripted_ego_keeps_its_speed_instead_of_following_its_idm():
    free, held = (make_scenario("stop_and_go", 3, seed=2) for _ in range(2))
    v0 = held.frame().ego_speed.copy()
    for _ in range(100):
        f_free = free.advance()
        f_held = held.advance(None, np.ones(3, dtype=bool))
    np.testing.assert_allclose(f_held.ego_speed, v0)
    assert np.abs(f_free.ego_speed - v0).max() > 1.0  # its IDM would have changed speed


def test_an_attentive_driver_who_sees_threats_brakes_by_himself():
    sees = Driver(2, DriverConfig(sees_threats=True), seed=1)
    blind = Driver(2, DriverConfig(), seed=1)
    threat = np.array([True, False])
    for k in range(40):
        f = frame(k * DT, 2)
        b_sees, b_blind = sees.step(np.zeros(2), f, threat), blind.step(np.zeros(2), f, threat)
    assert b_sees[0] == sees.deceleration[0] and b_sees[1] == 0.0
    assert (b_blind == 0).all()


def test_a_driver_who_judges_brakes_for_a_warning_only_in_a_crash_relevant_situation():
    cfg = DriverConfig(react_to_level=1, brakes_only_for_threats=True)
    d = Driver(2, cfg, seed=1)
    threat = np.array([True, False])
    for k in range(40):  # both warned from the start; only run 0 is in danger
        brake = d.step(np.ones(2), frame(k * DT, 2), threat)
    assert brake[0] == d.deceleration[0] and brake[1] == 0.0


def test_the_scripted_comparison_with_a_human_driver_pairs_runs(tmp_path, capsys):
    args = ["compare", "--runs", "20", "--distraction", "120", "--out", str(tmp_path)]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "brakes by himself for a crash-relevant situation" in out
    data = json.loads((tmp_path / "compare.json").read_text())
    assert data["benefit"]["crashes_off"] == data["collisions"]["off"]
    assert data["benefit"]["crashes_on"] == data["collisions"]["on"]


def test_the_paired_benefit_and_its_interval():
    rng = np.random.default_rng(0)
    off = {i: 10.0 for i in range(1000) if rng.random() < 0.1}
    on = {i: 5.0 for i in off if rng.random() < 0.5}
    b = paired_benefit(range(1000), off, on, 2000.0, 2000.0)
    assert b.reduction == pytest.approx(1 - len(on) / len(off))
    assert b.reduction_lo < b.reduction < b.reduction_hi
    assert 0.3 < b.reduction_lo and b.reduction_hi < 0.7
    assert b.avoided == len(off) - len(on) and b.mitigated == len(on) and b.introduced == 0
    new = paired_benefit(range(1000), off, {**on, 5000: 1.0}, 2000.0, 2000.0)
    assert new.introduced == 1 and new.vehicles == 1001
    assert b.per_million_km_off == pytest.approx(len(off) / 2000.0 * 1e6)
    same = paired_benefit(range(1000), off, off, 2000.0, 2000.0)
    assert same.reduction == same.reduction_lo == same.reduction_hi == 0.0
    none = paired_benefit(range(10), {}, {}, 1.0, 1.0)
    assert np.isnan(none.reduction) and none.as_dict()["reduction"] is None


def test_the_benefit_interval_does_not_depend_on_the_hash_seed():
    code = (
        "from acc_fusion.metrics.benefit import paired_benefit\n"
        "ids = {f'v{i}' for i in range(600)}\n"
        "off = {f'v{i}': 1.0 for i in range(0, 600, 17)}\n"
        "on = {f'v{i}': 1.0 for i in range(5, 600, 19)}\n"
        "b = paired_benefit(ids, off, on, 1.0, 1.0)\n"
        "print(b.reduction_lo, b.reduction_hi)\n"
    )
    outs = {
        subprocess.run(
            [sys.executable, "-c", code],
            capture_output=True,
            text=True,
            env={**os.environ, "PYTHONHASHSEED": seed},
            check=True,
        ).stdout
        for seed in ("1", "2", "3")
    }
    assert len(outs) == 1


def test_a_driver_looks_away_only_when_the_situation_is_calm():
    """With calm_headway / calm_ttc, an episode that falls due while the driver follows
    closely or closes fast on his lead is skipped; alone on the road, or far behind and not
    closing, he looks away as often as without the gate."""
    from acc_fusion.truth.distraction import calm

    cfg = DistractionConfig(calm_headway=1.0, calm_ttc=10.0)
    speed, has = np.full(4, 20.0), np.array([True, True, True, False])
    gap, rr = np.array([10.0, 40.0, 40.0, 5.0]), np.array([0.0, 0.0, -5.0, -5.0])
    # 0.5 s headway; 2 s and not closing; 2 s but 8 s to collision; no lead
    assert calm(cfg, gap, speed, rr, has).tolist() == [False, True, False, True]
    for range_rate, gated in ((-5.0, True), (0.0, False)):  # 30 m at 20 m/s: 1.5 s headway
        free = run(distracted(rate=600.0), range_rate=range_rate, steps=600)
        calm_only = run(distracted(rate=600.0, calm_headway=1.0, calm_ttc=10.0),
                        range_rate=range_rate, steps=600)  # fmt: skip
        assert free[:, 0].any()
        # TTC 30/5 = 6 s < 10 s: never calm; not closing: the same episodes as without
        assert (not calm_only[:, 0].any()) if gated else (calm_only == free).all()
