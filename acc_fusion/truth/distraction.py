r"""Eyes-off-road episodes of the simulated drivers: what makes real rear-end crashes.

A driver looks away from the road now and then; during an *episode* he does not respond to
his lead: the vehicle keeps its speed (the truth source takes it out of its car-following
model).  The episode ends by itself after its duration, or earlier when a forward-collision
warning (FCW on) makes him look back; either way he then needs his reaction time before he
brakes (:class:`acc_fusion.truth.driver.Driver`).

Each driver's episodes are a schedule fixed in advance, in simulated time from when he
takes the wheel: episode k starts a gap after the drawn end of episode k-1 and lasts its
drawn duration,

.. math::

    S_k = S_{k-1} + T_{\text{off},k-1} + \Delta t_{\text{gap},k}, \qquad
    \Delta t_\text{gap} \sim \operatorname{Exp}(3600 / r), \qquad
    T_\text{off} = \operatorname{clip}\!\left(m\, e^{s z},\ T_{\min}, T_{\max}\right),
    \quad z \sim N(0, 1)

with ``r`` episodes per hour of scheduled attentive time.  An episode that falls due while
the driver is reacting or braking is skipped.  The draws of a driver's k-th episode are a
function of the seed, his key (his slot, or his vehicle's id:
:meth:`acc_fusion.truth.driver.Driver.assign`) and k only, and a warning that cuts an
episode short moves none of the later ones, so two runs on the same seed (FCW off and on)
give a driver the same episodes at the same times: common random numbers for the paired
comparison (:mod:`acc_fusion.metrics.benefit`).

Drivers choose when to look away (self-regulation): an episode that falls due while the
situation is not calm is skipped, calm being a time headway of at least ``calm_headway`` and,
when closing on the lead, a time to collision of at least ``calm_ttc`` (no lead: calm).
Naturalistic data show that drivers engage in visual-manual tasks less in demanding
situations (Tivesten & Dozza, "Driving context influences drivers' decision to engage in
visual-manual phone tasks: evidence from a naturalistic driving study", *J. Safety Res.*
53:87-96, 2015); the thresholds are assumptions (:data:`TRAFFIC_CALM`).  Without the gate a
driver at 0.4 s behind his lead looks away for seconds as often as one alone on the road, and
the traffic's crashes come from that alone.

Where the numbers come from (assumptions anchored in published figures; no naturalistic
distribution was fitted here):

- Duration.  The NHTSA *Visual-Manual Driver Distraction Guidelines* (2013, 78 FR 24818)
  accept a task whose glances away from the road last at most 2 s for 85 % of drivers; the
  100-Car naturalistic study found that eyes-off-road durations over 2 s about double the
  risk of a crash or near-crash (Klauer, Dingus, Neale, Sudweeks & Ramsey, *The impact of
  driver inattention on near-crash/crash risk*, DOT HS 810 594, 2006).  Default: log-normal
  with median 1.2 s and log-sd 0.5, so that 15 % of episodes exceed 2 s, clipped to
  0.3-6 s.
- Frequency.  Default 0 (off), so every study states the rate it assumes; ``acc-fusion sumo``
  uses :data:`TRAFFIC_DISTRACTION_RATE`, 300 episodes per hour of attentive driving: with the
  default durations (mean 1.36 s) the eyes are off the road about 10 % of the driving time,
  the share reported for the naturalistic drivers of Klauer, Guo, Simons-Morton, Ouimet, Lee
  & Dingus, "Distracted driving and risk of road crashes among novice and experienced
  drivers", *N. Engl. J. Med.* 370:54-59, 2014 (as summarised in the NIH's release of the
  study; the figure was not checked in the paper itself, so treat it as an assumption).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acc_fusion.core.validation import check_interval, check_range

#: Episodes per hour of attentive driving that the traffic commands (``acc-fusion sumo``,
#: ``make run``) assume: eyes off the road about 10 % of the time (see the module docstring).
TRAFFIC_DISTRACTION_RATE = 300.0
#: The calm of the traffic commands' drivers (``calm_headway`` [s], ``calm_ttc`` [s]): they
#: look away only at 1 s of time headway or more, and not while closing on the lead with a
#: time to collision under 10 s.  Assumptions (see the module docstring): 1 s is the headway
#: under which drivers follow closely by choice in the headway data of King et al. (2022), 10 s
#: a closing the driver notices.
TRAFFIC_CALM = (1.0, 10.0)


@dataclass(frozen=True)
class DistractionConfig:
    """Eyes-off-road episodes of the simulated drivers (validated on construction).

    Attributes:
        rate: episodes per hour of attentive driving [1/h]; 0 (none).
        duration_median: median episode duration [s]; 1.2.
        duration_log_sd: standard deviation of ``ln`` duration; 0.5.
        duration_range: ``(low, high)`` clip of the duration [s]; (0.3, 6.0).
        calm_headway: an episode starts only at this time headway (gap over speed) or more
            [s]; 0 (any).
        calm_ttc: ... and, when closing on the lead, at this time to collision or more [s];
            0 (any).
    """

    rate: float = 0.0
    duration_median: float = 1.2
    duration_log_sd: float = 0.5
    duration_range: tuple[float, float] = (0.3, 6.0)
    calm_headway: float = 0.0
    calm_ttc: float = 0.0

    def __post_init__(self) -> None:
        check_range("driver.distraction.calm_headway", self.calm_headway, 0.0, 60.0)
        check_range("driver.distraction.calm_ttc", self.calm_ttc, 0.0, 600.0)
        check_range("driver.distraction.rate", self.rate, 0.0, 3600.0)
        check_range(
            "driver.distraction.duration_median", self.duration_median, 0.0, 60.0, lo_open=True
        )
        check_range("driver.distraction.duration_log_sd", self.duration_log_sd, 0.0, 3.0)
        object.__setattr__(
            self,
            "duration_range",
            check_interval("driver.distraction.duration_range", self.duration_range, lo_open=True),
        )


def calm(config: DistractionConfig, gap, speed, range_rate, has_leader) -> np.ndarray:
    """Where a driver may look away (see the module docstring): no lead, or a time headway
    ``gap / speed`` of ``calm_headway`` or more and, when closing (``range_rate`` < 0), a time
    to collision ``gap / -range_rate`` of ``calm_ttc`` or more (arrays ``(N,)``, SI)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        headway = np.where(speed > 0.0, gap / speed, np.inf)
        ttc = np.where(range_rate < 0.0, gap / -range_rate, np.inf)
    ok = (headway >= config.calm_headway) & (ttc >= config.calm_ttc)
    return ~has_leader | ok


class EpisodeDraws:
    """The gap before and the duration of each driver's k-th episode (see the module
    docstring): reproducible per (seed, key, k), independent of the other drivers."""

    def __init__(self, config: DistractionConfig, key: int) -> None:
        self.config, self.key = config, int(key)

    def gap(self, slots: np.ndarray, count: np.ndarray) -> np.ndarray:
        """Attentive time [s] before episode ``count`` of each of ``slots`` (their keys)."""
        mean = 3600.0 / self.config.rate
        return np.array(
            [self._rng(0, s, k).exponential(mean) for s, k in zip(slots, count, strict=True)]
        )

    def duration(self, slots: np.ndarray, count: np.ndarray) -> np.ndarray:
        """Duration [s] of episode ``count`` of each of ``slots`` (their keys)."""
        c = self.config
        z = np.array(
            [self._rng(1, s, k).standard_normal() for s, k in zip(slots, count, strict=True)]
        )
        return np.clip(c.duration_median * np.exp(c.duration_log_sd * z), *c.duration_range)

    def _rng(self, kind: int, slot, count) -> np.random.Generator:
        return np.random.default_rng([self.key, kind, int(slot), int(count)])
