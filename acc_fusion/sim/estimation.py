r"""The estimation pipeline: truth source → sensors → estimators, with streaming error statistics.

:func:`run_estimation` steps a truth source, lets every sensor measure the same truth, feeds
the same measurements to several estimators (the methods being compared) and accumulates
their errors in :class:`ErrorStats`, which keeps running sums only, so memory does not grow
with the length of the run.

Statistics (Bar-Shalom, Li & Kirubarajan 2001, §5.4): root-mean-square error of gap and
range-rate; normalised estimation error squared :math:`\epsilon = e^\top P^{-1} e` with
:math:`e = \hat x - x` (mean :math:`n_x = 3` for a consistent filter); normalised innovation
squared per sensor (mean :math:`n_z = 2`).  :func:`chi2_mean_bounds` gives the two-sided
95 % acceptance interval of a mean of K such values.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from tqdm.auto import tqdm

from acc_fusion.core.distributions import chi2_ppf
from acc_fusion.fusion.base import Estimate, Estimator
from acc_fusion.sensors.sensor import Measurement, Sensor
from acc_fusion.truth.frame import TruthFrame


class TruthSource(Protocol):
    """Anything that yields :class:`TruthFrame` s step by step."""

    def frame(self) -> TruthFrame: ...

    def advance(self) -> TruthFrame: ...


def chi2_mean_bounds(dof: int, count: int, confidence: float = 0.95) -> tuple[float, float]:
    """Two-sided acceptance interval of the mean of ``count`` independent χ²(dof) values."""
    a = (1.0 - confidence) / 2.0
    k = dof * count
    return float(chi2_ppf(a, k) / count), float(chi2_ppf(1.0 - a, k) / count)


@dataclass
class _SquaredErrors:
    """Running sums of squared gap and range-rate errors."""

    count: int = 0
    sq_gap: float = 0.0
    sq_rate: float = 0.0

    def _accumulate(self, gap_err: np.ndarray, rate_err: np.ndarray) -> None:
        self.count += int(gap_err.size)
        self.sq_gap += float(np.sum(gap_err**2))
        self.sq_rate += float(np.sum(rate_err**2))

    @property
    def rmse_gap(self) -> float:
        """RMSE of the gap [m]."""
        return float(np.sqrt(self.sq_gap / max(self.count, 1)))

    @property
    def rmse_rate(self) -> float:
        """RMSE of the range-rate [m/s]."""
        return float(np.sqrt(self.sq_rate / max(self.count, 1)))


@dataclass
class ErrorStats(_SquaredErrors):
    """Streaming error statistics of one estimator (running sums only)."""

    n_sensors: int = 2
    nees_sum: float = 0.0
    nis_sum: np.ndarray = field(default=None)  # type: ignore[assignment]
    nis_count: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        if self.nis_sum is None:
            self.nis_sum = np.zeros(self.n_sensors)
            self.nis_count = np.zeros(self.n_sensors, dtype=np.int64)

    def add(self, est: Estimate, truth: TruthFrame, mask: np.ndarray | None = None) -> None:
        """Accumulate the errors of the pairs that have a leader and a track (and ``mask``)."""
        use = est.valid & truth.has_leader
        if mask is not None:
            use &= mask
        e = est.x[use] - truth.state[use]
        self._accumulate(e[:, 0], e[:, 1])
        self.nees_sum += float(
            np.einsum("ni,ni->", e, np.linalg.solve(est.p[use], e[..., None])[..., 0])
        )
        nis = est.nis[use]
        ok = np.isfinite(nis)
        self.nis_sum += np.where(ok, nis, 0.0).sum(axis=0)
        self.nis_count += ok.sum(axis=0)

    @property
    def mean_nees(self) -> float:
        """Mean NEES over every pair-step (3 for a consistent filter)."""
        return self.nees_sum / max(self.count, 1)

    @property
    def mean_nis(self) -> np.ndarray:
        """Mean NIS per sensor (2 for a consistent filter)."""
        return self.nis_sum / np.maximum(self.nis_count, 1)


@dataclass
class RawStats(_SquaredErrors):
    """Streaming RMSE of one sensor's raw measurements (range and range-rate)."""

    def add(self, m: Measurement, truth: TruthFrame, mask: np.ndarray | None = None) -> None:
        use = m.valid & truth.has_leader
        if mask is not None:
            use &= mask
        self._accumulate(m.z[use, 0] - truth.gap[use], m.z[use, 1] - truth.range_rate[use])


@dataclass
class EstimationResult:
    """Errors of every estimator and every raw sensor over one run."""

    estimators: dict[str, ErrorStats]
    raw: dict[str, RawStats]
    steps: int


def run_estimation(
    source: TruthSource,
    sensors: Sequence[Sensor],
    estimators: Mapping[str, Estimator],
    n_steps: int,
    *,
    score_from: float = 0.0,
    common: bool = True,
    progress: bool = False,
    on_step: Callable[[TruthFrame, list[Measurement], dict[str, Estimate]], None] | None = None,
) -> EstimationResult:
    """Run ``n_steps`` of the pipeline and return the streaming error statistics.

    Every estimator sees the same measurements.  Errors are scored from ``score_from``
    seconds on (to leave out the initial transient if wanted) and, with ``common``, only on
    the pair-steps where every estimator has a track, so that no method is scored on pairs
    another one has not yet picked up.  ``on_step`` is called with
    the truth, the measurements and the estimates of each step (for plots and traces).
    """
    n_sensors = len(sensors)
    stats = {name: ErrorStats(n_sensors=n_sensors) for name in estimators}
    raw = {s.spec.name: RawStats() for s in sensors}
    frame = source.frame()
    for _ in tqdm(range(n_steps), disable=None if progress else True, desc="steps", unit="step"):
        meas = [s.measure(frame) for s in sensors]
        ests = {name: e.step(meas, frame.leader_id) for name, e in estimators.items()}
        if frame.t >= score_from - 1e-9:
            mask = np.logical_and.reduce([e.valid for e in ests.values()]) if common else None
            for name, est in ests.items():
                stats[name].add(est, frame, mask)
            for s, m in zip(sensors, meas, strict=True):
                raw[s.spec.name].add(m, frame)
        if on_step is not None:
            on_step(frame, meas, ests)
        frame = source.advance()
    return EstimationResult(stats, raw, n_steps)
