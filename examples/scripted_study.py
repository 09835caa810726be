"""Compare radar, infrared, centralized and federated warnings on the randomised scripted suite.

The closed FCW loop (truth → sensors → filters → fusion → warning → metrics) over N Monte Carlo
runs of the standard FCW/AEB manoeuvres, with radar clutter; then collisions with the federated
alerts on and off, on the same seeds.  Run it:

    python examples/scripted_study.py            # 200 runs, about a minute
    python examples/scripted_study.py --runs 20  # a quick look
"""

from __future__ import annotations

import argparse

from acc_fusion.studies.compare import compare, compare_config


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=200, help="Monte Carlo runs (default 200)")
    parser.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    args = parser.parse_args(argv)

    comparison = compare(compare_config(runs=args.runs, seed=args.seed))
    print(comparison.table().format())
    c = comparison.collisions
    print(f"collisions: {c['off']} without warnings, {c['on']} with {c['drive']} alerts")


if __name__ == "__main__":
    main()
