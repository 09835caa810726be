"""Reproduce yang2009 §4: wheel speed + accelerometer with a bias state (the ego filter).

Runs :func:`acc_fusion.filters.ego.simulate_yang2009` (v_i = sin 5t + w_v, var 0.04;
a_i = 5 cos 5t - 10 + w_a, var 1; 100 Hz; Q = diag(1e-4, 0), R = 0.04, x0 = 0, P0 = I) and
prints, per time window, the bias estimate at the window's end and the speed RMSE of the raw
wheel speed and of the filter.  The bias converges to the accelerometer offset, -10 m/s²,
within about 0.5 s (see the docstring of acc_fusion.filters.ego for the sign).

    python scripts/reproduce_yang2009.py --seed 1 --plot out/yang2009.png
"""

from __future__ import annotations

import argparse

import numpy as np

from acc_fusion.cli.arguments import output_path
from acc_fusion.core.outputs import save_figure_atomic
from acc_fusion.filters.ego import YANG2009_ACCEL_OFFSET, Yang2009Run, simulate_yang2009

WINDOW_EDGES = (0.0, 0.1, 0.25, 0.5, 1.0, 2.0, 3.0, 4.0)


def table(run: Yang2009Run) -> str:
    """Rows: window [t0, t1), bias estimate at t1, speed RMSE raw and filtered in the window."""
    lines = [
        f"{'window [s]':>12}  {'bias at end':>11}  {'RMSE raw':>9}  {'RMSE filt':>9}",
    ]
    speed = run.true_speed
    for t0, t1 in zip(WINDOW_EDGES[:-1], WINDOW_EDGES[1:], strict=True):
        sel = (run.t >= t0) & (run.t < t1)
        end = np.searchsorted(run.t, t1) - 1
        raw = np.sqrt(np.mean((run.speed_meas[sel, 0] - speed[sel]) ** 2))
        filt = np.sqrt(np.mean((run.speed_est[sel, 0] - speed[sel]) ** 2))
        lines.append(
            f"{f'{t0:g}-{t1:g}':>12}  {run.bias_est[end, 0]:11.3f}  {raw:9.3f}  {filt:9.3f}"
        )
    return "\n".join(lines)


def plot(run: Yang2009Run, path: str) -> None:
    """Write a PNG of the speeds (true, raw, filtered) and of the bias estimate."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_v, ax_b) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
    ax_v.plot(run.t, run.speed_meas[:, 0], ".", ms=2, color="0.6", label="wheel speed $v_i$")
    ax_v.plot(run.t, run.true_speed, "k-", lw=1, label="true $\\sin 5t$")
    ax_v.plot(run.t, run.speed_est[:, 0], "C0-", lw=1.5, label="filtered $v_o$")
    ax_v.set_ylabel("speed [m/s]")
    ax_v.legend(loc="upper right", fontsize=8)
    ax_b.plot(run.t, run.bias_est[:, 0], "C1-", label="bias estimate $b$")
    ax_b.axhline(YANG2009_ACCEL_OFFSET, color="k", ls="--", lw=1, label="offset of $a_i$")
    ax_b.set_xlabel("time [s]")
    ax_b.set_ylabel("bias [m/s²]")
    ax_b.legend(loc="upper right", fontsize=8)
    fig.suptitle("yang2009 §4: speed sensor + accelerometer with bias state")
    fig.tight_layout()
    save_figure_atomic(fig, path)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    parser.add_argument(
        "--plot", metavar="PATH", type=output_path, help="write a PNG of speed and bias here"
    )
    args = parser.parse_args(argv)
    run = simulate_yang2009(duration=WINDOW_EDGES[-1], seed=args.seed)
    print(f"yang2009 §4 reproduction, seed {args.seed}; true offset {YANG2009_ACCEL_OFFSET:g}")
    print(table(run))
    if args.plot:
        plot(run, args.plot)
        print(f"plot written to {args.plot}")


if __name__ == "__main__":
    main()
