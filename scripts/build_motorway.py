"""Write the bundled motorway's sources: its alignment (straights, circular arcs, an exit and an
entry per carriageway) and its demand (drivers of SUMO's EIDM, calibrated to people).

The motorway is designed like a real one, because that is where FCW's false alarms come from:
vehicles of the adjacent lane straight ahead of the ego in a curve, cut-ins at an entry's
acceleration lane, lane changes before an exit, the guardrail and gantries of
:mod:`acc_fusion.truth.sumo.roadside`. Its alignment (:data:`ALIGNMENT`) is a sequence of
straights and circular arcs along the eastbound carriageway's median edge; the westbound
carriageway is the same line offset by :data:`MEDIAN` to the north and driven the other way.

Design values and their sources:

- Curve radii 900 m and 1 300 m, above the 720 m minimum radius of the German motorway design
  guideline for its highest design class EKA 1 A at 7 % cross-fall (FGSV, *Richtlinien für die
  Anlage von Autobahnen* RAA, 2008, Table 13) and the 594 m of AASHTO for 120 km/h at 8 %
  superelevation (*A Policy on Geometric Design of Highways and Streets*, 2011, Table 3-7).
  Deflection 22° and 18°: each arc about 350-410 m long. (Both minima are quoted from the
  guidelines as we know them; the tables themselves were not retrieved here: assumption.)
- Lanes 3.5 m, hard shoulder 2.5 m (roadside objects), median 4.0 m: the RAA cross-section
  RQ 31 (3 x 3.50 m lanes, 2.50 m hard shoulder, 4.00 m central reserve).
- Entry: a parallel acceleration lane of 250 m plus the merge, RAA entry type E 1 (250 m);
  exit: a direct taper (RAA exit type A 1), the exit ramp leaving the right lane.
- Ramps 1 lane at 80 km/h (22.22 m/s).

The script writes ``motorway.nod.xml``, ``motorway.edg.xml``, ``motorway.con.xml`` and the
demand ``motorway.rou.xml`` (:class:`Drivers`, :func:`routes`), each with a comment naming this
script, deterministic to the byte; then ``python scripts/build_nets.py --only motorway`` makes
the ``.net.xml``.

    python scripts/build_motorway.py            # write the sources into sumo_nets/motorway
    python scripts/build_motorway.py --print    # print the alignment's stations and curves
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from statistics import NormalDist

import numpy as np

FOLDER = Path(__file__).resolve().parents[1] / "sumo_nets" / "motorway"

#: The eastbound median edge: ("straight", length m) or ("arc", radius m, deflection deg, left
#: turns positive).
ALIGNMENT = (
    ("straight", 1400.0),
    ("arc", 900.0, 22.0),
    ("straight", 600.0),
    ("arc", 1300.0, -18.0),
    ("straight", 2146.0),
)
#: Width of the central reserve between the carriageways' median edges [m] (RAA RQ 31).
MEDIAN = 4.0
#: Lanes per carriageway, lane width [m], speed limit [m/s] (120 km/h), ramps' speed [m/s].
LANES, LANE_WIDTH, SPEED, RAMP_SPEED = 3, 3.5, 33.33, 22.22
#: Length of the acceleration lane [m] (RAA entry type E 1).
ACCEL_LANE = 250.0
#: Stations (along the eastbound line, from its west end) of each carriageway's exit
#: (diverge) and entry (start of the acceleration lane), on straights [m].
EAST_EXIT, EAST_ENTRY = 900.0, 3700.0
WEST_EXIT, WEST_ENTRY = 4300.0, 1150.0
#: The XML schema attributes of SUMO's input files (followed by the schema's URL).
XSD = 'xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation'
#: Chord angle of the arcs' polylines [deg]: a vertex every 4-6 m, so that a vehicle, which SUMO
#: turns at the vertices, yaws smoothly through a curve.
CHORD_DEG = 0.25


def centreline(step_deg: float = CHORD_DEG) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points (x, y), headings [rad] and stations [m] of the eastbound median edge: the ends of
    each straight and the chord points of each arc."""
    x, y, h, s = 0.0, 0.0, 0.0, 0.0
    pts, heads, stations = [(x, y)], [h], [s]
    for part in ALIGNMENT:
        if part[0] == "straight":
            length = part[1]
            x, y, s = x + length * math.cos(h), y + length * math.sin(h), s + length
            pts.append((x, y)), heads.append(h), stations.append(s)
            continue
        radius, deflection = part[1], math.radians(part[2])
        n = max(1, math.ceil(abs(part[2]) / step_deg))
        dh = deflection / n
        chord = 2.0 * radius * math.sin(abs(dh) / 2.0)
        for _ in range(n):
            mid = h + dh / 2.0
            x, y, h, s = x + chord * math.cos(mid), y + chord * math.sin(mid), h + dh, s + chord
            pts.append((x, y)), heads.append(h), stations.append(s)
    return np.array(pts), np.array(heads), np.array(stations)


def _normal(heading: np.ndarray) -> np.ndarray:
    """Unit normals to the left of ``heading``."""
    return np.stack([-np.sin(heading), np.cos(heading)], axis=-1)


def _offset(points: np.ndarray, heads: np.ndarray, d: float) -> np.ndarray:
    """``points`` moved ``d`` to the left; at the chord points of arcs along the bisector of
    the two chords' headings, so that the offset polyline stays parallel."""
    seg = np.diff(points, axis=0)
    seg_h = np.arctan2(seg[:, 1], seg[:, 0])
    bis = np.empty(len(points))
    bis[0], bis[-1] = seg_h[0], seg_h[-1]
    half = 0.5 * np.angle(np.exp(1j * (seg_h[1:] - seg_h[:-1])))
    bis[1:-1] = seg_h[:-1] + half
    scale = 1.0 / np.cos(np.concatenate([[0.0], half, [0.0]]))
    return points + d * scale[:, None] * _normal(bis)


def at_station(points: np.ndarray, stations: np.ndarray, s: float) -> tuple[float, float]:
    """The point of the polyline at station ``s`` (linear between its points)."""
    return float(np.interp(s, stations, points[:, 0])), float(np.interp(s, stations, points[:, 1]))


def _between(points, stations, lo: float, hi: float, reverse: bool = False) -> list:
    """The polyline's inner points strictly between stations ``lo`` and ``hi``."""
    inner = [tuple(p) for p, s in zip(points, stations, strict=True) if lo < s < hi]
    return inner[::-1] if reverse else inner


def _shape(points: list) -> str:
    return " ".join(f"{x:.2f},{y:.2f}" for x, y in points)


def _ramp(start: tuple, heading: float, side: float, length: float, outward: float) -> list:
    """A ramp's points from ``start`` (on the carriageway's edge) along ``heading``: a cubic
    swing of ``outward`` metres to the ``side`` (-1 right) over ``length`` metres."""
    t = np.linspace(0.0, 1.0, 61)  # a vertex every 5 m: the vehicles yaw smoothly
    along = length * t
    across = side * outward * (3 * t**2 - 2 * t**3)
    c, s = math.cos(heading), math.sin(heading)
    xs = start[0] + along * c - across * s
    ys = start[1] + along * s + across * c
    return list(zip(xs.tolist(), ys.tolist(), strict=True))


def sources() -> dict[str, str]:
    """The XML text of ``motorway.{nod,edg,con}.xml``."""
    east, heads, st = centreline()
    west = _offset(east, heads, MEDIAN)
    total = float(st[-1])
    edge_w = LANES * LANE_WIDTH
    nodes: dict[str, tuple[float, float]] = {}
    edges: list[str] = []

    def node(name: str, line, s: float) -> str:
        nodes[name] = at_station(line, st, s)
        return name

    def heading_at(s: float) -> float:
        return float(np.interp(s, st, np.unwrap(heads)))

    # eastbound: W -> exit EX -> entry EM -> end of the acceleration lane EA -> E
    node("EW", east, 0.0), node("EX", east, EAST_EXIT), node("EM", east, EAST_ENTRY)
    node("EA", east, EAST_ENTRY + ACCEL_LANE), node("EE", east, total)
    # westbound, along the eastbound stations backwards
    node("WE", west, total), node("WX", west, WEST_EXIT), node("WM", west, WEST_ENTRY)
    node("WA", west, WEST_ENTRY - ACCEL_LANE), node("WW", west, 0.0)

    def main(eid, a, b, line, lo, hi, lanes=LANES, reverse=False) -> None:
        shape = [nodes[a], *_between(line, st, lo, hi, reverse), nodes[b]]
        edges.append(
            f'    <edge id="{eid}" from="{a}" to="{b}" numLanes="{lanes}" speed="{SPEED}" '
            f'width="{LANE_WIDTH:.2f}" priority="13" spreadType="right" '
            f'shape="{_shape(shape)}"/>'
        )

    main("east0", "EW", "EX", east, 0.0, EAST_EXIT)
    main("east1", "EX", "EM", east, EAST_EXIT, EAST_ENTRY)
    main("east_acc", "EM", "EA", east, EAST_ENTRY, EAST_ENTRY + ACCEL_LANE, LANES + 1)
    main("east2", "EA", "EE", east, EAST_ENTRY + ACCEL_LANE, total)
    main("west0", "WE", "WX", west, WEST_EXIT, total, reverse=True)
    main("west1", "WX", "WM", west, WEST_ENTRY, WEST_EXIT, reverse=True)
    main("west_acc", "WM", "WA", west, WEST_ENTRY - ACCEL_LANE, WEST_ENTRY, LANES + 1, True)
    main("west2", "WA", "WW", west, 0.0, WEST_ENTRY - ACCEL_LANE, reverse=True)

    def ramp(eid, at: str, heading: float, exit_: bool) -> None:
        # the ramp's line is the right edge of the carriageway's rightmost lane
        x, y = nodes[at]  # exits leave the right lane, entries join the acceleration lane
        right = _normal(np.array(heading)) * -(edge_w + (-0.5 if exit_ else 0.5) * LANE_WIDTH)
        start = (x + right[0], y + right[1])
        direction = heading if exit_ else heading + math.pi
        pts = _ramp(start, direction, -1.0 if exit_ else 1.0, 300.0, 60.0)
        far = f"{eid}_end"
        nodes[far] = pts[-1]
        a, b = (at, far) if exit_ else (far, at)
        shape = pts if exit_ else pts[::-1]
        edges.append(
            f'    <edge id="{eid}" from="{a}" to="{b}" numLanes="1" speed="{RAMP_SPEED}" '
            f'width="{LANE_WIDTH:.2f}" priority="9" spreadType="center" '
            f'shape="{_shape(shape)}"/>'
        )

    ramp("east_off", "EX", heading_at(EAST_EXIT), True)
    ramp("east_on", "EM", heading_at(EAST_ENTRY), False)
    ramp("west_off", "WX", heading_at(WEST_EXIT) + math.pi, True)
    ramp("west_on", "WM", heading_at(WEST_ENTRY) + math.pi, False)

    head = (
        "<!-- motorway: written by scripts/build_motorway.py from its alignment (see the "
        "script's docstring\n     for the design values and their sources); do not edit by "
        "hand. Rebuild the net with\n     python scripts/build_nets.py, option only motorway. -->\n"
    )
    nod = "".join(f'    <node id="{n}" x="{x:.2f}" y="{y:.2f}"/>\n' for n, (x, y) in nodes.items())
    con = []
    for d in ("east", "west"):
        for i in range(LANES):
            con.append((f"{d}0", f"{d}1", i, i))
            con.append((f"{d}1", f"{d}_acc", i, i + 1))
            con.append((f"{d}_acc", f"{d}2", i + 1, i))
        con.append((f"{d}0", f"{d}_off", 0, 0))
        con.append((f"{d}_on", f"{d}_acc", 0, 0))
    cons = "".join(
        f'    <connection from="{a}" to="{b}" fromLane="{i}" toLane="{j}"/>\n' for a, b, i, j in con
    )
    xsd = XSD
    return {
        "nod": f'<?xml version="1.0" encoding="UTF-8"?>\n{head}<nodes {xsd}='
        f'"http://sumo.dlr.de/xsd/nodes_file.xsd">\n{nod}</nodes>\n',
        "edg": f'<?xml version="1.0" encoding="UTF-8"?>\n{head}<edges {xsd}='
        f'"http://sumo.dlr.de/xsd/edges_file.xsd">\n' + "\n".join(edges) + "\n</edges>\n",
        "con": f'<?xml version="1.0" encoding="UTF-8"?>\n{head}<connections {xsd}='
        f'"http://sumo.dlr.de/xsd/connections_file.xsd">\n{cons}</connections>\n',
    }


# ------------------------------------------------------------------------------------- demand
#: Vehicles per hour entering each carriageway's main line, taking its exit, joining at its
#: entry: 5 400 veh/h (1 800 per lane) on the sections before the exit and after the entry.
MAIN_FLOW, EXIT_FLOW, ENTRY_FLOW = 5400.0, 600.0, 600.0
#: Share of each vehicle class (85 % cars, 5 % rigid trucks, 10 % articulated lorries).
SHARES = {"car": 0.85, "truck": 0.05, "semi": 0.10}
#: Car types: quantiles of the drivers' desired time gap.
CAR_TYPES = 20


@dataclass(frozen=True)
class Drivers:
    """The drivers' car-following parameters: SUMO's Extended Intelligent Driver Model (EIDM;
    Salles, Kaufmann & Reuss, "Extending the Intelligent Driver Model in SUMO and verifying the
    drive off trajectories with aerial measurements", SUMO User Conference 2020), its other
    parameters at SUMO's defaults.

    Attributes:
        tau_median, tau_log_sd: the desired time gap T [s] of the car types, the quantiles
            (i + 0.5)/20 of a log-normal; calibrated on this motorway so that the time headways
            of car following match King, Gold, Phillips & Krauss, "Headway times on urban,
            multiple lane freeways", Proc. HFES 66(1):1225-1229, 2022 (median 1.74 s, 58.3 %
            under 2 s): measured median 1.84 s, 56 % (scripts/traffic_realism.py).
        min_gap: the standstill gap s0 [m]; 2 m, the IDM's motorway value (Treiber, Hennecke
            & Helbing, "Congested traffic states in empirical observations and microscopic
            simulations", Phys. Rev. E 62:1805, 2000, Table I).
        accel, decel: the cars' maximum acceleration a and comfortable deceleration b
            [m/s²]; 1.5 and 2.5, between the IDM's motorway values (0.73 and 1.67, same
            source) and SUMO's passenger-car defaults (2.6 and 4.5, which make SUMO's drivers
            brake at 4.4 m/s² or harder a hundred times as often as people do). Assumption,
            checked against the naturalistic braking rates of the realism check.
        truck_decel, truck_tau: the heavy vehicles' b [m/s²] and T [s]; assumption.
        lc_speed_gain: the eagerness of SUMO's lane-change model LC2013 to change lanes for
            speed (``lcSpeedGain``, SUMO's default 1); 0.1 brings the lane changes to about 17
            per 100 km, inside the band of highD and of commuters' naturalistic driving that
            the realism check prints (12.4-22.5), where SUMO's default gives 35. Calibrated
            (assumption).
        depart_speed: SUMO's ``departSpeed``; ``desired`` inserts a vehicle at its desired
            speed where that is safe and waits otherwise, instead of squeezing it in at the
            highest safe speed (``max``), which makes it brake hard at once.
    """

    tau_median: float = 1.1
    tau_log_sd: float = 0.6
    min_gap: float = 2.0
    accel: float = 1.5
    decel: float = 2.5
    truck_decel: float = 2.0
    truck_tau: float = 1.2
    lc_speed_gain: float = 0.1
    depart_speed: str = "desired"


def _quantiles(n: int) -> np.ndarray:
    """Standard normal quantiles of (i + 0.5)/n, i = 0..n-1."""
    return np.array([NormalDist().inv_cdf((i + 0.5) / n) for i in range(n)])


def vtypes(d: Drivers) -> list[str]:
    """The ``<vType>`` lines of the mix: twenty car types, a rigid truck, an articulated lorry
    (lengths and speed limiters as documented in sumo_nets/README.md)."""
    tau = d.tau_median * np.exp(d.tau_log_sd * _quantiles(CAR_TYPES))
    common = f'carFollowModel="EIDM" minGap="{d.min_gap:g}" lcSpeedGain="{d.lc_speed_gain:g}"'
    lines = [
        f'        <vType id="car{i:02d}" vClass="passenger" '
        f'probability="{SHARES["car"] / CAR_TYPES:.4f}" {common} length="5.0" '
        f'maxSpeed="55.56" accel="{d.accel:g}" decel="{d.decel:g}" emergencyDecel="9.0" '
        f'tau="{t:.3f}" speedDev="0.1"/>'
        for i, t in enumerate(tau)
    ]
    for vid, vclass, length, accel in (
        ("truck", "truck", 12.0, 1.3),
        ("semi", "trailer", 16.5, 1.1),
    ):
        lines.append(
            f'        <vType id="{vid}" vClass="{vclass}" probability="{SHARES[vid]:.2f}" '
            f'{common} length="{length:g}" maxSpeed="25.0" accel="{accel:g}" '
            f'decel="{d.truck_decel:g}" emergencyDecel="7.0" tau="{d.truck_tau:g}" '
            'speedDev="0.05"/>'
        )
    return lines


def routes(d: Drivers = Drivers()) -> str:
    """The text of ``motorway.rou.xml``: the vehicle types, a route per origin and destination
    on each carriageway, and a Poisson flow on each."""
    flows = []
    for c in ("east", "west"):
        flows += [
            (c, f"{c}0 {c}1 {c}_acc {c}2", MAIN_FLOW - EXIT_FLOW),
            (f"{c}_exit", f"{c}0 {c}_off", EXIT_FLOW),
            (f"{c}_entry", f"{c}_on {c}_acc {c}2", ENTRY_FLOW),
        ]
    head = (
        "<!-- motorway demand: written by scripts/build_motorway.py (see its Drivers for the\n"
        "     car-following parameters and their sources); do not edit by hand. Poisson arrivals,\n"
        "     random lane, vehicles inserted at their desired speed where that is safe. -->"
    )
    schema = f'<routes {XSD}="http://sumo.dlr.de/xsd/routes_file.xsd">'
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        head,
        schema,
        '    <vTypeDistribution id="mix">',
    ]
    lines += [*vtypes(d), "    </vTypeDistribution>"]
    lines += [f'    <route id="{rid}" edges="{edges}"/>' for rid, edges, _ in flows]
    lines += [
        f'    <flow id="{rid}" type="mix" route="{rid}" begin="0" end="3600" '
        f'period="exp({rate / 3600.0:.6f})" departLane="random" departSpeed="{d.depart_speed}"/>'
        for rid, _, rate in flows
    ]
    return "\n".join([*lines, "</routes>"]) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--print", action="store_true", help="print the alignment instead")
    p.add_argument("--output-dir", type=Path, default=FOLDER, help="where to write the sources")
    args = p.parse_args(argv)
    if args.print:
        _, heads, st = centreline()
        s = 0.0
        for part in ALIGNMENT:
            length = part[1] if part[0] == "straight" else part[1] * math.radians(abs(part[2]))
            what = "straight" if part[0] == "straight" else f"arc R = {part[1]:g} m, {part[2]:+g}°"
            print(f"{s:7.0f}-{s + length:7.0f} m  {what}")
            s += length
        print(f"length {st[-1]:.1f} m, final heading {math.degrees(heads[-1]):.1f}°")
        return 0
    args.output_dir.mkdir(parents=True, exist_ok=True)
    for suffix, text in {**sources(), "rou": routes()}.items():
        (args.output_dir / f"motorway.{suffix}.xml").write_text(text, encoding="utf-8")
        print(f"wrote {args.output_dir / f'motorway.{suffix}.xml'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
