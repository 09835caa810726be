"""The ``acc-fusion`` command line.

Every command has ``--help``.  A user's mistake (an unknown name, a value out of range, an
unwritable folder) ends with one line ``acc-fusion: error: …`` and exit code 2, never a
Python traceback.

Commands:
    run          one scenario, closed loop: summary, PNG, trace CSV and JSON summary
    compare      every method on the randomised suite: false alarms, misses, lead time
    conformance  the standard FCW test manoeuvres against the protocols' requirements
    sumo         FCW in SUMO traffic (bundled networks or any .sumocfg), FCW on and off
    highway      FCW in highway-env traffic, FCW on and off, rendered replays
    evaluate     a warning policy against the baselines in the gymnasium environment
    sweep        Monte Carlo sweeps (local processes or Ray), resumable, ROC curves, report
    estimation   federated fusion against its baselines (RMSE, NEES, cost per pair-step)

Settings come from ``--config FILE`` (TOML or YAML, the fields of
:class:`acc_fusion.sim.closed_loop.SimConfig`) and from flags, which override the file.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

import numpy as np

from acc_fusion.cli.common import (
    write_summary,
    positive_float,
    positive_int,
    sim_config,
    write_study,
)
from acc_fusion.core.errors import AccFusionError


def _cmd_run(args: argparse.Namespace) -> int:
    from acc_fusion.core.outputs import output_dir, save_figure_atomic, write_csv_atomic
    from acc_fusion.core.plots import run_figure
    from acc_fusion.sim.closed_loop import Trace, simulate

    cfg = sim_config(args, runs=1, drive="federated", methods=("radar", "infrared", "federated"))
    out = output_dir(args.out)
    trace = Trace(cfg.warning)
    result = simulate(cfg, progress=True, on_step=trace)
    for method, summary in result.summaries.items():
        print(f"== {method}{' (drives the closed loop)' if method == cfg.drive else ''}")
        print(summary.format())
    print(f"collisions: {int(result.collided.sum())} of {cfg.runs} runs")
    stem = f"run_{cfg.scenario}_seed{cfg.seed}"
    write_csv_atomic(out / f"{stem}.csv", list(trace.rows[0]), trace.rows)
    save_figure_atomic(run_figure(trace, cfg), out / f"{stem}.png")
    print(f"wrote {out / (stem + '.csv')} and {out / (stem + '.png')}")
    write_summary(
        out,
        f"{stem}.json",
        {
            "scenario": cfg.scenario,
            "seed": cfg.seed,
            "runs": cfg.runs,
            "drive": cfg.drive,
            "collisions": int(result.collided.sum()),
            "methods": {m: s.as_dict() for m, s in result.summaries.items()},
        },
    )
    return 0


def _cmd_compare(args: argparse.Namespace) -> int:
    from acc_fusion.core.outputs import output_dir, save_figure_atomic, write_csv_atomic
    from acc_fusion.core.plots import rates_figure
    from acc_fusion.studies.compare import COMPARE_CLUTTER, compare

    cfg = sim_config(args, scenario="random", radar=COMPARE_CLUTTER)
    out = output_dir(args.out) if args.out else None
    comparison = compare(cfg, progress=True)
    table = comparison.table()
    print(table.format())
    if out is not None:
        write_csv_atomic(out / "compare.csv", table.columns, table.rows)
        c = comparison.collisions
        title = (
            f"{cfg.runs} randomised runs, 95% intervals; closed loop: {c['on']} collisions "
            f"with {c['drive']} alerts, {c['off']} without"
        )
        save_figure_atomic(rates_figure(comparison.result.summaries, title), out / "compare.png")
        print(f"wrote {out / 'compare.csv'} and {out / 'compare.png'}")
        write_summary(
            out,
            "compare.json",
            {
                "config": {"scenario": cfg.scenario, "runs": cfg.runs, "seed": cfg.seed},
                "collisions": comparison.collisions,
                "methods": {m: s.as_dict() for m, s in comparison.result.summaries.items()},
            },
        )
    return 0


def _cmd_conformance(args: argparse.Namespace) -> int:
    from acc_fusion.core.outputs import output_dir, write_csv_atomic
    from acc_fusion.studies.compare import conformance

    cfg = sim_config(args)
    out = output_dir(args.out) if args.out else None
    results = conformance(args.trials, cfg.seed, cfg, progress=True)
    rows = []
    for res in results:
        req = res.requirement
        for i, (ttc, ok) in enumerate(zip(res.ttc, res.passed, strict=True), start=1):
            rows.append(
                {
                    "manoeuvre": req.scenario,
                    "trial": i,
                    "ttc_at_warning_s": "no warning" if np.isnan(ttc) else f"{ttc:.2f}",
                    "required_ttc_s": f">= {req.required_ttc:g}",
                    "result": "pass" if ok else "FAIL",
                }
            )
    from acc_fusion.core.table import Table

    table = Table(
        f"FCW conformance: {args.trials} trials per manoeuvre, seed {cfg.seed}",
        ("manoeuvre", "trial", "ttc_at_warning_s", "required_ttc_s", "result"),
        rows,
    )
    print(table.format())
    print()
    for res in results:
        req = res.requirement
        verdict = "PASS" if res.ok else "FAIL"
        note = "" if req.verified else "  (requirement assumed, see acc_fusion.metrics.protocols)"
        print(
            f"{req.scenario:10s} {verdict}: {int(res.passed.sum())} of {len(res.passed)} trials "
            f"passed, {res.needed} needed ({req.protocol}: {req.test}){note}"
        )
    if out is not None:
        write_csv_atomic(out / "conformance.csv", table.columns, rows)
        print(f"wrote {out / 'conformance.csv'}")
    return 0 if all(r.ok for r in results) else 1


def _cmd_sumo(args: argparse.Namespace) -> int:
    from acc_fusion.core.outputs import output_dir
    from acc_fusion.studies.traffic import resolve_sumocfg, sumo_study
    from acc_fusion.truth.sumo.source import SumoConfig

    path = resolve_sumocfg(args.net, args.sumocfg)
    sumo_cfg = SumoConfig(
        sumocfg=str(path),
        end=args.end,
        penetration=args.penetration,
        seed=args.seed or 0,
        hazard_rate=args.hazard_rate,
        inattentive=args.inattentive,
        gui=args.gui,
        step_length=args.step_length,
    )
    out = output_dir(args.out) if args.out else None
    sim = sim_config(args, runs=1)
    study = sumo_study(sumo_cfg, sim, progress=True)
    table = study.table()
    print(table.format())
    if out is not None:
        write_study(
            out,
            f"sumo_{path.stem}_seed{sumo_cfg.seed}",
            table,
            study,
            sumocfg=str(path),
            seed=sumo_cfg.seed,
            ssm=study.ssm_agreement(),
            errors=[e for e in (study.off.error, study.on.error) if e],
        )
    return 1 if (study.off.error or study.on.error) else 0


def _cmd_estimation(args: argparse.Namespace) -> int:
    from acc_fusion.core.outputs import output_dir, save_figure_atomic, write_csv_atomic
    from acc_fusion.core.plots import estimation_bars
    from acc_fusion.studies.estimation import compare_methods

    out = output_dir(args.out) if args.out else None
    table = compare_methods(
        n_runs=args.runs, duration=args.duration, seed=args.seed, engine=args.engine
    )
    print(table.format())
    if out is not None:
        write_csv_atomic(out / "estimation.csv", table.columns, table.rows)
        save_figure_atomic(estimation_bars(table), out / "estimation.png")
        print(f"wrote {out / 'estimation.csv'} and {out / 'estimation.png'}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="acc-fusion",
        description="Forward-collision-warning research by simulation: radar + infrared "
        "sensors, per-sensor Kalman filters and a federated fusion center.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def common(p: argparse.ArgumentParser, runs_help: str | None) -> None:
        p.add_argument("--config", metavar="FILE", help="TOML or YAML file of SimConfig fields")
        p.add_argument("--seed", type=int, help="random seed (default 0)")
        if runs_help:
            p.add_argument("--runs", type=positive_int, help=runs_help)

    run = sub.add_parser(
        "run",
        help="one scenario, closed loop: summary, PNG, trace CSV, JSON",
        description="Run one scenario closed loop: the federated filter's alerts make the "
        "simulated driver brake. Prints each method's FCW summary and writes a PNG (truth, "
        "radar, infrared, local and fused gap with 2-sigma bands, safety distance, warning "
        "bands), the trace of run 0 as CSV and a JSON summary.",
    )
    run.add_argument("--scenario", required=True, help="scenario name (see the error for the list)")
    common(run, "runs of the scenario (default 1)")
    run.add_argument(
        "--method", help="method whose alerts drive the closed loop (default federated)"
    )
    run.add_argument("--out", metavar="DIR", default="out", help="output folder (default out)")
    run.set_defaults(func=_cmd_run)

    cmp_ = sub.add_parser(
        "compare",
        help="radar, infrared, centralized, federated: false alarms, misses, lead time",
        description="Radar alone, infrared alone, centralized and federated fusion on the "
        "same randomised scenarios and seeds (with radar clutter): false alarms per hour and "
        "per 100 km, miss rate, lead time, with 95% intervals; then collisions with the "
        "federated alerts on and off, closed loop, on the same seeds.",
    )
    common(cmp_, "Monte Carlo runs (default 200)")
    cmp_.add_argument("--out", metavar="DIR", help="also write compare.csv/.png/.json here")
    cmp_.set_defaults(func=_cmd_compare)

    conf = sub.add_parser(
        "conformance",
        help="standard FCW manoeuvres against the protocols' requirements (exit 1 on failure)",
        description="Run the NHTSA FCW confirmation tests and the Euro NCAP car-to-car rear "
        "manoeuvres with noisy sensors, several trials each; print the TTC at the first "
        "alert of every trial against the protocol's requirement. Exit code 0 only when every "
        "manoeuvre passes by its pass rule (5 of 7 trials).",
    )
    conf.add_argument(
        "--trials", type=positive_int, default=7, help="trials per manoeuvre (default 7)"
    )
    common(conf, None)
    conf.add_argument("--out", metavar="DIR", help="also write conformance.csv here")
    conf.set_defaults(func=_cmd_conformance)

    sm = sub.add_parser(
        "sumo",
        help="FCW in SUMO traffic: false alarms per method, collisions with FCW on and off",
        description="Run a SUMO scenario (a bundled network or any .sumocfg) with libsumo, "
        "embedded: every equipped vehicle and its leader are a pair. Twice, in two "
        "processes: FCW off (every method watches, no driver is warned) and FCW on (the "
        "federated alerts make equipped drivers brake), on the same seed. Prints false "
        "alarms per hour and per 100 km, miss rate, lead time and collisions, with 95% "
        "intervals, and the oracle's TTC against SUMO's SSM device.",
    )
    where = sm.add_mutually_exclusive_group(required=True)
    where.add_argument("--net", help="bundled network: motorway, onramp, ring, arterial")
    where.add_argument("--sumocfg", metavar="PATH", help="any SUMO configuration file")
    sm.add_argument("--end", type=positive_float, help="simulated seconds (default: the file's)")
    sm.add_argument(
        "--penetration", type=float, default=1.0, help="fraction of equipped vehicles (default 1)"
    )
    sm.add_argument(
        "--hazard-rate",
        type=float,
        default=2.0,
        help="injected emergency brakings per vehicle-hour (default 2)",
    )
    sm.add_argument(
        "--inattentive",
        type=float,
        default=0.2,
        help="fraction of equipped drivers who react late (default 0.2)",
    )
    sm.add_argument(
        "--step-length", type=positive_float, help="SUMO step [s] (default: the file's)"
    )
    sm.add_argument("--gui", action="store_true", help="sumo-gui, vehicles coloured by warning")
    common(sm, None)
    sm.add_argument("--out", metavar="DIR", help="also write CSV, PNG and JSON here")
    sm.set_defaults(func=_cmd_sumo)

    from acc_fusion.envs.evaluation import add_evaluate_parser
    from acc_fusion.sweep.run import add_sweep_parser
    from acc_fusion.truth.highway.source import add_highway_parser

    add_highway_parser(sub)
    add_evaluate_parser(sub)
    add_sweep_parser(sub)

    est = sub.add_parser(
        "estimation",
        help="compare federated fusion with its baselines (RMSE, NEES, cost)",
        description="Run every fusion method (each sensor alone, centralized sequential and "
        "stacked, federated in its three reset modes, with fault isolation, and the plain "
        "formula) on the same car-following truth and measurements; print RMSE, mean NEES "
        "with its 95% bounds, and the cost per pair-step.",
    )
    est.add_argument(
        "--runs", type=positive_int, default=500, help="Monte Carlo runs (default 500)"
    )
    est.add_argument(
        "--duration", type=positive_float, default=10.0, help="seconds per run (default 10)"
    )
    est.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    est.add_argument(
        "--engine",
        choices=("batched", "filterpy"),
        default="batched",
        help="filter engine (default batched)",
    )
    est.add_argument(
        "--out", metavar="DIR", help="also write estimation.csv and estimation.png here"
    )
    est.set_defaults(func=_cmd_estimation)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``acc-fusion`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except AccFusionError as exc:
        print(f"acc-fusion: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("acc-fusion: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
