"""Warning logic on synthetic gap sequences with known level sequences."""

from __future__ import annotations

import numpy as np
import pytest

from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.levels import CAUTION, IMMINENT, LEVEL_NAMES, NONE
from acc_fusion.warning.logic import WarningConfig, WarningLogic
from acc_fusion.warning.safety_params import MazdaParams, TTCParams

# TTC model closing at 10 m/s: d_caution = 2.0 s * 10 = 20 m, d_imminent = 1.0 s * 10 = 10 m.
TTC = TTCParams(ttc_caution=2.0, ttc_imminent=1.0)
V_EGO, V_REL = 20.0, -10.0


def config(**kw) -> WarningConfig:
    kw = {"model": "ttc", "params": TTC, "hysteresis": 0.1, "min_on_time": 0.0} | kw
    return WarningConfig(**kw)


def run(gaps, cfg=None, dt=0.1, gap_std=None, valid=None):
    """Levels of one pair fed the gap sequence ``gaps``."""
    logic = WarningLogic(cfg or config(), 1, dt)
    out = []
    for k, g in enumerate(gaps):
        std = None if gap_std is None else [gap_std[k]]
        ok = None if valid is None else np.array([valid[k]])
        out.append(int(logic.step([g], V_EGO, V_REL, gap_std=std, valid=ok)[0]))
    return out


def test_levels_and_names():
    assert (NONE, CAUTION, IMMINENT) == (0, 1, 2)
    assert LEVEL_NAMES == ("none", "caution", "imminent")


def test_raise_and_lower_through_both_levels():
    # release thresholds with 10 % hysteresis: caution 22 m, imminent 11 m
    gaps = [30, 19, 15, 9, 12, 21, 23, 30]
    assert run(gaps) == [0, 1, 1, 2, 1, 1, 0, 0]


def test_straight_to_imminent_also_raises_caution():
    assert run([30, 5, 15, 25]) == [0, 2, 1, 0]


def test_hysteresis_holds_a_warning_inside_the_band():
    gaps = [19, 21, 21.9, 22.1]
    assert run(gaps) == [1, 1, 1, 0]
    assert run(gaps, config(hysteresis=0.0)) == [1, 0, 0, 0]
    # inside the band a warning that is off is not raised either
    assert run([21, 21.9, 19.9]) == [0, 0, 1]


def test_min_on_time_holds_each_level():
    # dt = 0.1 s, hold 0.3 s: a warning raised at step 0 lasts steps 0, 1, 2 at least
    assert run([19, 30, 30, 30, 30], config(min_on_time=0.3)) == [1, 1, 1, 0, 0]
    # ... and so does a warning raised again later
    again = [19, 30, 30, 30, 19, 30, 30, 30]
    assert run(again, config(min_on_time=0.3)) == [1, 1, 1, 0, 1, 1, 1, 0]
    # imminent held 0.2 s, then caution (the gap is between 11 and 22 m), then none
    assert run([5, 15, 15, 15, 30], config(min_on_time=0.2)) == [2, 2, 1, 1, 0]
    # caution stays latched under a held imminent, then keeps its own hysteresis band:
    # at step 3 the caution alone would be lowered (30 > 22 m after its 0.3 s hold)
    held = config(min_on_time=0.3)
    assert run([19, 19, 5, 30, 21, 21, 21], held) == [1, 1, 2, 2, 2, 1, 1]
    # a hold does not extend a warning whose gap stays inside the hysteresis band
    assert run([19, 21, 21, 21, 23], config(min_on_time=0.2)) == [1, 1, 1, 1, 0]


def test_k_of_n_confirmation_delays_the_onset_by_k_minus_1_steps():
    gaps = [30, 30] + [15] * 6
    assert run(gaps) == [0, 0, 1, 1, 1, 1, 1, 1]
    assert run(gaps, config(confirm=(3, 5))) == [0, 0, 0, 0, 1, 1, 1, 1]
    assert run(gaps, config(confirm=(5, 5))) == [0, 0, 0, 0, 0, 0, 1, 1]
    # intermittent condition: the third hit within 5 steps raises, if it holds now
    assert run([15, 30, 15, 30, 15], config(confirm=(3, 5))) == [0, 0, 0, 0, 1]
    assert run([15, 15, 15, 30], config(confirm=(4, 5))) == [0, 0, 0, 0]
    # old hits alone do not re-raise a warning once the gap has opened
    assert run([15, 15, 30, 30], config(confirm=(2, 5))) == [0, 1, 0, 0]


def test_persistence_is_the_same_time_whatever_the_step():
    """The condition must hold for ``persistence`` seconds, to the nearest step: 0.2 s is
    2 more steps at 0.1 s, 4 at 0.05 s and none at 0.5 s (the nearest step is 0)."""
    gaps = [30, 30] + [15] * 8
    assert run(gaps, config(persistence=0.2), dt=0.1) == run(gaps, config(confirm=(3, 3)))
    assert run(gaps, config(persistence=0.2), dt=0.1) == [0, 0, 0, 0, 1, 1, 1, 1, 1, 1]
    fine = run([30] * 4 + [15] * 8, config(persistence=0.2), dt=0.05)
    assert fine.index(1) == 4 + 4
    assert run(gaps, config(persistence=0.2), dt=0.5) == run(gaps, config(), dt=0.5)
    # a one-step spike, the sensing-false alert it is meant to remove, raises nothing
    assert run([30, 15, 30, 30], config(persistence=0.1)) == [0, 0, 0, 0]


def test_lower_quantile_warns_earlier_with_larger_sigma():
    gaps = 40.0 - np.arange(30.0)  # closing 1 m per step

    def onset(sigma: float) -> int:
        levels = run(gaps, config(z=2.0), gap_std=np.full(30, sigma))
        return levels.index(CAUTION)

    # 40 - k - 2 sigma < 20  <=>  k > 20 - 2 sigma
    assert [onset(0.0), onset(1.0), onset(3.0)] == [21, 19, 15]
    # z = 0 ignores sigma; gap_std=None is an exact gap
    assert run(gaps, config(z=0.0), gap_std=np.full(30, 3.0)).index(CAUTION) == 21
    assert run(gaps, config(z=2.0)).index(CAUTION) == 21


def test_invalid_pairs_get_no_warning_and_lose_their_state():
    cfg = config(min_on_time=1.0)
    gaps = [19, 19, np.nan, 21, 21, 19]
    valid = [True, True, False, True, True, True]
    # without the dropout the 1 s hold and the band would keep the warning on
    assert run(gaps, cfg, valid=valid) == [1, 1, 0, 0, 0, 1]
    # confirmation history is cleared too: 2-of-2 needs two new hits after the dropout
    assert run([15, 15, np.nan, 15, 15], config(confirm=(2, 2)), valid=valid) == [0, 1, 0, 0, 1]


def test_pairs_are_independent_and_the_logic_is_deterministic():
    rng = np.random.default_rng(3)
    steps, n = 60, 4
    gaps = rng.uniform(0.0, 35.0, (steps, n))
    std = rng.uniform(0.0, 3.0, (steps, n))
    valid = rng.random((steps, n)) > 0.1
    cfg = config(min_on_time=0.2, confirm=(2, 3), z=1.0)

    def batch(logic):
        return np.array(
            [
                logic.step(gaps[k], V_EGO, V_REL, gap_std=std[k], valid=valid[k])
                for k in range(steps)
            ]
        )

    logic = WarningLogic(cfg, n, 0.1)
    together = batch(logic)
    assert together.dtype == np.int8 and set(np.unique(together)) <= {0, 1, 2}
    for i in range(n):
        alone = WarningLogic(cfg, 1, 0.1)
        single = [
            alone.step(
                gaps[k, i : i + 1],
                V_EGO,
                V_REL,
                gap_std=std[k, i : i + 1],
                valid=valid[k, i : i + 1],
            )[0]
            for k in range(steps)
        ]
        assert np.array_equal(together[:, i], single)
    assert np.array_equal(batch(WarningLogic(cfg, n, 0.1)), together)
    logic.reset()
    assert np.array_equal(batch(logic), together)


def test_reset_of_some_pairs():
    logic = WarningLogic(config(min_on_time=1.0), 3, 0.1)
    assert list(logic.step([15.0, 15.0, 5.0], V_EGO, V_REL)) == [1, 1, 2]
    logic.reset(np.array([False, True, True]))
    assert list(logic.level) == [1, 0, 0]
    assert list(logic.step([21.0, 21.0, 21.0], V_EGO, V_REL)) == [1, 0, 0]


def test_oracle_on_exact_truth_with_per_pair_kinematics():
    # Three pairs at 20 m/s: closing at 10, steady, and no leader (NaN gap).  The default
    # required-deceleration model: at 20 m/s with a lead at 10 m/s the caution distance is
    # 10*1.25 + 10²/(2*3.4) + 2.5 = 29.706, the imminent 12.5 + 10²/(2*5) + 2.5 = 25; for a
    # lead at 20 m/s both are 0 (the gap never shrinks), even at 2 m.
    logic = WarningLogic(WarningConfig(), 3, 0.05)
    gap = np.array([28.0, 50.0, np.nan])
    v_rel = np.array([-10.0, 0.0, np.nan])
    has_leader = np.array([True, True, False])
    assert list(logic.step(gap, 20.0, v_rel, valid=has_leader)) == [CAUTION, NONE, NONE]
    gap = np.array([24.0, 2.0, np.nan])
    assert list(logic.step(gap, 20.0, v_rel, valid=has_leader)) == [IMMINENT, NONE, NONE]


def test_a_large_batch_runs_on_arrays():
    n = 100_000
    logic = WarningLogic(config(confirm=(2, 4), z=1.0), n, 0.05)
    gaps = np.linspace(0.0, 40.0, n)
    for _ in range(5):
        levels = logic.step(gaps, V_EGO, V_REL, gap_std=np.full(n, 0.5))
    assert levels.shape == (n,)
    assert np.array_equal(levels, np.where(gaps < 10.5, 2, np.where(gaps < 20.5, 1, 0)))


def test_params_from_a_mapping_and_from_toml_like_config():
    cfg = WarningConfig(model="mazda", params={"tau2": 1.0})
    assert cfg.params == MazdaParams(tau2=1.0)
    cfg = from_mapping(
        WarningConfig,
        {"model": "ttc", "params": {"ttc_caution": 3.0}, "confirm": [2, 3], "z": 1.5},
    )
    assert cfg.params == TTCParams(ttc_caution=3.0) and cfg.confirm == (2, 3) and cfg.z == 1.5


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"model": "volvo"}, r"warning.model must be one of 'time_headway', 'ttc', .*'volvo'"),
        ({"params": MazdaParams()}, r"warning.params must be a TTCParams for model 'ttc'"),
        ({"params": {"tau9": 1.0}}, r"unknown key warning.params.'tau9'"),
        ({"hysteresis": -0.1}, r"warning.hysteresis must be in \[0, 10\]"),
        ({"min_on_time": -1.0}, r"warning.min_on_time must be in"),
        ({"z": -1.0}, r"warning.z must be in"),
        ({"confirm": (3, 2)}, r"warning.confirm must be None or two whole numbers"),
        ({"confirm": (0, 2)}, r"1 <= k <= n"),
        ({"confirm": (1.5, 2)}, r"warning.confirm"),
        ({"confirm": 3}, r"warning.confirm"),
        ({"persistence": -0.1}, r"warning.persistence must be in \[0, 10\]"),
        ({"persistence": 0.1, "confirm": (2, 2)}, "warning.persistence and warning.confirm"),
    ],
)
def test_bad_config_is_rejected(kw, match):
    with pytest.raises(ConfigError, match=match):
        config(**kw)


def test_bad_construction_and_inputs_are_rejected():
    with pytest.raises(ConfigError, match="n_pairs must be a whole number >= 1"):
        WarningLogic(config(), 0, 0.1)
    with pytest.raises(ConfigError, match=r"warning.dt must be in \(0, 10\]"):
        WarningLogic(config(), 2, 0.0)
    logic = WarningLogic(config(), 2, 0.1)
    with pytest.raises(InputError, match=r"gap must have shape \(2,\)"):
        logic.step([10.0], V_EGO, V_REL)
    with pytest.raises(InputError, match="gap must be finite"):
        logic.step([10.0, np.nan], V_EGO, V_REL)
    with pytest.raises(InputError, match=r"valid must be a boolean array of shape \(2,\)"):
        logic.step([10.0, 10.0], V_EGO, V_REL, valid=[1, 1])
    with pytest.raises(InputError, match="gap_std must be >= 0"):
        logic.step([10.0, 10.0], V_EGO, V_REL, gap_std=[-1.0, 0.0])
    with pytest.raises(InputError, match="v_rel must be finite"):
        logic.step([10.0, 10.0], V_EGO, [np.nan, -1.0])


def test_reset_by_indices_equals_reset_by_mask_and_clears_only_those_pairs():
    rng = np.random.default_rng(0)
    logics = [WarningLogic(WarningConfig(), 6, 0.05) for _ in range(3)]
    for _ in range(10):
        gap = rng.uniform(0.0, 30.0, 6)
        for logic in logics:
            logic.step(gap, 25.0, -8.0)
    logics[0].reset(np.array([False, True, False, False, True, False]))
    logics[1].reset(np.array([1, 4]))
    for name in ("_on", "_steps_on", "_history", "_count"):
        assert np.array_equal(getattr(logics[0], name), getattr(logics[1], name))
    kept = np.array([True, False, True, True, False, True])
    assert np.array_equal(logics[0].level[kept], logics[2].level[kept])
    assert (logics[0].level[~kept] == NONE).all()
    assert (logics[2].level[~kept] != NONE).any()


def test_no_warning_below_the_minimum_speed():
    """A queue creeping at 2 m/s with the gap under the margin: off below ``min_speed``,
    on at the same gap and closing speed above it; 10 km/h itself warns."""
    logic = WarningLogic(WarningConfig(), 3, 0.1)
    v_ego = np.array([2.0, 3.0, 10.0 / 3.6])
    assert list(logic.step([1.5] * 3, v_ego, -0.5)) == [NONE, IMMINENT, IMMINENT]
    slow = WarningLogic(WarningConfig(min_speed=0.0), 1, 0.1)
    assert list(slow.step([1.5], 2.0, -0.5)) == [IMMINENT]


def test_slowing_below_the_minimum_speed_clears_a_held_warning():
    """A level held by ``min_on_time`` drops at once below ``min_speed``, and its state is
    cleared: back above it with nothing to warn about, it does not come back."""
    logic = WarningLogic(WarningConfig(min_on_time=1.0), 1, 0.1)
    assert list(logic.step([1.5], 3.0, -0.5)) == [IMMINENT]
    assert list(logic.step([1.5], 3.0, 1.0)) == [IMMINENT]  # held: the gap opens
    assert list(logic.step([1.5], 2.0, 1.0)) == [NONE]  # below 10 km/h
    assert list(logic.step([1.5], 3.0, 1.0)) == [NONE]  # the hold did not survive


def test_no_level_where_no_distance_is_needed_even_on_a_negative_lower_quantile():
    """An opening range (distance 0) with a gap estimate so uncertain that its lower
    quantile is below 0: no warning."""
    logic = WarningLogic(WarningConfig(z=1.0), 1, 0.1)
    assert list(logic.step([1.0], 20.0, 2.0, gap_std=[2.0])) == [NONE]
    assert list(logic.step([1.0], 20.0, -2.0, gap_std=[2.0])) == [IMMINENT]
    with pytest.raises(ConfigError, match=r"warning.min_speed must be in \[0, 100\]"):
        WarningConfig(min_speed=-1.0)
