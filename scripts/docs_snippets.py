"""Regenerate the program output that the docs site shows: `make run`'s and the examples'.

Runs the main job's command once, exactly as `make run` does, and writes what it prints to
``docs/snippets/make_run.txt``, followed by a line with the time it took; Home and Getting
started include that file (``pymdownx.snippets``), so their tables and times are never
retyped. ``--examples`` runs each script of ``examples/`` at a small size instead and writes
``docs/snippets/examples/NAME.txt``, which the examples gallery shows. Run it after a change
to what they print:

    python scripts/docs_snippets.py             # `make run`: a few minutes on 2 cores
    python scripts/docs_snippets.py --examples  # the seven examples: a few minutes

The main job's command is read from the Makefile's ``run`` target, so the two cannot drift
apart.
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SNIPPETS = ROOT / "docs" / "snippets"
# Each example at the small size its test runs it at (tests/test_examples.py).
EXAMPLES = {
    "scripted_study.py": ["--runs", "10"],
    "sumo_study.py": ["--end", "20"],
    "osi_trace.py": ["--end", "5", "--vehicles", "1", "--out", "out/example_osi"],
    "gym_sb3.py": ["--timesteps", "512", "--episodes", "1"],
    "gym_braking_ppo.py": ["--timesteps", "4096", "--episodes", "2"],
    "sweep.py": ["--runs", "4", "--out", "out/example_sweep"],
    "rllib_sumo_ppo.py": [
        "--iterations",
        "2",
        "--batch",
        "200",
        "--episode-steps",
        "50",
        "--warmup",
        "10",
    ],
}


def make_run_command() -> list[str]:
    """The command of the Makefile's ``run`` target, with ``$(BIN)/`` as this interpreter's."""
    makefile = (ROOT / "Makefile").read_text()
    recipe = re.search(r"^run:.*\n\t(.+)$", makefile, re.M).group(1)
    words = shlex.split(recipe)
    return [str(Path(sys.executable).parent / words[0].removeprefix("$(BIN)/")), *words[1:]]


def run(command: list[str], out: Path, shown: str) -> None:
    """Run ``command`` in the repository and write ``$ shown``, its output and its time."""
    start = time.monotonic()
    proc = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, check=True)
    minutes = (time.monotonic() - start) / 60
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(
        f"$ {shown}\n{proc.stdout.rstrip()}\n# took {minutes:.1f} min on {os.cpu_count()} cores\n"
    )
    print(f"wrote {out.relative_to(ROOT)} ({minutes:.1f} min)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", action="store_true", help="the examples, not `make run`")
    args = parser.parse_args()
    if not args.examples:
        run(make_run_command(), SNIPPETS / "make_run.txt", "make run")
        return
    for name, small in EXAMPLES.items():
        script = f"examples/{name}"
        run(
            [sys.executable, script, *small],
            SNIPPETS / "examples" / f"{name[:-3]}.txt",
            " ".join(["python", script, *small]),
        )


if __name__ == "__main__":
    main()
