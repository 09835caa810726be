"""Reproducible estimation studies: the papers' set-ups and the fusion-method comparisons.

Each study is a function returning a :class:`Table` (rows of named values), shared by the
scripts under ``scripts/``, the CLI and the tests, so a figure quoted anywhere comes from one
piece of code.  Monte Carlo runs are independent pairs of one batch (the estimators are
batched over pairs), so hundreds of runs cost little more than one.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.table import Table
from acc_fusion.core.validation import check_range
from acc_fusion.filters import kalman
from acc_fusion.fusion.config import FilterConfig, FusionConfig
from acc_fusion.fusion.estimators import make_estimator
from acc_fusion.fusion.fdi import FDIConfig
from acc_fusion.sensors.faults import Fault
from acc_fusion.sensors.spec import infrared_spec, radar_spec
from acc_fusion.sensors.suite import SENSOR_NAMES, make_sensors
from acc_fusion.sim.estimation import chi2_mean_bounds, run_estimation
from acc_fusion.truth.frame import LinearGaussianSource

#: Relative-jerk std of the car-following studies [m/s³]: the truth and the filters share it.
FOLLOWING_JERK = 0.5
#: The estimation study's step [s], the time its errors are scored from [s] (the filters
#: converge before), and its bounds: runs, and the seconds of a run.
STEP = 0.05
SCORE_FROM = 1.0
MAX_RUNS = 1_000_000
MAX_DURATION = 3600.0
FOLLOWING_FILTER = FilterConfig(jerk_std=FOLLOWING_JERK)
#: The fault detector of the studies unless told otherwise (the default one).
DEFAULT_FDI = FDIConfig()


def kong2011(
    n_runs: int = 200,
    duration: float = 30.0,
    seed: int = 0,
    engine: str = "batched",
    on_step: Callable | None = None,
) -> Table:
    """kong2011's simulation: a target at 3 m/s observed by radar and infrared, T = 1 s.

    The target closes on the (stationary) sensor platform at 3 m/s from 100 m with small
    zero-mean Gaussian process noise; both sensors sample once per second with their default
    noise (the paper gives no noise figures).  Over ``n_runs`` Monte Carlo runs the table
    gives the RMSE of each raw sensor, each local Kalman filter and the federated fusion.
    The paper's claims: each local filter beats its raw sensor; the fused estimate beats both.
    ``on_step`` is passed to :func:`~acc_fusion.sim.estimation.run_estimation` (for plots).
    """
    dt = 1.0
    fc = FusionConfig(
        engine=engine, fdi=None, filter=FilterConfig(dt=dt, jerk_std=0.01, max_coast=3.0)
    )
    src = LinearGaussianSource(
        n_runs,
        dt=dt,
        jerk_std=0.01,
        x0=(100.0, -3.0, 0.0),
        x0_std=(2.0, 0.2, 0.05),
        ego_speed=0.0,
        seed=seed,
    )
    sensors = make_sensors(seed + 1, radar_spec(rate_hz=1.0), infrared_spec(rate_hz=1.0))
    ests = {
        "radar KF": make_estimator(replace(fc, method="radar"), SENSOR_NAMES, n_runs),
        "infrared KF": make_estimator(replace(fc, method="infrared"), SENSOR_NAMES, n_runs),
        "federated": make_estimator(replace(fc, method="federated"), SENSOR_NAMES, n_runs),
    }
    res = run_estimation(src, sensors, ests, int(round(duration / dt)), on_step=on_step)
    table = Table(
        f"kong2011 set-up: target closing at 3 m/s, T = 1 s, {n_runs} Monte Carlo runs",
        ("estimate", "rmse_gap_m", "rmse_rate_mps"),
    )
    for name in SENSOR_NAMES:
        raw = res.raw[name]
        table.rows.append(
            {"estimate": f"{name} raw", "rmse_gap_m": raw.rmse_gap, "rmse_rate_mps": raw.rmse_rate}
        )
    for name, st in res.estimators.items():
        table.rows.append(
            {"estimate": name, "rmse_gap_m": st.rmse_gap, "rmse_rate_mps": st.rmse_rate}
        )
    return table


#: Fault scenarios of :func:`fault_tolerance` (active from 3 s to 8 s of a 10 s run).
FAULT_SCENARIOS: dict[str, dict[str, tuple[Fault, ...]]] = {
    "healthy": {},
    "infrared stuck": {"infrared_faults": (Fault("stuck", start=3.0, end=8.0),)},
    "radar bias +5 m": {"radar_faults": (Fault("bias", start=3.0, end=8.0, magnitude=5.0),)},
    "2% spikes": {
        "radar_faults": (
            Fault(
                "spikes", start=3.0, end=8.0, magnitude=10.0, rate_magnitude=5.0, probability=0.02
            ),
        ),
        "infrared_faults": (
            Fault(
                "spikes", start=3.0, end=8.0, magnitude=10.0, rate_magnitude=5.0, probability=0.02
            ),
        ),
    },
}


def following_source(n_runs: int, seed: int, gap: float = 20.0) -> LinearGaussianSource:
    """Car following at ``gap`` ± 3 m with mild relative manoeuvres (jerk 0.5 m/s³), 20 Hz."""
    return LinearGaussianSource(
        n_runs,
        dt=0.05,
        jerk_std=FOLLOWING_JERK,
        x0=(gap, 0.0, 0.0),
        x0_std=(3.0, 0.3, 0.0),
        ego_speed=25.0,
        seed=seed,
    )


def lasting_bias(
    n_runs: int,
    seed: int,
    bias_end: float,
    bias_reports: int,
    steps: int = 600,
    fdi: FDIConfig = DEFAULT_FDI,
) -> tuple:
    """Car following at 25 ± 3 m (slow relative motion, so the gap stays in the camera's
    range), the radar biased by +5 m from 3 s to ``bias_end``, federated filter with the
    fault detector ``fdi`` and ``fdi.bias_reports = bias_reports`` (0: no bias
    accommodation): ``(estimator, errors)``, the estimator after ``steps`` steps of 0.05 s
    and the fused gap errors ``(steps, N)``."""
    fdi = replace(fdi, bias_reports=bias_reports)
    cfg = FusionConfig(method="federated", filter=FOLLOWING_FILTER, fdi=fdi)
    est = make_estimator(cfg, SENSOR_NAMES, n_runs)
    src = LinearGaussianSource(
        n_runs, dt=0.05, jerk_std=0.05, x0=(25.0, 0.0, 0.0), x0_std=(3.0, 0.05, 0.0), seed=seed
    )
    sensors = make_sensors(seed + 1, radar_faults=(Fault("bias", 3.0, bias_end, magnitude=5.0),))
    frame, errors = src.frame(), []
    for _ in range(steps):
        e = est.step([s.measure(frame) for s in sensors], frame.leader_id)
        errors.append(e.x[:, 0] - frame.gap)
        frame = src.advance()
    return est, np.array(errors)


def wrong_sensor_runs(errors: np.ndarray, last: int = 100, off: float = 2.0) -> int:
    """Runs of :func:`lasting_bias` (``errors (steps, N)``) whose fused gap is still more than
    ``off`` metres wrong on average over the ``last`` steps: with a +5 m radar bias, runs
    that blamed the healthy camera (isolated it, or corrected it for the radar's bias) and
    kept the biased radar.  Two sensors of
    one quantity detect a fault by disagreeing but cannot always say which one is wrong; a
    third would outvote it (Isermann 2006, *Fault-Diagnosis Systems*, hardware redundancy)."""
    return int((np.abs(errors[-last:]).mean(axis=0) > off).sum())


def lasting_bias_table(n_runs: int = 200, seed: int = 4, fdi: FDIConfig = DEFAULT_FDI) -> Table:
    """A +5 m radar bias from 3 s to the end of 30 s runs (:func:`lasting_bias`, fault
    detector ``fdi``), with the bias accommodation of :mod:`acc_fusion.fusion.bias` (unless
    ``fdi.bias_reports`` is 0) and without: the share of runs whose radar is back in the
    fusion, corrected, at 30 s, the runs that blamed the camera (:func:`wrong_sensor_runs`)
    and the median fused gap error from 15 to 30 s."""
    t = Table(
        f"Lasting radar bias +5 m from 3 s, {n_runs} runs of 30 s, car following at 25 m",
        ("bias_accommodation", "radar_back_corrected", "camera_blamed_runs",
         "median_gap_error_15_30s_m"),
    )  # fmt: skip
    rows = (("on", fdi.bias_reports), ("off", 0)) if fdi.bias_reports else (("off", 0),)
    for label, reports in rows:
        est, errors = lasting_bias(n_runs, seed, np.inf, reports, fdi=fdi)
        back = est.fdi.bias_corrected[:, 0] & ~est.fdi.isolated[:, 0]
        t.rows.append({
            "bias_accommodation": label,
            "radar_back_corrected": float(back.mean()),
            "camera_blamed_runs": wrong_sensor_runs(errors),
            "median_gap_error_15_30s_m": float(np.median(np.abs(errors[300:]))),
        })  # fmt: skip
    return t


def fault_tolerance(
    n_runs: int = 200, duration: float = 10.0, seed: int = 0, engine: str = "batched"
) -> Table:
    """Fused-gap RMSE of federated fusion with fault isolation vs the centralized filter.

    The same truth and noise for every scenario of :data:`FAULT_SCENARIOS`; the ratio column
    is each method's RMSE over its healthy RMSE.
    """
    methods = {
        "federated+FDI": FusionConfig(method="federated", engine=engine, filter=FOLLOWING_FILTER),
        "centralized": FusionConfig(method="centralized", engine=engine, filter=FOLLOWING_FILTER),
    }
    table = Table(
        f"Fault tolerance: fused gap RMSE, {n_runs} runs of {duration:g} s, faults active 3-8 s",
        ("fault", "method", "rmse_gap_m", "ratio_to_healthy", "isolated_frac"),
    )
    healthy: dict[str, float] = {}
    for fault, kwargs in FAULT_SCENARIOS.items():
        ests = {m: make_estimator(c, SENSOR_NAMES, n_runs) for m, c in methods.items()}
        iso = {"n": 0, "k": 0}

        def count_isolation(frame, meas, out, iso=iso):
            if 3.0 <= frame.t < 8.0:
                iso["n"] += int(out["federated+FDI"].isolated.sum())
                iso["k"] += out["federated+FDI"].isolated.size

        res = run_estimation(
            following_source(n_runs, seed),
            make_sensors(seed + 1, **kwargs),
            ests,
            int(round(duration / 0.05)),
            score_from=SCORE_FROM,
            on_step=count_isolation,
        )
        for m, st in res.estimators.items():
            healthy.setdefault(m, st.rmse_gap)
            table.rows.append(
                {
                    "fault": fault,
                    "method": m,
                    "rmse_gap_m": st.rmse_gap,
                    "ratio_to_healthy": st.rmse_gap / healthy[m],
                    "isolated_frac": iso["n"] / max(iso["k"], 1) if m == "federated+FDI" else "-",
                }
            )
    return table


class _Timed:
    """Wraps an estimator and adds the wall time of its ``step`` calls to ``timers[label]``."""

    def __init__(self, est, timers: dict[str, float], label: str) -> None:
        self.est, self.timers, self.label = est, timers, label

    def step(self, meas, target):
        t0 = time.perf_counter()
        out = self.est.step(meas, target)
        self.timers[self.label] += time.perf_counter() - t0
        return out


#: Methods of :func:`compare_methods`: label -> FusionConfig overrides.
COMPARED_METHODS: dict[str, dict] = {
    "radar alone": {"method": "radar"},
    "infrared alone": {"method": "infrared"},
    "centralized (sequential)": {"method": "centralized"},
    "centralized (stacked)": {"method": "centralized_stacked"},
    "federated fusion-reset": {"method": "federated", "reset": "fusion", "fdi": None},
    "federated zero-reset": {"method": "federated", "reset": "zero", "fdi": None},
    "federated no-reset": {"method": "federated", "reset": "none", "fdi": None},
    "federated + FDI": {"method": "federated"},
    "plain formula (no beta)": {"method": "plain"},
}


def compare_methods(
    n_runs: int = 500, duration: float = 10.0, seed: int = 0, engine: str = "batched"
) -> Table:
    """Federated fusion against its baselines on the same truth and measurements.

    Car following with the default radar (20 Hz) and infrared (10 Hz) sensors; per method:
    RMSE of gap and range-rate, mean NEES with its 95 % bounds (3 for a consistent filter),
    and the cost per pair-step.  ``n_runs`` is at most :data:`MAX_RUNS` and ``duration`` in
    (:data:`SCORE_FROM`, :data:`MAX_DURATION`] s (else one :class:`ConfigError`), so that
    something is scored and the run ends.
    """
    if not isinstance(n_runs, int) or not 1 <= n_runs <= MAX_RUNS:
        raise ConfigError(f"runs must be a whole number in [1, {MAX_RUNS}], got {n_runs!r}")
    check_range("duration", duration, SCORE_FROM + STEP, MAX_DURATION)
    ests = {
        label: make_estimator(
            FusionConfig(engine=engine, filter=FOLLOWING_FILTER, **kw), SENSOR_NAMES, n_runs
        )
        for label, kw in COMPARED_METHODS.items()
    }
    timers = dict.fromkeys(ests, 0.0)
    kalman.warmup()
    n_steps = int(round(duration / STEP))
    res = run_estimation(
        following_source(n_runs, seed),
        make_sensors(seed + 1),
        {label: _Timed(e, timers, label) for label, e in ests.items()},
        n_steps,
        score_from=SCORE_FROM,
    )
    lo, hi = chi2_mean_bounds(3, n_runs)
    table = Table(
        f"Federated fusion vs baselines: car following, {n_runs} runs x {duration:g} s, "
        "radar 20 Hz + infrared 10 Hz",
        ("method", "rmse_gap_m", "rmse_rate_mps", "mean_nees", "nees_verdict", "us_per_pair_step"),
        notes=[f"NEES 95% bounds for {n_runs} runs: [{lo:.3f}, {hi:.3f}] (3 = consistent)"],
    )
    for label, st in res.estimators.items():
        nees = st.mean_nees
        verdict = (
            "consistent"
            if lo <= nees <= hi
            else ("conservative" if nees < lo else "over-confident")
        )
        table.rows.append(
            {
                "method": label,
                "rmse_gap_m": st.rmse_gap,
                "rmse_rate_mps": st.rmse_rate,
                "mean_nees": nees,
                "nees_verdict": verdict,
                "us_per_pair_step": 1e6 * timers[label] / (n_steps * n_runs),
            }
        )
    return table


def steady_vs_full(
    n_runs: int = 500, duration: float = 10.0, seed: int = 0, sensor: str = "radar"
) -> Table:
    """Constant-gain (steady-state) local filter against the full Kalman filter.

    Car following, one sensor; RMSE of gap and range-rate during the transient (first 2 s of
    each track) and in steady state (after 4 s), mean NEES, and the cost per pair-step of
    each (both on numpy/numba arrays, same run).
    """
    specs = [radar_spec(), infrared_spec()]
    ests = {
        "full KF": make_estimator(
            FusionConfig(method=sensor, filter=FOLLOWING_FILTER), SENSOR_NAMES, n_runs, specs
        ),
        "steady-state KF": make_estimator(
            FusionConfig(method=sensor, filter=FOLLOWING_FILTER, local="steady"),
            SENSOR_NAMES,
            n_runs,
            specs,
        ),
    }
    stats = {}
    for phase, start, end in (("transient", 0.0, 2.0), ("steady", 4.0, duration)):
        for est in ests.values():
            est.reset()
        timers = dict.fromkeys(ests, 0.0)
        kalman.warmup()
        n_steps = int(round(end / 0.05))
        res = run_estimation(
            following_source(n_runs, seed),
            make_sensors(seed + 1),
            {label: _Timed(e, timers, label) for label, e in ests.items()},
            n_steps,
            score_from=start,
        )
        for label, st in res.estimators.items():
            stats[(label, phase)] = st
            stats[(label, "us")] = 1e6 * timers[label] / (n_steps * n_runs)
    table = Table(
        f"Steady-state vs full Kalman filter ({sensor}), {n_runs} runs x {duration:g} s",
        (
            "filter",
            "transient_rmse_gap_m",
            "steady_rmse_gap_m",
            "steady_rmse_rate_mps",
            "steady_mean_nees",
            "us_per_pair_step",
        ),
    )
    for label in ests:
        table.rows.append(
            {
                "filter": label,
                "transient_rmse_gap_m": stats[(label, "transient")].rmse_gap,
                "steady_rmse_gap_m": stats[(label, "steady")].rmse_gap,
                "steady_rmse_rate_mps": stats[(label, "steady")].rmse_rate,
                "steady_mean_nees": stats[(label, "steady")].mean_nees,
                "us_per_pair_step": stats[(label, "us")],
            }
        )
    return table
