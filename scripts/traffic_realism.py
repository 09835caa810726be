"""Does a traffic source drive like people?  Its kinematics beside naturalistic driving.

Runs the source with its own drivers (SUMO's or highway-env's: nothing injected, nobody warned
or distracted) or reads a recording, takes every vehicle at every step from ``--warmup`` on
(SUMO: seconds from the start, default 60; highway-env: seconds into every episode, default 5;
a recording: seconds into it, default 0) to ``--end`` (default 300 s; a recording: its end),
and prints, for each figure of :mod:`acc_fusion.metrics.realism` (braking onsets per 100 km at
3.0, 3.6 and 4.4 m/s², car-following headways, TTC exposure, lane changes, speed and
acceleration), its value beside the published naturalistic reference
(:mod:`acc_fusion.metrics.realism_references`: the band, the source, pass or fail; "no
reference" where none was found), then the definitions and full citations. ``--plot`` draws
the figure of :mod:`acc_fusion.metrics.realism_plot`. The last line is
``hard_brakes_per_100km=<onsets of 4.4 m/s² or harder per 100 km>``.

    python scripts/traffic_realism.py                             # bundled motorway, 60-300 s
    python scripts/traffic_realism.py --net onramp --plot realism.png
    python scripts/traffic_realism.py --sumocfg my.sumocfg --end 600 --warmup 120
    python scripts/traffic_realism.py --highway highway-v0 --end 400
    python scripts/traffic_realism.py --replay highd --path data/highD/
"""

from __future__ import annotations

import argparse
import sys
import textwrap

from acc_fusion.cli.arguments import add_scenario_arguments
from acc_fusion.cli.common import scenario_config
from acc_fusion.core.errors import AccFusionError
from acc_fusion.core.outputs import save_figure_atomic
from acc_fusion.core.table import Table
from acc_fusion.metrics.realism import RealismStats, realism_stats
from acc_fusion.metrics.realism_plot import realism_figure
from acc_fusion.metrics.realism_references import CheckRow, check
from acc_fusion.metrics.stats import Rate
from acc_fusion.truth.highway.config import SUPPORTED, HighwayConfig
from acc_fusion.truth.highway.trajectories import highway_trajectories
from acc_fusion.truth.replay.source import FORMATS, ReplayConfig
from acc_fusion.truth.replay.trajectories import replay_trajectories
from acc_fusion.truth.sumo.trajectories import sumo_trajectories
from acc_fusion.truth.trajectories import Trajectories

#: The threshold of the last line's hard braking [m/s²] (0.45 g).
HARD = 4.4
#: Defaults of ``--end`` (SUMO and highway-env; a recording: to its end) and ``--warmup``
#: (SUMO: from the run's start; highway-env: from each episode's start; a recording: 0) [s].
DEFAULT_END, SUMO_WARMUP, HIGHWAY_WARMUP = 300.0, 60.0, 5.0
NAME = "traffic_realism.py"


def collect(args: argparse.Namespace) -> Trajectories:
    """The trajectories of the source the flags name, from the warm-up on."""
    if args.highway:
        end = DEFAULT_END if args.end is None else args.end
        warmup = HIGHWAY_WARMUP if args.warmup is None else args.warmup
        config = HighwayConfig(args.highway, seed=args.seed)
        return highway_trajectories(config, warmup, end)
    if args.replay:
        if not args.path:
            raise AccFusionError("--replay needs --path (the recording's folder or file)")
        warmup = 0.0 if args.warmup is None else args.warmup
        config = ReplayConfig(args.replay, args.path)
        return replay_trajectories(config, warmup, args.end)
    args.end = DEFAULT_END if args.end is None else args.end
    args.warmup = SUMO_WARMUP if args.warmup is None else args.warmup
    path, config = scenario_config(args)
    return sumo_trajectories(config, args.end, args.warmup, label=path.name)


def _value(row: CheckRow, stats: RealismStats) -> str:
    """The figure's value as printed: rates of onsets with their 95 % interval."""
    fig = row.figure
    if fig.key.startswith("onsets_") and stats.km > 0:
        n = stats.onsets[[f"onsets_{b:g}" for b in stats.thresholds].index(fig.key)]
        return Rate.poisson(n, stats.km / 100.0).format(".3g")
    if fig.unit == "share":
        return f"{fig.value:.2%}"
    return f"{fig.value:.3g}"


def table(stats: RealismStats, rows: list[CheckRow]) -> Table:
    """The check as a :class:`Table` (figure, value, band, reference, check)."""
    t = Table(
        f"{stats.label}: {stats.km:.0f} km, {stats.vehicles} vehicles, "
        f"{stats.hours:.1f} vehicle-hours, {stats.headways} car-following samples",
        ("figure", "unit", "value", "reference band", "source", "check"),
    )
    for row in rows:
        ref, fig = row.reference, row.figure
        if ref is None:
            band = source = "-"
        elif fig.unit == "share":
            band, source = f"{ref.low:.0%}-{ref.high:.0%}", ref.cite
        else:
            band, source = f"{ref.low:g}-{ref.high:g}", ref.cite
        t.rows.append(
            {
                "figure": fig.label,
                "unit": fig.unit,
                "value": _value(row, stats),
                "reference band": band,
                "source": source,
                "check": row.status,
            }
        )
    return t


def references_text(rows: list[CheckRow]) -> str:
    """The definitions, published values, bands and full citations of the references used."""
    out, seen = ["References:"], set()
    for row in rows:
        ref = row.reference
        if ref is None or ref.key in seen:
            continue
        seen.add(ref.key)
        body = (
            f"{row.figure.label}: {ref.published}. Definition: {ref.definition}. "
            f"Band: {ref.band}. Source: {ref.source}."
        )
        out.append(textwrap.fill(body, 100, initial_indent="- ", subsequent_indent="  "))
    missing = [r.figure.label for r in rows if r.reference is None]
    note = "No published reference found (printed for comparison only): " + ", ".join(missing)
    out.append(textwrap.fill(note + ".", 100))
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    where = add_scenario_arguments(p, None, "measuring")
    where.add_argument(
        "--highway", metavar="ENV", help=f"a highway-env id ({', '.join(SUPPORTED)})"
    )
    where.add_argument("--replay", metavar="FORMAT", help=f"a recording ({', '.join(FORMATS)})")
    p.add_argument("--path", help="--replay: the recording's folder (highD) or file")
    p.set_defaults(end=None)  # by source: see DEFAULT_END
    p.add_argument("--plot", metavar="PNG", help="write the check's figure here")
    args = p.parse_args(argv)
    try:
        traj = collect(args)
    except AccFusionError as exc:
        print(f"{NAME}: error: {exc}", file=sys.stderr)
        return 2
    if traj.km <= 0:
        print(f"{NAME}: error: no vehicle drove after the warm-up", file=sys.stderr)
        return 2
    stats = realism_stats(traj)
    rows = check(stats)
    print(table(stats, rows).format())
    print()
    print(references_text(rows))
    if args.plot:
        save_figure_atomic(realism_figure(traj, stats), args.plot)
        print(f"wrote {args.plot}")
    print(f"hard_brakes_per_100km={stats.onsets_per_100km(HARD):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
