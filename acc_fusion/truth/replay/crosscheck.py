r"""The replay's headways against the data set's own columns, and the data's headway
distribution.

For every pair-step where the data set gives a figure, the replay's value (from positions,
lengths and speeds, :mod:`acc_fusion.truth.replay.pairs`) is compared with it:

* distance headway: the gap :math:`g` (highD's ``dhw``, taken as bumper to bumper) or the
  spacing :math:`g + \ell_l` (NGSIM's ``Space_Headway``, front centre to front centre);
* time headway :math:`h / u_f` on the same basis (highD ``thw``, NGSIM ``Time_Headway``);
* TTC :math:`g / (u_f - u_l)` where the ego closes in (highD ``ttc``).  highD writes a TTC
  also where the gap opens (negative, or 0: "no valid TTC"); the replay's TTC is infinite
  there, so only closing steps with :math:`u_f - u_l \ge` :data:`MIN_CLOSING` are compared
  (below it the TTC is huge and the files' 0.01 m/s rounding of speeds dominates it).

A figure agrees within :math:`|x_{\text{replay}} - x_{\text{data}}| \le a + r\,|x_{\text{data}}|`
(:data:`TOLERANCES`: the files round positions and speeds to 0.01 m and 0.01 m/s, and headways to
0.01 m and 0.01 s).  The mean difference shows a systematic one: were highD's ``dhw`` front to
front, the mean difference of the distance headway would be the mean leader length (about
4.5 m for cars) instead of 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from acc_fusion.truth.replay.pairs import Pairs

#: Absolute and relative tolerance of each compared figure (m or s, share of the value).
TOLERANCES = {"headway": (0.05, 0.001), "thw": (0.02, 0.01), "ttc": (0.02, 0.05)}
#: Closing speed [m/s] from which TTCs are compared.
MIN_CLOSING = 0.5
#: Bins of the headway distribution: time headway [s] and gap [m] (lo, hi, width).
THW_BINS = (0.0, 6.0, 0.1)
GAP_BINS = (0.0, 150.0, 2.0)


@dataclass
class Agreement:
    """How one figure of the replay agrees with the data set's (mergeable across windows)."""

    compared: int = 0
    within: int = 0
    sum_diff: float = 0.0
    max_abs: float = 0.0

    def add(self, replay: np.ndarray, data: np.ndarray, tol: tuple[float, float]) -> None:
        """Compare where both are finite."""
        ok = np.isfinite(replay) & np.isfinite(data)
        diff = replay[ok] - data[ok]
        self.compared += int(ok.sum())
        self.within += int((np.abs(diff) <= tol[0] + tol[1] * np.abs(data[ok])).sum())
        self.sum_diff += float(diff.sum())
        if diff.size:
            self.max_abs = max(self.max_abs, float(np.abs(diff).max()))

    @property
    def share_within(self) -> float:
        return self.within / self.compared if self.compared else float("nan")

    @property
    def mean_diff(self) -> float:
        return self.sum_diff / self.compared if self.compared else float("nan")


def _counts(values: np.ndarray, bins: tuple[float, float, float]) -> np.ndarray:
    """Counts of the finite ``values`` in ``bins`` (the last bin takes all above ``hi``)."""
    lo, hi, width = bins
    n = int(round((hi - lo) / width))
    v = values[np.isfinite(values) & (values >= lo)]
    return np.bincount(np.minimum(((v - lo) / width).astype(np.int64), n - 1), minlength=n)


@dataclass
class CrossCheck:
    """The cross-check and the headway distribution of the replayed rows so far."""

    basis: str = "gap"
    figures: dict[str, Agreement] = field(
        default_factory=lambda: {k: Agreement() for k in TOLERANCES}
    )
    thw_counts: np.ndarray = field(default_factory=lambda: _counts(np.zeros(0), THW_BINS))
    gap_counts: np.ndarray = field(default_factory=lambda: _counts(np.zeros(0), GAP_BINS))

    def add(self, p: Pairs) -> None:
        """Add the pair-steps of ``p``."""
        with np.errstate(divide="ignore", invalid="ignore"):
            moving = p.ego_speed > 0.0
            thw = np.where(moving, p.gap / p.ego_speed, np.nan)
            closing = p.ego_speed - p.lead_speed
            ttc = np.where(closing >= MIN_CLOSING, p.gap / closing, np.nan)
            headway = p.gap + p.lead_length if self.basis == "spacing" else p.gap
            replay = {"headway": headway, "thw": np.where(moving, headway / p.ego_speed, np.nan)}
        replay["ttc"] = ttc
        for name, agreement in self.figures.items():
            if name in p.ref:
                agreement.add(replay[name], p.ref[name], TOLERANCES[name])
        self.thw_counts = self.thw_counts + _counts(thw, THW_BINS)
        self.gap_counts = self.gap_counts + _counts(p.gap, GAP_BINS)
