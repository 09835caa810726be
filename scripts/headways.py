"""Time headways of car following in a SUMO scenario, against the published distribution.

Samples, once per simulated second after a warm-up, every vehicle faster than 5 m/s with a
leader (the definitions of :mod:`acc_fusion.metrics.realism`, which
``scripts/traffic_realism.py`` applies at every step): its time headway front to front,
:math:`h = (g + L_\\text{lead}) / v` (bumper gap
``g`` plus the leader's length, over the follower's speed), keeping :math:`h \\le 5` s (car
following, as the reference does). The reference: King, Gold, Phillips & Krauss, "Headway
times on urban, multiple lane freeways", Proc. HFES 66(1):1225-1229, 2022 (video of Los
Angeles freeways, headways up to 5 s): median 1.74 s, 58.3 % under 2 s. Prints the figures
of both and, with ``--plot``, the histogram and the cumulative distribution with the
reference's two points. The last line is ``median_s=<x> share_below_1s=<y>
share_below_2s=<z>``.

    python scripts/headways.py                          # bundled motorway, 300 s
    python scripts/headways.py --net onramp --plot hw.png
    python scripts/headways.py --sumocfg my.sumocfg --end 600 --warmup 200
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from acc_fusion.cli.arguments import add_scenario_arguments, output_path
from acc_fusion.cli.common import scenario_config
from acc_fusion.core.errors import AccFusionError
from acc_fusion.core.outputs import save_figure_atomic
from acc_fusion.core.plots import pyplot
from acc_fusion.metrics.realism import MAX_HEADWAY, time_headways
from acc_fusion.metrics.realism_plot import headway_panel
from acc_fusion.metrics.realism_references import reference_of
from acc_fusion.truth.sumo.config import SumoConfig
from acc_fusion.truth.sumo.trajectories import sumo_trajectories

#: King et al. (2022), as the realism check holds them: the median headway [s] and the share
#: of headways under 2 s (headways <= 5 s).
REFERENCE = {
    "median_s": reference_of("headway_median").value,
    "share_below_2s": reference_of("headway_below_2s").value,
}


def headways(config: SumoConfig, end: float, warmup: float, progress: bool = True) -> np.ndarray:
    """Time headways [s] of car following sampled every second from ``warmup`` to ``end``
    (:func:`~acc_fusion.metrics.realism.time_headways` of the samples at whole seconds)."""
    traj = sumo_trajectories(config, end, warmup, progress=progress)
    whole = np.abs(traj.time - np.round(traj.time)) < 0.5 * traj.dt
    return time_headways(traj.subset(whole))


def figure(h: np.ndarray, title: str):
    """Histogram and cumulative distribution of ``h`` with the reference's points."""
    plt = pyplot()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    ax1.hist(h, bins=np.arange(0.0, MAX_HEADWAY + 0.1, 0.1), density=True, color="tab:blue")
    ax1.axvline(REFERENCE["median_s"], color="k", ls="--", label="King et al. 2022 median")
    ax1.axvline(np.median(h), color="tab:blue", ls=":", label="simulated median")
    ax1.set(xlabel="time headway [s]", ylabel="density")
    ax1.legend()
    headway_panel(ax2, h)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_scenario_arguments(p, 120.0, "sampling")
    p.add_argument(
        "--plot", metavar="PNG", type=output_path, help="write the histogram and CDF here"
    )
    args = p.parse_args(argv)
    try:
        path, config = scenario_config(args)
        h = headways(config, args.end, args.warmup)
    except AccFusionError as exc:
        print(f"headways.py: error: {exc}", file=sys.stderr)
        return 2
    if h.size == 0:
        print("headways.py: error: no vehicle was following another", file=sys.stderr)
        return 2
    median, below1, below2 = np.median(h), np.mean(h < 1.0), np.mean(h < 2.0)
    print(f"{path.name}: {h.size} samples of car following (headway <= 5 s, speed > 5 m/s)")
    print(f"  simulated: median {median:.2f} s, {below2:.1%} under 2 s, {below1:.1%} under 1 s")
    ref = REFERENCE
    print(
        f"  King et al. 2022: median {ref['median_s']:.2f} s, {ref['share_below_2s']:.1%} under 2 s"
    )
    if args.plot:
        save_figure_atomic(figure(h, f"Time headways in car following, {path.name}"), args.plot)
        print(f"wrote {args.plot}")
    print(f"median_s={median:.3f} share_below_1s={below1:.3f} share_below_2s={below2:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
