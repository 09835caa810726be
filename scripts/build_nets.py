"""Rebuild the SUMO networks bundled in ``sumo_nets/`` from their sources, and check them.

Each network lives in ``sumo_nets/<name>/``: its plain-XML sources (``<name>.nod.xml``,
``<name>.edg.xml`` and, where used, ``<name>.con.xml`` / ``<name>.tll.xml``), the generated
``<name>.net.xml``, the demand ``<name>.rou.xml`` and ``<name>.sumocfg``.  This script runs the
netconvert of the eclipse-sumo wheel (found with ``import sumo; sumo.SUMO_HOME``, no system SUMO
needed) on the sources with the options recorded in :data:`NETWORKS`, in the network's folder and
with relative file names, and removes the date netconvert writes into the header comment, so that
a rebuild from unchanged sources gives byte-identical files.  No option involves randomness (the
demand's randomness is SUMO's, seeded by ``<seed>`` in each ``.sumocfg``).

With ``--check`` it then runs every ``.sumocfg`` for ``--check-seconds`` of simulated time (in a
subprocess each: libsumo allows one simulation per process; the ``sumo`` binary of the wheel when
libsumo is not installed or with ``--engine sumo``) and reports the vehicles, collisions,
teleports and SUMO's warnings and errors.  The exit code is 1 when a check fails (SUMO error, no
vehicle, a collision or a teleport).

    python scripts/build_nets.py                       # rebuild every network
    python scripts/build_nets.py --only ring --check   # rebuild one, then run it for 300 s
    python scripts/build_nets.py --no-build --check    # check the networks as they are
    python scripts/build_nets.py --output-dir /tmp/nets # build copies, leave sumo_nets/ alone
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

NETS_DIR = Path(__file__).resolve().parents[1] / "sumo_nets"

#: netconvert options used for every network: no U-turn connections (vehicles leave at the ends
#: of the open roads; the ring and the arterial have no use for them).
COMMON_OPTIONS = ("--no-turnarounds", "true")


@dataclass(frozen=True)
class Network:
    """One bundled network: what it is for, its netconvert sources and extra options."""

    description: str
    sources: dict[str, str]  # netconvert option (without --) -> file suffix
    options: tuple[str, ...] = ()


NETWORKS: dict[str, Network] = {
    "motorway": Network(
        "two 3-lane carriageways, 4.9 km with two curves, an exit and an entry each way, "
        "33.33 m/s; sources written by scripts/build_motorway.py",
        {"node-files": "nod", "edge-files": "edg", "connection-files": "con"},
    ),
    "onramp": Network(
        "2-lane motorway with an on-ramp and a 250 m acceleration lane (cut-ins)",
        {"node-files": "nod", "edge-files": "edg", "connection-files": "con"},
    ),
    "ring": Network(
        "single-lane 2.3 km ring, 120 cars, stop-and-go waves (Sugiyama et al. 2008)",
        {"node-files": "nod", "edge-files": "edg"},
    ),
    "arterial": Network(
        "2 km urban arterial, 2 lanes each way, 13.89 m/s, 4 fixed-time traffic lights",
        {"node-files": "nod", "edge-files": "edg", "tllogic-files": "tll"},
    ),
}

#: The date netconvert writes into its header comment (the only run-dependent output).
_DATE_HEADER = re.compile(r"<!-- generated on \S+ by (Eclipse SUMO \w+ [\w.]+)")

#: Run in a subprocess by ``--check``: load a .sumocfg with libsumo, step it, print JSON.
_LIBSUMO_PROBE = r"""
import json, sys
import libsumo
cfg, seconds = sys.argv[1], float(sys.argv[2])
libsumo.start(["sumo", "-c", cfg, "--no-step-log", "true"])
begin = libsumo.simulation.getTime()
peak = collisions = teleports = departed = 0
while libsumo.simulation.getTime() < begin + seconds:
    libsumo.simulationStep()
    peak = max(peak, libsumo.vehicle.getIDCount())
    collisions += libsumo.simulation.getCollidingVehiclesNumber()
    teleports += libsumo.simulation.getStartingTeleportNumber()
    departed += libsumo.simulation.getDepartedNumber()
out = {"time": libsumo.simulation.getTime() - begin, "running": libsumo.vehicle.getIDCount(),
       "peak": peak, "departed": departed,
       "tls": len(libsumo.trafficlight.getIDList()),
       "collisions": collisions, "teleports": teleports}
libsumo.close()
print(json.dumps(out))
"""


def sumo_home() -> Path:
    """SUMO_HOME of the eclipse-sumo wheel; exits with a clear message when it is missing."""
    try:
        import sumo
    except ImportError:
        sys.exit(
            "build_nets.py: error: the eclipse-sumo wheel is not installed "
            "(pip install 'acc_fusion[sumo]')"
        )
    return Path(sumo.SUMO_HOME)


def binary(name: str) -> Path:
    """Path of a SUMO tool (netconvert, sumo, ...) inside the eclipse-sumo wheel."""
    exe = sumo_home() / "bin" / (name + (".exe" if os.name == "nt" else ""))
    if not exe.is_file():
        sys.exit(f"build_nets.py: error: {exe} not found in the eclipse-sumo wheel")
    return exe


def sumo_env() -> dict[str, str]:
    """Environment for SUMO tools: SUMO_HOME set, so that inputs are validated by local XSDs."""
    return {**os.environ, "SUMO_HOME": str(sumo_home())}


def netconvert_command(name: str) -> list[str]:
    """The netconvert command line that builds ``<name>.net.xml`` (run in its folder)."""
    net = NETWORKS[name]
    cmd = [str(binary("netconvert"))]
    for option, suffix in net.sources.items():
        cmd += [f"--{option}", f"{name}.{suffix}.xml"]
    cmd += [*COMMON_OPTIONS, *net.options, "--output-file", f"{name}.net.xml"]
    return cmd


def summarize_net(path: Path) -> str:
    """One line on a built network: size, edges, lanes, junctions, traffic lights."""
    root = ET.parse(path).getroot()
    edges = [e for e in root.iter("edge") if e.get("function") != "internal"]
    lanes = sum(len(e.findall("lane")) for e in edges)
    length = sum(float(e.find("lane").get("length")) for e in edges)
    junctions = [j for j in root.iter("junction") if j.get("type") != "internal"]
    tls = len(root.findall("tlLogic"))
    size_kb = path.stat().st_size / 1024
    return (
        f"{size_kb:.0f} kB, {len(edges)} edges ({length / 1000:.2f} km of road), {lanes} lanes, "
        f"{len(junctions)} junctions, {tls} traffic lights"
    )


def build(name: str, nets_dir: Path = NETS_DIR) -> Path:
    """Run netconvert for one network, strip the date from its header, return the net path.

    With ``nets_dir`` other than the bundled folder, the network's sources, routes and
    .sumocfg are copied to ``nets_dir/<name>/`` first and the net is built there.
    """
    source_dir = NETS_DIR / name
    folder = nets_dir / name
    for suffix in NETWORKS[name].sources.values():
        if not (source_dir / f"{name}.{suffix}.xml").is_file():
            sys.exit(
                f"build_nets.py: error: source {source_dir / f'{name}.{suffix}.xml'} is missing"
            )
    if folder.resolve() != source_dir.resolve():
        folder.mkdir(parents=True, exist_ok=True)
        for path in source_dir.iterdir():
            if path.is_file() and path.name != f"{name}.net.xml":
                shutil.copyfile(path, folder / path.name)
    cmd = netconvert_command(name)
    proc = subprocess.run(cmd, cwd=folder, env=sumo_env(), capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit(f"build_nets.py: error: netconvert failed for {name}:\n{proc.stderr.strip()}")
    warnings = [line for line in proc.stderr.splitlines() if line.startswith("Warning")]
    net = folder / f"{name}.net.xml"
    text = net.read_text(encoding="utf-8")
    text = _DATE_HEADER.sub(r"<!-- generated by \1 (scripts/build_nets.py)", text, count=1)
    net.write_text(text, encoding="utf-8")
    print(f"built {net}: {summarize_net(net)}")
    print(f"    netconvert {' '.join(cmd[1:])}")
    for line in warnings:
        print(f"    {line}")
    return net


def check(name: str, seconds: float, engine: str, nets_dir: Path = NETS_DIR) -> bool:
    """Run ``<name>.sumocfg`` for ``seconds`` simulated seconds; print a report; True if sound."""
    cfg = nets_dir / name / f"{name}.sumocfg"
    if not cfg.is_file():
        print(f"check {name}: FAILED: {cfg} is missing")
        return False
    if engine == "libsumo":
        proc = subprocess.run(
            [sys.executable, "-c", _LIBSUMO_PROBE, str(cfg), str(seconds)],
            env=sumo_env(),
            capture_output=True,
            text=True,
        )
        lines = proc.stdout.strip().splitlines()
        result = json.loads(lines[-1]) if proc.returncode == 0 and lines else None
    else:
        result, proc = _check_with_binary(cfg, seconds)
    messages = [ln for ln in proc.stderr.splitlines() if ln.startswith(("Warning", "Error"))]
    if result is None:
        print(f"check {name}: FAILED: SUMO did not run {cfg.name}")
        for line in proc.stderr.strip().splitlines()[-10:]:
            print(f"    {line}")
        return False
    ok = result["peak"] > 0 and result["collisions"] == 0 and result["teleports"] == 0
    tls = f", {result['tls']} traffic lights" if result.get("tls") else ""
    print(
        f"check {name}: {'ok' if ok else 'FAILED'}: {result['time']:.0f} s simulated with "
        f"{engine}: {result['running']} vehicles running (peak {result['peak']}, "
        f"{result['departed']} departed){tls}, {result['collisions']} collisions, "
        f"{result['teleports']} teleports, {len(messages)} SUMO warnings/errors"
    )
    for line in messages[:10]:
        print(f"    {line}")
    return ok


def _check_with_binary(cfg: Path, seconds: float):
    """``check`` with the ``sumo`` binary: the summary output gives the vehicle counts."""
    with tempfile.TemporaryDirectory() as tmp:
        summary = Path(tmp) / "summary.xml"
        begin = float(ET.parse(cfg).getroot().find("./time/begin").get("value", "0"))
        proc = subprocess.run(
            [
                str(binary("sumo")),
                "-c",
                str(cfg),
                "--end",
                str(begin + seconds),
                "--no-step-log",
                "true",
                "--summary-output",
                str(summary),
            ],
            env=sumo_env(),
            capture_output=True,
            text=True,
        )
        if proc.returncode != 0 or not summary.is_file():
            return None, proc
        steps = list(ET.parse(summary).getroot().iter("step"))
    last = steps[-1]
    result = {
        "time": float(last.get("time")) - begin,
        "running": int(last.get("running")),
        "peak": max(int(s.get("running")) for s in steps),
        "departed": int(last.get("inserted")),
        "collisions": int(last.get("collisions")),
        "teleports": int(last.get("teleports")),
    }
    return result, proc


def positive_seconds(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError("must be > 0")
    return value


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    epilog = "networks:\n" + "\n".join(
        f"  {name:9s} {net.description}" for name, net in NETWORKS.items()
    )
    parser = argparse.ArgumentParser(
        description="Rebuild the bundled SUMO networks (sumo_nets/) from their sources with the "
        "netconvert of the eclipse-sumo wheel; optionally run each .sumocfg briefly.",
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--only", choices=sorted(NETWORKS), action="append", help="this network only (repeatable)"
    )
    parser.add_argument(
        "--check", action="store_true", help="run each .sumocfg briefly and report its vehicles"
    )
    parser.add_argument(
        "--check-seconds",
        type=positive_seconds,
        default=300.0,
        help="simulated seconds per check (default: 300)",
    )
    parser.add_argument(
        "--engine",
        choices=("libsumo", "sumo"),
        default=None,
        help="how --check runs SUMO (default: libsumo when installed, else the sumo binary)",
    )
    parser.add_argument(
        "--no-build", action="store_true", help="do not rebuild (with --check: check as they are)"
    )
    parser.add_argument(
        "--output-dir",
        type=Path,
        default=None,
        metavar="DIR",
        help="build into DIR/<name>/ (with a copy of the sources, routes and .sumocfg) instead "
        "of rewriting sumo_nets/",
    )
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    names = args.only or list(NETWORKS)
    nets_dir = args.output_dir or NETS_DIR
    if not args.no_build:
        for name in names:
            build(name, nets_dir)
    if not args.check:
        return 0
    engine = args.engine or ("libsumo" if importlib.util.find_spec("libsumo") else "sumo")
    results = [check(name, args.check_seconds, engine, nets_dir) for name in names]
    return 0 if all(results) else 1


if __name__ == "__main__":
    sys.exit(main())
