r"""Crash-relevant situations and crashes by the hazard that made them, as simulated and
re-weighted to naturalistic rates: the traffic commands are an accelerated test, and this is
how to read them back at road rates.

The processes
    The traffic commands make crash-relevant situations on purpose, with two documented
    processes on top of the traffic's own driving (which the realism check holds to
    naturalistic figures, :mod:`acc_fusion.metrics.realism`):

    - *lead emergency braking* (``lead_braking``): every vehicle brakes at ``hazard_decel``
      (8 m/s²) for ``hazard_duration`` (3 s) at ``hazard_rate`` events per vehicle-hour
      (:mod:`acc_fusion.truth.sumo.control`);
    - *distraction* (``distracted``): the drivers' eyes-off-road episodes
      (:mod:`acc_fusion.truth.distraction`), each followed by the reaction time in which the
      driver, eyes back on the road, has not yet acted;
    - *late drivers* (``late``): the fraction ``inattentive`` of the equipped drivers whose
      car-following model decides every 1.5 s (:mod:`acc_fusion.truth.sumo.control`).

    The traffic's own processes run at their natural rates where the traffic passes the
    realism check: ``lane_change`` (a cut-in, or a cut-out revealing the next car) and
    ``traffic`` (its own braking, slow or stopped leaders), each met by a driver who is
    ``distracted``, ``late`` or ``attentive``.

Attribution
    A crash-relevant situation (truth's, :mod:`acc_fusion.metrics.alert_classes`; its onsets
    and ends as :class:`~acc_fusion.metrics.events.FCWMetrics` counts them) belongs to
    ``lead_braking`` if at any of its steps the ego's leader is under an injected emergency
    braking or was within the last :data:`LEAD_BRAKING_WINDOW` seconds; else to
    ``lane_change`` if at any of its steps the leader had taken over from another vehicle
    within the last :data:`LANE_CHANGE_WINDOW` seconds; and to ``distracted``
    if at any of its steps the driver is in a distraction episode or its reaction time
    (:attr:`acc_fusion.truth.driver.Driver.holding`), else ``late`` for a late driver.  A crash
    belongs to the situation it ends
    (what the situation met up to the contact; without one, its own step).

Re-weighting
    Each category :math:`c` gets the likelihood ratio of the natural to the simulated rate of
    its processes, as importance sampling weights an accelerated test's events (D. Zhao, H.
    Lam, H. Peng, S. Bao, D. J. LeBlanc, K. Nobukawa, C. S. Pan, "Accelerated evaluation of
    automated vehicles safety in lane-change scenarios based on importance sampling
    techniques", *IEEE Trans. Intelligent Transportation Systems* 18(3):595-607, 2017):

    .. math::

        w_c = w_{\text{process}} \, w_{\text{driver}}, \qquad
        w_{\text{lead\_braking}} = \frac{h_{\text{nat}} \, \bar v}{100\, r_{\text{sim}}}, \quad
        w_{\text{lane\_change}} = w_{\text{traffic}} = 1, \quad
        w_{\text{distracted}} = \frac{p_{\text{nat}}}{p_{\text{sim}}}, \quad
        w_{\text{late}} = w_{\text{attentive}} = \frac{1 - p_{\text{nat}}}{1 - p_{\text{sim}}}

    with :math:`h_{\text{nat}}` the naturalistic hard-braking onsets per 100 km, :math:`\bar v`
    the run's mean speed [km/h], :math:`r_{\text{sim}}` the injected rate per vehicle-hour,
    :math:`p` the share of driving time with the eyes off the road (simulated: measured in the
    run; the episodes' rate, of which the reaction times are a fixed multiple, scales with it).
    No natural share of late drivers was found: their weight carries none (an assumption:
    the late drivers are read as they are simulated).  The re-weighted rate is
    :math:`\sum_c w_c n_c / \text{km}`.  The ratio is first order: it holds while a
    situation needs one lead braking and one eyes-off episode, and while the simulated
    episodes' durations are the natural ones; both are assumptions, and the traffic's weight
    of 1 holds only where the traffic passes the realism check (the bundled motorway).  Every
    reference is a range, so every weight and re-weighted rate is a range: the low
    references give the low end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acc_fusion.core.plots import pyplot
from acc_fusion.core.table import Table
from acc_fusion.core.validation import check_range
from acc_fusion.metrics.stats import Rate

#: The processes, by precedence: a situation that met an injected braking of its leader is
#: ``lead_braking``, else one whose leader changed by a lane change is ``lane_change``, else
#: ``traffic``.
PROCESSES = ("lead_braking", "lane_change", "traffic")

#: The categories, in the order of :class:`HazardCounts`' tuples: (process, driver).
#: The drivers, by precedence.
DRIVERS = ("distracted", "late", "attentive")

#: The categories, in the order of :class:`HazardCounts`' tuples: (process, driver).
CATEGORIES = tuple((p, d) for p in PROCESSES for d in DRIVERS)

#: The bits of a situation's flags (:func:`category`).
LEAD_BRAKING, LANE_CHANGE, DISTRACTED, LATE = 1, 2, 4, 8

#: Seconds after an injected emergency braking of the leader during which a new crash-relevant
#: situation is still its doing (the braking lasts 3 s; a follower then closes on a slow or
#: stopped lead).  Assumption.
LEAD_BRAKING_WINDOW = 10.0

#: Seconds after the ego's leader changed from one vehicle to another (a cut-in, or a cut-out
#: that reveals the next car) during which a situation is the lane change's doing.  Assumption.
LANE_CHANGE_WINDOW = 3.0


def category(flags: np.ndarray) -> np.ndarray:
    """The index into :data:`CATEGORIES` of each of ``flags`` (ints: an OR of
    :data:`LEAD_BRAKING`, :data:`LANE_CHANGE`, :data:`DISTRACTED` and :data:`LATE`)."""
    flags = np.asarray(flags)
    process = np.where(flags & LEAD_BRAKING, 0, np.where(flags & LANE_CHANGE, 1, 2))
    driver = np.where(flags & DISTRACTED, 0, np.where(flags & LATE, 1, 2))
    return (len(DRIVERS) * process + driver).astype(np.int8)


@dataclass(frozen=True)
class NaturalisticRates:
    """The natural rate of each hazard process and the field's crash rate (ranges, low to high).

    Attributes:
        hard_braking_per_100km: braking onsets of 0.45 g or harder per 100 km: 0.12 (parents)
            to 0.57 (novice teens), B. G. Simons-Morton et al., *American Journal of Public
            Health* 101(12):2362, 2011, Table 1 (hard stops).  An injected braking (8 m/s²)
            is harder than 0.45 g, so this is an upper bound of the natural rate of such
            events (the re-weighted rates lean high).
        eyes_off_share: share of driving time with the eyes off the forward roadway: about
            10 %, Klauer, Guo, Simons-Morton, Ouimet, Lee & Dingus, *N. Engl. J. Med.*
            370:54-59, 2014, as the NIH's release of the study reports it (the paper's own
            figure was not seen here, and no baseline share of the 100-Car or SHRP2 studies
            could be retrieved: an assumption, the one the distraction model's rate is set to,
            :mod:`acc_fusion.truth.distraction`).
        field_rear_end_per_million_km: police-reported rear-end crashes per million
            vehicle-km on US roads: 1 846 988 in 2012 and 1 966 000 in 2014 (NHTSA, *Traffic
            Safety Facts*, crashes by first harmful event and type of collision) over 2 969 433
            and 3 025 656 million vehicle-miles (FHWA, as FMCSA's *Pocket Guide* trends table
            12 gives them): 0.386 and 0.404.  All roads; motorways have fewer crashes per km.
    """

    hard_braking_per_100km: tuple[float, float] = (0.12, 0.57)
    eyes_off_share: tuple[float, float] = (0.10, 0.10)
    field_rear_end_per_million_km: tuple[float, float] = (0.386, 0.404)

    def __post_init__(self) -> None:
        for name in ("hard_braking_per_100km", "eyes_off_share", "field_rear_end_per_million_km"):
            lo, hi = getattr(self, name)
            check_range(f"{name}[0]", lo, 0.0, hi)
        check_range("eyes_off_share[1]", self.eyes_off_share[1], 0.0, 1.0, hi_open=True)


@dataclass(frozen=True)
class HazardCounts:
    """What one run saw of the hazards (counts by :data:`CATEGORIES`).

    Attributes:
        relevant: crash-relevant situations by category.
        crashes: crashes (first contacts of equipped vehicles) by category.
        driven_s: equipped driving time [s]; eyes_off_s: of it with the driver's eyes off.
        injected_per_hour: the injected emergency brakings per vehicle-hour of the run.
    """

    relevant: tuple[int, ...]
    crashes: tuple[int, ...]
    driven_s: float
    eyes_off_s: float
    injected_per_hour: float

    def __add__(self, other: HazardCounts) -> HazardCounts:
        """Two runs (of different seeds) as one."""
        return HazardCounts(
            tuple(a + b for a, b in zip(self.relevant, other.relevant, strict=True)),
            tuple(a + b for a, b in zip(self.crashes, other.crashes, strict=True)),
            self.driven_s + other.driven_s,
            self.eyes_off_s + other.eyes_off_s,
            self.injected_per_hour,
        )

    @property
    def eyes_off_share(self) -> float:
        """The simulated share of driving time with the eyes off the road (0 without driving)."""
        return self.eyes_off_s / self.driven_s if self.driven_s > 0 else 0.0

    def weights(self, rates: NaturalisticRates, km_per_h: float) -> np.ndarray:
        """``(2, 4)``: each category's weight (module docstring) at the low and the high
        references; a process the run did not simulate keeps weight 1 (its category is
        empty)."""
        w = np.ones((2, len(PROCESSES), len(DRIVERS)))
        p = self.eyes_off_share
        for end in (0, 1):
            if self.injected_per_hour > 0:
                nat = rates.hard_braking_per_100km[end] * km_per_h / 100.0
                w[end, 0] *= nat / self.injected_per_hour
            if 0 < p < 1:
                q = rates.eyes_off_share[end]
                w[end, :, 0] *= q / p
                w[end, :, 1:] *= (1 - q) / (1 - p)
        return w.reshape(2, len(CATEGORIES))


def _span(lo: float, hi: float) -> str:
    return f"{lo:.3g}" if f"{lo:.3g}" == f"{hi:.3g}" else f"{lo:.3g}-{hi:.3g}"


def hazard_table(
    title: str,
    off: HazardCounts,
    km: float,
    hours: float,
    rates: NaturalisticRates,
    on: HazardCounts | None = None,
    km_on: float = 0.0,
) -> Table:
    """The FCW-off run's crash-relevant situations and crashes by category, as simulated (exact
    Poisson intervals) and re-weighted (the range of the references), with the field's rate;
    with ``on`` (the FCW-on run, ``km_on`` driven) the re-weighted crash reduction (the
    FCW-off run's weights for both runs)."""
    w = off.weights(rates, km / hours if hours > 0 else 0.0)
    t = Table(
        title,
        ("hazard", "driver", "relevant", "relevant_per_100km", "crashes",
         "crashes_per_million_km", "weight", "relevant_per_100km_reweighted",
         "crashes_per_million_km_reweighted"),
    )  # fmt: skip
    rel, crash = np.array(off.relevant), np.array(off.crashes)
    labels = [*CATEGORIES, ("all", "all")]
    for i, (hazard, driver) in enumerate(labels):
        pick = slice(None) if hazard == "all" else slice(i, i + 1)
        n_rel, n_crash = int(rel[pick].sum()), int(crash[pick].sum())
        rw_rel = (w[:, pick] * rel[pick]).sum(axis=1) / km * 100.0
        rw_crash = (w[:, pick] * crash[pick]).sum(axis=1) / km * 1e6
        t.rows.append(
            {
                "hazard": hazard,
                "driver": driver,
                "relevant": n_rel,
                "relevant_per_100km": Rate.poisson(n_rel, km / 100.0).format(),
                "crashes": n_crash,
                "crashes_per_million_km": Rate.poisson(n_crash, km / 1e6).format(),
                "weight": "" if hazard == "all" else _span(*w[:, i]),
                "relevant_per_100km_reweighted": _span(*rw_rel),
                "crashes_per_million_km_reweighted": _span(*rw_crash),
            }
        )
    field = rates.field_rear_end_per_million_km
    total = (w * crash).sum(axis=1) / km * 1e6
    t.notes += [
        f"hazard: lead_braking = the leader under an injected emergency braking "
        f"({off.injected_per_hour:g} per vehicle-hour) during the situation or in the "
        f"{LEAD_BRAKING_WINDOW:g} s before; lane_change = a new leader (cut-in or cut-out) in the "
        f"{LANE_CHANGE_WINDOW:g} s before; traffic = the rest; distracted = eyes off the road, "
        "or back on and not yet reacted, during the situation; late = a driver who decides "
        "every 1.5 s; a crash counts under the situation it ends",
        f"weights: lead braking x (natural hard braking {_span(*rates.hard_braking_per_100km)} "
        f"per 100 km / injected), distracted x (natural eyes-off share "
        f"{_span(*rates.eyes_off_share)} / simulated {off.eyes_off_share:.3g})",
        f"re-weighted, FCW off: {_span(*total)} crashes per million km; the field: "
        f"{_span(*field)} police-reported rear-end crashes per million vehicle-km",
    ]
    if sum(off.crashes) == 0:
        t.notes.append("no crash with FCW off: nothing to re-weight")
    elif on is not None and km_on > 0:
        on_total = (w * np.array(on.crashes)).sum(axis=1) / km_on * 1e6
        t.notes.append(
            f"re-weighted, FCW on: {_span(*on_total)} crashes per million km; reduction "
            f"{_span(*(1 - on_total / total))} (the FCW-off run's weights)"
        )
    return t


def hazard_figure(off: HazardCounts, km: float, hours: float, rates: NaturalisticRates):
    """The crashes of :func:`hazard_table` as a figure: per category the simulated rate (bar)
    and the re-weighted range (black ticks) in crashes per million km, on a log scale, beside
    the field's rate (grey band); the crash count at each bar.  Returns the figure."""
    plt = pyplot()
    w = off.weights(rates, km / hours if hours > 0 else 0.0)
    crash = np.array(off.crashes, dtype=float)
    simulated, reweighted = crash / km * 1e6, w * crash / km * 1e6
    fig, ax = plt.subplots(figsize=(9, 4.8))
    rows = np.arange(len(CATEGORIES))[::-1]
    ax.barh(rows, simulated, color="tab:blue", alpha=0.6, label="as simulated")
    ax.hlines(rows, reweighted[0], reweighted[1], color="black", lw=3)
    ax.plot(reweighted.ravel(), np.tile(rows, 2), "k|", ms=14, mew=3, label="re-weighted")
    ax.axvspan(*rates.field_rear_end_per_million_km, color="grey", alpha=0.5,
               label="field: police-reported rear-end crashes")  # fmt: skip
    for y, n, x in zip(rows, off.crashes, np.maximum(simulated, reweighted[1]), strict=True):
        ax.annotate(f"{n}", (max(x, 0.1), y), xytext=(6, -4), textcoords="offset points")
    ax.set_yticks(rows, [f"{p}, {d}" for p, d in CATEGORIES])
    ax.set_xscale("log")
    ax.set_xlim(0.1, max(1e3, 3 * float(np.max(reweighted, initial=0.0)), 3 * simulated.max()))
    ax.set_xlabel("crashes per million km (FCW off)")
    ax.set_title(f"Crashes by hazard: {int(crash.sum())} in {km:.0f} km")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3, fontsize=8)
    fig.tight_layout()
    return fig
