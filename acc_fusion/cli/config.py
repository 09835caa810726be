"""``acc-fusion config``: the resolved configuration, and its JSON Schema for editors.

``config show [--config F] [--set KEY=VALUE ...]`` prints every field of the simulation config
(:class:`~acc_fusion.sim.closed_loop.SimConfig` and the tables nested in it) with its value, unit
and origin: the config file, a ``--set`` flag, or the class that declares the default.
``config schema [--out F]`` writes the JSON Schema of config files (TOML or YAML), generated
from the same dataclasses, so an editor can validate and complete them.
"""

from __future__ import annotations

import argparse
import json
import sys

from acc_fusion.cli.common import config_data, sim_config
from acc_fusion.core.outputs import json_text, write_text_atomic
from acc_fusion.core.schema import describe, json_schema
from acc_fusion.sim.closed_loop import SimConfig


def run(args: argparse.Namespace) -> int:
    if args.config_command == "schema":
        text = json_text(json_schema(SimConfig, title="acc_fusion config file"))
        if args.out:
            write_text_atomic(args.out, text + "\n")
            print(f"wrote {args.out}")
        else:
            sys.stdout.write(text + "\n")
        return 0
    cfg = sim_config(args)
    given, source = config_data(args)
    rows = describe(cfg, given, source)
    if args.json:
        print(json_text(rows))
        return 0
    print(format_rows(rows))
    return 0


def format_rows(rows: list[dict]) -> str:
    """The rows of :func:`~acc_fusion.core.schema.describe` as an aligned table."""

    def text(v: object) -> str:
        return json.dumps(v, ensure_ascii=False) if not isinstance(v, str) else v

    cells = [(r["key"], text(r["value"]), r["unit"], r["origin"]) for r in rows]
    head = ("key", "value", "unit", "origin")
    widths = [max(len(h), *(len(c[i]) for c in cells)) for i, h in enumerate(head[:3])]
    lines = ["  ".join(h.ljust(w) for h, w in zip(head, [*widths, 0], strict=True)).rstrip()]
    for c in cells:
        lines.append(
            "  ".join([c[0].ljust(widths[0]), c[1].ljust(widths[1]), c[2].ljust(widths[2]), c[3]])
        )
    return "\n".join(lines)
