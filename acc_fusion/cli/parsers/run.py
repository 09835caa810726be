"""The arguments of ``acc-fusion run`` (its work: :mod:`acc_fusion.cli.run`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import (
    add_sim_arguments,
    output_folder,
)


def add_parser(subparsers, summary: str) -> argparse.ArgumentParser:
    """Add the ``run`` command."""
    p = subparsers.add_parser(
        "run",
        help=summary,
        description="Run one scenario closed loop: the federated filter's alerts make the "
        "simulated driver brake. Prints each method's FCW summary and writes a PNG (truth, "
        "radar, infrared, local and fused gap with 2-sigma bands, safety distance, warning "
        "bands), the trace of run 0 as CSV and a JSON summary.",
    )
    p.add_argument("--scenario", required=True, help="scenario name (see the error for the list)")
    add_sim_arguments(p, "runs of the scenario (default 1)")
    p.add_argument("--method", help="method whose alerts drive the closed loop (default federated)")
    p.add_argument(
        "--out",
        metavar="DIR",
        type=output_folder,
        default="out",
        help="output folder (default out)",
    )
    return p
