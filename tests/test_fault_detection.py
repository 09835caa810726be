"""The fault detectors of the federated filter: each injected fault is caught within a stated
delay, and healthy data gives no detection over a fixed-seed batch of runs."""

from __future__ import annotations

import numpy as np
import pytest

from acc_fusion.fusion.config import FusionConfig
from acc_fusion.fusion.estimators import make_estimator
from acc_fusion.fusion.fdi import FDIConfig, WindowedChiSquare
from acc_fusion.sensors.faults import Fault
from acc_fusion.sensors.suite import SENSOR_NAMES, make_sensors
from acc_fusion.studies.estimation import FOLLOWING_FILTER, following_source

N_RUNS, ONSET, DT = 200, 3.0, 0.05


def isolation_trace(sensor_faults: dict, steps: int = 140, seed: int = 4) -> np.ndarray:
    """``(steps, N, S)`` isolation flags of the federated filter on car following."""
    est = make_estimator(
        FusionConfig(method="federated", filter=FOLLOWING_FILTER), SENSOR_NAMES, N_RUNS
    )
    src, sensors = following_source(N_RUNS, seed), make_sensors(seed + 1, **sensor_faults)
    frame, out = src.frame(), []
    for _ in range(steps):
        out.append(est.step([s.measure(frame) for s in sensors], frame.leader_id).isolated)
        frame = src.advance()
    return np.array(out)


def test_healthy_sensors_are_never_isolated_on_a_fixed_seed():
    assert not isolation_trace({}, steps=200).any()


@pytest.mark.parametrize(
    ("sensor", "index", "reports_per_s"), [("radar", 0, 20), ("infrared", 1, 10)]
)
def test_a_stuck_sensor_is_isolated_within_two_frozen_tests(sensor, index, reports_per_s):
    """A frozen output fails the successive-difference test at the end of the first full
    test after onset: at most 2 x 2K reports (K = 5 pairs), 1 s of radar, 2 s of infrared."""
    trace = isolation_trace({f"{sensor}_faults": (Fault("stuck", start=ONSET),)})
    limit = int(round((ONSET + 4 * FDIConfig().stuck_pairs / reports_per_s) / DT))
    onset = int(round(ONSET / DT))
    assert not trace[:onset].any()
    assert trace[limit, :, index].all()  # every run
    assert not trace[limit:, :, 1 - index].any()  # the healthy sensor stays in


def test_the_frozen_test_flags_exact_repeats_and_passes_noise():
    fdi = WindowedChiSquare(2, 1, FDIConfig())
    rng = np.random.default_rng(0)
    r = np.tile(np.diag([0.0625, 0.0144]), (1, 2, 1, 1))
    for _ in range(2 * FDIConfig().stuck_pairs):
        z = np.empty((1, 2, 2))
        z[0, 0] = [20.0, 0.1]  # pair 0 repeats one value
        z[0, 1] = [20.0, 0.1] + rng.normal(0.0, [0.25, 0.12])  # pair 1 is noisy
        fdi.step(np.ones((2, 1)), np.ones((2, 1), dtype=bool), z, r)
    assert fdi.frozen[0, 0] and fdi.isolated[0, 0]
    assert not fdi.frozen[1, 0] and not fdi.isolated[1, 0]


def test_two_disagreeing_reports_beyond_the_gate_are_not_a_common_cause():
    """Both sensors fail the gate at one step: the common-cause rule uses them only when they
    agree with each other (a manoeuvre), not when they disagree (two spikes)."""
    fdi = WindowedChiSquare(2, 2, FDIConfig())
    nis = np.full((2, 2), 40.0)
    reported = np.ones((2, 2), dtype=bool)
    r = np.tile(np.diag([0.0625, 0.25]), (2, 2, 1, 1))
    z = np.zeros((2, 2, 2))
    z[:, 0] = [30.0, -2.0]  # pair 0: both report the same (the lead braked)
    z[0, 1], z[1, 1] = [0.0, -7.6], [29.4, 8.8]  # pair 1: two unrelated spikes
    accepted, _, _ = fdi.step(nis, reported, z, r)
    assert accepted[0].all() and not accepted[1].any()
