"""``acc-fusion replay``: recorded traffic (highD, NGSIM, any mapped trajectory CSV) through the
FCW pipeline, open loop: alerts per 100 km by class per method, the data's headway
distribution, per-recording exposure and the cross-check against the data set's columns.
"""

from __future__ import annotations

import argparse
import re

from acc_fusion.cli.common import (
    add_config_arguments,
    output_folder,
    positive_int,
    sim_config,
    write_summary,
)
from acc_fusion.core.outputs import save_figure_atomic, write_csv_atomic
from acc_fusion.studies.replay import replay_study
from acc_fusion.truth.replay.source import FORMATS, ReplayConfig


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``replay`` command."""
    p = subparsers.add_parser(
        "replay",
        help="recorded traffic (highD, NGSIM, trajectory CSV) through the FCW pipeline, "
        "open loop: alert classes per method, headways, exposure",
        description="Replay recorded vehicle trajectories as truth: every vehicle is an ego, "
        "its preceding vehicle the target (from the data set's leader column, or recomputed "
        "from lanes and positions). Open loop only: a recorded driver cannot react. Prints "
        "per method (radar, infrared, centralized, federated) the alerts per 100 km by class "
        "with 95%% intervals, the exposure per recording and the cross-check of the replay's "
        "gap, time headway and TTC against the data set's own columns. No data set ships "
        "with acc_fusion: see the replay guide for where to obtain highD and NGSIM.",
    )
    p.add_argument("--format", required=True, choices=FORMATS, help="the recording's format")
    p.add_argument(
        "--path",
        required=True,
        help="highD: the folder of NN_tracks.csv, NN_tracksMeta.csv, NN_recordingMeta.csv; "
        "ngsim, csv: the trajectory file",
    )
    p.add_argument(
        "--recording",
        action="append",
        default=[],
        metavar="N",
        help="highD: a recording number; ngsim: a Location value (repeatable; default: all)",
    )
    p.add_argument("--mapping", metavar="FILE", help="csv: TOML/YAML file of the column mapping")
    p.add_argument(
        "--recompute-leaders",
        action="store_true",
        help="recompute leaders from lanes and positions even where the file names them",
    )
    p.add_argument(
        "--slots", type=positive_int, default=2048, help="pairs replayed at once (default 2048)"
    )
    add_config_arguments(p)
    p.add_argument(
        "--out",
        metavar="DIR",
        type=output_folder,
        help="also write CSV, JSON and the headway PNG here",
    )
    return p


def run(args: argparse.Namespace) -> int:
    """``acc-fusion replay``: print the tables (and write them with ``--out``)."""
    config = ReplayConfig(
        format=args.format,
        path=args.path,
        recordings=tuple(args.recording),
        mapping=args.mapping,
        recompute_leaders=args.recompute_leaders,
        slots=args.slots,
    )
    out = args.out
    sim = sim_config(args, runs=1)
    study = replay_study(config, sim, progress=True)
    tables = {
        "": study.table(),
        "_classes": study.classes(),
        "_exposure": study.exposure(),
        "_crosscheck": study.crosscheck(),
    }
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
    return 0
