r"""The crashes FCW avoids: FCW off and on over the same traffic, paired by vehicle.

Each vehicle ``i`` of the study is driven twice on the same seed, FCW off and FCW on; it
crashes (``x_i``, ``y_i`` ∈ {0, 1}) with impact speeds (closing speed at contact) ``u_i``,
``w_i``.  The relative crash reduction is

.. math:: R = 1 - \frac{\sum_i y_i}{\sum_i x_i}

with a percentile-bootstrap interval over vehicles: the vehicles are resampled with
replacement, keeping each vehicle's pair (off, on) together (Efron & Tibshirani, *An
Introduction to the Bootstrap*, 1993, ch. 13).  The pairs are the unit because a vehicle's two
runs share its traffic up to the first difference FCW makes; vehicles are taken as
independent, which neglects that one crash can involve two equipped vehicles (each counts).

Severity: a crash FCW *avoided* (off, not on); *mitigated* (both, at a lower impact speed on);
*introduced* (on, not off: a vehicle whose traffic FCW changed, e.g. behind a driver braking
on an alert); the impact speeds off and on.  Rates per million km use each run's exposure.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acc_fusion.core.validation import check_range

#: Fewer crashes with FCW off than this give no interval worth printing (a bootstrap over two
#: crashes spans [-3, 1]): the tables say so in words.  Assumption: five events is the
#: usual floor below which resampling intervals are not reported.
MIN_CRASHES = 5


@dataclass(frozen=True)
class Benefit:
    """FCW off against on, paired by vehicle (see the module docstring).

    Attributes:
        vehicles: vehicles in the study (driven in either run).
        crashes_off, crashes_on: vehicles that crashed with FCW off / on.
        reduction: :math:`R` (NaN without a crash off); ``reduction_lo``/``_hi`` its interval.
        per_million_km_off, per_million_km_on: crashes per 10⁶ km of each run's driving.
        avoided: crashes off that did not happen on; ``mitigated``: crashes in both runs at a
            lower impact speed on; ``introduced``: crashes on that did not happen off.
        impact_speed_off, impact_speed_on: median impact speed [m/s] of the crashes (NaN: none).
        confidence: of the interval.
    """

    vehicles: int
    crashes_off: int
    crashes_on: int
    reduction: float
    reduction_lo: float
    reduction_hi: float
    per_million_km_off: float
    per_million_km_on: float
    avoided: int
    mitigated: int
    introduced: int
    impact_speed_off: float
    impact_speed_on: float
    confidence: float

    def as_dict(self) -> dict:
        """The fields as a JSON-ready mapping (NaN as ``None``)."""
        return {
            k: (None if isinstance(v, float) and v != v else v) for k, v in self.__dict__.items()
        }


def median_speed(speeds) -> float:
    """Median of the impact speeds ``speeds`` [m/s] (any iterable); NaN without one."""
    speeds = np.fromiter(speeds, dtype=float)
    return float(np.median(speeds)) if speeds.size else np.nan


def per_million(n: float, km: float) -> float:
    """``n`` crashes per million km of ``km`` driven (NaN without driving)."""
    return n / km * 1e6 if km > 0 else np.nan


def paired_benefit(
    vehicles,
    crashes_off: dict,
    crashes_on: dict,
    km_off: float,
    km_on: float,
    *,
    confidence: float = 0.95,
    resamples: int = 4000,
    seed: int = 0,
) -> Benefit:
    """:class:`Benefit` of the vehicles ``vehicles`` (ids; or any paired unit, such as the runs
    of a scripted batch), given the impact speed [m/s] of each vehicle that crashed in each
    run (``{id: speed}``) and each run's exposure [km].

    >>> b = paired_benefit(range(10), {0: 5.0, 1: 8.0}, {1: 3.0}, 100.0, 100.0)
    >>> b.crashes_off, b.crashes_on, b.reduction, b.avoided, b.mitigated, b.introduced
    (2, 1, 0.5, 1, 1, 0)
    """
    check_range("confidence", confidence, 0.0, 1.0, lo_open=True, hi_open=True)
    # Sorted: a set's order changes with the process's hash seed, the resampling must not.
    ids = sorted({*vehicles, *crashes_off, *crashes_on}, key=repr)
    x = np.array([v in crashes_off for v in ids], dtype=float)
    y = np.array([v in crashes_on for v in ids], dtype=float)
    both = [v for v in crashes_off if v in crashes_on]
    lo = hi = reduction = np.nan
    if x.sum() > 0:
        reduction = 1.0 - y.sum() / x.sum()
        rng = np.random.default_rng(seed)
        pick = rng.integers(len(ids), size=(resamples, len(ids)))
        off, on = x[pick].sum(axis=1), y[pick].sum(axis=1)
        r = 1.0 - on[off > 0] / off[off > 0]
        alpha = 1.0 - confidence
        lo, hi = np.quantile(r, [alpha / 2, 1 - alpha / 2])

    return Benefit(
        vehicles=len(ids),
        crashes_off=int(x.sum()),
        crashes_on=int(y.sum()),
        reduction=float(reduction),
        reduction_lo=float(lo),
        reduction_hi=float(hi),
        per_million_km_off=per_million(x.sum(), km_off),
        per_million_km_on=per_million(y.sum(), km_on),
        avoided=int(sum(v not in crashes_on for v in crashes_off)),
        mitigated=int(sum(crashes_on[v] < crashes_off[v] for v in both)),
        introduced=int(sum(v not in crashes_off for v in crashes_on)),
        impact_speed_off=median_speed(crashes_off.values()),
        impact_speed_on=median_speed(crashes_on.values()),
        confidence=confidence,
    )
