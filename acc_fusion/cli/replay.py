"""``acc-fusion replay``: recorded traffic (highD, NGSIM, any mapped trajectory CSV, ASAM OSI
traces) through the FCW pipeline, open loop: alerts per 100 km by class per method, the data's
headway distribution, per-recording exposure and the cross-check against the data set's columns
(and, for OSI traces, through the 2-D world unless ``--pair``, the alerts by cause).
"""

from __future__ import annotations

import argparse
import re

from acc_fusion.cli.common import (
    osi_output,
    sim_config,
    write_summary,
)
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.outputs import save_figure_atomic, write_csv_atomic
from acc_fusion.studies.replay import replay_study
from acc_fusion.truth.replay.source import ReplayConfig


def run(args: argparse.Namespace) -> int:
    """``acc-fusion replay``: print the tables (and write them with ``--out``)."""
    config = ReplayConfig(
        format=args.format,
        path=args.path,
        recordings=tuple(args.recording),
        mapping=args.mapping,
        recompute_leaders=args.recompute_leaders,
        slots=args.slots,
        bad_rows=args.bad_rows,
        cache=not args.no_cache,
    )
    out = args.out
    sim = sim_config(args, runs=1)
    if args.format != "osi" and (args.pair or args.topic):
        raise ConfigError("--pair and --topic are settings of --format osi (the other formats "
                          "replay the 1-D pair)")  # fmt: skip
    world = args.format == "osi" and not args.pair
    if args.osi is not None and not world:
        raise ConfigError("--osi writes the 2-D world's traces: give --format osi without --pair")
    study = replay_study(
        config, sim, progress=True, world=world, topic=args.topic, osi=osi_output(args)
    )
    tables = {
        "": study.table(),
        "_classes": study.classes(),
        "_exposure": study.exposure(),
        "_crosscheck": study.crosscheck(),
    }
    causes = study.causes()
    if causes is not None:  # the 2-D world's (osi --world)
        tables["_causes"] = causes
    shown = [t.format() if t.rows else f"{t.title}: none" for t in tables.values()]
    print("\n\n".join(shown))
    if out is not None:
        stem = "replay_" + re.sub(r"[^A-Za-z0-9]+", "_", study.name).strip("_")
        for suffix, t in tables.items():
            write_csv_atomic(out / f"{stem}{suffix}.csv", t.columns, t.rows)
        save_figure_atomic(study.headway_figure(), out / f"{stem}_headways.png")
        print(f"wrote {stem}*.csv and {stem}_headways.png in {out}")
        write_summary(
            out,
            f"{stem}.json",
            {
                "format": config.format,
                "path": config.path,
                "steps": study.steps,
                "exposure": tables["_exposure"].rows,
                "crosscheck": tables["_crosscheck"].rows,
                **{m: s.as_dict() for m, s in study.summaries.items()},
            },
        )
    if args.osi is not None:
        print(f"wrote {len(list(args.osi.glob('*.mcap')))} OSI traces in {args.osi}")
    return 0
