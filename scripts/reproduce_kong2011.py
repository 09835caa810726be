"""Reproduce kong2011 §3: radar + infrared local Kalman filters and their federated fusion.

A target closes on a stationary radar and infrared camera at 3 m/s from 100 m, both sampling
once per second (T = 1 s).  Prints the table of :func:`acc_fusion.studies.estimation.kong2011`: over
``--runs`` Monte Carlo runs, the RMSE of gap and range-rate of each raw sensor, each local
Kalman filter and the federated estimate (paper: each local filter beats its raw sensor, the
fused estimate beats both).  With ``--plot``, writes the paper's figures 3-5 and 7 for run 0
of the same Monte Carlo set: the range-rate of the truth, of each raw sensor, of each local
filter and of the federated filter over time, and below it the gap error of each.

    python scripts/reproduce_kong2011.py --runs 200 --seed 0 --plot out/kong2011.png
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from acc_fusion.cli.arguments import study_parser
from acc_fusion.core.outputs import save_figure_atomic
from acc_fusion.sensors.suite import SENSOR_NAMES
from acc_fusion.studies.estimation import kong2011

ESTIMATORS = ("radar KF", "infrared KF", "federated")


@dataclass
class Trace:
    """Run 0 over time: truth, raw measurements (NaN where none) and estimates."""

    t: list[float] = field(default_factory=list)
    truth: list[np.ndarray] = field(default_factory=list)
    raw: dict[str, list[np.ndarray]] = field(
        default_factory=lambda: {name: [] for name in SENSOR_NAMES}
    )
    est: dict[str, list[np.ndarray]] = field(
        default_factory=lambda: {name: [] for name in ESTIMATORS}
    )

    def record(self, frame, meas, ests) -> None:
        """``on_step`` callback of :func:`~acc_fusion.sim.estimation.run_estimation`."""
        self.t.append(frame.t)
        self.truth.append(frame.state[0, :2])
        for m in meas:
            self.raw[m.sensor].append(m.z[0] if m.valid[0] else np.full(2, np.nan))
        for name, e in ests.items():
            self.est[name].append(e.x[0, :2] if e.valid[0] else np.full(2, np.nan))


def plot(trace: Trace, seed: int, path: str) -> None:
    """Write a PNG: range-rate over time (figs. 3-5, 7) and the gap errors below it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.array(trace.t)
    truth = np.array(trace.truth)
    fig, (ax_v, ax_e) = plt.subplots(2, 1, sharex=True, figsize=(9, 7))
    ax_v.plot(t, truth[:, 1], "k-", lw=2, label="truth")
    for name, style in zip(SENSOR_NAMES, ("C0", "C1"), strict=True):
        raw = np.array(trace.raw[name])
        ax_v.plot(t, raw[:, 1], "x", color=style, ms=5, label=f"{name} raw")
        ax_e.plot(t, raw[:, 0] - truth[:, 0], "x", color=style, ms=5, label=f"{name} raw")
    for name, style in zip(ESTIMATORS, ("C0--", "C1--", "C2-"), strict=True):
        est = np.array(trace.est[name])
        ax_v.plot(t, est[:, 1], style, lw=1.5, label=name)
        ax_e.plot(t, est[:, 0] - truth[:, 0], style, lw=1.5, label=name)
    ax_v.set_ylabel("range-rate [m/s]\n(−3 = closing at 3 m/s)")
    ax_e.axhline(0.0, color="k", lw=0.8)
    # Linear within ±1 m (radar, fusion), logarithmic beyond (infrared's metres of error).
    ax_e.set_yscale("symlog", linthresh=1.0)
    ax_e.set_xlabel("time [s]")
    ax_e.set_ylabel("gap error (estimate − truth) [m]\n(symlog: linear within ±1 m)")
    # One legend for both panels (same styles), below them so it hides no data.
    fig.legend(*ax_v.get_legend_handles_labels(), loc="lower center", ncol=6, fontsize=8)
    fig.suptitle(
        f"kong2011 set-up, run 0 (seed {seed}): target closing at 3 m/s, T = 1 s, radar + infrared"
    )
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    save_figure_atomic(fig, path)


def main(argv: list[str] | None = None) -> None:
    parser = study_parser(__doc__, runs=200, plot_help="write a PNG of run 0 here")
    args = parser.parse_args(argv)
    trace = Trace()
    table = kong2011(n_runs=args.runs, seed=args.seed, on_step=trace.record if args.plot else None)
    print(table.format())
    if args.plot:
        plot(trace, args.seed, args.plot)
        print(f"plot written to {args.plot}")


if __name__ == "__main__":
    main()
