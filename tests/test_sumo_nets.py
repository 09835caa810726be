"""The bundled SUMO networks (sumo_nets/, installed as acc_fusion.sumo_nets) load and behave.

Every .sumocfg is run with libsumo in a subprocess of its own (libsumo runs one simulation per
process, and a subprocess keeps this module independent of any simulation another test left
open), found through importlib.resources as an installed package would find it.  Each
simulation is short (at most a few hundred simulated seconds); the whole module takes ~10 s.
"""

from __future__ import annotations

import json
import subprocess
import sys
import xml.etree.ElementTree as ET
from importlib.resources import as_file, files
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("libsumo")

ROOT = Path(__file__).resolve().parents[1]
NETWORKS = ("motorway", "onramp", "ring", "arterial")
#: Source files besides <name>.nod.xml and <name>.edg.xml.
EXTRA_SOURCES = {"onramp": ("con",), "arterial": ("tll",)}
#: sumo options that only sumo-gui understands: a bundled .sumocfg must not set them.
GUI_ONLY = {"gui-settings-file", "start", "quit-on-end", "delay", "window-size", "window-pos"}


def resource(name: str, suffix: str):
    """The installed package's file ``<name>/<name>.<suffix>`` (a Traversable)."""
    return files("acc_fusion.sumo_nets").joinpath(name, f"{name}.{suffix}")


def probe(code: str, name: str, *args) -> dict:
    """Run ``code`` in a fresh interpreter with the network's .sumocfg path as ``CFG``.

    ``code`` starts libsumo on ``CFG`` and prints one JSON object on its last line.
    """
    prelude = (
        "import json, sys\nimport libsumo\nCFG = sys.argv[1]\nARGS = sys.argv[2:]\n"
        "libsumo.start(['sumo', '-c', CFG, '--no-step-log', 'true', '--no-warnings', 'true'])\n"
    )
    with as_file(resource(name, "sumocfg")) as cfg:
        proc = subprocess.run(
            [
                sys.executable,
                "-c",
                prelude + code + "\nlibsumo.close()\n",
                str(cfg),
                *map(str, args),
            ],
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Error" not in proc.stderr, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def options(name: str) -> dict[str, str]:
    """The options a .sumocfg sets, as {option: value}."""
    root = ET.fromstring(resource(name, "sumocfg").read_text())
    return {opt.tag: opt.get("value") for section in root for opt in section}


@pytest.mark.parametrize("name", NETWORKS)
def test_network_files_are_installed(name):
    for suffix in ("nod.xml", "edg.xml", "net.xml", "rou.xml", "sumocfg"):
        assert resource(name, suffix).is_file(), f"{name}.{suffix}"
    for suffix in EXTRA_SOURCES.get(name, ()):
        assert resource(name, f"{suffix}.xml").is_file()
    total = sum(p.stat().st_size for p in (ROOT / "sumo_nets").rglob("*") if p.is_file())
    assert total < 5_000_000


@pytest.mark.parametrize("name", NETWORKS)
def test_sumocfg_settings_for_fcw_research(name):
    opts = options(name)
    assert opts["net-file"] == f"{name}.net.xml" and opts["route-files"] == f"{name}.rou.xml"
    assert float(opts["begin"]) == 0 and float(opts["end"]) == 3600
    assert float(opts["step-length"]) == 0.1
    assert opts["collision.action"] in ("warn", "remove")
    assert opts["collision.check-junctions"] == "true"
    assert float(opts["collision.mingap-factor"]) == 0
    assert float(opts["time-to-teleport"]) == -1
    assert opts["seed"] == "42"
    assert not GUI_ONLY & set(opts)


@pytest.mark.parametrize("name", NETWORKS)
def test_network_loads_and_runs(name):
    out = probe(
        """
collisions = 0
for _ in range(600):
    libsumo.simulationStep()
    collisions += libsumo.simulation.getCollidingVehiclesNumber()
print(json.dumps({"time": libsumo.simulation.getTime(), "vehicles": libsumo.vehicle.getIDCount(),
                  "collisions": collisions}))
""",
        name,
    )
    assert out["time"] == pytest.approx(60.0)
    assert out["vehicles"] > 10
    assert out["collisions"] == 0


def test_motorway_fills_with_its_demand_and_its_drivers_follow_eidm():
    """5400 veh/h per carriageway, at about 33 m/s, keep some 390 vehicles on the 2 x 4.9 km
    road once it is full (after about 200 s); the heavy vehicles' lengths; EIDM drivers."""
    out = probe(
        """
counts = []
while libsumo.simulation.getTime() < 300:
    libsumo.simulationStep()
    counts.append(libsumo.vehicle.getIDCount())
types = {libsumo.vehicle.getTypeID(v) for v in libsumo.vehicle.getIDList()}
lengths = {t: libsumo.vehicletype.getLength(t) for t in types}
print(json.dumps({"full": min(counts[2000:]), "lengths": lengths,
                  "lanes": [libsumo.edge.getLaneNumber(e) for e in ("east1", "east_acc")]}))
""",
        "motorway",
    )
    assert out["full"] > 350
    assert out["lanes"] == [3, 4]  # the acceleration lane of the entry
    lengths = {t.rstrip("0123456789"): length for t, length in out["lengths"].items()}
    assert lengths == {"car": 5.0, "truck": 12.0, "semi": 16.5}
    with as_file(resource("motorway", "rou.xml")) as path:
        models = {t.get("carFollowModel") for t in ET.parse(path).getroot().iter("vType")}
    assert models == {"EIDM"}


def test_motorway_sources_are_what_its_script_writes(tmp_path):
    """sumo_nets/motorway's nod, edg, con and rou files are scripts/build_motorway.py's output
    to the byte (edit the script, not the files)."""
    script = Path(__file__).resolve().parents[1] / "scripts" / "build_motorway.py"
    subprocess.run([sys.executable, str(script), "--output-dir", str(tmp_path)], check=True,
                   capture_output=True)  # fmt: skip
    for suffix in ("nod", "edg", "con", "rou"):
        with as_file(resource("motorway", f"{suffix}.xml")) as path:
            assert (tmp_path / f"motorway.{suffix}.xml").read_bytes() == path.read_bytes()


@pytest.mark.parametrize(("name", "median"), [("motorway", 1.1), ("onramp", 1.2)])
def test_car_drivers_keep_human_like_headways(name, median):
    """Twenty equally likely car types whose tau (Krauss) or desired time gap (EIDM) are the
    (i + 0.5)/20 quantiles of the documented log-normal (log-sd 0.6), all else equal."""
    from scipy.stats import norm

    with as_file(resource(name, "rou.xml")) as path:
        root = ET.parse(path).getroot()
    cars = [t for t in root.iter("vType") if t.get("id").startswith("car")]
    taus = np.array([float(t.get("tau")) for t in cars])
    want = median * np.exp(0.6 * norm.ppf((np.arange(20) + 0.5) / 20))
    np.testing.assert_allclose(taus, want, atol=6e-4)
    assert sum(float(t.get("probability")) for t in cars) == pytest.approx(0.85, abs=1e-3)
    others = {(k, v) for t in cars for k, v in t.attrib.items() if k not in ("id", "tau")}
    assert len(others) == len(cars[0].attrib) - 2  # identical but for id and tau


def test_onramp_vehicles_cut_in():
    """Ramp vehicles leave the acceleration lane (acc_0) for the main line: cut-ins."""
    out = probe(
        """
prev, cut_ins, ramp_departed = {}, 0, 0
while libsumo.simulation.getTime() < 300:
    libsumo.simulationStep()
    ramp_departed += sum(v.startswith("ramp") for v in libsumo.simulation.getDepartedIDList())
    for v in libsumo.vehicle.getIDList():
        lane = libsumo.vehicle.getLaneID(v)
        if v.startswith("ramp") and lane in ("acc_1", "acc_2") and prev.get(v) != lane:
            cut_ins += prev.get(v) not in ("acc_1", "acc_2")
        prev[v] = lane
print(json.dumps({"cut_ins": cut_ins, "ramp_departed": ramp_departed,
                  "acc_lanes": libsumo.edge.getLaneNumber("acc"),
                  "main_lanes": libsumo.edge.getLaneNumber("up")}))
""",
        "onramp",
    )
    assert out["acc_lanes"] == 3 and out["main_lanes"] == 2
    assert out["ramp_departed"] > 30  # 800 veh/h: about 67 in 300 s
    assert out["cut_ins"] >= 0.7 * out["ramp_departed"]


def test_ring_circulates_with_stop_and_go_waves():
    """All 120 cars stay on the ring, go round, and some stand while others drive (waves)."""
    out = probe(
        """
samples = []
while libsumo.simulation.getTime() < 300:
    libsumo.simulationStep()
    t = libsumo.simulation.getTime()
    if t >= 100 and round(t * 10) % 100 == 0:
        speeds = [libsumo.vehicle.getSpeed(v) for v in libsumo.vehicle.getIDList()]
        samples.append((sum(s < 1.0 for s in speeds), max(speeds)))
ids = libsumo.vehicle.getIDList()
edges_passed = [libsumo.vehicle.getRouteIndex(v) for v in ids]
routes = [libsumo.vehicle.getRoute(v) for v in ids]
loops = all(r[4:8] == r[:4] and r[-1] == r[3] and len(r) >= 400 for r in routes)
print(json.dumps({"vehicles": len(ids), "samples": samples, "min_edges": min(edges_passed),
                  "loops": loops, "lanes": libsumo.edge.getLaneNumber("ring0")}))
""",
        "ring",
    )
    assert out["vehicles"] == 120 and out["lanes"] == 1
    assert out["loops"]  # each route is its 4-edge loop repeated (>= 100 laps)
    assert out["min_edges"] >= 2  # everyone moved on by two quarter circles (> 575 m) in 300 s
    assert len(out["samples"]) >= 20
    for stopped, vmax in out["samples"]:
        assert stopped >= 3 and vmax > 8.0  # standing cars and moving cars at the same time


def test_arterial_has_signals_that_stop_traffic():
    out = probe(
        """
halted = 0
while libsumo.simulation.getTime() < 300:
    libsumo.simulationStep()
    halted = max(halted, sum(libsumo.lane.getLastStepHaltingNumber(f"eb{k}_{i}")
                             for k in range(4) for i in range(2)))
tls = libsumo.trafficlight.getIDList()
cycle = [sum(p.duration for p in libsumo.trafficlight.getAllProgramLogics(t)[0].phases)
         for t in tls]
print(json.dumps({"tls": sorted(tls), "cycle": cycle, "halted": halted}))
""",
        "arterial",
    )
    assert out["tls"] == ["J1", "J2", "J3", "J4"]
    assert out["cycle"] == [90.0] * 4
    assert out["halted"] > 0  # queues form at red lights


def run_build_script(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "build_nets.py"), *args],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_build_script_help():
    out = run_build_script("--help")
    assert out.returncode == 0
    assert out.stdout.startswith("usage:")
    for word in ("--only", "--check", "--output-dir", *NETWORKS):
        assert word in out.stdout


def test_build_reproduces_the_bundled_nets(tmp_path):
    """Rebuilding from the sources gives the bundled .net.xml byte for byte."""
    out = run_build_script("--output-dir", str(tmp_path))
    assert out.returncode == 0, out.stderr
    for name in NETWORKS:
        bundled = (ROOT / "sumo_nets" / name / f"{name}.net.xml").read_text()
        rebuilt = (tmp_path / name / f"{name}.net.xml").read_text()
        assert f"built {tmp_path / name / name}.net.xml" in out.stdout
        # line 3 names the netconvert version: another version may legitimately differ
        if rebuilt.splitlines()[2] != bundled.splitlines()[2]:
            pytest.skip(f"installed netconvert differs from the bundled nets' ({bundled[:120]})")
        assert rebuilt == bundled, f"{name}.net.xml differs from a rebuild of its sources"


def test_build_check_reports_vehicles():
    out = run_build_script("--no-build", "--check", "--only", "ring", "--check-seconds", "20")
    assert out.returncode == 0, out.stdout + out.stderr
    assert "check ring: ok: 20 s simulated" in out.stdout
    assert "120 vehicles running" in out.stdout


def test_build_script_rejects_unknown_network():
    out = run_build_script("--only", "autobahn")
    assert out.returncode == 2
    assert "invalid choice: 'autobahn'" in out.stderr
