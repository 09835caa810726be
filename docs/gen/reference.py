"""Pages generated at build time (mkdocs-gen-files), so they follow the code:

* ``reference/``: one API page per module of ``acc_fusion``, by stage;
* ``commands/``: one page per ``acc-fusion`` command, its ``--help`` as the parser prints it;
* ``configuration.md``: every field of the config files, from the same dataclasses as
  ``acc-fusion config schema``;
* ``examples.md``: the gallery of ``examples/``, each script's docstring, its source and what
  it printed when ``python scripts/docs_snippets.py --examples`` last ran it.
"""

from __future__ import annotations

import argparse
import ast
import importlib.util
import json
import re
import textwrap
from pathlib import Path

import mkdocs_gen_files

from acc_fusion.cli.main import COMMANDS, build_parser, command_module
from acc_fusion.core.schema import fields
from acc_fusion.sim.closed_loop import SimConfig

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "acc_fusion"

# ---------------------------------------------------------------- API reference
nav = mkdocs_gen_files.Nav()
for path in sorted(PACKAGE.rglob("*.py")):
    parts = path.relative_to(ROOT).with_suffix("").parts
    if "sumo_nets" in parts or any(p.startswith("_") and p != "__init__" for p in parts):
        continue
    if parts[-1] == "__init__":
        parts = parts[:-1]
        doc = Path("reference", *parts, "index.md")
    else:
        doc = Path("reference", *parts).with_suffix(".md")
    nav[parts] = doc.relative_to("reference").as_posix()
    with mkdocs_gen_files.open(doc, "w") as f:
        # The module's own heading is the page's title (one heading, not two).
        f.write(f"::: {'.'.join(parts)}\n    options:\n      heading_level: 1\n")
with mkdocs_gen_files.open("reference/SUMMARY.md", "w") as f:
    f.writelines(nav.build_literate_nav())

# ---------------------------------------------------------------- commands
# Help wrapped at the characters a code block of the site's column shows without scrolling
# (Material's content column beside the navigation and the table of contents).
HELP_WIDTH = 76
parser = build_parser()
subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
summary = ["* [All commands](index.md)\n"]
index = ["# Commands\n\n", "| command | what it does |\n|---|---|\n"]
for name in COMMANDS:
    sub = subparsers.choices[name]
    sub.formatter_class = lambda prog: argparse.HelpFormatter(prog, width=HELP_WIDTH)
    intro = (command_module(name).__doc__ or "").strip()
    helps = [sub.format_help()]
    for action in sub._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                child.formatter_class = sub.formatter_class
                helps.append(child.format_help())
    blocks = "\n".join(f"```text\n{h}```\n" for h in helps)
    with mkdocs_gen_files.open(f"commands/{name}.md", "w") as f:
        f.write(f"# `acc-fusion {name}`\n\n{intro}\n\n## Usage\n\n{blocks}")
    summary.append(f"* [{name}]({name}.md)\n")
    help_line = next(a.help for a in subparsers._choices_actions if a.dest == name)
    index.append(f"| [`{name}`]({name}.md) | {help_line} |\n")
index.append(
    "\nEvery command has `--help`. A user's mistake ends with one line `acc-fusion: error: …` "
    "and exit code 2, never a traceback, and nothing is written.\n"
)
with mkdocs_gen_files.open("commands/index.md", "w") as f:
    f.writelines(index)
with mkdocs_gen_files.open("commands/SUMMARY.md", "w") as f:
    f.writelines(summary)

# ---------------------------------------------------------------- configuration reference
rows = []
for fi in fields(SimConfig):
    default = (
        json.dumps(fi.default, default=str)
        if not hasattr(fi.default, "__dataclass_fields__")
        else "(table)"
    )
    doc = " ".join(fi.doc.split()).replace("|", "\\|")
    rows.append(f"| `{fi.path}` | `{default}` | {fi.unit} | {doc} |\n")
with mkdocs_gen_files.open("configuration.md", "w") as f:
    f.write((ROOT / "docs" / "gen" / "configuration_intro.md").read_text())
    f.write("\n| key | default | unit | meaning |\n|---|---|---|---|\n")
    f.writelines(rows)

# ---------------------------------------------------------------- examples gallery
# The docstrings' reST, as the API reference renders it (this script is run, not imported).
_spec = importlib.util.spec_from_file_location(
    "rst_roles", Path(__file__).with_name("rst_roles.py")
)
rst_roles = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rst_roles)
EXAMPLES = ROOT / "examples"
OUTPUTS = ROOT / "docs" / "snippets" / "examples"
# A docstring's indented lines ("Run it:") are commands, not Markdown's indented code.
COMMANDS_BLOCK = re.compile(r"(?:^    .*\n)+", re.M)
gallery = [
    "# Examples\n\n"
    "Short scripts, one per use, each run by the tests (`tests/test_examples.py`). Each is "
    "shown with its source and with what it printed at a small size the last time "
    "`python scripts/docs_snippets.py --examples` ran it.\n"
]
# From a first study to the largest; any other example after them.
ORDER = ("scripted_study", "sumo_study", "osi_trace", "sweep", "gym_sb3", "gym_braking_ppo",
         "rllib_sumo_ppo")  # fmt: skip
for path in sorted(EXAMPLES.glob("*.py"), key=lambda p: (ORDER + (p.stem,)).index(p.stem)):
    title, _, body = ast.get_docstring(ast.parse(path.read_text())).partition("\n\n")
    body = COMMANDS_BLOCK.sub(lambda m: f"```bash\n{textwrap.dedent(m.group(0))}```\n", body + "\n")
    body = rst_roles.render(body)
    source = textwrap.indent(path.read_text(), "    ")
    gallery.append(
        f"\n## `{path.name}`\n\n**{title}**\n\n{body}\n"
        f'??? example "The source of `{path.name}`"\n\n    ```python\n{source}    ```\n'
    )
    output = OUTPUTS / f"{path.stem}.txt"
    if output.is_file():
        gallery.append(f"\nWhat it printed:\n\n```text\n{output.read_text()}```\n")
with mkdocs_gen_files.open("examples.md", "w") as f:
    f.writelines(gallery)
