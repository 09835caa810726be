"""AEB on the test track: FMVSS 127's lead-vehicle and false-activation tests and Euro NCAP's
Car-to-Car rear tests, run in the 2-D world and judged as the rule and the protocol judge.

Every test point is one run of a batch (:class:`~acc_fusion.truth.procedures.ProcedureSource`):
the subject vehicle (the ego) holds its test speed with the whole pipeline on it — radar and
thermal camera, their trackers, association, the method's estimator, in-path selection, the
warning and AEB (:mod:`acc_fusion.braking.aeb`, enabled whatever ``config.aeb.enabled`` says:
these are AEB tests).  Points whose procedure has the driver brake after the warning run as a
second batch with a robot driver (:func:`robot_driver`): FMVSS 127's manual braking (1.0 s
after the FCW onset at 0.4 g), Euro NCAP's FCW tests (1.2 s at 4 m/s²).

FMVSS 127 (:func:`fmvss127`): a lead-vehicle trial passes with no contact; a false-activation
trial passes when AEB's peak deceleration beyond the manual braking stays below 0.25 g
(:data:`FALSE_ACTIVATION_LIMIT`); a test point passes when all its trials pass (the rule
requires each trial to meet the requirement).  Euro NCAP (:func:`euroncap_aeb`): one trial per
grid point, scored by :mod:`acc_fusion.metrics.euroncap`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from acc_fusion.core.levels import IMMINENT
from acc_fusion.core.units import KMH, G
from acc_fusion.metrics.euroncap import (
    FCW_DECELERATION,
    FCW_REACTION_TIME,
    CCRPoint,
    EuroNcapScore,
    assessment_speed,
    ccr_grid,
    score,
)
from acc_fusion.sim.closed_loop import SimConfig, StepView
from acc_fusion.sim.hooks import BrakingRecord
from acc_fusion.sim.world import simulate_world
from acc_fusion.truth.driver import DriverConfig
from acc_fusion.truth.procedures import (
    MANUAL_BRAKE_DECEL,
    MANUAL_BRAKE_DELAY,
    ProcedureSource,
    TestPoint,
    decelerating_lead,
    fmvss127_points,
    slower_lead,
    stopped_lead,
)

#: FMVSS 127's false-activation limit: AEB's peak deceleration beyond the manual braking's
#: must stay below 0.25 g [m/s²].
FALSE_ACTIVATION_LIMIT = 0.25 * G
#: The kinds of test point that are false-activation tests.
FALSE_ACTIVATION_KINDS = ("plate", "pass_through")


def robot_driver(reaction_time: float, deceleration: float) -> DriverConfig:
    """A test robot: it brakes ``reaction_time`` [s] after the FCW onset (the imminent level),
    at ``deceleration`` [m/s²], and holds the brake until the ego stops; no spread."""
    return DriverConfig(
        reaction_time_median=reaction_time, reaction_time_log_sd=0.0,
        reaction_time_range=(0.5 * reaction_time, 2.0 * reaction_time),
        deceleration_mean=deceleration, deceleration_sd=0.0,
        deceleration_range=(0.5 * deceleration, 2.0 * deceleration),
        react_to_level=IMMINENT, release="stopped",
    )  # fmt: skip


@dataclass
class Trial:
    """What one trial of a test point gave: contact and the speeds at contact [m/s] (the
    ego's and the closing speed; NaN without contact), the TTC at the FCW onset [s] (NaN: no
    warning), the ego's speed when AEB first braked [m/s] (NaN: never), AEB's peak and peak
    additional deceleration [m/s²]."""

    point: TestPoint
    contact: bool
    ego_speed_at_contact: float
    closing_speed: float
    fcw_ttc: float
    speed_at_aeb: float
    peak_decel: float
    peak_additional: float

    @property
    def false_activation_test(self) -> bool:
        """Whether the trial is a false-activation test (the plate, the pass-through)."""
        return self.point.kind in FALSE_ACTIVATION_KINDS

    @property
    def passed(self) -> bool:
        """FMVSS 127's criterion: no contact (a lead test), or AEB's additional deceleration
        below :data:`FALSE_ACTIVATION_LIMIT` (a false-activation test)."""
        if self.false_activation_test:
            return self.peak_additional < FALSE_ACTIVATION_LIMIT
        return not self.contact


class _Contact(BrakingRecord):
    """:class:`BrakingRecord` plus each run's ego and lead speed at its last step with a lead
    (the speeds at contact, to within one step)."""

    def __init__(self, n_runs: int, method: str) -> None:
        super().__init__(n_runs, method, IMMINENT)
        self.ego_speed = np.full(n_runs, np.nan)
        self.lead_speed = np.full(n_runs, np.nan)

    def __call__(self, view: StepView) -> None:
        super().__call__(view)
        f = view.frame
        self.ego_speed = np.where(f.has_leader, f.ego_speed, self.ego_speed)
        self.lead_speed = np.where(f.has_leader, f.lead_speed, self.lead_speed)


def run_trials(
    points: list[TestPoint], config: SimConfig, driver: DriverConfig, *, progress: bool = False
) -> list[Trial]:
    """Run ``points`` with AEB on ``config``'s last method; the points with ``manual_brake``
    as a second batch, their ego braked by ``driver`` as well."""
    method = config.methods[-1]
    base = replace(config, methods=(method,), aeb=replace(config.aeb, enabled=True, method=None))
    trials: list[Trial | None] = [None] * len(points)
    for manual in (False, True):
        index = [i for i, p in enumerate(points) if p.manual_brake == manual]
        if not index:
            continue
        batch = [points[i] for i in index]
        cfg = replace(base, runs=len(batch), drive=method if manual else None, driver=driver)
        source = ProcedureSource(batch, dt=cfg.dt)
        record = _Contact(len(batch), method)
        simulate_world(cfg, source=source, on_step=record, progress=progress)
        closing = np.where(source.collided, source.collision_speed, np.nan)
        ego = np.where(source.collided, closing + record.lead_speed, np.nan)
        for k, i in enumerate(index):
            trials[i] = Trial(batch[k], bool(source.collided[k]), float(ego[k]),
                              float(closing[k]), float(record.ttc[k]),
                              float(record.speed_at_braking[k]), float(record.peak[k]),
                              float(record.peak_additional[k]))  # fmt: skip
    return trials


@dataclass
class Fmvss127Result:
    """Every trial of every FMVSS 127 test point (``trials[i]``: point ``i``'s trials)."""

    points: list[TestPoint]
    trials: list[list[Trial]]

    def point_passed(self, i: int) -> bool:
        """Whether point ``i`` passed: every one of its trials did."""
        return all(t.passed for t in self.trials[i])

    @property
    def passed(self) -> int:
        """Test points passed."""
        return sum(self.point_passed(i) for i in range(len(self.points)))


def fmvss127(
    config: SimConfig, trials: int = 1, *, progress: bool = False, speed_step: float = 10 * KMH
) -> Fmvss127Result:
    """Run every test point of :func:`~acc_fusion.truth.procedures.fmvss127_points` (speeds
    every ``speed_step`` [m/s]) ``trials`` times, the trials of a point with independent
    sensor noise (one batch: every run has its own draws)."""
    points = fmvss127_points(speed_step=speed_step)
    runs = [p for p in points for _ in range(trials)]
    driver = robot_driver(MANUAL_BRAKE_DELAY, MANUAL_BRAKE_DECEL)
    done = run_trials(runs, config, driver, progress=progress)
    grouped = [done[i * trials : (i + 1) * trials] for i in range(len(points))]
    return Fmvss127Result(points, grouped)


def ccr_test_point(point: CCRPoint) -> TestPoint:
    """The trial of a Euro NCAP grid point: CCRs a stopped target, CCRm a slower one, CCRb a
    decelerating one at its headway; FCW points with the robot's braking (``manual_brake``)."""
    fcw = point.mode == "fcw"
    if point.scenario == "CCRs":
        return stopped_lead(point.subject_speed, overlap=point.overlap, manual_brake=fcw)
    if point.scenario == "CCRm":
        return slower_lead(point.subject_speed, point.target_speed, overlap=point.overlap,
                           manual_brake=fcw)  # fmt: skip
    return decelerating_lead(point.subject_speed, point.headway, point.target_deceleration,
                             overlap=point.overlap, manual_brake=fcw)  # fmt: skip


@dataclass
class EuroNcapResult:
    """The grid points, their trials, the speeds the protocol scores [m/s] and the score."""

    points: tuple[CCRPoint, ...]
    trials: list[Trial]
    impact_speeds: np.ndarray
    score: EuroNcapScore


def euroncap_aeb(config: SimConfig, *, progress: bool = False) -> EuroNcapResult:
    """Run every Euro NCAP Car-to-Car rear grid point once (:func:`ccr_test_point`) and score
    them (AP §3.3.1: the ego's speed at contact in CCRs and CCRb, the closing speed in CCRm;
    0 where the contact was avoided)."""
    grid = ccr_grid()
    driver = robot_driver(FCW_REACTION_TIME, FCW_DECELERATION)
    trials = run_trials([ccr_test_point(p) for p in grid], config, driver, progress=progress)
    speeds = np.array([
        assessment_speed(p, t.ego_speed_at_contact, t.ego_speed_at_contact - t.closing_speed)
        if t.contact else 0.0
        for p, t in zip(grid, trials, strict=True)
    ])  # fmt: skip
    return EuroNcapResult(grid, trials, speeds, score(grid, speeds))
