"""The arguments of ``acc-fusion replay`` (its work: :mod:`acc_fusion.cli.replay`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import (
    add_config_arguments,
    add_osi_argument,
    output_folder,
    positive_int,
)
from acc_fusion.truth.replay import BAD_ROWS, FORMATS


def add_parser(subparsers, summary: str) -> argparse.ArgumentParser:
    """Add the ``replay`` command."""
    p = subparsers.add_parser(
        "replay",
        help=summary,
        description="Replay recorded vehicle trajectories as truth: every vehicle is an ego, "
        "its preceding vehicle the target (from the data set's leader column, or recomputed "
        "from lanes and positions). Open loop only: a recorded driver cannot react. Prints "
        "per method (radar, infrared, centralized, federated) the alerts per 100 km by class "
        "with 95%% intervals, the exposure per recording and the cross-check of the replay's "
        "gap, time headway and TTC against the data set's own columns. No data set ships "
        "with acc_fusion: see the replay guide for where to obtain highD and NGSIM. Format "
        "osi: ASAM OSI ground-truth traces, each trace's host an ego, through the 2-D world "
        "(alerts also by cause; a trace written with --osi replays with its recorded "
        "detections, so it gives its run's alerts again), or the 1-D pair with --pair.",
    )
    p.add_argument("--format", required=True, choices=FORMATS, help="the recording's format")
    p.add_argument(
        "--path",
        required=True,
        help="highD: the folder of NN_tracks.csv, NN_tracksMeta.csv, NN_recordingMeta.csv; "
        "ngsim, csv: the trajectory file; osi: a .mcap or .osi trace of GroundTruth or "
        "SensorView messages, or a folder of them (one ego each)",
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
    p.add_argument(
        "--bad-rows",
        choices=BAD_ROWS,
        default="refuse",
        help="a row outside the physical bounds (position, speed, acceleration, length, id): "
        "refuse the recording, naming its row and column (default), or drop it and count it",
    )
    p.add_argument(
        "--no-cache",
        action="store_true",
        help="parse the CSV recordings without keeping a binary copy of their columns (by "
        "default the first replay of a file keeps one in $ACC_FUSION_REPLAY_CACHE, else "
        "replay/ of $ACC_FUSION_CACHE, $XDG_CACHE_HOME/acc_fusion or ~/.cache/acc_fusion, and "
        "later replays read it instead of parsing)",
    )
    p.add_argument(
        "--pair",
        action="store_true",
        help="osi: the 1-D pair of host and lead (each sensor sees only the true leader) "
        "instead of the 2-D world (radar and thermal camera seeing every object of the trace, "
        "trackers, in-path selection)",
    )
    p.add_argument(
        "--topic",
        help="osi: the MCAP channel to read (default: the first GroundTruth channel, else the "
        "first SensorView channel)",
    )
    add_osi_argument(p, "the replay (osi, 2-D world; files named as their source traces)")
    add_config_arguments(p)
    p.add_argument(
        "--out",
        metavar="DIR",
        type=output_folder,
        help="also write CSV, JSON and the headway PNG here",
    )
    return p
