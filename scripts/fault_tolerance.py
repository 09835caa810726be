"""Fault tolerance: every sensor fault of faults.py on each sensor, and two sensors at once.

Car following (radar 20 Hz, infrared 10 Hz, 10 s runs scored from 1 s, the set-up of
:func:`acc_fusion.studies.estimation.following_source`) with each fault active from 3 s to
8 s.  Per fault, the fused-gap RMSE of federated + FDI, of the centralized filter and of each
sensor alone, and the ratio of the federated RMSE to its bound: 1.5x the healthy federated
RMSE, or 1.1x the RMSE of the filter that uses only the remaining healthy sensor when that is
larger (``bound_rule`` says which).  The delay from fault onset to the first detection of a
faulty sensor (median over the runs that detect it) and the fraction of runs that detect it
during the fault, where detected means isolated (``I``), R adapted to a noise burst (``N``)
or silent for ``dropout_time`` (``D``), or a report beyond the gate (``G``, a spike;
``detected_by`` lists what fired); on healthy data,
the false-isolation and false-adaptation rates per pair-hour.  Then the alerts under each
fault, and a lasting radar bias with and without its accommodation
(:func:`acc_fusion.studies.estimation.lasting_bias_table`).  The last line is
``worst_ratio_to_bound=<x>`` (a fault-tolerant federated filter has x <= 1).  ``--set
fusion.fdi.KEY=VALUE`` runs every table with another setting of the fault detector
(:class:`acc_fusion.fusion.fdi.FDIConfig`).  ``--seeds K`` runs K seeds and prints, per
fault, the median and the worst ratio to the bound, and the alerts summed over the seeds.

    python scripts/fault_tolerance.py --runs 100 --seed 0 --plot out/fault_tolerance.png
    python scripts/fault_tolerance.py --seeds 10
    python scripts/fault_tolerance.py --quick
    python scripts/fault_tolerance.py --quick --set fusion.fdi.manoeuvre=false
"""

from __future__ import annotations

import math

import numpy as np
from tqdm.auto import tqdm

from acc_fusion.cli.arguments import positive_int, study_parser
from acc_fusion.cli.common import sim_config
from acc_fusion.core.errors import AccFusionError, ConfigError
from acc_fusion.core.outputs import save_figure_atomic
from acc_fusion.core.table import Table
from acc_fusion.fusion.config import FusionConfig
from acc_fusion.fusion.estimators import make_estimator
from acc_fusion.fusion.fdi import FDIConfig
from acc_fusion.sensors.faults import Fault
from acc_fusion.sensors.suite import SENSOR_NAMES, make_sensors
from acc_fusion.sim.closed_loop import SimConfig, simulate
from acc_fusion.sim.estimation import run_estimation
from acc_fusion.studies.estimation import FOLLOWING_FILTER, following_source, lasting_bias_table

#: Ratio to the healthy RMSE a fault-tolerant method stays below (the issue's bound).
TOLERATED_RATIO = 1.5
#: Ratio to the RMSE of the filter on the remaining healthy sensor(s) (the issue's bound).
REMAINING_RATIO = 1.1
#: The fault window [s] and the run length [s]; errors are scored from SCORE_FROM on.
ONSET, END, DURATION, SCORE_FROM, DT = 3.0, 8.0, 10.0, 1.0, 0.05
#: Runs of ``--quick`` (the whole table in well under a minute).
QUICK_RUNS = 100

#: The alert table: runs of the random FCW suite [s], faults active from ONSET to the end.
ALERT_DURATION, ALERT_SCENARIO = 20.0, "random"


def kind_faults(start: float, end: float) -> dict[str, Fault]:
    """One fault per kind of :data:`acc_fusion.sensors.faults.FAULT_KINDS`, as in the issue,
    active from ``start`` to ``end`` [s]."""
    return {
        "dropout": Fault("dropout", start=start, end=end),
        "stuck": Fault("stuck", start=start, end=end),
        "bias +5 m": Fault("bias", start=start, end=end, magnitude=5.0),
        "2% spikes": Fault(
            "spikes", start=start, end=end, magnitude=10.0, rate_magnitude=5.0, probability=0.02
        ),
        "noise x10": Fault("noise_burst", start=start, end=end, magnitude=10.0),
    }


#: Estimators of the table: label -> fusion method.
METHODS = {
    "federated+FDI": "federated",
    "centralized": "centralized",
    **{f"{s} alone": s for s in SENSOR_NAMES},
}
FEDERATED = "federated+FDI"


def scenarios(start: float = ONSET, end: float = END) -> dict[str, dict[str, tuple[Fault, ...]]]:
    """Fault label -> ``{"<sensor>_faults": faults}``: healthy, every kind on each sensor,
    and two sensors faulty at once (faults active from ``start`` to ``end``)."""
    kinds = kind_faults(start, end)
    out: dict[str, dict[str, tuple[Fault, ...]]] = {"healthy": {}}
    for sensor in SENSOR_NAMES:
        for label, fault in kinds.items():
            out[f"{sensor} {label}"] = {f"{sensor}_faults": (fault,)}
    out["both 2% spikes"] = {f"{s}_faults": (kinds["2% spikes"],) for s in SENSOR_NAMES}
    out["infrared stuck + radar 2% spikes"] = {
        "infrared_faults": (kinds["stuck"],),
        "radar_faults": (kinds["2% spikes"],),
    }
    return out


#: Short column names of the alert table.
ALERT_SHORT = {FEDERATED: "fed", "centralized": "central", "radar alone": "radar",
               "infrared alone": "infrared"}  # fmt: skip


def alert_counts(n_runs: int, seed: int, fdi: FDIConfig) -> dict[str, np.ndarray]:
    """Alerts under each fault: the FCW warnings of each method (fault detector ``fdi``),
    classed from truth (:mod:`acc_fusion.metrics.alert_classes`), on the random FCW suite
    (open loop). Fault -> ``(1 + methods, 2)`` counts: the crash-relevant situations, then
    per method of :data:`METHODS` its sensing-false alerts and missed situations."""
    out = {}
    for fault, faults in scenarios(ONSET, math.inf).items():
        res = simulate(
            SimConfig(
                scenario=ALERT_SCENARIO, runs=n_runs, seed=seed, duration=ALERT_DURATION,
                methods=tuple(METHODS.values()), fusion=FusionConfig(fdi=fdi), **faults,
            )
        )  # fmt: skip
        stats = [res.summaries[method] for method in METHODS.values()]
        out[fault] = np.array(
            [[res.summaries["federated"].relevant, 0]]
            + [[st.sensing_false, st.relevant_missed] for st in stats]
        )
    return out


def alert_table(counts: dict[str, np.ndarray], n_runs: int, seeds: str) -> Table:
    """:func:`alert_counts` (of the ``seeds``, summed) as a table, with their sum over its
    rows, the healthy one included, as its last row."""
    table = Table(
        f"Alert classes under each fault: {n_runs} runs of {ALERT_DURATION:g} s of the "
        f"{ALERT_SCENARIO} FCW suite ({seeds}), faults active from {ONSET:g} s to the end; "
        "sensing-false alerts / crash-relevant situations missed",
        ("fault", "relevant", *(f"{short}_false/missed" for short in ALERT_SHORT.values())),
    )
    for fault, c in {**counts, "all rows": sum(counts.values())}.items():
        row = {"fault": fault, "relevant": int(c[0, 0])}
        for short, (false, missed) in zip(ALERT_SHORT.values(), c[1:], strict=True):
            row[f"{short}_false/missed"] = f"{false}/{missed}"
        table.rows.append(row)
    return table


def seeds_table(
    n_runs: int, seeds: range, fdi: FDIConfig
) -> tuple[Table, dict[str, np.ndarray], float]:
    """:func:`fault_table` and :func:`alert_counts` of every seed of ``seeds``: per fault the
    median and the worst federated ratio to its bound, the seed of the worst and the seeds
    over the bound; the alert counts summed; the worst ratio of all."""
    ratios: dict[str, list[float]] = {}
    counts: dict[str, np.ndarray] = {}
    for seed in tqdm(seeds, desc="seeds", unit="seed", leave=False):
        for row in fault_table(n_runs, seed, fdi)[0].rows:
            ratios.setdefault(row["fault"], []).append(row["ratio_to_bound"])
        for fault, c in alert_counts(n_runs, seed, fdi).items():
            counts[fault] = counts.get(fault, 0) + c
    table = Table(
        f"Fault tolerance over seeds {seeds[0]}-{seeds[-1]}: the federated gap RMSE's ratio "
        f"to its bound, {n_runs} runs of {DURATION:g} s per seed",
        ("fault", "median_ratio", "worst_ratio", "worst_seed", "seeds_over_bound"),
    )
    for fault, r in ratios.items():
        table.rows.append(
            {
                "fault": fault,
                "median_ratio": float(np.median(r)),
                "worst_ratio": max(r),
                "worst_seed": seeds[int(np.argmax(r))],
                "seeds_over_bound": sum(x > 1.0 for x in r),
            }
        )
    return table, counts, max(max(r) for r in ratios.values())


#: What a detection is: isolation, R adapted to a noise burst, silence (a dropout), a report
#: beyond the gate (a spike).
DETECTORS = {"I": "isolated", "N": "adapted", "D": "silent", "G": "gated"}


class _Detections:
    """Per step of one scenario: the first detection of each (pair, sensor) during the fault
    and which detectors fired; isolation and adaptation events (a sensor newly isolated or
    newly adapted) over the whole run."""

    def __init__(self, fdi, n_runs: int) -> None:
        self.fdi = fdi
        shape = (n_runs, len(SENSOR_NAMES))
        self.first = np.full(shape, np.nan)
        self.fired = {k: np.zeros(shape, dtype=bool) for k in DETECTORS}
        self.before = {k: np.zeros(shape, dtype=bool) for k in ("isolated", "adapted")}
        self.events = dict.fromkeys(self.before, 0)

    def __call__(self, frame, meas, out) -> None:
        est = out[FEDERATED]
        now = {
            "isolated": est.isolated,
            "adapted": self.fdi.noise_scale > 1.0,
            "silent": self.fdi.silent & est.valid[:, None],
            "gated": np.nan_to_num(est.nis, nan=0.0) > self.fdi.gate,
        }
        for k in self.before:
            self.events[k] += int((now[k] & ~self.before[k]).sum())
            self.before[k] = now[k].copy()
        if ONSET <= frame.t < END:
            for key, name in DETECTORS.items():
                self.fired[key] |= now[name]
            new = np.logical_or.reduce(list(now.values())) & np.isnan(self.first)
            self.first[new] = frame.t - ONSET


def run_scenario(faults: dict[str, tuple[Fault, ...]], n_runs: int, seed: int, fdi: FDIConfig):
    """Every method (fault detector ``fdi``) on the same truth and measurements; returns
    (stats, isolations)."""
    ests = {
        label: make_estimator(
            FusionConfig(method=method, filter=FOLLOWING_FILTER, fdi=fdi), SENSOR_NAMES, n_runs
        )
        for label, method in METHODS.items()
    }
    iso = _Detections(ests[FEDERATED].fdi, n_runs)
    res = run_estimation(
        following_source(n_runs, seed),
        make_sensors(seed + 1, **faults),
        ests,
        int(round(DURATION / DT)),
        score_from=SCORE_FROM,
        common=False,  # a sensor alone has no track during its dropout: score each on its own
        on_step=iso,
    )
    return res.estimators, iso


def fault_table(n_runs: int, seed: int, fdi: FDIConfig) -> tuple[Table, float]:
    """The whole table and the worst ratio of the federated RMSE to its bound."""
    columns = (
        "fault", *(f"{m}_m" for m in METHODS), "fed_ratio", "central_ratio", "bound_m",
        "bound_rule", "ratio_to_bound", "detect_delay_s", "detected_frac", "detected_by",
    )  # fmt: skip
    table = Table(
        f"Fault tolerance: fused gap RMSE, {n_runs} runs of {DURATION:g} s, "
        f"faults active {ONSET:g}-{END:g} s",
        columns,
    )
    healthy: dict[str, float] = {}
    worst = 0.0
    for fault, faults in scenarios().items():
        stats, iso = run_scenario(faults, n_runs, seed, fdi)
        rmse = {m: st.rmse_gap for m, st in stats.items()}
        healthy = healthy or rmse
        faulty = [i for i, s in enumerate(SENSOR_NAMES) if f"{s}_faults" in faults]
        remaining = [s for i, s in enumerate(SENSOR_NAMES) if i not in faulty]
        bound, rule = TOLERATED_RATIO * healthy[FEDERATED], f"{TOLERATED_RATIO:g}x healthy"
        if len(remaining) == 1 and REMAINING_RATIO * rmse[f"{remaining[0]} alone"] > bound:
            bound = REMAINING_RATIO * rmse[f"{remaining[0]} alone"]
            rule = f"{REMAINING_RATIO:g}x {remaining[0]} alone"
        first = iso.first[:, faulty]
        row = {
            "fault": fault,
            **{f"{m}_m": v for m, v in rmse.items()},
            "fed_ratio": rmse[FEDERATED] / healthy[FEDERATED],
            "central_ratio": rmse["centralized"] / healthy["centralized"],
            "bound_m": bound,
            "bound_rule": rule,
            "ratio_to_bound": rmse[FEDERATED] / bound,
            "detect_delay_s": float(np.nanmedian(first)) if np.isfinite(first).any() else "-",
            "detected_frac": float(np.isfinite(first).mean()) if faulty else "-",
            "detected_by": "".join(k for k, f in iso.fired.items() if f[:, faulty].any()) or "-",
        }
        if not faulty:
            hours = n_runs * DURATION / 3600.0
            rates = {k: v / hours for k, v in iso.events.items()}
            table.notes.append(
                f"on healthy data, per pair-hour: false isolations {rates['isolated']:.3g}, "
                f"false noise adaptations {rates['adapted']:.3g} ({n_runs} runs of {DURATION:g} s)"
            )
        table.rows.append(row)
        worst = max(worst, row["ratio_to_bound"])
    return table, worst


def plot(table: Table, path: str) -> None:
    """Write a PNG: one group of bars per fault, the federated and centralized ratios to
    their healthy RMSE, with the federated bound."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    faults = [r["fault"] for r in table.rows]
    x = np.arange(len(faults))
    fig, ax = plt.subplots(figsize=(11, 4.5))
    for i, (col, label) in enumerate((("fed_ratio", FEDERATED), ("central_ratio", "centralized"))):
        bars = ax.bar(x + (i - 0.5) * 0.4, [r[col] for r in table.rows], 0.4, label=label)
        ax.bar_label(bars, fmt="%.3g", fontsize=7)
    healthy = table.rows[0][f"{FEDERATED}_m"]
    ax.scatter(x, [r["bound_m"] / healthy for r in table.rows], marker="_", s=300, c="k",
               label="bound (federated)")  # fmt: skip
    ax.set_yscale("log")
    ax.set_ylim(bottom=0.5)  # so that the healthy bars (ratio 1) show
    ax.set_xticks(x, faults, rotation=35, ha="right", fontsize=8)
    ax.set_ylabel("fused gap RMSE / healthy RMSE")
    ax.set_title(table.title, fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure_atomic(fig, path)


def main(argv: list[str] | None = None) -> None:
    parser = study_parser(__doc__, runs=200, plot_help="write a bar chart of the ratios here")
    parser.add_argument(
        "--quick", action="store_true", help=f"{QUICK_RUNS} runs (overrides --runs)"
    )
    parser.add_argument(
        "--set",
        metavar="fusion.fdi.KEY=VALUE",
        action="append",
        default=[],
        dest="overrides",
        help="set a field of the fault detector for every table (repeatable), e.g. "
        "--set fusion.fdi.manoeuvre=false",
    )
    parser.add_argument(
        "--seeds",
        type=positive_int,
        default=1,
        metavar="K",
        help="run seeds --seed to --seed + K - 1 and print, per fault, the median and worst "
        "ratio to the bound, and the alerts summed over the seeds (default 1)",
    )
    args = parser.parse_args(argv)
    runs = QUICK_RUNS if args.quick else args.runs
    try:
        for item in args.overrides:
            if not item.startswith("fusion.fdi."):
                raise ConfigError(f"--set takes fusion.fdi.KEY=VALUE here, got {item!r}")
        if args.seeds > 1 and args.plot:
            raise ConfigError("--plot draws one seed's table; leave out --seeds or --plot")
        fdi = sim_config(args).fusion.fdi
    except AccFusionError as exc:
        parser.exit(2, f"fault_tolerance.py: error: {exc}\n")
    seeds = range(args.seed, args.seed + args.seeds)
    if args.seeds > 1:
        table, counts, worst = seeds_table(runs, seeds, fdi)
        label = f"seeds {seeds[0]}-{seeds[-1]} summed"
    else:
        table, worst = fault_table(runs, args.seed, fdi)
        counts, label = alert_counts(runs, args.seed, fdi), f"seed {args.seed}"
    print(table.format())
    print()
    print(alert_table(counts, runs, label).format())
    print()
    print(lasting_bias_table(runs, fdi=fdi).format())
    if args.plot:
        plot(table, args.plot)
        print(f"plot written to {args.plot}")
    print(f"worst_ratio_to_bound={worst:.3f}")


if __name__ == "__main__":
    main()
