"""FCW in SUMO traffic: every equipped vehicle and its leader, FCW off and on, same seed.

SUMO runs embedded (libsumo from PyPI: no SUMO install, no SUMO_HOME) in its own process for
each of the two runs.  Run it:

    python examples/sumo_study.py                    # the bundled ring, 120 s
    python examples/sumo_study.py --net motorway --end 300
"""

from __future__ import annotations

import argparse

from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.studies.traffic import sumo_study
from acc_fusion.truth.sumo.nets import resolve_sumocfg
from acc_fusion.truth.sumo.source import SumoConfig


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--net", default="ring", help="bundled network (default ring)")
    parser.add_argument("--end", type=float, default=120.0, help="simulated seconds (default 120)")
    parser.add_argument("--seed", type=int, default=0, help="SUMO's seed (default 0)")
    args = parser.parse_args(argv)

    sumo = SumoConfig(str(resolve_sumocfg(args.net)), end=args.end, seed=args.seed)
    study = sumo_study(sumo, SimConfig(runs=1))
    print(study.table().format())


if __name__ == "__main__":
    main()
