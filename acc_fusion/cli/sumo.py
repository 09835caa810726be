"""``acc-fusion sumo``: FCW in SUMO traffic, FCW off and on on the same seed, in the 2-D world
(every object, trackers, in-path selection; alerts by class and cause) or, with ``--pair``, in
the 1-D pair world; ``--open-loop`` the 2-D pipeline without drivers, under several conditions;
``--seeds`` many seeds in parallel processes (or on Ray), pooled."""

from __future__ import annotations

import argparse
from dataclasses import replace

from acc_fusion.cli.common import (
    osi_output,
    report_world,
    sim_config,
    traffic_config,
    traffic_sim_config,
    write_study,
)
from acc_fusion.cli.world import parse_conditions
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.outputs import output_dir, save_figure_atomic, write_csv_atomic
from acc_fusion.studies.traffic import sumo_study
from acc_fusion.studies.world import WorldStudy, sumo_world_study
from acc_fusion.sweep.executors import make_map
from acc_fusion.sweep.seeds import parse_seeds, seeds_study
from acc_fusion.truth.sumo.nets import resolve_sumocfg


def run_world(args: argparse.Namespace, path, sumo_cfg, conditions) -> int:
    """``acc-fusion sumo --open-loop``, once per condition: print the tables (and write them
    with ``--out``)."""
    sim = sim_config(args, runs=1)
    if sim.drive is not None:
        raise ConfigError("--open-loop runs without drivers reacting to warnings; drop it")
    out = output_dir(args.out) if args.out else None
    study = sumo_world_study(sumo_cfg, sim, conditions, progress=True)
    stem = f"sumo_world_{path.stem}_seed{sumo_cfg.seed}"
    report_world(study, out, stem, sumocfg=str(path), seed=sumo_cfg.seed)
    return 0


def _check(args: argparse.Namespace, conditions: list) -> None:
    """Refuse the flags that do not go together, in one sentence each."""
    world = not args.pair
    if args.pair and (args.open_loop or args.conditions):
        raise ConfigError("--open-loop and --conditions are settings of the 2-D world; drop --pair")
    if world and (args.gui or args.ssm):
        raise ConfigError("the 2-D world runs headless, without the SSM cross-check; add --pair")
    if args.open_loop and (args.all_drives or args.seeds or args.aeb):
        raise ConfigError(
            "--open-loop runs one seed without drivers; drop --all-drives, --seeds, --aeb"
        )
    if not args.open_loop and len(conditions) > 1:
        raise ConfigError("a closed loop runs one condition; give --conditions one value")
    if args.seeds and (args.gui or args.seed is not None):
        raise ConfigError("--seeds runs headless over its own seeds; drop --gui and --seed")
    if not args.seeds and (args.address or args.executor != "local"):
        raise ConfigError("--executor and --address are settings of --seeds")
    if args.osi is not None and (args.pair or args.seeds or args.open_loop):
        raise ConfigError("--osi records the 2-D world of one seed's run; drop --pair, --seeds "
                          "and --open-loop")  # fmt: skip


def run(args: argparse.Namespace) -> int:
    """``acc-fusion sumo``: print the tables (and write them with ``--out``)."""
    path = resolve_sumocfg(args.net, args.sumocfg)
    conditions = [parse_conditions(c) for c in args.conditions or ["day"]]
    _check(args, conditions)
    seeds = parse_seeds(args.seeds) if args.seeds else None
    mapper = make_map(args.executor, args.workers, args.address) if seeds else None
    sumo_cfg = traffic_config(
        args, path, seed=args.seed or 0, gui=args.gui, step_length=args.step_length
    )
    if args.open_loop:
        return run_world(args, path, sumo_cfg, conditions)
    out = output_dir(args.out) if args.out else None
    world = not args.pair
    sim = traffic_sim_config(args)
    if world:
        sim = replace(sim, world=replace(sim.world, conditions=conditions[0]))
    drives = sim.methods if args.all_drives else ()
    if seeds:
        store = out / "runs" if out else None
        study, _ = seeds_study(
            sumo_cfg, sim, seeds, mapper, drives=drives, world=world, store=store, aeb=args.aeb
        )
        stem, seed_field = f"sumo_{path.stem}_seeds", list(seeds)
    else:
        study = sumo_study(sumo_cfg, sim, progress=True, drives=drives, ssm=args.ssm,
                           world=world, aeb=args.aeb, osi=osi_output(args))  # fmt: skip
        stem, seed_field = f"sumo_{path.stem}_seed{sumo_cfg.seed}", sumo_cfg.seed
    table = study.table()
    if seeds:
        table.title += f", {len(seeds)} seeds pooled"
    print(table.format() + "\n\n" + study.classes().format())
    causes = {}
    if world:
        runs = {(path.stem, conditions[0].label): study.off.summaries}
        where = f"SUMO {path.stem}, FCW off" + (f", {len(seeds)} seeds" if seeds else "")
        world_study = WorldStudy(sim, runs, where=where)
        causes = {"causes": world_study.causes(), "cause_rates": world_study.cause_rates()}
        print("\n" + causes["causes"].format())
    print("\n" + study.benefits().format())
    aeb = study.aeb_table()
    if aeb is not None:
        print("\n" + aeb.format())
    replayed = study.replayed
    if replayed:
        print("\n" + study.replayed_table().format())
    hazards = study.hazard_table()
    if hazards is not None:
        print("\n" + hazards.format())
    if args.osi is not None:
        print(f"\nwrote {len(list(args.osi.glob('*.mcap')))} OSI traces in {args.osi}")
    if out is not None:
        tables = {**causes, **({} if aeb is None else {"aeb": aeb})}
        tables |= {} if hazards is None else {"hazards": hazards}
        for name, t in tables.items():
            write_csv_atomic(out / f"{stem}_{name}.csv", t.columns, t.rows)
        if world:
            save_figure_atomic(world_study.figure(), out / f"{stem}_causes.png")
        if hazards is not None:
            save_figure_atomic(study.hazard_figure(), out / f"{stem}_hazards.png")
        write_study(
            out,
            stem,
            table,
            study,
            sumocfg=str(path),
            seed=seed_field,
            ssm=study.ssm_agreement(),
            benefit=study.benefit().as_dict(),
            benefit_by_method={m: b.as_dict() for m, b in study.benefit_by_method().items()},
            benefit_replayed={m: b.as_dict() for m, b in replayed.items()},
            hazards=None if hazards is None else hazards.rows,
            errors=list(study.errors().values()),
        )
    return 1 if study.errors() else 0
