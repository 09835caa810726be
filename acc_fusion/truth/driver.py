r"""The simulated driver who reacts to forward-collision warnings (closes the loop).

Pipeline: ... → warning → **driver** → truth source (``ScenarioSource.advance(ego_brake)``).
Each of N drivers (one per run) watches the warning level of his run:

1. At a warning *onset* (the level rises to ``react_to_level`` or above while he is neither
   reacting nor braking) he starts reacting.
2. After his reaction time :math:`t_r` he brakes with his deceleration :math:`d`: the first
   step with :math:`t \ge t_{\text{onset}} + t_r` (exact to the step).
3. He releases by the ``release`` rule, watching the road (the truth frame): ``not_closing``
   (default) when he no longer closes on his lead (range-rate >= 0, or no lead) or the ego
   has stopped; ``warning_ended`` as ``not_closing`` but only once the warning has also ended;
   ``stopped`` only when the ego has stopped.
4. A later warning onset starts a new reaction.
5. With distraction (:mod:`acc_fusion.truth.distraction`) he looks away now and then, when
   idle: while his eyes are off the road, and from the end of the episode until he has
   reacted and released, he is *holding* (:attr:`Driver.holding`): the truth source keeps
   his vehicle's speed and ignores its car-following model, which would see the lead for him.
   The end of an episode is an onset like a warning's (he looks, then after his reaction
   time brakes if he is closing on his lead); a warning during an episode ends it by the
   same route, earlier.  Braking after an episode is his own, at :math:`d`, with no help
   from the source's car-following model.
6. With ``sees_threats`` (for egos without a car-following model of their own) the onset of
   a crash-relevant situation in truth, seen with his eyes on the road, is an onset too.
7. With ``brakes_only_for_threats``, when his reaction time has passed he looks at the road
   and brakes only if the situation is crash-relevant in truth; otherwise he leaves it to his
   car-following model (a nuisance alert costs no hard braking).  Lee et al. (2002) found that
   a warning hastens the release of the accelerator, not braking itself; that a driver
   ignores an alert he sees no reason for is our assumption.

Per-driver draws (at construction, from ``numpy.random.default_rng(seed)``; same seed, same
drivers):

.. math::

    t_r = \operatorname{clip}\left(m\, e^{s z_1},\ t_{\min}, t_{\max}\right),\qquad
    d = \operatorname{clip}\left(\mu + \sigma z_2,\ d_{\min}, d_{\max}\right),\qquad
    z_1, z_2 \sim N(0, 1)

Where the numbers come from (see :class:`DriverConfig` for the values):

- Reaction time.  Green (2000) finds that expectation dominates brake reaction time: about
  0.70-0.75 s when the driver expects the signal, about 1.25 s for an unexpected but common
  signal (a lead car's brake lights), about 1.5 s for a surprise.  Lee, McGehee, Brown & Reyes
  (2002) show that a collision warning shortens the time drivers take to release the
  accelerator but not the time to reach the brake.  A warned driver therefore sits between
  Green's "expected" and "surprise" values: the default log-normal has median 1.1 s and log-sd
  0.3 (90 % of drivers between 0.67 and 1.8 s), clipped to 0.5-3 s.  The log-normal shape is
  the usual right-skewed reaction-time model; the median and spread are our fit to Green's
  range (assumption, not a fitted data set).
- Deceleration.  Lee et al. (2002): warnings do not raise the drivers' maximum or mean
  deceleration.  The CAMP closed-course studies of "last-second" hard braking (Kiefer et al.
  1999; Kiefer, LeBlanc & Flannagan 2005) model the driver's braking in response to an alert;
  their hard-braking levels are commonly summarised as about 0.4-0.6 g.  Default: normal with
  mean 0.5 g and sd 0.08 g, clipped to 0.3-0.9 g (assumption matching that range; the CAMP
  distributions themselves were not available here).

Sources: M. Green, "'How long does it take to stop?' Methodological analysis of driver
perception-brake times", Transportation Human Factors 2(3):195-216, 2000; J. D. Lee,
D. V. McGehee, T. L. Brown, M. L. Reyes, "Collision warning timing, driver distraction, and
driver response to imminent rear-end collisions in a high-fidelity driving simulator",
Human Factors 44(2):314-334, 2002; R. J. Kiefer et al., *Development and validation of
functional definitions and evaluation procedures for collision warning/avoidance systems*
(CAMP), DOT HS 808 964, 1999; R. J. Kiefer, D. J. LeBlanc, C. A. Flannagan, "Developing an
inverse time-to-collision crash alert timing approach based on drivers' last-second braking
and steering judgments", Accident Analysis & Prevention 37(2):295-303, 2005.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.slots import PairState, unit_key
from acc_fusion.core.units import TIME_TOL, G
from acc_fusion.core.validation import check_choice, check_interval, check_range
from acc_fusion.truth.distraction import DistractionConfig, EpisodeDraws, calm
from acc_fusion.truth.frame import TruthFrame

#: The release rules of :class:`DriverConfig`.
RELEASE_RULES = ("not_closing", "warning_ended", "stopped")


@dataclass(frozen=True)
class DriverConfig:
    """How the simulated drivers react (all fields validated on construction).

    Attributes:
        reaction_time_median: median reaction time [s]; 1.1.
        reaction_time_log_sd: standard deviation of ``ln`` reaction time; 0.3.
        reaction_time_range: ``(low, high)`` clip of the reaction time [s]; (0.5, 3.0).
        deceleration_mean: mean braking deceleration [m/s²]; 0.5 g.
        deceleration_sd: its standard deviation [m/s²]; 0.08 g.
        deceleration_range: ``(low, high)`` clip of the deceleration [m/s²]; (0.3 g, 0.9 g).
        react_to_level: lowest warning level the driver reacts to; 1 (caution).
        release: when he stops braking, one of :data:`RELEASE_RULES`; ``"not_closing"``.
        distraction: his eyes-off-road episodes; none by default.
        sees_threats: whether, eyes on the road, he brakes by himself at the onset of a
            crash-relevant situation (truth's, :mod:`acc_fusion.metrics.alert_classes`) after
            his reaction time; False.  For truth sources whose ego has no car-following model
            of its own (the scripted manoeuvres); SUMO's and highway-env's vehicles have one.
        brakes_only_for_threats: whether, his reaction time passed, he brakes only in a
            crash-relevant situation (else he leaves it to his car-following model); False.
    """

    reaction_time_median: float = 1.1
    reaction_time_log_sd: float = 0.3
    reaction_time_range: tuple[float, float] = (0.5, 3.0)
    deceleration_mean: float = 0.5 * G
    deceleration_sd: float = 0.08 * G
    deceleration_range: tuple[float, float] = (0.3 * G, 0.9 * G)
    react_to_level: int = 1
    release: str = "not_closing"
    distraction: DistractionConfig = DistractionConfig()
    sees_threats: bool = False
    brakes_only_for_threats: bool = False

    def __post_init__(self) -> None:
        checked = {
            "reaction_time_median": check_range(
                "driver.reaction_time_median", self.reaction_time_median, 0.0, 10.0, lo_open=True
            ),
            "reaction_time_log_sd": check_range(
                "driver.reaction_time_log_sd", self.reaction_time_log_sd, 0.0, 3.0
            ),
            "reaction_time_range": check_interval(
                "driver.reaction_time_range", self.reaction_time_range, lo_open=True
            ),
            "deceleration_mean": check_range(
                "driver.deceleration_mean", self.deceleration_mean, 0.0, 15.0, lo_open=True
            ),
            "deceleration_sd": check_range(
                "driver.deceleration_sd", self.deceleration_sd, 0.0, 15.0
            ),
            "deceleration_range": check_interval(
                "driver.deceleration_range", self.deceleration_range, lo_open=True
            ),
            "release": check_choice("driver.release", self.release, RELEASE_RULES),
        }
        level = self.react_to_level
        if isinstance(level, bool) or not isinstance(level, (int, np.integer)) or level < 1:
            raise ConfigError(f"driver.react_to_level must be an integer >= 1, got {level!r}")
        for name, value in checked.items():
            object.__setattr__(self, name, value)


class Driver(PairState):
    """N simulated drivers, one per run (see the module docstring).

    Args:
        n_runs: number of runs N.
        config: the drivers' :class:`DriverConfig` (default: defaults).
        seed: seed of the generator (``int``, ``numpy.random.Generator`` or ``None``).

    Attributes:
        reaction_time: ``(N,)`` each driver's reaction time [s].
        deceleration: ``(N,)`` each driver's braking deceleration [m/s²].
    """

    _PAIR_AXES = dict.fromkeys(
        (
            "reaction_time", "deceleration", "_onset", "_braking", "_alarmed",
            "_eyes_back", "_next_episode", "_episodes", "_holding", "_slot",
        ),
        0,
    )  # fmt: skip

    def __init__(
        self,
        n_runs: int,
        config: DriverConfig | None = None,
        seed: int | np.random.Generator | None = None,
    ) -> None:
        if isinstance(n_runs, bool) or not isinstance(n_runs, (int, np.integer)) or n_runs < 1:
            raise ConfigError(f"n_runs must be an integer >= 1, got {n_runs!r}")
        self.n_runs = int(n_runs)
        self.config = config = DriverConfig() if config is None else config
        rng = np.random.default_rng(seed)
        self.reaction_time, self.deceleration = self._traits(rng.standard_normal((2, self.n_runs)))
        self._onset = np.full(self.n_runs, np.nan)
        self._braking = np.zeros(self.n_runs, dtype=bool)
        self._alarmed = np.zeros(self.n_runs, dtype=bool)
        distracts = config.distraction.rate > 0
        # A spawned key leaves the draws above as they were and is the same for any n_runs.
        self._key = int(rng.spawn(1)[0].integers(2**63))
        self._draws = EpisodeDraws(config.distraction, self._key) if distracts else None
        self._eyes_back = np.full(self.n_runs, np.nan)  # end of the episode, NaN: eyes on
        self._next_episode = np.full(self.n_runs, np.nan)  # NaN: not drawn yet
        self._episodes = np.zeros(self.n_runs, dtype=np.int64)
        self._holding = np.zeros(self.n_runs, dtype=bool)
        self._slot = np.arange(self.n_runs)

    @property
    def braking(self) -> np.ndarray:
        """``(N,)`` drivers braking now."""
        return self._braking.copy()

    @property
    def distracts(self) -> bool:
        """Whether the drivers have eyes-off-road episodes (the source must hold vehicles)."""
        return self._draws is not None

    @property
    def holding(self) -> np.ndarray:
        """``(N,)`` drivers outside their car-following model: eyes off the road, or reacting
        to and braking after an episode (the source keeps their speed, minus their brake)."""
        return self._holding.copy()

    @property
    def reacting(self) -> np.ndarray:
        """``(N,)`` drivers with an onset pending: reacting, not yet braking."""
        return ~np.isnan(self._onset)

    @property
    def eyes_off(self) -> np.ndarray:
        """``(N,)`` drivers looking away from the road now."""
        return ~np.isnan(self._eyes_back)

    def _traits(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Reaction times and decelerations from standard normal draws ``z (2, M)``."""
        c = self.config
        reaction = c.reaction_time_median * np.exp(c.reaction_time_log_sd * z[0])
        decel = c.deceleration_mean + c.deceleration_sd * z[1]
        return np.clip(reaction, *c.reaction_time_range), np.clip(decel, *c.deceleration_range)

    def assign(self, mask: np.ndarray, units: np.ndarray) -> None:
        """Give the runs in ``mask`` new drivers, each drawn from his unit's key in
        ``units (N,)`` (int, e.g. a hash of a SUMO vehicle id): his reaction time,
        deceleration and eyes-off-road episodes are a function of the seed and his key only,
        whatever slot he gets.  So two runs of the same traffic (FCW off and on) give a
        vehicle the same driver even when their slots differ: common random numbers for the
        paired comparison (:mod:`acc_fusion.metrics.benefit`).  Also :meth:`reset`."""
        idx = np.flatnonzero(mask)
        units = np.asarray(units, dtype=np.int64)
        z = np.array([np.random.default_rng([self._key, 2, int(units[i])]).standard_normal(2)
                      for i in idx]).reshape(-1, 2)  # fmt: skip
        self.reaction_time[idx], self.deceleration[idx] = self._traits(z.T)
        self._slot[idx] = units[idx]
        self._episodes[idx] = 0
        self._next_episode[idx] = np.nan
        self.reset(mask)

    def new_vehicles(self, mask: np.ndarray, vehicle_ids: list | None = None) -> None:
        """The slots ``mask`` got new vehicles: give each its own driver (:meth:`assign`,
        keyed by :func:`~acc_fusion.core.slots.unit_key` of its id) where the source names
        its vehicles (``vehicle_ids``, one per slot), else :meth:`reset` them."""
        if vehicle_ids is None:
            self.reset(mask)
            return
        units = np.zeros(np.size(mask), dtype=np.int64)
        for i in np.flatnonzero(mask):
            units[i] = unit_key(vehicle_ids[i])
        self.assign(mask, units)

    def reset(self, mask: np.ndarray) -> None:
        """Forget the warning and braking state of the runs in ``mask`` (a new driver's
        vehicle in that slot keeps the slot's reaction time and deceleration draws and its
        episode clock; :meth:`assign` gives him his own)."""
        self._onset[mask] = np.nan
        self._braking[mask] = False
        self._alarmed[mask] = False
        self._eyes_back[mask] = np.nan
        self._holding[mask] = False

    def _resized(self, m: int) -> None:
        self.n_runs = m

    def step(
        self, warning: np.ndarray, frame: TruthFrame, threat: np.ndarray | None = None
    ) -> np.ndarray:
        """The brake request of every driver for the step starting at ``frame.t``.

        Args:
            warning: ``(N,)`` warning level of each run (0 = none; ``bool`` is level 1).
            frame: what the drivers see: the truth at this step (time, ego speed, range-rate).
            threat: ``(N,)`` bool, the runs in a crash-relevant situation in truth; with
                :attr:`DriverConfig.sees_threats`, a driver whose eyes are on the road reacts
                to its onset as to a warning's; with
                :attr:`DriverConfig.brakes_only_for_threats`, a driver whose reaction is due
                brakes only where it is set.

        Returns:
            ``(N,)`` requested deceleration [m/s², >= 0]; 0 where the driver does not brake.
        """
        level = check_array("warning", warning, (self.n_runs,))
        if frame.n_pairs != self.n_runs:
            raise InputError(f"frame must hold {self.n_runs} runs, got {frame.n_pairs}")
        t = frame.t
        warned = level >= self.config.react_to_level
        alarmed = warned
        if self.config.sees_threats and threat is not None:
            alarmed = warned | (np.asarray(threat, dtype=bool) & ~self.eyes_off)
        idle = np.isnan(self._onset) & ~self._braking
        self._onset[alarmed & ~self._alarmed & idle] = t
        self._alarmed = alarmed
        if self.distracts:
            ended = t >= self._eyes_back - TIME_TOL  # False where eyes on (NaN)
            self._look_back(ended)
            self._onset[ended & np.isnan(self._onset) & ~self._braking] = t
        due = t >= self._onset + self.reaction_time - TIME_TOL  # False where no onset (NaN)
        if self.config.brakes_only_for_threats and threat is not None:
            self._braking |= due & np.asarray(threat, dtype=bool)
        else:
            self._braking |= due
        self._onset[due] = np.nan
        self._braking &= ~self._released(warned, frame)
        if self.distracts:
            self._look_back(due & self.eyes_off)  # a warning cut the episode short
            self._look_away(t, frame)
        return np.where(self._braking, self.deceleration, 0.0)

    def _look_away(self, t: float, frame: TruthFrame) -> None:
        """Start the episodes that are due, where the driver is idle and the situation calm
        (:func:`acc_fusion.truth.distraction.calm`; else the episode is skipped); schedule
        each due episode's successor; keep :attr:`holding`.

        The schedule is fixed in advance, whatever happens on the road: episode k+1 is due
        ``gap`` after the *drawn* end of episode k (:mod:`acc_fusion.truth.distraction`), so
        a warning that cuts an episode short moves none of the later ones."""
        undrawn = np.flatnonzero(np.isnan(self._next_episode))
        self._next_episode[undrawn] = t + self._draws.gap(
            self._slot[undrawn], self._episodes[undrawn]
        )
        due = np.flatnonzero(t >= self._next_episode - TIME_TOL)
        if due.size:
            k = self._episodes[due]
            length = self._draws.duration(self._slot[due], k)
            idle = np.isnan(self._onset[due]) & ~self._braking[due] & ~self.eyes_off[due]
            d = self.config.distraction
            if d.calm_headway > 0 or d.calm_ttc > 0:
                idle &= calm(d, frame.gap[due], frame.ego_speed[due], frame.range_rate[due],
                             frame.has_leader[due])  # fmt: skip
            start = due[idle]
            self._eyes_back[start] = t + length[idle]
            self._holding[start] = True
            self._episodes[due] += 1
            self._next_episode[due] += length + self._draws.gap(self._slot[due], k + 1)
        self._holding &= self.eyes_off | ~np.isnan(self._onset) | self._braking

    def _look_back(self, mask: np.ndarray) -> None:
        """End the episodes of ``mask`` now."""
        self._eyes_back[mask] = np.nan

    def _released(self, warned: np.ndarray, frame: TruthFrame) -> np.ndarray:
        """Drivers whose release condition holds now."""
        stopped = frame.ego_speed <= 0.0
        if self.config.release == "stopped":
            return stopped
        not_closing = ~frame.has_leader | (frame.range_rate >= 0.0) | stopped
        if self.config.release == "warning_ended":
            return not_closing & ~warned
        return not_closing
