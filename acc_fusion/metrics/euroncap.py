r"""Euro NCAP AEB Car-to-Car rear (CCRs, CCRm, CCRb): the test grid and its scoring.

Sources, read in full as text (their figures only as the labels a PDF-to-text pass keeps):

* Euro NCAP, *Test Protocol - AEB Car-to-Car systems*, v4.3.1, February 2024 ("TP"):
  scenarios §2.2 and §8.2.2, manufacturer grid §6.1.3, FCW braking robot §8.4.6 and annex A.4.
* Euro NCAP, *Assessment Protocol - Safety Assist - Collision Avoidance*, v10.4.1, February
  2024 ("AP"): preconditions §3.3, assessment criteria §3.3.1, Car-to-Car rear §3.3.2.

The grid (:func:`ccr_grid`, 134 points)
    ========  ========  ===================  =============================  ======================
    scenario  function  subject speed        target                         overlaps
    ========  ========  ===================  =============================  ======================
    CCRs      AEB       10-50 km/h, 5 km/h   stationary                     -50, -75, 100, 75, 50 %
    CCRs      FCW       55-80 km/h, 5 km/h   stationary                     -50, -75, 100, 75, 50 %
    CCRm      AEB       30-80 km/h, 5 km/h   20 km/h                        -50, -75, 100, 75, 50 %
    CCRb      AEB       50 km/h              50 km/h, braking at 2 or 6     100 %
                                             m/s² from 12 or 40 m headway
    ========  ========  ===================  =============================  ======================

    TP §8.2.2.1-2 give the overlaps as "-50% to 50%" in 25 % steps (the lateral offset of the
    centrelines as a share of the subject's width), AP §3.3.2 labels the same five points by
    their overlap, -50, -75, 100, 75 and 50 %; :attr:`CCRPoint.overlap` is that label as a
    signed fraction.  The side a sign stands for is drawn only in TP Figure 3-3, which was not
    readable here: the simulation must take it from there.  CCRb is tested at 100 % overlap
    (TP §8.2.2.3; other overlaps "for monitoring purpose" only).  The FCW points are driven by
    a robot that brakes :data:`FCW_REACTION_TIME` after the warning's onset at
    :data:`FCW_DECELERATION` (TP §8.4.6, A.4); the AEB points have no driver reaction.

Scoring (AP §3.3.2)
    Each point gets a colour from its impact speed, scored green 1, yellow 0.75, orange 0.5,
    brown 0.25, red 0.  Per test speed of CCRs and CCRm the five overlaps are averaged with
    the 100 % point counted twice, ``(s[-50] + s[-75] + 2 s[100] + s[75] + s[50]) / 6``, and
    multiplied by the speed's points: CCRs AEB 10 km/h 1, 15-35 km/h 2, 40-50 km/h 1 (total
    14); CCRm 30-60 km/h 1, 65-80 km/h 2 (15); CCRs FCW 55-80 km/h 1 (6); CCRb 4 × 1 (4).
    :attr:`CCRPoint.weight` is a point's share of these totals (speed points × 1 or 2 / 6).
    Each scenario's sum over its total is scaled to its points, CCRs AEB 1, CCRm 1, CCRb 1,
    CCRs FCW 0.5: at most :data:`MAX_POINTS` = 3.5 (AP §3.3.2 table, §3.3.7).  The CCRs AEB
    points count only when every CCRs AEB point up to 20 km/h is avoided (AP §3.3).

    The impact speed is ``V_impact``, the subject's speed at contact, in CCRs and CCRb and
    ``V_rel_impact``, subject minus target speed at contact, in CCRm (AP §3.3.1);
    :func:`assessment_speed` picks it.  In CCRs both are equal; in CCRb they differ when the
    target still moves at contact, and the protocol scores ``V_impact``.

Colour bands
    AP §3.3.2 draws them only as figures (impact speed against test speed for CCRs and CCRb,
    relative impact speed against test speed for CCRm, where the 130 km/h-against-70 km/h
    evidence shares the 80 km/h row: both close at 60 km/h).  Its one table, for CCRs and CCRb
    at 50 km/h, is green < 5, yellow 5-15, orange 15-30, brown 30-40, red >= 40 km/h (lower
    edges inclusive); CCRb is "equivalent to a CCRs test with a 50km/h VUT test speed", so its
    bands are exactly these.  ASSUMPTION (:data:`BAND_FRACTIONS`): for every other speed the
    edges are the same fractions, 10, 30, 60 and 80 %, of the :attr:`CCRPoint.reference_speed`
    (the impact speed without any reaction: the subject's test speed in CCRs and CCRb, the
    closing speed in CCRm), i.e. a speed reduction of more than 90, 70, 40 and 20 %.

Left out
    The manufacturer's predicted grid, the verification tests and their correction factors
    with the 2 km/h tolerance (AP §3.3.2.1-2; TP §8.2.1.1): every point here is simulated, so
    it is scored as tested, as if every point were a verification test with correction factor
    1.  The preconditions that are not results of these tests (system default on and not off
    below 130 km/h, a loud FCW, a "Good" front whiplash score, the OEM's 130/70 km/h CCRm
    evidence, AP §3.3), ESS at the -50 % FCW point (AP §3.3.1), and the other Car-to-Car
    scenarios and HMI points of the 9-point AEB Car-to-Car total (AP §3.3.3-3.3.7).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import InputError
from acc_fusion.core.outputs import save_figure_atomic
from acc_fusion.core.plots import pyplot
from acc_fusion.core.table import Table
from acc_fusion.core.units import KMH
from acc_fusion.core.validation import check_choice, check_range

PROTOCOLS = (
    "Euro NCAP Assessment Protocol - Safety Assist - Collision Avoidance v10.4.1 §3.3.2; "
    "Euro NCAP Test Protocol - AEB Car-to-Car systems v4.3.1 §8.2.2"
)

#: The FCW robot brakes this long after the warning's onset [s] (TP §8.4.6, A.4: its pedal
#: then reaches the position of the deceleration below within 0.2 s) ...
FCW_REACTION_TIME = 1.2
#: ... at this deceleration [m/s²] (TP §8.4.6.1: "-4 m/s² - 0.50 m/s²", i.e. 4.0 to 4.5) ...
FCW_DECELERATION = 4.0
#: ... having released the accelerator this long after the onset [s] (TP A.4).
FCW_ACCELERATOR_RELEASE = 1.0

COLOURS = ("green", "yellow", "orange", "brown", "red")
#: The share of a point's points each colour scores (AP §3.3.2).
COLOUR_SCORES = {"green": 1.0, "yellow": 0.75, "orange": 0.5, "brown": 0.25, "red": 0.0}
#: ASSUMPTION (module docstring): the lower edges of yellow, orange, brown and red as fractions
#: of the reference speed; exact for 50 km/h (AP §3.3.2's table), assumed for the others.
BAND_FRACTIONS = (0.1, 0.3, 0.6, 0.8)

#: The scoring groups and their points (AP §3.3.2 table, "Scenario Points").
GROUPS = ("CCRs AEB", "CCRs FCW", "CCRm", "CCRb")
GROUP_POINTS = {"CCRs AEB": 1.0, "CCRs FCW": 0.5, "CCRm": 1.0, "CCRb": 1.0}
MAX_POINTS = sum(GROUP_POINTS.values())
#: Points per test speed [km/h] (AP §3.3.2 table); CCRb has four points of 1.
SPEED_POINTS = {
    "CCRs AEB": {10: 1.0, **dict.fromkeys(range(15, 40, 5), 2.0), 40: 1.0, 45: 1.0, 50: 1.0},
    "CCRs FCW": dict.fromkeys(range(55, 85, 5), 1.0),
    "CCRm": {**dict.fromkeys(range(30, 65, 5), 1.0), **dict.fromkeys(range(65, 85, 5), 2.0)},
}
GROUP_TOTALS = {**{g: sum(s.values()) for g, s in SPEED_POINTS.items()}, "CCRb": 4.0}
#: The overlaps of a CCRs/CCRm test speed, in AP §3.3.2's order; 100 % counts twice.
OVERLAPS = (-0.5, -0.75, 1.0, 0.75, 0.5)
CCRM_TARGET_KMH = 20
CCRB_KMH = 50
CCRB_DECELERATIONS = (2.0, 6.0)
CCRB_HEADWAYS = (12.0, 40.0)
#: CCRs AEB scores only if every point up to this test speed [km/h] is avoided (AP §3.3).
CCRS_AVOIDANCE_KMH = 20


@dataclass(frozen=True)
class CCRPoint:
    """One test point.  Speeds in m/s; ``speed_kmh`` is the protocol's label of
    ``subject_speed``; ``overlap`` the signed overlap fraction (1.0 = 100 %); ``headway`` [m]
    and ``target_deceleration`` [m/s², positive] for CCRb (else ``None`` and 0); ``weight`` the
    point's share of its group's total (module docstring)."""

    scenario: str
    mode: str
    subject_speed: float
    speed_kmh: int
    target_speed: float
    overlap: float
    headway: float | None
    target_deceleration: float
    weight: float

    def __post_init__(self) -> None:
        check_choice("scenario", self.scenario, ("CCRs", "CCRm", "CCRb"))
        check_choice("mode", self.mode, ("aeb", "fcw"))
        check_range("subject_speed", self.subject_speed, 0.0, lo_open=True)
        # The target stands in CCRs, is slower in CCRm and starts as fast in CCRb.
        top = 0.0 if self.scenario == "CCRs" else self.subject_speed
        check_range("target_speed", self.target_speed, 0.0, top, hi_open=self.scenario == "CCRm")
        check_range("overlap", abs(self.overlap), 0.0, 1.0, lo_open=True)
        check_range("target_deceleration", self.target_deceleration, 0.0)
        check_range("weight", self.weight, 0.0)
        if self.headway is not None:
            check_range("headway", self.headway, 0.0, lo_open=True)

    @property
    def group(self) -> str:
        """The scoring group: ``"CCRs AEB"``, ``"CCRs FCW"``, ``"CCRm"`` or ``"CCRb"``."""
        return f"{self.scenario} {self.mode.upper()}" if self.scenario == "CCRs" else self.scenario

    @property
    def reference_speed(self) -> float:
        """The impact speed without any reaction [m/s], which the colour bands scale with:
        the subject's speed in CCRs and CCRb, the closing speed in CCRm."""
        if self.scenario == "CCRm":
            return self.subject_speed - self.target_speed
        return self.subject_speed

    @property
    def label(self) -> str:
        """A short name, e.g. ``CCRs AEB 50 km/h -75%`` or ``CCRb 50 km/h 12 m -6 m/s²``."""
        text = f"{self.group} {self.speed_kmh} km/h"
        if self.scenario == "CCRb":
            return f"{text} {self.headway:g} m -{self.target_deceleration:g} m/s²"
        return f"{text} {self.overlap:+.0%}".replace("+", "")


def _point(group: str, kmh: int, overlap: float) -> CCRPoint:
    scenario, _, mode = group.partition(" ")
    double = 2.0 if overlap == 1.0 else 1.0
    target = CCRM_TARGET_KMH * KMH if scenario == "CCRm" else 0.0
    weight = SPEED_POINTS[group][kmh] * double / 6.0
    return CCRPoint(
        scenario, mode.lower() or "aeb", kmh * KMH, kmh, target, overlap, None, 0.0, weight
    )


def ccr_grid() -> tuple[CCRPoint, ...]:
    """Every test point of the protocol (module docstring), CCRs AEB, CCRs FCW, CCRm, CCRb."""
    points = [
        _point(group, kmh, overlap)
        for group in ("CCRs AEB", "CCRs FCW", "CCRm")
        for kmh in SPEED_POINTS[group]
        for overlap in OVERLAPS
    ]
    v = CCRB_KMH * KMH
    points += [
        CCRPoint("CCRb", "aeb", v, CCRB_KMH, v, 1.0, headway, decel, 1.0)
        for headway in CCRB_HEADWAYS
        for decel in CCRB_DECELERATIONS
    ]
    return tuple(points)


_GRID = ccr_grid()
_GRID_INDEX = {p: i for i, p in enumerate(_GRID)}


def assessment_speed(point: CCRPoint, subject_speed: float, target_speed: float) -> float:
    """The speed AP §3.3.1 scores [m/s] from the speeds at contact: the subject's
    (``V_impact``) in CCRs and CCRb, the closing speed (``V_rel_impact``) in CCRm."""
    v = _speed("subject_speed", subject_speed)
    if point.scenario != "CCRm":
        return v
    return max(v - _speed("target_speed", target_speed), 0.0)


def point_colour(point: CCRPoint, impact_speed: float) -> str:
    """The colour of ``point`` for ``impact_speed`` [m/s, 0 when avoided; see
    :func:`assessment_speed`]: green below 10 % of :attr:`CCRPoint.reference_speed`, yellow
    below 30 %, orange below 60 %, brown below 80 %, red above (edges: module docstring)."""
    ratio = round(_speed("impact_speed", impact_speed) / point.reference_speed, 9)
    for colour, edge in zip(COLOURS, BAND_FRACTIONS, strict=False):
        if ratio < edge:
            return colour
    return "red"


def point_score(point: CCRPoint, impact_speed: float) -> float:
    """The share (1, 0.75, 0.5, 0.25 or 0) of its points that ``point`` scores."""
    return COLOUR_SCORES[point_colour(point, impact_speed)]


@dataclass(frozen=True)
class EuroNcapScore:
    """The points of each group (AP §3.3.2), their total and the maximum of 3.5;
    ``ccrs_avoidance`` whether the CCRs AEB points up to 20 km/h were all avoided (AP §3.3:
    if not, CCRs AEB scores 0).  A grid point not given scores as red."""

    ccrs_aeb: float
    ccrs_fcw: float
    ccrm: float
    ccrb: float
    total: float
    maximum: float
    ccrs_avoidance: bool

    def points(self, group: str) -> float:
        """The points of ``group`` (one of :data:`GROUPS`)."""
        return getattr(self, _FIELDS[check_choice("group", group, GROUPS)])


_FIELDS = {"CCRs AEB": "ccrs_aeb", "CCRs FCW": "ccrs_fcw", "CCRm": "ccrm", "CCRb": "ccrb"}


def score(points: Sequence[CCRPoint], impact_speeds: object) -> EuroNcapScore:
    """Score the grid points ``points`` with their ``impact_speeds`` [m/s] (module docstring)."""
    speeds = _check(points, impact_speeds)
    earned = dict.fromkeys(GROUPS, 0.0)
    avoided = True
    for p, v in zip(points, speeds, strict=True):
        earned[p.group] += p.weight * point_score(p, v)
        if p.group == "CCRs AEB" and p.speed_kmh <= CCRS_AVOIDANCE_KMH and v > 0.0:
            avoided = False
    # Rounded to 1e-12: the weights are sixths, which binary floats do not hold exactly.
    got = {g: round(earned[g] / GROUP_TOTALS[g] * GROUP_POINTS[g], 12) for g in GROUPS}
    if not avoided:
        got["CCRs AEB"] = 0.0
    return EuroNcapScore(
        got["CCRs AEB"],
        got["CCRs FCW"],
        got["CCRm"],
        got["CCRb"],
        sum(got.values()),
        MAX_POINTS,
        avoided,
    )


def rating_sheet(points: Sequence[CCRPoint], impact_speeds: object) -> Table:
    """One row per point: its scenario, function, speed, target, overlap, impact speed [km/h],
    colour and the points it adds to the total; the notes hold each group's points."""
    speeds = _check(points, impact_speeds)
    result = score(points, speeds)
    rows = []
    for p, v in zip(points, speeds, strict=True):
        share = p.weight * point_score(p, v) / GROUP_TOTALS[p.group] * GROUP_POINTS[p.group]
        if p.group == "CCRs AEB" and not result.ccrs_avoidance:
            share = 0.0
        rows.append(
            {
                "scenario": p.scenario,
                "function": p.mode.upper(),
                "speed_kmh": p.speed_kmh,
                "target": _target_text(p),
                "overlap_pct": round(100 * p.overlap),
                "impact_kmh": round(v / KMH, 1),
                "colour": point_colour(p, v),
                "points": round(share, 4),
            }
        )
    notes = [f"{g}: {result.points(g):.3f} of {GROUP_POINTS[g]:.3f} points" for g in GROUPS]
    notes.append(f"total: {result.total:.3f} of {result.maximum:.3f} points")
    if not result.ccrs_avoidance:
        notes.append("CCRs AEB: contact at or below 20 km/h, so no CCRs AEB points (AP §3.3)")
    return Table(
        f"Euro NCAP AEB Car-to-Car rear ({PROTOCOLS})",
        (
            "scenario",
            "function",
            "speed_kmh",
            "target",
            "overlap_pct",
            "impact_kmh",
            "colour",
            "points",
        ),
        rows,
        notes,
    )


#: The colour of each band in :func:`plot_grid`.
BAND_RGB = {
    "green": "#2ca02c",
    "yellow": "#f5d327",
    "orange": "#ff8c1a",
    "brown": "#8c564b",
    "red": "#d62728",
}


def plot_grid(points: Sequence[CCRPoint], impact_speeds: object, path: str | Path) -> Path:
    """A PNG at ``path`` (written atomically): one panel per scenario, a cell per test speed
    and overlap (CCRb: headway and target deceleration) coloured by its band, the impact speed
    [km/h] written in it; grid points not given are blank.  Returns the path."""
    from matplotlib.patches import Rectangle

    plt = pyplot()
    speeds = _check(points, impact_speeds)
    given = {p: float(v) for p, v in zip(points, speeds, strict=True)}
    result = score(points, speeds)
    fig, axes = plt.subplots(1, 3, figsize=(13, 6.5), gridspec_kw={"width_ratios": [5, 5, 2.4]})
    for ax, scenario in zip(axes, ("CCRs", "CCRm", "CCRb"), strict=True):
        cells = [p for p in _GRID if p.scenario == scenario]
        if scenario == "CCRb":
            cols = [f"-{d:g} m/s²" for d in CCRB_DECELERATIONS]
            rows = [f"{h:g} m" for h in CCRB_HEADWAYS]
            where = [
                (CCRB_HEADWAYS.index(p.headway), CCRB_DECELERATIONS.index(p.target_deceleration))
                for p in cells
            ]
        else:
            cols = [f"{o:.0%}" for o in OVERLAPS]
            kmh = sorted({p.speed_kmh for p in cells})
            rows = [f"{k} km/h" + (" FCW" if scenario == "CCRs" and k > 50 else "") for k in kmh]
            where = [(kmh.index(p.speed_kmh), OVERLAPS.index(p.overlap)) for p in cells]
        for p, (r, c) in zip(cells, where, strict=True):
            v = given.get(p)
            face = "white" if v is None else BAND_RGB[point_colour(p, v)]
            ax.add_patch(Rectangle((c, r), 1, 1, facecolor=face, edgecolor="0.3"))
            if v is not None:
                dark = face in (BAND_RGB["brown"], BAND_RGB["red"], BAND_RGB["green"])
                ax.text(
                    c + 0.5,
                    r + 0.5,
                    f"{v / KMH:.1f}",
                    ha="center",
                    va="center",
                    fontsize=8,
                    color="white" if dark else "black",
                )
        ax.set_xlim(0, len(cols))
        ax.set_ylim(len(rows), 0)
        ax.set_xticks(np.arange(len(cols)) + 0.5, cols)
        ax.set_yticks(np.arange(len(rows)) + 0.5, rows)
        ax.tick_params(length=0)
        if scenario == "CCRs":
            ax.axhline(len(SPEED_POINTS["CCRs AEB"]), color="k", lw=2.5)
            groups = ("CCRs AEB", "CCRs FCW")
        else:
            groups = (scenario,)
        got = ", ".join(f"{g} {result.points(g):.3f}/{GROUP_POINTS[g]:g}" for g in groups)
        ax.set_title(f"{got} points", fontsize=10)
    axes[0].set_xlabel("overlap")
    axes[1].set_xlabel("overlap (target at 20 km/h)")
    axes[2].set_xlabel("target deceleration (both 50 km/h)")
    fig.legend(
        handles=[Rectangle((0, 0), 1, 1, facecolor=BAND_RGB[c], label=c) for c in COLOURS],
        loc="lower center",
        ncol=len(COLOURS),
        frameon=False,
    )
    fig.suptitle(
        f"Euro NCAP AEB Car-to-Car rear: {result.total:.3f} of {result.maximum:g} points "
        "(impact speed in km/h written in each cell)",
        fontsize=11,
    )
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    return save_figure_atomic(fig, path)


def _target_text(p: CCRPoint) -> str:
    if p.scenario == "CCRs":
        return "stationary"
    text = f"{p.target_speed / KMH:.0f} km/h"
    if p.scenario == "CCRb":
        text += f", -{p.target_deceleration:g} m/s² at {p.headway:g} m"
    return text


def _speed(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number in m/s, got {value!r}") from None
    if not math.isfinite(v) or v < 0.0:
        raise InputError(f"{name} must be a finite speed >= 0 m/s, got {value!r}")
    return v


def _check(points: Sequence[CCRPoint], impact_speeds: object) -> np.ndarray:
    points = list(points)
    try:
        values = np.asarray(impact_speeds, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"impact_speeds must be numbers in m/s, got {impact_speeds!r}") from None
    speeds = check_array("impact_speeds", values, (len(points),), nonnegative=True)
    seen: set[CCRPoint] = set()
    for i, p in enumerate(points):
        if p not in _GRID_INDEX:
            raise InputError(f"points[{i}] is not a test point of the Euro NCAP CCR grid: {p!r}")
        if p in seen:
            raise InputError(f"points[{i}] ({p.label}) is given twice")
        seen.add(p)
    return speeds
