"""Compare radar, infrared, centralized and federated warnings on the randomised scripted suite.

The closed FCW loop (truth → sensors → local Kalman filters → federated fusion → warning →
metrics) over N Monte Carlo runs of the standard FCW/AEB test manoeuvres (NHTSA, Euro NCAP,
cut-ins, stop-and-go...), with radar clutter.  Open loop, every method watches the same runs:
false alarms per hour and per 100 km, misses and lead time against the oracle (the same
warning rule on ground truth), with 95% intervals.  Closed loop, a simulated driver brakes for
the federated alerts: collisions with the warnings on and off, on the same seeds.  This is
``acc-fusion compare``; :func:`acc_fusion.sim.closed_loop.simulate` runs any single
:class:`~acc_fusion.sim.closed_loop.SimConfig`.  Run it:

    python examples/scripted_study.py                          # 200 runs, under a minute
    python examples/scripted_study.py --runs 20 --model ttc    # a quick look, TTC warnings
"""

from __future__ import annotations

import argparse

from acc_fusion.studies.compare import compare, compare_config
from acc_fusion.warning.logic import WarningConfig
from acc_fusion.warning.safety import SAFETY_MODELS


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=200, help="Monte Carlo runs (200)")
    parser.add_argument("--seed", type=int, default=0, help="seed (0)")
    parser.add_argument("--model", choices=list(SAFETY_MODELS), help="safety-distance model")
    args = parser.parse_args(argv)

    warning = WarningConfig(model=args.model) if args.model else WarningConfig()
    config = compare_config(runs=args.runs, seed=args.seed, warning=warning)
    print(compare(config).table().format())


if __name__ == "__main__":
    main()
