"""Every benchmark in one table: each figure, its value, its target and whether it holds.

Runs each benchmark script of ``scripts/`` (its quick form by default) as a user would, in a
process of its own, one after the other, and reads the figure from the ``NAME=value`` its
output ends with.  With ``--repeat N`` each runs N times and the table holds the median, the
value the targets are judged on (the machine is shared and noisy: ±20 % between runs).
Prints the table — figure, value, target, pass, the seconds it took, the command — and writes
it as JSON (``--json``) and as the Markdown table that docs/benchmarks.md includes
(``--markdown``), with the date and the machine (CPU model and cores).

    python scripts/bench_all.py                    # quick forms, once each (make bench)
    python scripts/bench_all.py --repeat 5         # the median of five runs
    python scripts/bench_all.py --only filters env # some rows
    python scripts/bench_all.py --full             # the full forms (tens of minutes)
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import re
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from acc_fusion.core.outputs import write_json_atomic, write_text_atomic
from acc_fusion.core.table import Table

ROOT = Path(__file__).resolve().parents[1]
MARKDOWN = ROOT / "docs" / "snippets" / "benchmarks.md"


@dataclass(frozen=True)
class Bench:
    """One row: ``script`` run with ``quick`` (or ``full``) arguments prints ``key=value``;
    the target holds when the value is at least (``at_least``) or at most ``target``."""

    name: str
    figure: str
    script: str
    key: str
    target: float
    at_least: bool
    quick: tuple[str, ...] = ("--quick",)
    full: tuple[str, ...] = ()

    def command(self, full: bool) -> list[str]:
        """The command line, as a user types it."""
        return ["python", f"scripts/{self.script}", *(self.full if full else self.quick)]

    def holds(self, value: float) -> bool:
        """The target holds for ``value``."""
        return value >= self.target if self.at_least else value <= self.target


#: The rows, in the order of the issue's table (targets: issue "The speed back and forward").
BENCHES = (
    Bench("sumo", "SUMO 1-D pipeline / bare SUMO", "bench_sumo.py", "overhead_ratio", 1.25,
          False),
    Bench("env", "vector env steps/s (1 024 copies)", "bench_env.py", "vector_env_steps_per_s",
          5e5, True),
    Bench("sweep", "sweep runs/s (scripted, 2 workers)", "bench_sweep.py", "runs_per_s", 1800,
          True, ("--quick", "--no-ray"), ("--no-ray",)),
    Bench("filters", "federated + FDI bank vs filterpy", "bench_filters.py",
          "speedup_vs_filterpy", 500, True),
    Bench("world", "2-D world / bare SUMO, A10KW", "bench_world.py", "overhead_ratio", 3.0,
          False),
    Bench("replay", "replay pair-steps/s (recordings replayed before)", "bench_replay.py",
          "pair_steps_per_s", 1e6, True),
    *(
        Bench(f"highway:{env}", f"highway-env pipeline / bare, {env}", "bench_highway.py",
              "overhead_ratio", 1.2, False, ("--quick", "--env", env), ("--env", env))
        for env in ("highway-v0", "highway-fast-v0", "merge-v0")
    ),
)  # fmt: skip


def machine() -> str:
    """The CPU model and the cores this runs on."""
    model = platform.processor() or platform.machine()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.is_file():
        found = re.search(r"^model name\s*:\s*(.+)$", cpuinfo.read_text(), re.M)
        model = found.group(1).strip() if found else model
    return f"{model}, {os.cpu_count()} cores, Python {platform.python_version()}"


def measure(bench: Bench, full: bool) -> tuple[float, float]:
    """The figure ``bench`` prints and the seconds it took (one run, its own process)."""
    command = [sys.executable, *bench.command(full)[1:]]
    start = time.monotonic()
    proc = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    seconds = time.monotonic() - start
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(bench.command(full))} failed:\n{proc.stderr[-2000:]}")
    found = re.findall(rf"\b{re.escape(bench.key)}=([-+0-9.eE]+)", proc.stdout)
    if not found:
        raise SystemExit(f"{' '.join(bench.command(full))} printed no {bench.key}=")
    return float(found[-1]), seconds


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=1, help="runs of each; the median counts")
    parser.add_argument("--full", action="store_true", help="the full forms, not --quick")
    names = [b.name for b in BENCHES]
    parser.add_argument("--only", nargs="+", choices=names, metavar="NAME",
                        help=f"these rows only ({', '.join(names)})")  # fmt: skip
    parser.add_argument("--json", type=Path, default=ROOT / "out" / "bench.json",
                        help="write the table here as JSON (default out/bench.json)")  # fmt: skip
    parser.add_argument("--markdown", type=Path,
                        help="write the table here as Markdown (default: the docs' include, "
                        "when every row ran)")  # fmt: skip
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"--repeat must be at least 1, got {args.repeat}")
    chosen = [b for b in BENCHES if args.only is None or b.name in args.only]
    when, where = datetime.date.today().isoformat(), machine()
    table = Table(f"Benchmarks, {when}, {where}", ("figure", "value", "target", "pass",
                                                   "runs", "seconds", "command"))  # fmt: skip
    rows = []
    for bench in chosen:
        runs = [measure(bench, args.full) for _ in range(args.repeat)]
        value = statistics.median(v for v, _ in runs)
        row = {
            "figure": bench.figure,
            "key": bench.key,
            "value": value,
            "values": [v for v, _ in runs],
            "target": f"{'≥' if bench.at_least else '≤'} {bench.target:g}",
            "pass": "yes" if bench.holds(value) else "no",
            "runs": len(runs),
            "seconds": round(statistics.median(s for _, s in runs)),
            "command": " ".join(bench.command(args.full)),
        }
        rows.append(row)
        table.rows.append({**row, "value": f"{value:.4g}"})
        print(f"{bench.figure}: {value:.4g} ({row['pass']})", file=sys.stderr, flush=True)
    table.notes.append("value: the median of the runs; pass: the target holds for it")
    print(table.format())
    write_json_atomic(args.json, {"date": when, "machine": where, "rows": rows})
    lines = [
        f"Measured {when} on {where}, {'full' if args.full else 'quick'} forms, the median of "
        f"{args.repeat} run{'s' if args.repeat > 1 else ''} each (`python scripts/bench_all.py"
        f"{' --full' if args.full else ''} --repeat {args.repeat}`).",
        "",
        "| figure | value | target | holds | command |",
        "|---|---|---|---|---|",
        *(
            f"| {r['figure']} | {r['value']:.4g} | {r['target']} | {r['pass']} | `{r['command']}` |"
            for r in rows
        ),
    ]
    markdown = args.markdown or (MARKDOWN if args.only is None else None)
    if markdown is not None:
        write_text_atomic(markdown, "\n".join(lines) + "\n")
    print(f"wrote {args.json}" + ("" if markdown is None else f" and {markdown}"))
    passed = sum(r["pass"] == "yes" for r in rows)
    print(f"benchmarks_passed={passed}/{len(rows)}")


if __name__ == "__main__":
    main()
