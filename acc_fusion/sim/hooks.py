"""Hooks for the ``on_step`` callback of :func:`acc_fusion.sim.closed_loop.simulate`: a run's
trace step by step (:class:`Trace`), the true TTC at each run's first warning
(:class:`FirstWarning`) and what AEB did in each run (:class:`BrakingRecord`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from acc_fusion.sim.closed_loop import StepView
from acc_fusion.warning.kinematics import time_to_collision_braking_lead
from acc_fusion.warning.logic import WarningConfig
from acc_fusion.warning.safety import safety_distances


@dataclass
class Trace:
    """What happened to one run, step by step (for the ``run`` command's plot and CSV)."""

    warning: WarningConfig
    run: int = 0
    rows: list[dict] = field(default_factory=list)

    def __call__(self, view: StepView) -> None:
        i, frame = self.run, view.frame
        has = bool(frame.has_leader[i])
        d_caution, d_imminent = safety_distances(
            self.warning.model,
            frame.ego_speed[i : i + 1],
            frame.range_rate[i : i + 1] if has else np.zeros(1),
            frame.lead_accel[i : i + 1] if has else np.zeros(1),
            self.warning.params,
        )
        row = {
            "t": frame.t,
            "gap": frame.gap[i] if has else np.nan,
            "range_rate": frame.range_rate[i] if has else np.nan,
            "ego_speed": frame.ego_speed[i],
            "ttc": view.ttc[i],
            "oracle_level": int(view.oracle[i]),
            "crash_relevant": bool(view.relevant[i]),
            "d_caution": d_caution[0] if has else np.nan,
            "d_imminent": d_imminent[0] if has else np.nan,
        }
        for m in view.measurements:
            row[f"{m.sensor}_range"] = m.z[i, 0] if m.valid[i] else np.nan
            row[f"{m.sensor}_range_rate"] = m.z[i, 1] if m.valid[i] else np.nan
        for name, est in view.estimates.items():
            ok = est.valid[i]
            row[f"{name}_gap"] = est.gap[i] if ok else np.nan
            row[f"{name}_gap_std"] = est.gap_std[i] if ok else np.nan
            row[f"{name}_level"] = int(view.levels[name][i])
        self.rows.append(row)


class FirstWarning:
    """Records, per run, the true TTC at the onset of the first warning of ``method``, judged
    as NHTSA's FCW confirmation test (2013) judges it: the lead keeping its deceleration to a
    stop (:func:`~acc_fusion.warning.kinematics.time_to_collision_braking_lead`; the
    constant-speed TTC where the lead does not brake)."""

    def __init__(self, n_runs: int, method: str, level: int) -> None:
        self.method, self.level = method, level
        self.ttc = np.full(n_runs, np.nan)

    def __call__(self, view: StepView) -> None:
        new = np.isnan(self.ttc) & (view.levels[self.method] >= self.level)
        if new.any():
            f = view.frame
            has = f.has_leader
            ttc = time_to_collision_braking_lead(
                np.where(has, f.gap, 1.0), f.ego_speed, np.where(has, f.lead_speed, 0.0),
                np.where(has, f.lead_accel, 0.0),
            )  # fmt: skip
            self.ttc[new] = np.where(has, ttc, np.inf)[new]


class BrakingRecord(FirstWarning):
    """Per run, besides :class:`FirstWarning`'s TTC at the first warning: the time of that
    warning and of AEB's first activation [s] (NaN: none), AEB's peak deceleration and its
    peak *additional* deceleration over the driver's braking [m/s²] (the quantity FMVSS 127's
    false-activation tests limit), and the ego's speed at the first activation [m/s]."""

    def __init__(self, n_runs: int, method: str, level: int) -> None:
        super().__init__(n_runs, method, level)
        self.warned_at = np.full(n_runs, np.nan)
        self.braked_at = np.full(n_runs, np.nan)
        self.speed_at_braking = np.full(n_runs, np.nan)
        self.peak = np.zeros(n_runs)
        self.peak_additional = np.zeros(n_runs)

    def __call__(self, view: StepView) -> None:
        new = np.isnan(self.warned_at) & (view.levels[self.method] >= self.level)
        self.warned_at[new] = view.frame.t
        super().__call__(view)
        if view.aeb is None:
            return
        aeb, n = view.aeb, view.frame.n_pairs
        driver = np.zeros(n)
        if view.driver is not None:
            driver = np.where(view.driver.braking, view.driver.deceleration, 0.0)[:n]
        first = np.isnan(self.braked_at[:n]) & (aeb.stage[:n] > 0)
        self.braked_at[:n][first] = view.frame.t
        self.speed_at_braking[:n][first] = view.frame.ego_speed[first]
        self.peak[:n] = np.maximum(self.peak[:n], aeb.decel[:n])
        extra = np.maximum(aeb.decel[:n] - driver, 0.0)
        self.peak_additional[:n] = np.maximum(self.peak_additional[:n], extra)
