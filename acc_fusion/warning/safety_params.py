"""The parameters of the safety-distance models (one frozen dataclass per model, each field with
its unit and the published value it defaults to)."""

from __future__ import annotations

from dataclasses import dataclass

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_range


@dataclass(frozen=True)
class TimeHeadwayParams:
    """Parameters of :func:`time_headway`.

    Attributes:
        headway_caution: time headway h of the caution level [s] (default 2.0: the
            "two-second rule" of driver training, quoted by Vogel, *Accid. Anal. Prev.*
            35:427, 2003, §1).
        headway_imminent: time headway of the imminent level [s] (default 1.0: half the
            two-second rule, the "small headway" class of Vogel 2003).
        d0: standstill distance [m] (default 2.5: SUMO's default ``minGap``).
    """

    headway_caution: float = 2.0
    headway_imminent: float = 1.0
    d0: float = 2.5

    def __post_init__(self) -> None:
        _check_times("time_headway", self, "headway_caution", "headway_imminent")
        _check_lengths("time_headway", self, "d0")
        _check_order("time_headway", self, "headway_imminent", "headway_caution")

    def _constants(self) -> tuple[float, ...]:
        return self.headway_caution, self.headway_imminent, self.d0


@dataclass(frozen=True)
class TTCParams:
    """Parameters of :func:`ttc`.

    Attributes:
        ttc_caution: TTC threshold of the caution level [s] (default 2.4: the latest alert
            NHTSA's NCAP "Forward Collision Warning System Confirmation Test" (2013) accepts
            in its lead-vehicle-decelerating test; 2.1 s and 2.0 s for a stopped and a slower
            lead).
        ttc_imminent: TTC threshold of the imminent level [s] (default 1.5: van der Horst's
            minimum TTC separating critical from normal approaches, discussed for collision
            avoidance systems by van der Horst & Hogema, "Time-to-collision and collision
            avoidance systems", Proc. 6th ICTCT workshop, 1994).
        d0: distance added to both thresholds [m] (default 0: the pure TTC criterion).
        lead_braking: judge the TTC with the lead keeping its deceleration until it stops, as
            NHTSA's confirmation test (2013) judges its decelerating-lead test (default False:
            the constant-speed TTC :math:`g/v_c`).
    """

    ttc_caution: float = 2.4
    ttc_imminent: float = 1.5
    d0: float = 0.0
    lead_braking: bool = False

    def __post_init__(self) -> None:
        _check_times("ttc", self, "ttc_caution", "ttc_imminent")
        _check_lengths("ttc", self, "d0")
        _check_order("ttc", self, "ttc_imminent", "ttc_caution")

    def _constants(self) -> tuple[float, ...]:
        return self.ttc_caution, self.ttc_imminent, self.d0, float(self.lead_braking)


@dataclass(frozen=True)
class StoppingDistanceParams:
    """Parameters of :func:`stopping_distance`.

    Attributes:
        reaction_caution: driver reaction time of the caution level [s] (default 1.5: brake
            reaction to a surprise event, Green, "How long does it take to stop?",
            *Transportation Human Factors* 2(3):195, 2000).
        decel_caution: ego deceleration of the caution level [m/s²] (default 4.9 ≈ 0.5 g,
            firm braking).
        reaction_imminent: reaction time of the imminent level [s] (default 1.0: between
            Green's 0.75 s for an expected signal and 1.25 s for an unexpected one; an FCW
            alert is a signal the driver knows but does not expect).
        decel_imminent: ego deceleration of the imminent level [m/s²] (default 6.0 ≈ 0.6 g,
            hard braking of an alerted driver; below the 0.8 g full braking of Fujita et al.
            1995, which few drivers reach).
        lead_decel: deceleration of the lead's emergency stop [m/s²] (default 6.0: as hard
            as the ego's imminent braking, the equal-braking assumption of kinematic FCW
            models such as Berkeley's; then steady following at a constant gap raises no
            imminent alert above a headway of ``reaction_imminent`` + d0/v).
        d0: standstill distance [m] (default 2.5: SUMO's default ``minGap``).
    """

    reaction_caution: float = 1.5
    decel_caution: float = 4.9
    reaction_imminent: float = 1.0
    decel_imminent: float = 6.0
    lead_decel: float = 6.0
    d0: float = 2.5

    def __post_init__(self) -> None:
        p = "stopping_distance"
        _check_times(p, self, "reaction_caution", "reaction_imminent")
        _check_decels(p, self, "decel_caution", "decel_imminent", "lead_decel")
        _check_lengths(p, self, "d0")
        _check_order(p, self, "reaction_imminent", "reaction_caution")
        _check_order(p, self, "decel_caution", "decel_imminent")

    def _constants(self) -> tuple[float, ...]:
        return (
            self.reaction_caution,
            self.decel_caution,
            self.reaction_imminent,
            self.decel_imminent,
            self.lead_decel,
            self.d0,
        )


@dataclass(frozen=True)
class MazdaParams:
    """Parameters of :func:`mazda` (Doi et al. 1994, as reproduced by Lee & Peng 2005).

    Attributes:
        alpha1: ego deceleration α1 [m/s²] (default 6).
        alpha2: lead deceleration α2 [m/s²] (default 8).
        tau1: system delay τ1 [s] (default 0.1).
        tau2: driver delay τ2 [s] (default 0.6), used by the caution level.
        tau2_imminent: driver delay of the imminent level [s] (default 0: no driver delay,
            only the system's; an acc_fusion choice, the published algorithm has one level).
        d0: headway offset [m] (default 5).
    """

    alpha1: float = 6.0
    alpha2: float = 8.0
    tau1: float = 0.1
    tau2: float = 0.6
    tau2_imminent: float = 0.0
    d0: float = 5.0

    def __post_init__(self) -> None:
        _check_decels("mazda", self, "alpha1", "alpha2")
        _check_times("mazda", self, "tau1", "tau2", "tau2_imminent")
        _check_lengths("mazda", self, "d0")
        _check_order("mazda", self, "tau2_imminent", "tau2")

    def _constants(self) -> tuple[float, ...]:
        return self.alpha1, self.alpha2, self.tau1, self.tau2, self.tau2_imminent, self.d0


@dataclass(frozen=True)
class HondaParams:
    """Parameters of :func:`honda` (Fujita, Akuzawa & Sato 1995, via Lee & Peng 2005).

    Attributes:
        warning_gain: closing-speed gain of the warning distance [s] (default 2.2).
        warning_offset: offset of the warning distance [m] (default 6.2).
        a1: ego deceleration [m/s²] (default 7.8).
        a2: lead deceleration [m/s²] (default 7.8).
        tau1: system delay before the ego brakes [s] (default 0.5).
        tau2: time horizon of the braking distance [s] (default 1.5).
    """

    warning_gain: float = 2.2
    warning_offset: float = 6.2
    a1: float = 7.8
    a2: float = 7.8
    tau1: float = 0.5
    tau2: float = 1.5

    def __post_init__(self) -> None:
        _check_times("honda", self, "warning_gain", "tau1", "tau2")
        _check_lengths("honda", self, "warning_offset")
        _check_decels("honda", self, "a1", "a2")
        _check_order("honda", self, "tau1", "tau2")

    def _constants(self) -> tuple[float, ...]:
        """The parameters, then the ego's braking term and the lead's travel term of
        :math:`d_{br}` (parameters only, computed once)."""
        return (
            self.warning_gain,
            self.warning_offset,
            self.a2,
            self.tau2,
            0.5 * self.a1 * (self.tau2 - self.tau1) ** 2,
            0.5 * self.a2 * self.tau2**2,
        )


@dataclass(frozen=True)
class BerkeleyParams:
    """Parameters of :func:`berkeley` (Seiler, Song & Hedrick 1998, via Lee & Peng 2005).

    Attributes:
        decel: deceleration a of both vehicles [m/s²] (default 6).
        tau: delay τ, system plus driver [s] (default 1.2).
        d0: headway offset [m] (default 5).
    """

    decel: float = 6.0
    tau: float = 1.2
    d0: float = 5.0

    def __post_init__(self) -> None:
        _check_decels("berkeley", self, "decel")
        _check_times("berkeley", self, "tau")
        _check_lengths("berkeley", self, "d0")

    def _constants(self) -> tuple[float, ...]:
        r"""The parameters, then :math:`\tfrac12 a\tau^2` (computed once)."""
        return self.decel, self.tau, self.d0, 0.5 * self.decel * self.tau**2


@dataclass(frozen=True)
class RSSParams:
    """Parameters of :func:`rss`.

    The defaults are those of Intel's reference implementation of RSS, ``ad-rss-lib``
    (``cResponseTimeEgoVehicle``, ``cMaximumLongitudinalAcceleration``,
    ``cMinimumLongitudinalBrakingDeceleleration``, ``cMaximumLongitudinalBrakingDeceleleration``
    of its test support).

    Attributes:
        response_time: response time ρ of the ego [s] (default 1.0).
        accel_max: maximum acceleration of the ego during ρ [m/s²] (default 3.5).
        brake_min: minimum braking the ego applies after ρ, caution level [m/s²] (default 4).
        brake_min_imminent: the same for the imminent level [m/s²] (default 8: the ego commits
            to the full braking the lead is assumed capable of; an acc_fusion choice).
        brake_max: maximum braking of the lead [m/s²] (default 8).
    """

    response_time: float = 1.0
    accel_max: float = 3.5
    brake_min: float = 4.0
    brake_min_imminent: float = 8.0
    brake_max: float = 8.0

    def __post_init__(self) -> None:
        _check_times("rss", self, "response_time")
        check_range("rss.accel_max", self.accel_max, 0.0, 20.0)
        _check_decels("rss", self, "brake_min", "brake_min_imminent", "brake_max")
        _check_order("rss", self, "brake_min", "brake_min_imminent")

    def _constants(self) -> tuple[float, ...]:
        r"""The parameters, then the distance :math:`\tfrac12 a_\text{accel,max}\rho^2` the
        acceleration adds during ρ (computed once)."""
        return (
            self.response_time,
            self.accel_max,
            self.brake_min,
            self.brake_min_imminent,
            self.brake_max,
            0.5 * self.accel_max * self.response_time**2,
        )


@dataclass(frozen=True)
class RequiredDecelerationParams:
    """Parameters of :func:`required_deceleration`.

    Attributes:
        reaction_time: delay before the ego brakes [s] (default 1.25: brake reaction to an
            unexpected but common signal such as the lead's brake lights, Green 2000).
        decel_caution: required-deceleration threshold of the caution level [m/s²]
            (default 3.4 ≈ 0.35 g: the deceleration most drivers exceed when stopping for an
            unexpected object, AASHTO, *A Policy on Geometric Design of Highways and Streets*,
            stopping sight distance, 2004).
        decel_imminent: threshold of the imminent level [m/s²] (default 5.0 ≈ 0.5 g,
            calibrated here, an assumption of this project: between AASHTO's 3.4 and the
            6.0 hard braking of the Mazda (α1) and PATH (a) algorithms, it is the value of
            the grid 4-7 m/s² × reaction 1-2 s with the fewest nuisance alerts in the
            bundled motorway's traffic that still passes the NHTSA tests, ``acc-fusion
            tune``, docs/theory/alert-classes.md).
        d0: margin left at the closest approach [m] (default 2.5: SUMO's default ``minGap``).
    """

    reaction_time: float = 1.25
    decel_caution: float = 3.4
    decel_imminent: float = 5.0
    d0: float = 2.5

    def __post_init__(self) -> None:
        p = "required_deceleration"
        _check_times(p, self, "reaction_time")
        _check_decels(p, self, "decel_caution", "decel_imminent")
        _check_lengths(p, self, "d0")
        _check_order(p, self, "decel_caution", "decel_imminent")

    def _constants(self) -> tuple[float, ...]:
        return self.reaction_time, self.decel_caution, self.decel_imminent, self.d0


def _check_times(prefix: str, obj: object, *names: str) -> None:
    for name in names:
        check_range(f"{prefix}.{name}", getattr(obj, name), 0.0, 10.0)


def _check_decels(prefix: str, obj: object, *names: str) -> None:
    for name in names:
        check_range(f"{prefix}.{name}", getattr(obj, name), 0.0, 20.0, lo_open=True)


def _check_lengths(prefix: str, obj: object, *names: str) -> None:
    for name in names:
        check_range(f"{prefix}.{name}", getattr(obj, name), 0.0, 100.0)


def _check_order(prefix: str, obj: object, low: str, high: str) -> None:
    lo, hi = getattr(obj, low), getattr(obj, high)
    if lo > hi:
        raise ConfigError(f"{prefix}.{low} must be <= {prefix}.{high}, got {lo!r} > {hi!r}")
