"""``acc-fusion world``: the scripted 2-D scenes (or an OpenSCENARIO file) — radar and
thermal camera seeing every object ahead, multi-target trackers, in-path selection — under
weather and light conditions: alerts by class and by cause per method."""

from __future__ import annotations

import argparse

from acc_fusion.cli.common import (
    osi_output,
    sim_config,
    write_summary,
)
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.outputs import save_figure_atomic, write_csv_atomic
from acc_fusion.studies.world import scenario_file_study, world_study
from acc_fusion.truth.conditions import Conditions
from acc_fusion.truth.scenes import SCENES


def parse_conditions(text: str) -> Conditions:
    """``day``, ``night``, ``fog=V`` (visibility [m]), ``rain=R`` [mm/h], joined by ``+``
    (``night+fog=60``) into :class:`Conditions`; anything else is one ConfigError."""
    fields: dict[str, object] = {}
    for part in text.split("+"):
        key, sep, value = part.strip().partition("=")
        if key in ("day", "night") and not sep:
            fields["light"] = key
        elif key in ("fog", "rain") and sep:
            try:
                number = float(value)
            except ValueError:
                raise ConfigError(
                    f"--conditions {text!r}: {key} takes a number, got {value!r}"
                ) from None
            fields["fog_visibility" if key == "fog" else "rain_rate"] = number
        else:
            raise ConfigError(
                f"--conditions takes day, night, fog=METRES, rain=MM_PER_H joined by '+', "
                f"got {text!r}"
            )
    return Conditions(**fields)


def run(args: argparse.Namespace) -> int:
    """``acc-fusion world``: print the tables (and write them with ``--out``)."""
    conditions = [parse_conditions(c) for c in args.conditions]
    scenes = args.scene or sorted(SCENES)
    config = sim_config(args, runs=50)
    out = args.out
    osi = osi_output(args)
    if args.scenario_file is not None:
        study = scenario_file_study(config, args.scenario_file, conditions, progress=True, osi=osi)
    else:
        study = world_study(config, scenes, conditions, progress=True, osi=osi)
    tables = {"world_scenes": study.scenes(), "world_causes": study.causes()}
    print("\n\n".join(t.format() for t in tables.values()))
    if args.plot:
        save_figure_atomic(study.figure(), args.plot)
        print(f"wrote {args.plot}")
    if out is not None:
        tables["world_cause_rates"] = study.cause_rates()
        for stem, t in tables.items():
            write_csv_atomic(out / f"{stem}.csv", t.columns, t.rows)
        write_summary(
            out,
            "world.json",
            {
                f"{scene} / {label}": {m: s.as_dict() for m, s in summaries.items()}
                for (scene, label), summaries in study.results.items()
            },
        )
    if args.osi is not None:
        print(f"wrote {len(study.traces)} OSI traces in {args.osi}")
    return 0
