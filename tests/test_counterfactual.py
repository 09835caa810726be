"""The crashes FCW avoids, replayed crash by crash (issue 26): the replay's rules on built
conflicts, and its kinematics against SUMO's own."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from acc_fusion.metrics.counterfactual import (
    ConflictRecord,
    braking_step,
    counterfactual_benefit,
    replay,
)
from acc_fusion.truth.driver import DriverConfig

DT = 0.1
JUDGED = DriverConfig(react_to_level=2, brakes_only_for_threats=True)


def conflict(warn_at: float | None, *, v=20.0, gap0=40.0, own_brake_at=None, level0=0):
    """A distracted follower at ``v`` holding his speed towards a stopped car ``gap0`` ahead
    (crash-relevant from the start), warned (level 2) from ``warn_at``; reaction 1.0 s,
    deceleration 6 m/s²; the record ends the step before contact."""
    t = np.arange(0.0, gap0 / v - DT - 1e-9, DT)
    n = t.size
    level = np.full(n, level0, dtype=np.int8)
    if warn_at is not None:
        level[t >= warn_at - 1e-9] = 2
    braking = np.zeros(n, bool) if own_brake_at is None else t >= own_brake_at - 1e-9
    return ConflictRecord(
        t=t,
        gap=gap0 - v * (t + DT),  # Euler: the position advances by the new speed
        ego_speed=np.full(n, v),
        lead_speed=np.zeros(n),
        lead_accel=np.zeros(n),
        relevant=np.ones(n, bool),
        levels={"federated": level},
        braking=braking,
        reacting=np.zeros(n, bool),
        reaction_time=1.0,
        deceleration=6.0,
        impact_speed=v,
    )


def test_an_early_warning_avoids_the_crash_and_a_late_one_only_mitigates_it():
    # Braking from 20 m/s at 6 m/s² needs 33.3 m; warned at 0.1 s he brakes at 1.1 s, with
    # 40 - 20·1.2 = 16 m left (60 m: 36 m, enough), so he hits at sqrt(20² - 2·6·16) =
    # 14.4 m/s (14.0 in Euler steps of 0.1 s).
    assert np.isnan(replay(conflict(0.1, gap0=60.0), "federated", JUDGED))
    hit = replay(conflict(0.1), "federated", JUDGED)
    assert 13.5 < hit < 15.0
    assert replay(conflict(1.5), "federated", JUDGED) == pytest.approx(20.0)  # too late
    assert replay(conflict(None), "federated", JUDGED) == 20.0  # never warned


def test_the_replay_changes_nothing_when_the_driver_would_have_braked_as_early():
    rec = conflict(0.5, gap0=60.0, own_brake_at=1.0)
    assert braking_step(rec, "federated", JUDGED) is None  # his own look-back came first
    assert replay(rec, "federated", JUDGED) == rec.impact_speed
    earlier = conflict(0.5, gap0=60.0, own_brake_at=2.0)
    assert braking_step(earlier, "federated", JUDGED) == 15


def test_a_warning_already_on_when_the_record_begins_is_not_an_onset():
    rec = conflict(0.1, gap0=60.0, level0=2)  # the level was up before the record
    assert braking_step(rec, "federated", JUDGED) is None
    assert replay(rec, "federated", JUDGED) == rec.impact_speed


def test_a_judging_driver_who_sees_no_threat_yet_brakes_a_reaction_after_its_onset():
    rec = conflict(0.1, gap0=80.0)
    later = replace(rec, relevant=rec.t >= 2.0 - 1e-9)
    assert braking_step(later, "federated", JUDGED) == 30  # onset 2.0 s + 1.0 s
    every = replace(JUDGED, brakes_only_for_threats=False)
    assert braking_step(later, "federated", every) == 11  # 0.1 s + 1.0 s, threat or not


def test_the_replayed_benefit_counts_avoided_and_mitigated_crashes_with_wilson():
    records = [conflict(0.1, gap0=60.0)] * 6 + [conflict(0.1)] * 2 + [conflict(None)] * 2
    b = counterfactual_benefit(records, "federated", JUDGED, 1000.0)
    assert (b.crashes_off, b.crashes_on, b.avoided, b.mitigated, b.introduced) == (10, 4, 6, 2, 0)
    assert b.reduction == 0.6 and 0.3 < b.reduction_lo < 0.6 < b.reduction_hi < 0.9
    assert b.per_million_km_off == 1e4 and b.per_million_km_on == 4e3


@pytest.mark.slow
def test_sumo_applies_a_drivers_braking_as_the_replay_integrates_it():
    """In SUMO's FCW-off run, a driver braking after his episode loses d·Δt of speed a step
    and the gap changes by (v_lead - v)·Δt (Euler with the new speeds), which is what the
    replay assumes; and each crash has its record."""
    pytest.importorskip("libsumo")
    from acc_fusion.sim.closed_loop import SimConfig
    from acc_fusion.studies.traffic import _run
    from acc_fusion.truth.distraction import DistractionConfig
    from acc_fusion.truth.sumo.config import SumoConfig
    from acc_fusion.truth.sumo.nets import bundled_nets

    cfg = SumoConfig(str(bundled_nets()["onramp"]), end=120.0, hazard_rate=30.0)
    driver = replace(JUDGED, distraction=DistractionConfig(rate=600.0))
    sim = SimConfig(runs=1, methods=("radar", "federated"), drive="federated", driver=driver)
    run = _run(cfg, sim, progress=False, cross_check=False, warnings_on=False)
    assert len(run.conflicts) == len(run.crashes) >= 3
    checked = 0
    for rec in run.conflicts:
        assert set(rec.levels) == {"radar", "federated"} and rec.t.size >= 2
        assert np.allclose(np.diff(rec.t), 0.1)
        ks = np.flatnonzero(rec.braking[:-1] & rec.braking[1:])
        for k in ks:
            if rec.ego_speed[k] <= rec.lead_speed[k] or rec.ego_speed[k] < 1.0:
                continue  # released, or about to stop
            assert rec.ego_speed[k + 1] == pytest.approx(
                rec.ego_speed[k] - rec.deceleration * 0.1, abs=1e-6
            )
            step = rec.gap[k + 1] - rec.gap[k]
            if abs(step) < 5.0:  # the same leader
                expected = (rec.lead_speed[k + 1] - rec.ego_speed[k + 1]) * 0.1
                assert step == pytest.approx(expected, abs=0.05)
            checked += 1
    assert checked >= 5
