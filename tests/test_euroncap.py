"""Euro NCAP AEB Car-to-Car rear scoring (Safety Assist - Collision Avoidance v10.4.1 §3.3.2):
the grid's counts and weights, the extremes, the band edges, bad input and the figure."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.units import KMH
from acc_fusion.metrics import euroncap as en

GRID = en.ccr_grid()


def pick(group: str, kmh: int, overlap: float = 1.0) -> en.CCRPoint:
    return next(p for p in GRID if p.group == group and p.speed_kmh == kmh and p.overlap == overlap)


def avoided_except(changes: dict[en.CCRPoint, float]) -> list[float]:
    """Impact speeds [m/s] of the whole grid: 0 (avoided) except ``changes`` [km/h]."""
    return [changes.get(p, 0.0) * KMH for p in GRID]


def test_grid_has_the_protocols_points_per_scenario():
    assert Counter(p.group for p in GRID) == {
        "CCRs AEB": 9 * 5,
        "CCRs FCW": 6 * 5,
        "CCRm": 11 * 5,
        "CCRb": 4,
    }
    assert len(set(GRID)) == len(GRID) == 134
    speeds = {g: sorted({p.speed_kmh for p in GRID if p.group == g}) for g in en.GROUPS}
    assert speeds == {
        "CCRs AEB": list(range(10, 55, 5)),
        "CCRs FCW": list(range(55, 85, 5)),
        "CCRm": list(range(30, 85, 5)),
        "CCRb": [50],
    }
    for p in GRID:
        if p.scenario != "CCRb":
            same = [q.overlap for q in GRID if q.group == p.group and q.speed_kmh == p.speed_kmh]
            assert same == [-0.5, -0.75, 1.0, 0.75, 0.5]
            assert p.headway is None and p.target_deceleration == 0.0
    ccrb = {(p.headway, p.target_deceleration) for p in GRID if p.scenario == "CCRb"}
    assert ccrb == {(12.0, 2.0), (12.0, 6.0), (40.0, 2.0), (40.0, 6.0)}
    assert all(
        p.overlap == 1.0 and p.target_speed == pytest.approx(50 * KMH)
        for p in GRID
        if p.scenario == "CCRb"
    )
    assert all(p.target_speed == pytest.approx(20 * KMH) for p in GRID if p.scenario == "CCRm")
    assert {p.mode for p in GRID if p.group == "CCRs FCW"} == {"fcw"}
    assert {p.mode for p in GRID if p.group != "CCRs FCW"} == {"aeb"}


def test_weights_sum_as_the_protocol_says():
    totals = {g: sum(p.weight for p in GRID if p.group == g) for g in en.GROUPS}
    assert totals == pytest.approx({"CCRs AEB": 14, "CCRs FCW": 6, "CCRm": 15, "CCRb": 4})
    per_speed = {
        (p.group, p.speed_kmh): sum(
            q.weight for q in GRID if q.group == p.group and q.speed_kmh == p.speed_kmh
        )
        for p in GRID
        if p.scenario != "CCRb"
    }
    assert per_speed[("CCRs AEB", 10)] == pytest.approx(1.0)
    assert per_speed[("CCRs AEB", 15)] == pytest.approx(2.0)
    assert per_speed[("CCRs AEB", 35)] == pytest.approx(2.0)
    assert per_speed[("CCRs AEB", 40)] == pytest.approx(1.0)
    assert per_speed[("CCRm", 60)] == pytest.approx(1.0)
    assert per_speed[("CCRm", 65)] == pytest.approx(2.0)
    assert per_speed[("CCRs FCW", 80)] == pytest.approx(1.0)
    # The 100 % overlap counts twice: 2/6 of its speed's points against 1/6.
    assert pick("CCRm", 80).weight == pytest.approx(2 * pick("CCRm", 80, 0.5).weight)
    assert en.MAX_POINTS == 3.5


def test_avoidance_everywhere_scores_the_maximum():
    s = en.score(GRID, np.zeros(len(GRID)))
    assert (s.ccrs_aeb, s.ccrs_fcw, s.ccrm, s.ccrb) == pytest.approx((1.0, 0.5, 1.0, 1.0))
    assert s.total == pytest.approx(3.5) and s.maximum == 3.5 and s.ccrs_avoidance
    assert {en.point_colour(p, 0.0) for p in GRID} == {"green"}


def test_contact_at_full_speed_everywhere_scores_zero():
    full = [p.reference_speed for p in GRID]
    s = en.score(GRID, full)
    assert (s.ccrs_aeb, s.ccrs_fcw, s.ccrm, s.ccrb, s.total) == (0.0, 0.0, 0.0, 0.0, 0.0)
    assert {en.point_colour(p, v) for p, v in zip(GRID, full, strict=True)} == {"red"}
    # The reference speed is the impact speed without reaction: closing speed in CCRm.
    assert pick("CCRm", 30).reference_speed == pytest.approx(10 * KMH)
    assert pick("CCRs FCW", 80).reference_speed == pytest.approx(80 * KMH)


@pytest.mark.parametrize("point", [pick("CCRs AEB", 50), *[p for p in GRID if p.group == "CCRb"]])
@pytest.mark.parametrize(
    "kmh, colour",
    [
        (0.0, "green"),
        (4.9, "green"),
        (5.0, "yellow"),
        (5.1, "yellow"),
        (14.9, "yellow"),
        (15.0, "orange"),
        (15.1, "orange"),
        (29.9, "orange"),
        (30.0, "brown"),
        (30.1, "brown"),
        (39.9, "brown"),
        (40.0, "red"),
        (40.1, "red"),
        (50.0, "red"),
    ],
)
def test_band_edges_at_50_kmh_are_the_protocols_table(point, kmh, colour):
    """AP §3.3.2: green < 5, yellow 5-15, orange 15-30, brown 30-40, red >= 40 km/h; CCRb
    scores as a 50 km/h CCRs test."""
    assert en.point_colour(point, kmh * KMH) == colour
    assert en.point_score(point, kmh * KMH) == en.COLOUR_SCORES[colour]


@pytest.mark.parametrize(
    "point, edges",
    [
        # ASSUMPTION under test: the 50 km/h edges scaled to the reference speed.
        (pick("CCRs FCW", 80), (8.0, 24.0, 48.0, 64.0)),
        (pick("CCRs AEB", 20, -0.75), (2.0, 6.0, 12.0, 16.0)),
        (pick("CCRm", 80, 0.75), (6.0, 18.0, 36.0, 48.0)),  # closing at 60 km/h
        (pick("CCRm", 50), (3.0, 9.0, 18.0, 24.0)),  # closing at 30 km/h
    ],
)
def test_band_edges_scale_with_the_reference_speed(point, edges):
    below = [en.point_colour(point, (e - 0.1) * KMH) for e in edges]
    above = [en.point_colour(point, (e + 0.1) * KMH) for e in edges]
    at = [en.point_colour(point, e * KMH) for e in edges]
    assert below == ["green", "yellow", "orange", "brown"]
    assert above == at == ["yellow", "orange", "brown", "red"]


def test_scores_combine_per_speed_with_the_full_overlap_counted_twice():
    full = en.score(GRID, avoided_except({pick("CCRs AEB", 40): 40.0}))  # 100 %: red
    side = en.score(GRID, avoided_except({pick("CCRs AEB", 40, -0.5): 40.0}))
    assert full.ccrs_aeb == pytest.approx((14 - 2 / 6) / 14)
    assert side.ccrs_aeb == pytest.approx((14 - 1 / 6) / 14)
    yellow = en.score(GRID, avoided_except({pick("CCRm", 80): 0.2 * 60}))  # 2 points/speed
    assert yellow.ccrm == pytest.approx((15 - 0.25 * 2 * 2 / 6) / 15)
    fcw = en.score(GRID, avoided_except({p: 64.0 for p in GRID if p.speed_kmh == 80}))
    assert fcw.ccrs_fcw == pytest.approx(0.5 * 5 / 6)
    ccrb = en.score(GRID, avoided_except({p: 20.0 for p in GRID if p.headway == 40.0}))
    assert ccrb.ccrb == pytest.approx((2 * 1.0 + 2 * 0.5) / 4)  # two of four points orange
    assert ccrb.total == pytest.approx(3.25)
    assert ccrb.points("CCRb") == ccrb.ccrb and ccrb.points("CCRs FCW") == 0.5


def test_ccrs_aeb_needs_avoidance_up_to_20_kmh():
    """AP §3.3: any contact in CCRs AEB at <= 20 km/h forfeits the CCRs AEB points."""
    green_contact = en.score(GRID, avoided_except({pick("CCRs AEB", 20, 0.5): 0.5}))
    assert en.point_colour(pick("CCRs AEB", 20, 0.5), 0.5 * KMH) == "green"
    assert not green_contact.ccrs_avoidance and green_contact.ccrs_aeb == 0.0
    assert green_contact.total == pytest.approx(2.5)
    later = en.score(GRID, avoided_except({pick("CCRs AEB", 25, 0.5): 0.5}))
    assert later.ccrs_avoidance and later.ccrs_aeb == pytest.approx(1.0)


def test_assessment_speed_is_v_impact_except_in_ccrm():
    ccrb, ccrm, ccrs = pick("CCRb", 50), pick("CCRm", 60), pick("CCRs AEB", 30)
    assert en.assessment_speed(ccrb, 8.0, 3.0) == 8.0
    assert en.assessment_speed(ccrm, 8.0, 3.0) == 5.0
    assert en.assessment_speed(ccrs, 8.0, 0.0) == 8.0


def test_rating_sheet_rows_add_up_to_the_total():
    speeds = [0.35 * p.reference_speed if p.speed_kmh > 20 else 0.0 for p in GRID]
    sheet = en.rating_sheet(GRID, speeds)
    assert len(sheet.rows) == len(GRID)
    assert {r["colour"] for r in sheet.rows} == {"green", "orange"}
    total = en.score(GRID, speeds).total
    assert sum(r["points"] for r in sheet.rows) == pytest.approx(total, abs=1e-3)
    row = sheet.rows[GRID.index(pick("CCRs AEB", 50, -0.75))]
    assert row["impact_kmh"] == pytest.approx(17.5)
    assert (row["scenario"], row["function"], row["overlap_pct"]) == ("CCRs", "AEB", -75)
    assert f"total: {total:.3f} of 3.500 points" in sheet.format()


BAD = [
    (lambda: en.score(GRID, np.zeros(3)), "impact_speeds must have shape"),
    (lambda: en.score(GRID[:2], [0.0, -1.0]), "impact_speeds must be >= 0"),
    (lambda: en.score(GRID[:2], [0.0, np.nan]), "NaN or inf"),
    (lambda: en.score(GRID[:2], [np.inf, 0.0]), "NaN or inf"),
    (lambda: en.score(GRID[:2], ["fast", 0.0]), "must be numbers"),
    (lambda: en.score([GRID[0], GRID[0]], [0.0, 0.0]), "given twice"),
    (lambda: en.rating_sheet(GRID, [0.0]), "impact_speeds must have shape"),
    (lambda: en.point_colour(GRID[0], -0.1), "impact_speed must be a finite speed"),
    (lambda: en.point_colour(GRID[0], float("nan")), "impact_speed must be a finite speed"),
    (lambda: en.point_score(GRID[0], None), "impact_speed must be a number"),
]


@pytest.mark.parametrize("call, match", BAD)
def test_bad_input_is_one_line_input_error(call, match):
    with pytest.raises(InputError, match=match) as err:
        call()
    assert "\n" not in str(err.value)


def test_points_outside_the_grid_are_rejected():
    odd = en.CCRPoint("CCRs", "aeb", 12 * KMH, 12, 0.0, 1.0, None, 0.0, 1.0)
    assert en.point_colour(odd, 1.3 * KMH) == "yellow"  # a colour for any speed ...
    with pytest.raises(InputError, match=r"points\[0\] is not a test point"):
        en.score([odd], [0.0])  # ... but scored only on the protocol's grid


@pytest.mark.parametrize(
    "fields, match",
    [
        ({"scenario": "CCRx"}, "scenario must be one of"),
        ({"mode": "aes"}, "mode must be one of"),
        ({"subject_speed": 0.0}, "subject_speed"),
        ({"target_speed": 30.0}, "target_speed"),
        ({"target_speed": 1.0}, "target_speed"),  # CCRs: a stationary target
        ({"scenario": "CCRm", "target_speed": 10.0}, "target_speed"),  # CCRm: a slower one
        ({"overlap": 0.0}, "overlap"),
        ({"overlap": -1.5}, "overlap"),
        ({"subject_speed": float("nan")}, "subject_speed"),
    ],
)
def test_bad_point_is_config_error(fields, match):
    kw = dict(
        scenario="CCRs",
        mode="aeb",
        subject_speed=10.0,
        speed_kmh=36,
        target_speed=0.0,
        overlap=1.0,
        headway=None,
        target_deceleration=0.0,
        weight=1.0,
    )
    with pytest.raises(ConfigError, match=match) as err:
        en.CCRPoint(**{**kw, **fields})
    assert "\n" not in str(err.value)


def test_fcw_driver_model_constants():
    """TP §8.4.6 and A.4: the robot brakes 1.2 s after the warning at 4 m/s²."""
    assert (en.FCW_REACTION_TIME, en.FCW_DECELERATION) == (1.2, 4.0)


def test_plot_grid_writes_a_png(tmp_path):
    rng = np.random.default_rng(0)
    speeds = rng.uniform(0.0, 1.0, len(GRID)) * [p.reference_speed for p in GRID]
    out = en.plot_grid(GRID, speeds, tmp_path / "figs" / "ccr.png")
    assert out == tmp_path / "figs" / "ccr.png"
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    part = en.plot_grid(GRID[:10], speeds[:10], tmp_path / "part.png")  # the rest blank
    assert part.stat().st_size > 1000
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["ccr.png", "figs", "part.png"]
