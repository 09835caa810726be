r"""The network's geometry as SUMO simulates it (:class:`LaneTable`), and the stationary roadside
objects placed once along it (:class:`RoadsideConfig`, :func:`place_roadside`).

Lane geometry
    Read from the running simulation (libsumo ``edge.getIDList``, ``lane.getShape``,
    ``getWidth``, ``getMaxSpeed``) once at start: the very polylines SUMO moves the vehicles on,
    internal (junction) lanes included, without parsing the ``.net.xml`` a second time.  SUMO
    names lane ``i`` of edge ``e`` ``"e_i"``, lane 0 the rightmost.  The curvature of a lane
    at lane position :math:`s` is the heading change between the shape's segments at
    :math:`s \mp h` over the distance between their midpoints,

    .. math::

        \kappa(s) = \frac{\operatorname{wrap}(\theta_{+} - \theta_{-})}{m_{+} - m_{-}}

    (:math:`h` half of :data:`CURVATURE_WINDOW`, 20 m, the window clipped to the lane;
    :math:`\theta` a segment's heading, left turns positive; :math:`m` its midpoint's lane
    position; when both ends fall in one segment, the segments before and after it): on a
    circle of radius :math:`R` drawn with equal chords of angle :math:`\Delta\varphi`,
    :math:`\kappa = \Delta\varphi / (2R\sin(\Delta\varphi/2)) \approx (1 +
    \Delta\varphi^2/24)/R` (0.03 % high for 5° chords) wherever the ego is; bounded at the
    kinks of coarse OSM shapes, where the curvature of a single vertex would be a spike.

Roadside objects (every value SI; the kinds of :class:`~acc_fusion.truth.objects.ObjectKind`)
    Placed on the *motorway-like* edges only: not internal, at least ``min_lanes`` lanes and a
    speed limit of at least ``min_speed`` (defaults 2 and 80 km/h).  Along an edge of length
    :math:`L` an object series of spacing :math:`d` starts at a seeded uniform phase in
    :math:`[0, d)` and repeats every :math:`d` (so :math:`L/d` per edge on average, even on the
    short edges of an OSM network).

    * **Gantry**: across the carriageway at ``gantry_spacing`` (2 km, assumption: overhead
      direction signs cluster at interchanges; no guideline gives a spacing), its lower edge
      at ``gantry_clearance`` 5.18 m — 17 ft, the interstate clearance of sign trusses, 1 ft
      above the 16 ft of bridges (AASHTO, *A Policy on Design Standards – Interstate System*,
      2016; FHWA *Vertical Clearance* guidance); a truss 1.5 m high and 1 m deep (assumption).
    * **Bridge**: across the carriageway at ``bridge_spacing`` (0: none, the bundled nets
      have no bridges), lower edge at ``bridge_clearance`` 4.88 m (16 ft, same source), a deck
      1.5 m thick and 12 m wide along the road (assumption).
    * **Guardrail post**: along the outer (right) edge, ``shoulder_width`` beyond the right
      lane's edge, every ``guardrail_spacing`` (25 m).  Real posts stand every 2 or 4 m
      (EN 1317 steel barriers); one representative return per 25 m keeps about 8 posts in a
      200 m field instead of 50-100 (the radar's clutter model spreads it).
    * **Parked vehicle**: on the hard shoulder (centred in it), ``parked_per_km`` per km of
      edge (a Poisson count per edge, uniform positions), a car of 4.5 x 1.8 x 1.5 m.
      ``shoulder_width`` 2.5 m: the German RAA hard shoulder (2.50 m on RQ 31, 3.00 m on
      RQ 36; FGSV, *Richtlinien für die Anlage von Autobahnen*, 2008).

    A guardrail post or parked vehicle whose footprint would reach onto a lane of another edge
    (:data:`SHOULDER_CLEARANCE` from its edge) is not placed: where a ramp diverges or
    merges, or a junction's lanes pass, the shoulder gives way to that lane, as on a real
    road (guardrails and hard shoulders end at a diverge; RAA 2008, interchange design), and
    a vehicle taking the ramp must not meet a car parked in its lane.

    Radar cross-section and thermal contrast of each kind: :data:`KIND_SIGNATURE` (order of
    magnitude; assumption).  Every object gets a stable id :data:`ROADSIDE_ID_BASE` ``+ k``,
    above every vehicle id of a run.  The placement depends on the network and ``seed`` only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_range
from acc_fusion.truth.objects import ObjectKind

#: Length of the window the lane curvature is averaged over [m] (module docstring).
CURVATURE_WINDOW = 20.0

#: Free space [m] kept between a shoulder object's footprint and the edge of another edge's
#: lane (assumption: a lane needs its width plus some room to be driven).
SHOULDER_CLEARANCE = 0.5

#: Object id of the first roadside object (vehicle ids count from 0 and stay far below it).
ROADSIDE_ID_BASE = 1 << 40

#: Per stationary kind: (radar cross-section [dBsm], thermal contrast [K]).  Assumptions of
#: order of magnitude: large metal structures return 20-30 dBsm at 77 GHz (the overhead-gantry
#: false alarm of FCW), a post about 0 dBsm; structures sit at ambient temperature (1 K of
#: sky-reflection contrast), a parked car's cold body 2 K (a running one: ``VCLASS_SIGNATURE``
#: of :mod:`acc_fusion.truth.sumo.objects`).
KIND_SIGNATURE = {
    ObjectKind.GANTRY: (25.0, 1.0),
    ObjectKind.BRIDGE: (30.0, 1.0),
    ObjectKind.GUARDRAIL: (0.0, 1.0),
    ObjectKind.PARKED: (10.0, 2.0),
}

#: Per kind: (length along the road, height) [m] of the placed objects (assumption; the width
#: of gantries and bridges is the carriageway's, of posts 0.2 m, of parked cars 1.8 m).
_SIZE = {
    ObjectKind.GANTRY: (1.0, 1.5),
    ObjectKind.BRIDGE: (12.0, 1.5),
    ObjectKind.GUARDRAIL: (0.2, 0.75),
    ObjectKind.PARKED: (4.5, 1.5),
}
_POST_WIDTH, _PARKED_WIDTH = 0.2, 1.8


@dataclass(frozen=True)
class RoadsideConfig:
    """Where stationary roadside objects stand (validated on construction; SI units; see the
    module docstring for the sources).

    Attributes:
        seed: seed of the placement (phases and parked vehicles); 0.
        gantry_spacing: distance between sign gantries [m], 0 for none; 2000 (assumption).
        gantry_clearance: height of a gantry's lower edge [m]; 5.18 (AASHTO 17 ft).
        bridge_spacing: distance between bridges [m], 0 for none; 0.
        bridge_clearance: height of a bridge's lower edge [m]; 4.88 (AASHTO 16 ft).
        guardrail_spacing: distance between representative guardrail posts [m], 0 for none;
            25.
        parked_per_km: vehicles parked on the shoulder per km of edge; 0.5 (assumption).
        shoulder_width: hard shoulder beside the right lane [m]; 2.5 (RAA RQ 31).
        min_speed: lowest speed limit of an edge that gets roadside objects [m/s]; 22.22
            (80 km/h).
        min_lanes: fewest lanes of an edge that gets roadside objects; 2.
    """

    seed: int = 0
    gantry_spacing: float = 2000.0
    gantry_clearance: float = 5.18
    bridge_spacing: float = 0.0
    bridge_clearance: float = 4.88
    guardrail_spacing: float = 25.0
    parked_per_km: float = 0.5
    shoulder_width: float = 2.5
    min_speed: float = 80.0 / 3.6
    min_lanes: int = 2

    def __post_init__(self) -> None:
        for name in ("seed", "min_lanes"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
                raise ConfigError(f"roadside.{name} must be an integer >= 0, got {value!r}")
        for name in ("gantry_spacing", "bridge_spacing", "guardrail_spacing"):
            value = check_range(f"roadside.{name}", getattr(self, name), 0.0, 1e6)
            if 0.0 < value < 1.0:
                raise ConfigError(f"roadside.{name} must be 0 (none) or >= 1 m, got {value!r}")
        check_range("roadside.gantry_clearance", self.gantry_clearance, 0.0, 20.0, lo_open=True)
        check_range("roadside.bridge_clearance", self.bridge_clearance, 0.0, 20.0, lo_open=True)
        check_range("roadside.parked_per_km", self.parked_per_km, 0.0, 100.0)
        check_range("roadside.shoulder_width", self.shoulder_width, 0.0, 10.0)
        check_range("roadside.min_speed", self.min_speed, 0.0, 200.0)


@dataclass(frozen=True)
class LaneTable:
    """Every lane of the running network, flattened for compiled code.

    Attributes:
        edge_code: SUMO edge id -> its row in the edge arrays.
        edge_ids: the edge ids in row order.
        first_lane: ``(n_edges,)`` global index of each edge's lane 0 (lane ``i`` of edge
            row ``r`` is ``first_lane[r] + i``).
        n_lanes: ``(n_edges,)`` number of lanes of each edge.
        internal: ``(n_edges,)`` the edge is inside a junction.
        width: ``(n_lanes,)`` lane width [m].
        speed: ``(n_lanes,)`` lane speed limit [m/s].
        start: ``(n_lanes + 1,)`` offsets of each lane's vertices in the vertex arrays.
        vx, vy: vertex coordinates [m] (SUMO's network frame: x east, y north).
        vs: lane position of each vertex [m] (cumulative length along the shape).
        vh: heading of the segment from each vertex [rad], counter-clockwise from east (the
            last vertex repeats its segment's).
    """

    edge_code: dict[str, int]
    edge_ids: tuple[str, ...]
    first_lane: np.ndarray
    n_lanes: np.ndarray
    internal: np.ndarray
    width: np.ndarray
    speed: np.ndarray
    start: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    vs: np.ndarray
    vh: np.ndarray

    @classmethod
    def read(cls, api: Any) -> LaneTable:
        """Read every lane's shape, width and speed limit from the running simulation ``api``
        (libsumo or TraCI), edges in sorted id order."""
        edge_ids = tuple(sorted(api.edge.getIDList()))
        counts = [int(api.edge.getLaneNumber(e)) for e in edge_ids]
        lanes = [f"{e}_{i}" for e, n in zip(edge_ids, counts, strict=True) for i in range(n)]
        shapes = [np.asarray(api.lane.getShape(lane), dtype=float).reshape(-1, 2) for lane in lanes]
        geometry = [_lane_geometry(s) for s in shapes]
        sizes = np.array([len(s) for s in shapes], dtype=np.int64)
        return cls(
            edge_code={e: i for i, e in enumerate(edge_ids)},
            edge_ids=edge_ids,
            first_lane=np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64),
            n_lanes=np.array(counts, dtype=np.int64),
            internal=np.array([e.startswith(":") for e in edge_ids], dtype=bool),
            width=np.array([api.lane.getWidth(lane) for lane in lanes], dtype=float),
            speed=np.array([api.lane.getMaxSpeed(lane) for lane in lanes], dtype=float),
            start=np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
            vx=np.concatenate([s[:, 0] for s in shapes]) if shapes else np.zeros(0),
            vy=np.concatenate([s[:, 1] for s in shapes]) if shapes else np.zeros(0),
            vs=np.concatenate([g[0] for g in geometry]) if geometry else np.zeros(0),
            vh=np.concatenate([g[1] for g in geometry]) if geometry else np.zeros(0),
        )

    def shape(self, lane: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Vertices ``x``, ``y`` and lane positions ``s`` of global lane ``lane``."""
        a, b = self.start[lane], self.start[lane + 1]
        return self.vx[a:b], self.vy[a:b], self.vs[a:b]


def _lane_geometry(shape: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lane position of each vertex of a polyline and the heading of the segment from it."""
    seg = np.diff(shape, axis=0)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(seg[:, 0], seg[:, 1]))])
    heading = np.arctan2(seg[:, 1], seg[:, 0]) if len(seg) else np.zeros(0)
    return s, np.concatenate([heading, heading[-1:] if len(seg) else [0.0]])


@njit(cache=True)
def curvature_at(lane, pos, start, vs, vh):  # pragma: no cover - compiled
    """Curvature [1/m] of global lanes ``lane`` at lane positions ``pos`` (module docstring;
    0 for ``lane < 0``, off the network, and on lanes of a single segment)."""
    out = np.zeros(lane.shape[0])
    half = 0.5 * CURVATURE_WINDOW
    for i in range(lane.shape[0]):
        g = lane[i]
        if g < 0 or start[g + 1] - start[g] < 3:  # off the network, or no vertex to turn at
            continue
        v = vs[start[g] : start[g + 1]]
        last = v.shape[0] - 2  # the last segment
        lo = min(max(np.searchsorted(v, pos[i] - half, side="right") - 1, 0), last)
        hi = min(max(np.searchsorted(v, pos[i] + half, side="left") - 1, 0), last)
        if hi == lo:  # inside one segment: its neighbours on either side
            lo, hi = max(lo - 1, 0), min(hi + 1, last)
        if hi > lo:
            turn = vh[start[g] + hi] - vh[start[g] + lo]
            mid = 0.5 * (v[hi] + v[hi + 1] - v[lo] - v[lo + 1])
            out[i] = math.atan2(math.sin(turn), math.cos(turn)) / mid
    return out


@dataclass(frozen=True)
class Roadside:
    """The stationary objects of a network, ``(K,)`` arrays in the network frame.

    Attributes:
        object_id: stable ids, ``ROADSIDE_ID_BASE + k``.
        kind: :class:`~acc_fusion.truth.objects.ObjectKind` of each.
        x, y: centre of the object's footprint [m] (SUMO's network frame).
        heading: direction of the road there [rad], counter-clockwise from east.
        length: extent along the road [m]; width: across it [m]; height: own height [m].
        elevation: height of the lower edge above the road [m].
        rcs: radar cross-section [dBsm]; thermal_contrast: [K].
    """

    object_id: np.ndarray
    kind: np.ndarray
    x: np.ndarray
    y: np.ndarray
    heading: np.ndarray
    length: np.ndarray
    width: np.ndarray
    height: np.ndarray
    elevation: np.ndarray
    rcs: np.ndarray
    thermal_contrast: np.ndarray

    def __len__(self) -> int:
        return int(self.object_id.shape[0])

    def count(self, kind: ObjectKind) -> int:
        """Number of objects of ``kind``."""
        return int(np.count_nonzero(self.kind == kind))


def _along(lanes: LaneTable, lane: int, s: np.ndarray) -> tuple[np.ndarray, ...]:
    """Points at lane positions ``s`` of a lane: ``x``, ``y`` and the heading [rad] there."""
    x, y, vs = lanes.shape(lane)
    seg = np.clip(np.searchsorted(vs, s, side="right") - 1, 0, len(vs) - 1)
    return np.interp(s, vs, x), np.interp(s, vs, y), lanes.vh[lanes.start[lane] + seg]


def place_roadside(lanes: LaneTable, config: RoadsideConfig) -> Roadside:
    """Place the stationary objects of ``config`` along the motorway-like edges of ``lanes``
    (module docstring); deterministic in the network and ``config.seed``."""
    if not isinstance(config, RoadsideConfig):
        raise ConfigError(f"roadside must be a RoadsideConfig, got {type(config).__name__}")
    rng = np.random.default_rng(config.seed)
    cols: dict[str, list[np.ndarray]] = {k: [] for k in Roadside.__dataclass_fields__}
    edges: list[np.ndarray] = []

    def add(kind: ObjectKind, x, y, heading, width: np.ndarray | float, elevation: float) -> None:
        n = len(x)
        length, height = _SIZE[kind]
        rcs, thermal = KIND_SIGNATURE[kind]
        for name, value in (
            ("kind", np.full(n, int(kind), np.int8)), ("x", x), ("y", y),
            ("heading", heading), ("length", np.full(n, length)),
            ("width", np.broadcast_to(width, (n,))), ("height", np.full(n, height)),
            ("elevation", np.full(n, elevation)), ("rcs", np.full(n, rcs)),
            ("thermal_contrast", np.full(n, thermal)),
        ):  # fmt: skip
            cols[name].append(np.asarray(value, dtype=_dtype(name)))
        edges.append(np.full(n, row, dtype=np.int64))  # the edge of the loop below

    for row in range(len(lanes.edge_ids)):
        first, n = int(lanes.first_lane[row]), int(lanes.n_lanes[row])
        if lanes.internal[row] or n < config.min_lanes or n == 0:
            continue
        if lanes.speed[first : first + n].max() < config.min_speed:
            continue
        right, left = first, first + n - 1
        length = float(lanes.shape(right)[2][-1])
        w_right = float(lanes.width[right])
        carriageway = float(lanes.width[first : first + n].sum())
        edge_out = w_right / 2 + config.shoulder_width  # right lane centre -> outer edge
        across = carriageway + 2 * config.shoulder_width
        for kind, spacing, clearance in (
            (ObjectKind.GANTRY, config.gantry_spacing, config.gantry_clearance),
            (ObjectKind.BRIDGE, config.bridge_spacing, config.bridge_clearance),
        ):
            s = _series(rng, length, spacing)
            if s.size:  # centred between the right and left lanes' centrelines
                xr, yr, h = _along(lanes, right, s)
                xl, yl, _ = _along(lanes, left, s * _ratio(lanes, left, length))
                add(kind, (xr + xl) / 2, (yr + yl) / 2, h, across, clearance)
        s = _series(rng, length, config.guardrail_spacing)
        if s.size:
            x, y, h = _along(lanes, right, s)
            add(ObjectKind.GUARDRAIL, x + edge_out * np.sin(h), y - edge_out * np.cos(h), h,
                _POST_WIDTH, 0.0)  # fmt: skip
        parked = rng.poisson(config.parked_per_km * length / 1000.0)
        if parked:
            s = np.sort(rng.uniform(0.0, length, parked))
            x, y, h = _along(lanes, right, s)
            off = w_right / 2 + config.shoulder_width / 2
            add(ObjectKind.PARKED, x + off * np.sin(h), y - off * np.cos(h), h,
                _PARKED_WIDTH, 0.0)  # fmt: skip
    out = {
        name: np.concatenate(parts) if parts else np.zeros(0, _dtype(name))
        for name, parts in cols.items()
        if name != "object_id"
    }
    edge = np.concatenate(edges) if edges else np.zeros(0, np.int64)
    lane_edge = np.repeat(np.arange(len(lanes.edge_ids)), lanes.n_lanes)
    shoulder = np.isin(out["kind"], [int(ObjectKind.GUARDRAIL), int(ObjectKind.PARKED)])
    keep = ~shoulder | _clear(out["x"], out["y"], out["width"] / 2 + SHOULDER_CLEARANCE, edge,
                             lane_edge, lanes.width, lanes.start, lanes.vx, lanes.vy)  # fmt: skip
    out = {name: a[keep] for name, a in out.items()}
    ids = ROADSIDE_ID_BASE + np.arange(len(out["kind"]), dtype=np.int64)
    return Roadside(object_id=ids, **out)


@njit(cache=True)
def _clear(x, y, reach, edge, lane_edge, width, start, vx, vy):  # pragma: no cover - compiled
    """Whether each object ``(K,)`` at ``(x, y)`` stays ``reach`` [m] clear of the edge of
    every lane of another edge than its own ``edge`` (lanes by ``lane_edge``, ``width``
    and their polylines ``start``, ``vx``, ``vy``)."""
    out = np.ones(x.shape[0], dtype=np.bool_)
    for k in range(x.shape[0]):
        for g in range(width.shape[0]):
            if lane_edge[g] == edge[k]:
                continue
            limit = reach[k] + 0.5 * width[g]
            for i in range(start[g], start[g + 1] - 1):
                ax, ay = vx[i + 1] - vx[i], vy[i + 1] - vy[i]
                seg = ax * ax + ay * ay
                u = 0.0 if seg == 0.0 else ((x[k] - vx[i]) * ax + (y[k] - vy[i]) * ay) / seg
                u = min(max(u, 0.0), 1.0)
                dx, dy = x[k] - vx[i] - u * ax, y[k] - vy[i] - u * ay
                if dx * dx + dy * dy < limit * limit:
                    out[k] = False
                    break
            if not out[k]:
                break
    return out


def _dtype(name: str) -> type:
    """The dtype of a :class:`Roadside` column."""
    return {"object_id": np.int64, "kind": np.int8}.get(name, np.float64)


def _ratio(lanes: LaneTable, lane: int, length: float) -> float:
    """Length of ``lane`` over ``length`` (lanes of one edge differ in length on curves)."""
    return float(lanes.shape(lane)[2][-1]) / max(length, 1e-9)


def _series(rng: np.random.Generator, length: float, spacing: float) -> np.ndarray:
    """Positions ``phase + k spacing`` in ``[0, length)``, the phase uniform in
    ``[0, spacing)`` (one draw per series, also for none: the draws do not depend on the
    lengths); none when ``spacing`` is 0."""
    phase = rng.uniform()
    if spacing <= 0.0:
        return np.zeros(0)
    return np.arange(phase * spacing, length, spacing) if length > 0 else np.zeros(0)
