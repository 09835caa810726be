"""``acc-fusion sumo``: FCW in SUMO traffic, FCW off and on on the same seed; with ``--world``
the 2-D object pipeline in the same traffic, open loop, alerts by class and cause, or with
``--closed-loop`` as well FCW off and on, the drivers hearing the 2-D pipeline's warnings."""

from __future__ import annotations

import argparse
from dataclasses import replace

from acc_fusion.cli.common import (
    add_sim_arguments,
    add_traffic_arguments,
    output_folder,
    positive_float,
    report_world,
    sim_config,
    traffic_config,
    traffic_sim_config,
    write_study,
)
from acc_fusion.cli.world import parse_conditions
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.outputs import output_dir, write_csv_atomic
from acc_fusion.studies.traffic import sumo_study
from acc_fusion.studies.world import WorldStudy, sumo_world_study
from acc_fusion.truth.sumo.nets import resolve_sumocfg


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``sumo`` command."""
    p = subparsers.add_parser(
        "sumo",
        help="FCW in SUMO traffic: false alarms per method, collisions with FCW on and off",
        description="Run a SUMO scenario (a bundled network or any .sumocfg) with libsumo, "
        "embedded: every equipped vehicle and its leader are a pair. Twice, in two "
        "processes: FCW off (every method watches, no driver is warned) and FCW on (the "
        "federated alerts make equipped drivers brake), on the same seed. Prints false "
        "alarms per hour and per 100 km, miss rate, lead time and collisions, with 95% "
        "intervals, the alerts by class judged from truth, and the crashes FCW avoids: "
        "paired by vehicle (bootstrap interval), and each crash of the FCW-off run replayed "
        "with every method's warnings (Wilson interval). "
        "The equipped drivers look away from the road now and then (--distraction). "
        "With --world, the 2-D object pipeline instead, open loop (FCW off); with "
        "--world --closed-loop, FCW off and on as above with the 2-D pipeline's warnings.",
    )
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--net", help="bundled network: motorway, onramp, ring, arterial")
    where.add_argument("--sumocfg", metavar="PATH", help="any SUMO configuration file")
    p.add_argument("--end", type=positive_float, help="simulated seconds (default: the file's)")
    add_traffic_arguments(p)
    p.add_argument("--step-length", type=positive_float, help="SUMO step [s] (default: the file's)")
    p.add_argument("--gui", action="store_true", help="sumo-gui, vehicles coloured by warning")
    p.add_argument(
        "--all-drives",
        action="store_true",
        help="one FCW-on run per method (radar, infrared, centralized, federated driving the "
        "alert), to compare the crashes each avoids (two at a time)",
    )
    p.add_argument(
        "--ssm",
        action="store_true",
        help="also compare the oracle's minimum TTC per vehicle with SUMO's SSM device in the "
        "FCW-off run (a cross-check of the TTC; more than doubles that run's time)",
    )
    p.add_argument(
        "--world",
        action="store_true",
        help="run the 2-D object pipeline instead (radar and thermal camera seeing every object "
        "ahead, trackers, association, every method's estimator per object, in-path selection; "
        "world.* settings): open loop, FCW off (no driver reacts to a warning); prints per "
        "method the alerts by class per 100 km and the nuisance and sensing-false alerts by "
        "cause",
    )
    p.add_argument(
        "--closed-loop",
        action="store_true",
        help="with --world: FCW off and on, as without --world, the equipped drivers hearing "
        "the 2-D pipeline's federated warnings (one condition); prints the same tables and the "
        "FCW-off run's alerts by cause",
    )
    p.add_argument(
        "--conditions",
        nargs="+",
        metavar="C",
        help="with --world: weather and light, day, night, fog=METRES, rain=MM_PER_H joined by "
        "'+', one SUMO run each (default: day)",
    )
    add_sim_arguments(p, None)
    p.add_argument(
        "--out", metavar="DIR", type=output_folder, help="also write CSV, PNG and JSON here"
    )
    return p


def run_world(args: argparse.Namespace, path, sumo_cfg, conditions) -> int:
    """``acc-fusion sumo --world``, open loop, once per condition: print the tables (and write
    them with ``--out``)."""
    sim = sim_config(args, runs=1)
    if sim.drive is not None:
        raise ConfigError(
            "--world runs open loop, nobody driving on the warnings; add --closed-loop"
        )
    out = output_dir(args.out) if args.out else None
    study = sumo_world_study(sumo_cfg, sim, conditions, progress=True)
    stem = f"sumo_world_{path.stem}_seed{sumo_cfg.seed}"
    report_world(study, out, stem, sumocfg=str(path), seed=sumo_cfg.seed)
    return 0


def run(args: argparse.Namespace) -> int:
    """``acc-fusion sumo``: print the tables (and write them with ``--out``)."""
    path = resolve_sumocfg(args.net, args.sumocfg)
    for flag, given in (("--conditions", args.conditions), ("--closed-loop", args.closed_loop)):
        if given and not args.world:
            raise ConfigError(f"{flag} is a setting of the 2-D pipeline; add --world")
    if args.world and (args.gui or args.ssm):
        raise ConfigError("--world runs headless, without the SSM cross-check; drop --gui, --ssm")
    if args.world and args.all_drives and not args.closed_loop:
        raise ConfigError("--world runs open loop unless --closed-loop; add it for --all-drives")
    conditions = [parse_conditions(c) for c in args.conditions or ["day"]]
    if args.closed_loop and len(conditions) > 1:
        raise ConfigError("--closed-loop runs one condition; give --conditions one value")
    sumo_cfg = traffic_config(
        args, path, seed=args.seed or 0, gui=args.gui, step_length=args.step_length
    )
    if args.world and not args.closed_loop:
        return run_world(args, path, sumo_cfg, conditions)
    out = output_dir(args.out) if args.out else None
    sim = traffic_sim_config(args)
    if args.world:
        sim = replace(sim, world=replace(sim.world, conditions=conditions[0]))
    drives = sim.methods if args.all_drives else ()
    study = sumo_study(sumo_cfg, sim, progress=True, drives=drives, ssm=args.ssm, world=args.world)
    table = study.table()
    print(table.format() + "\n\n" + study.classes().format())
    causes = {}
    if args.world:
        runs = {(path.stem, conditions[0].label): study.off.summaries}
        world = WorldStudy(sim, runs, where=f"SUMO {path.stem}, FCW off")
        causes = {"causes": world.causes(), "cause_rates": world.cause_rates()}
        print("\n" + causes["causes"].format())
    print("\n" + study.benefits().format())
    replayed = study.replayed
    if replayed:
        print("\n" + study.replayed_table().format())
    if out is not None:
        stem = f"sumo_{path.stem}_seed{sumo_cfg.seed}"
        for name, t in causes.items():
            write_csv_atomic(out / f"{stem}_{name}.csv", t.columns, t.rows)
        write_study(
            out,
            stem,
            table,
            study,
            sumocfg=str(path),
            seed=sumo_cfg.seed,
            ssm=study.ssm_agreement(),
            benefit=study.benefit().as_dict(),
            benefit_by_method={m: b.as_dict() for m, b in study.benefit_by_method().items()},
            benefit_replayed={m: b.as_dict() for m, b in replayed.items()},
            errors=list(study.errors().values()),
        )
    return 1 if study.errors() else 0
