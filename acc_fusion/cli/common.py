"""What the commands share: argparse types, the study-script parser, the SimConfig from file and
flags, and the writing of a study's outputs."""

from __future__ import annotations

import argparse


def positive_int(text: str) -> int:
    """argparse type: a whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def positive_float(text: str) -> float:
    """argparse type: a number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {value:g}")
    return value


def study_parser(doc: str, runs: int, plot_help: str | None = None) -> argparse.ArgumentParser:
    """Parser of a study script: ``--runs``, ``--seed`` and, with ``plot_help``, ``--plot``."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument(
        "--runs", type=positive_int, default=runs, help=f"Monte Carlo runs (default {runs})"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of truth and noise (default 0)")
    if plot_help:
        parser.add_argument("--plot", metavar="PATH", help=plot_help)
    return parser


def sim_config(args: argparse.Namespace, **defaults):
    """SimConfig from defaults, then ``--config`` FILE, then the flags given."""
    from acc_fusion.core.config import from_mapping, load_mapping
    from acc_fusion.sim.closed_loop import SimConfig

    data = dict(defaults)
    if args.config:
        data.update(load_mapping(args.config))
    for key in ("scenario", "runs", "seed", "method"):
        value = getattr(args, key, None)
        if value is not None:
            if key == "method":
                data["methods"] = tuple(dict.fromkeys([*data.get("methods", ()), value]))
                data["drive"] = value
            else:
                data[key] = value
    return from_mapping(SimConfig, data)


def write_summary(out, name: str, payload: dict) -> None:
    from acc_fusion.core.outputs import write_json_atomic

    write_json_atomic(out / name, payload)
    print(f"wrote {out / name}")


def write_study(out, stem: str, table, study, **fields) -> None:
    """Write a traffic study (FCW off and on): ``stem``.csv (the table), .png (the rates of
    the FCW-off run) and .json (``fields`` and both runs' summaries) into ``out``."""
    from acc_fusion.core.outputs import save_figure_atomic, write_csv_atomic
    from acc_fusion.core.plots import rates_figure

    write_csv_atomic(out / f"{stem}.csv", table.columns, table.rows)
    save_figure_atomic(rates_figure(study.off.summaries, table.title), out / f"{stem}.png")
    print(f"wrote {out / (stem + '.csv')} and {out / (stem + '.png')}")
    runs = {"fcw_off": study.off, "fcw_on": study.on}
    summaries = {k: {m: s.as_dict() for m, s in r.summaries.items()} for k, r in runs.items()}
    write_summary(out, f"{stem}.json", {**fields, **summaries})
