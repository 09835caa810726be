"""The published naturalistic figures the traffic realism check compares with, and the check.

Each :class:`Reference` names the figure of :meth:`RealismStats.figures
<acc_fusion.metrics.realism.RealismStats.figures>` it stands beside (``key``), what was
published (``published``), how the study defined it (``definition``), the full citation with
its table or section (``source``), and the band a simulated figure must lie in to pass
(``low``, ``high``) with why the band is drawn there (``band``). Where a band is wider than
the published values, or a value could not be re-read in its source, ``band`` says so: those
are assumptions of this check, not findings of the studies.

Figures without a reference (no published value found for a comparable definition): the
onsets of 3.0 m/s² or harder, the share of headways under 1 s, the time in car following,
the TTC shares, and the speed and acceleration distributions (which depend on the road's
limits and density more than on how people drive; the check prints them for comparison
between sources).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from acc_fusion.metrics.realism import Figure, RealismStats

#: Full citations of the references.
SIMONS_MORTON_2011 = (
    "B. G. Simons-Morton, M. C. Ouimet, Z. Zhang, S. E. Klauer, S. E. Lee, J. Wang, P. S. "
    "Albert, T. A. Dingus, 'Crash and risky driving involvement among novice adolescent "
    "drivers and their parents', American Journal of Public Health 101(12):2362-2367, 2011, "
    "Table 1 (hard stops)"
)
ALLSTATE_2018 = (
    "Allstate, 'The 14th annual Allstate America's Best Drivers Report', press release "
    "(PR Newswire), 29 August 2018: hard braking of the drivers enrolled in Drivewise "
    "telematics, 2016-2017, national average"
)
KING_2022 = (
    "D. R. King, A. Gold, K. B. Phillips, D. A. Krauss, 'Headway times on urban, multiple "
    "lane freeways', Proceedings of the Human Factors and Ergonomics Society Annual Meeting "
    "66(1):1225-1229, 2022 (abstract; doi:10.1177/1071181322661413)"
)
KRAJEWSKI_2018 = (
    "R. Krajewski, J. Bock, L. Kloeker, L. Eckstein, 'The highD dataset: a drone dataset of "
    "naturalistic vehicle trajectories on German highways for validation of highly automated "
    "driving systems', IEEE 21st International Conference on Intelligent Transportation "
    "Systems (ITSC), 2018, pp. 2118-2125 (abstract)"
)
LEE_2004 = (
    "S. E. Lee, E. C. B. Olsen, W. W. Wierwille, 'A comprehensive examination of naturalistic "
    "lane-changes', NHTSA report DOT HS 809 702, 2004 (abstract)"
)


@dataclass(frozen=True)
class Reference:
    """A published naturalistic figure and the band a simulated one must lie in.

    Attributes:
        key: the :class:`~acc_fusion.metrics.realism.Figure` key it stands beside.
        cite: the short citation of the tables ("Author et al. year, table").
        value: the published figure where the study gives one value (NaN for a range).
        low, high: the band of a passing figure (in the figure's unit).
        published: what the study reports, in words and numbers.
        definition: how the study measured it.
        source: full citation with its table or section.
        band: why the band is ``[low, high]`` (assumptions marked as such).
    """

    key: str
    cite: str
    value: float
    low: float
    high: float
    published: str
    definition: str
    source: str
    band: str

    def contains(self, value: float) -> bool:
        """Whether ``value`` lies in ``[low, high]``."""
        return self.low <= value <= self.high


REFERENCES: tuple[Reference, ...] = (
    Reference(
        key="onsets_4.4",
        cite="Simons-Morton et al. 2011, Table 1",
        value=math.nan,
        low=0.0,
        high=0.57,
        published="0.12 (parents) to 0.57 (novice teens) per 100 km (0.20 and 0.91 per 100 miles)",
        definition="elevated g-force events of longitudinal deceleration -0.45 g or harder "
        "('hard stops'), 42 newly licensed drivers and their parents, 18 months, all roads",
        source=SIMONS_MORTON_2011,
        band="up to the novices' rate, from 0: motorways brake less than all roads, and a "
        "run of a few thousand km may see none. The two rates are as this project quoted "
        "them in docs/theory/alert-classes.md; Table 1 itself could not be re-read for this "
        "check (assumption: quoted correctly)",
    ),
    Reference(
        key="onsets_3.6",
        cite="Allstate 2018 (press)",
        value=1.18,
        low=0.0,
        high=1.18,
        published="1.18 per 100 km (19 per 1 000 miles, the national average)",
        definition="hard-braking events of insured drivers' telematics, all roads; the "
        "threshold (8 mph/s, 3.6 m/s²) is the one usually given for Drivewise, not stated "
        "in the report",
        source=ALLSTATE_2018,
        band="up to the published rate, from 0. A press figure, not peer reviewed, and its "
        "threshold is an assumption: the weakest reference of the table",
    ),
    Reference(
        key="headway_median",
        cite="King et al. 2022",
        value=1.74,
        low=1.5,
        high=2.0,
        published="median 1.74 s",
        definition="time headways front to front from video of 4- and 5-lane urban freeways "
        "in Los Angeles County, headways up to 5 s",
        source=KING_2022,
        band="1.74 s ± about 0.25 s (the tolerance is this check's assumption: the study "
        "reports headways fairly consistent across its sites, with longer ones at higher "
        "speed)",
    ),
    Reference(
        key="headway_below_2s",
        cite="King et al. 2022",
        value=0.583,
        low=0.48,
        high=0.68,
        published="58.3 % under 2 s",
        definition="as the median: headways up to 5 s",
        source=KING_2022,
        band="58.3 % ± 10 points (the tolerance is this check's assumption)",
    ),
    Reference(
        key="lane_changes",
        cite="highD 2018; Lee et al. 2004",
        value=math.nan,
        low=12.4,
        high=22.5,
        published="highD: 5 600 complete lane changes over 45 000 km (12.4 per 100 km); "
        "commuters: 8 667 lane changes over 23 949 miles = 38 542 km (22.5 per 100 km, one "
        "per 4.44 km)",
        definition="highD: lane changes completed within the 420 m filmed sections of "
        "German motorways (a lower bound: lane changes cut by the section's ends are not "
        "complete); commuters: every lane change of 16 drivers on interstates and highways",
        source=f"{KRAJEWSKI_2018}; {LEE_2004}",
        band="from highD's rate to the commuters' (drawn from the two studies' totals)",
    ),
)


@dataclass(frozen=True)
class CheckRow:
    """One line of the check: the figure, its reference (or ``None``) and the verdict
    (``"pass"``, ``"fail"``, ``"no reference"``, ``"no data"`` where the figure is NaN)."""

    figure: Figure
    reference: Reference | None
    status: str


def reference_of(key: str, references: tuple[Reference, ...] = REFERENCES) -> Reference | None:
    """The reference of figure ``key``, ``None`` without one."""
    return next((r for r in references if r.key == key), None)


def check(stats: RealismStats, references: tuple[Reference, ...] = REFERENCES) -> list[CheckRow]:
    """Every figure of ``stats`` beside its reference, with its verdict."""
    rows = []
    for fig in stats.figures():
        ref = reference_of(fig.key, references)
        if ref is None:
            status = "no reference"
        elif math.isnan(fig.value):
            status = "no data"
        else:
            status = "pass" if ref.contains(fig.value) else "fail"
        rows.append(CheckRow(fig, ref, status))
    return rows
