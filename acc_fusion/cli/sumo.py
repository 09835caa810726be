"""``acc-fusion sumo``: FCW in SUMO traffic, FCW off and on on the same seed; with ``--world``
the 2-D object pipeline in the same traffic, open loop, alerts by class and cause, or with
``--closed-loop`` as well FCW off and on, the drivers hearing the 2-D pipeline's warnings."""

from __future__ import annotations

import argparse
from dataclasses import replace

from acc_fusion.cli.common import (
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
