r"""Monte Carlo sweeps: thousands of FCW runs over a grid or random sample of settings.

A sweep runs :func:`acc_fusion.sim.closed_loop.simulate` (scripted truth) or a SUMO simulation
(:mod:`acc_fusion.studies.traffic`) at every *point* of a parameter space, ``runs`` times per point
and seed, on local processes or a Ray cluster (:mod:`acc_fusion.sweep.executors`), and
stores one row per run and method (parameters + metrics) in Parquet, resumably;
:func:`aggregate` pools the rows into tables with 95 % intervals and :mod:`acc_fusion.sweep.report`
draws ROC/DET curves and writes a report.

Config (TOML or YAML; :class:`SweepConfig`)
    ============  ================================================================================
    key           meaning (default)
    ============  ================================================================================
    name          label of the sweep and of its default output folder (``"sweep"``)
    source        truth source, ``"scripted"`` or ``"sumo"`` (``"scripted"``); may also be an axis
    seeds         master seeds, whole numbers >= 0 (``[0]``)
    runs          runs per point and seed (100)
    chunk_runs    runs simulated together in one batched call, a *chunk* (2000)
    n_samples     draws of the random axes (0; required >= 1 when there are random axes)
    sample_seed   seed of those draws (0)
    base          :class:`~acc_fusion.sim.closed_loop.SimConfig` fields shared by every point (not
                  ``runs`` nor ``seed``, which the sweep sets)
    sumo          :class:`~acc_fusion.truth.sumo.source.SumoConfig` fields of SUMO points, with
    ``net``
                  (a bundled network) or ``sumocfg`` (a file); not ``seed``
    axes          the swept settings: a dotted key into ``base`` (e.g. ``"warning.z"``,
                  ``"radar.range_std"``, ``"fusion.reset"``, ``"radar_faults"``), into
                  ``sumo`` (``"sumo.penetration"``) or ``"source"``, mapped to a list of
                  values (a grid axis) or to one distribution (a random axis):
                  ``{uniform = [lo, hi]}``, ``{loguniform = [lo, hi]}``,
                  ``{randint = [lo, hi]}`` (both ends included), ``{choice = [a, b, ...]}``
    report        :class:`ReportConfig`: ``threshold`` (the axis the ROC curves follow),
                  ``curves_by`` (an axis splitting the curves), ``format`` (``"markdown"``
                  or ``"html"``)
    ============  ================================================================================

Points
    The grid axes form a Cartesian product; with random axes, each of the ``n_samples``
    draws (all random axes at once, from ``sample_seed``) is combined with every grid point.
    A point is identified by a hash of its settings (:attr:`Point.id`), so ids do not depend
    on the order of the axes, and identical points (e.g. repeated ``choice`` draws) are run
    once.  Every method of ``base.methods`` (default: radar, infrared, centralized,
    federated) is evaluated in every run on the same truth and measurements, so a run gives
    one row per method.

Chunks, seeds and reproducibility
    The runs of one point and master seed ``s`` are cut into chunks of ``chunk_runs`` runs
    (the last one shorter); chunk ``b`` is one batched simulation seeded with the ``b``-th
    child of ``numpy.random.SeedSequence(s)`` (:func:`chunk_seed`).  Every point uses the
    same chunk seeds, so points are compared on common random numbers (the same scripted
    manoeuvres and noise draws where their settings allow).  A run's row depends on the
    sweep config, its master seed and its chunk (seed, size and position in it): chunk
    composition is a function of the config only, never of the executor, the number of
    workers or the order in which chunks finish, so the local and Ray executors give the same
    rows.  Changing ``chunk_runs`` changes the rows (a different, equally valid sample).
    A SUMO point runs one SUMO simulation per run (a chunk of its own), in a worker process
    that runs nothing else (libsumo allows one simulation per process).

Resuming
    The chunk is the unit of completion: each finished chunk's rows are written atomically
    (temporary file + rename) as ``parts/<chunk id>.parquet``, so a sweep killed at any moment,
    even with SIGKILL, leaves only whole parts.  Rerunning with the same output folder skips
    the chunks whose part exists and never writes a row twice; the folder's ``sweep.json``
    holds the config, and a different config is refused.  At the end the parts are
    consolidated into ``runs.parquet`` (sorted by point, seed, run, method), the aggregated
    tables and the report.

Rows (``runs.parquet``)
    ``run_id``, ``point_id``, ``chunk_id``, ``seed`` (master seed), ``run`` (index within the
    point and seed), one column per axis (numbers stay numbers, strings strings, anything
    else JSON), ``fault`` (the injected fault types, e.g. ``"radar:bias"``, or ``"none"``),
    ``method``, the event counts ``warnings``, ``false_alarms``, ``threats``, ``detected``,
    ``missed``, ``collisions``, the exposure ``hours`` and ``km``, ``lead_time_sum_s`` (sum of
    the lead times of the detected threats [s]) and ``steps`` (simulation steps of the chunk:
    of its scripted runs, or of its SUMO run).
    See :mod:`acc_fusion.metrics.events` for the definitions.
"""

from __future__ import annotations

import copy
import hashlib
import io
import itertools
import json
import math
import time
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from acc_fusion.core.config import from_mapping, load_mapping
from acc_fusion.core.errors import AccFusionError, ConfigError
from acc_fusion.core.validation import check_choice
from acc_fusion.metrics.events import event_rates

SOURCES = ("scripted", "sumo")
DISTRIBUTIONS = ("uniform", "loguniform", "randint", "choice")
REPORT_FORMATS = ("markdown", "html")
#: Event counts of a row (see :meth:`acc_fusion.metrics.events.FCWMetrics.per_pair`).
COUNT_COLUMNS = ("warnings", "false_alarms", "threats", "detected", "missed", "collisions")
#: Exposure and lead-time columns of a row.
SUM_COLUMNS = ("hours", "km", "lead_time_sum_s")
#: Columns of every row before the axes' columns.
ID_COLUMNS = ("run_id", "point_id", "chunk_id", "seed", "run")

_TOP_KEYS = (
    "name",
    "source",
    "seeds",
    "runs",
    "chunk_runs",
    "n_samples",
    "sample_seed",
    "base",
    "sumo",
    "axes",
    "report",
)
#: Keys the sweep sets itself, per chunk.
_RESERVED = {"base": ("runs", "seed"), "sumo": ("seed",)}


# --------------------------------------------------------------------------------------------
# Config
# --------------------------------------------------------------------------------------------


def _whole(name: str, value: object, lo: int, hi: int = 2**63 - 1) -> int:
    """``value`` as an int in ``[lo, hi]``, else a :class:`ConfigError` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise ConfigError(f"{name} must be a whole number in [{lo}, {hi}], got {value!r}")
    return int(value)


@dataclass(frozen=True)
class Axis:
    """One swept setting.

    Attributes:
        key: dotted key into ``base`` (a :class:`~acc_fusion.sim.closed_loop.SimConfig` field path),
            ``"sumo.<field>"`` or ``"source"``.
        values: the grid values (``None`` for a random axis).
        distribution: one of :data:`DISTRIBUTIONS` (``None`` for a grid axis).
        args: ``(lo, hi)`` of ``uniform``/``loguniform``/``randint``, the choices of ``choice``.
    """

    key: str
    values: tuple | None = None
    distribution: str | None = None
    args: tuple = ()

    @classmethod
    def parse(cls, key: str, spec: object) -> Axis:
        """An axis from its config entry: a list (grid) or ``{distribution = [...]}``."""
        where = f"axes.{key!r}"
        if isinstance(spec, (list, tuple)):
            if not spec:
                raise ConfigError(f"{where} must list at least one value")
            return cls(key, values=tuple(spec))
        if not (isinstance(spec, Mapping) and len(spec) == 1):
            raise ConfigError(
                f"{where} must be a list of values (grid) or a table with one of "
                f"{', '.join(DISTRIBUTIONS)} (random), got {spec!r}"
            )
        ((dist, args),) = spec.items()
        check_choice(f"{where} distribution", dist, DISTRIBUTIONS)
        if not isinstance(args, (list, tuple)) or not args:
            raise ConfigError(f"{where}.{dist} must be a list, got {args!r}")
        if dist != "choice":
            if len(args) != 2:
                raise ConfigError(f"{where}.{dist} must be [lo, hi], got {args!r}")
            check = (lambda n, v: _whole(n, v, -(2**62), 2**62)) if dist == "randint" else _number
            lo, hi = (check(f"{where}.{dist}[{i}]", v) for i, v in enumerate(args))
            if not lo <= hi or (dist == "loguniform" and not lo > 0):
                low = "0 < lo" if dist == "loguniform" else "lo"
                raise ConfigError(f"{where}.{dist} must have {low} <= hi, got {list(args)!r}")
            args = (lo, hi)
        return cls(key, distribution=dist, args=tuple(args))

    @property
    def is_random(self) -> bool:
        return self.distribution is not None

    def draw(self, rng: np.random.Generator) -> object:
        """One value of a random axis (loguniform: uniform in the logarithm)."""
        if self.distribution == "choice":
            return self.args[int(rng.integers(len(self.args)))]
        lo, hi = self.args
        if self.distribution == "uniform":
            return float(rng.uniform(lo, hi))
        if self.distribution == "loguniform":
            return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
        return int(rng.integers(lo, hi, endpoint=True))

    def possible_values(self) -> tuple:
        """The values the axis can take, as far as their types go."""
        if self.distribution == "uniform" or self.distribution == "loguniform":
            return (float(self.args[0]),)
        if self.distribution == "randint":
            return (int(self.args[0]),)
        return self.values if self.values is not None else self.args


def _number(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{name} must be a finite number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class ReportConfig:
    """What the report draws.

    Attributes:
        threshold: the axis the ROC/DET curves follow (``None``: the first axis whose key
            starts with ``"warning."``; without one each point is a separate operating point).
        curves_by: an axis whose values get curves of their own (``None``: pooled).
        format: ``"markdown"`` (``report.md``, default) or ``"html"`` (``report.html``).
    """

    threshold: str | None = None
    curves_by: str | None = None
    format: str = "markdown"

    def __post_init__(self) -> None:
        check_choice("report.format", self.format, REPORT_FORMATS)


@dataclass(frozen=True)
class SweepConfig:
    """A validated sweep (fields and defaults in the module docstring's table)."""

    name: str = "sweep"
    source: str = "scripted"
    seeds: tuple[int, ...] = (0,)
    runs: int = 100
    chunk_runs: int = 2000
    n_samples: int = 0
    sample_seed: int = 0
    base: dict = field(default_factory=dict)
    sumo: dict = field(default_factory=dict)
    axes: tuple[Axis, ...] = ()
    report: ReportConfig = field(default_factory=ReportConfig)

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any]) -> SweepConfig:
        """Build and validate a sweep from a config file's mapping."""
        data = dict(data)
        unknown = sorted(set(data) - set(_TOP_KEYS))
        if unknown:
            raise ConfigError(
                f"unknown key {unknown[0]!r} in the sweep config; allowed keys: "
                f"{', '.join(_TOP_KEYS)}"
            )
        axes = data.pop("axes", {}) or {}
        if not isinstance(axes, Mapping):
            raise ConfigError(f"axes must be a table of key = values, got {axes!r}")
        report = data.pop("report", {}) or {}
        if not isinstance(report, Mapping):
            raise ConfigError(f"report must be a table, got {report!r}")
        seeds = data.pop("seeds", (0,))
        if not isinstance(seeds, (list, tuple)) or not seeds:
            raise ConfigError(f"seeds must be a list of whole numbers >= 0, got {seeds!r}")
        for name in ("base", "sumo"):
            if not isinstance(data.get(name, {}), Mapping):
                raise ConfigError(f"{name} must be a table, got {data[name]!r}")
        return cls(
            **data,
            seeds=tuple(seeds),
            axes=tuple(Axis.parse(str(k), v) for k, v in axes.items()),
            report=from_mapping(ReportConfig, report, prefix="report."),
        )

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise ConfigError(f"name must be a non-empty string, got {self.name!r}")
        check_choice("source", self.source, SOURCES)
        for i, s in enumerate(self.seeds):
            _whole(f"seeds[{i}]", s, 0, 2**63 - 1)
        if len(set(self.seeds)) != len(self.seeds):
            raise ConfigError(f"seeds must not repeat, got {list(self.seeds)!r}")
        _whole("runs", self.runs, 1, 10_000_000)
        _whole("chunk_runs", self.chunk_runs, 1, 1_000_000)
        _whole("n_samples", self.n_samples, 0, 10_000_000)
        _whole("sample_seed", self.sample_seed, 0)
        object.__setattr__(self, "base", copy.deepcopy(dict(self.base)))
        object.__setattr__(self, "sumo", copy.deepcopy(dict(self.sumo)))
        for section, keys in _RESERVED.items():
            for key in keys:
                if key in getattr(self, section):
                    raise ConfigError(
                        f"{section}.{key} is set by the sweep (runs, chunk_runs and seeds); "
                        "remove it"
                    )
        from acc_fusion.sim.closed_loop import SimConfig

        from_mapping(SimConfig, {**self.base, "runs": 1, "seed": 0}, prefix="base.")
        keys = [a.key for a in self.axes]
        if len(set(keys)) != len(keys):
            raise ConfigError(f"axes must not repeat a key, got {keys!r}")
        for axis in self.axes:
            _check_axis_key(axis.key)
        random_axes = [a.key for a in self.axes if a.is_random]
        if random_axes and self.n_samples < 1:
            raise ConfigError(
                f"n_samples must be >= 1 with random axes ({', '.join(random_axes)}), got "
                f"{self.n_samples}"
            )
        if not random_axes and self.n_samples:
            raise ConfigError("n_samples needs at least one random axis ({uniform = [lo, hi]}…)")
        for name in ("threshold", "curves_by"):
            key = getattr(self.report, name)
            if key is not None:
                check_choice(f"report.{name}", key, keys)
        # Build every point now, so that a bad value fails here, naming its key.
        object.__setattr__(self, "_points", _expand(self))

    def as_dict(self) -> dict:
        """The config as plain JSON-able data (what ``sweep.json`` stores)."""
        data = asdict(self)
        data["axes"] = {
            a.key: list(a.values) if a.values is not None else {a.distribution: list(a.args)}
            for a in self.axes
        }
        return json.loads(json.dumps(data, default=list))

    def points(self) -> list[Point]:
        """Every point of the sweep (grid × random samples), each once, in config order."""
        return list(self._points)

    def chunks(self) -> list[Chunk]:
        """Every chunk of the sweep: per point, per master seed, runs cut into chunks."""
        out = []
        for point in self.points():
            size = 1 if point.source == "sumo" else self.chunk_runs
            for seed in self.seeds:
                for block, first in enumerate(range(0, self.runs, size)):
                    out.append(Chunk(point, seed, block, first, min(size, self.runs - first)))
        return out

    @property
    def total_runs(self) -> int:
        return len(self.points()) * len(self.seeds) * self.runs


def _check_axis_key(key: str) -> None:
    from acc_fusion.sim.closed_loop import SimConfig
    from acc_fusion.truth.sumo.source import SumoConfig

    head, _, rest = key.partition(".")
    sim_fields = [f for f in SimConfig.__dataclass_fields__ if f not in _RESERVED["base"]]
    sumo_fields = ["net", *(f for f in SumoConfig.__dataclass_fields__ if f != "seed")]
    if key == "source":
        return
    if head == "sumo":
        check_choice(f"axes key {key!r}: sumo field", rest, sumo_fields)
        return
    if head not in sim_fields:
        raise ConfigError(
            f"axes key {key!r} must be 'source', 'sumo.<field>' or a SimConfig field path; "
            f"allowed fields: {', '.join(sim_fields)}"
        )


def load_sweep(path: str | Path) -> SweepConfig:
    """Read and validate a sweep config file (TOML or YAML)."""
    return SweepConfig.from_mapping(load_mapping(path))


# --------------------------------------------------------------------------------------------
# Points and chunks
# --------------------------------------------------------------------------------------------


def _set(data: dict, dotted: str, value: object) -> None:
    """``data[a][b][c] = value`` for ``dotted = "a.b.c"`` (creating the tables on the way)."""
    *path, last = dotted.split(".")
    for part in path:
        inner = data.get(part)
        data[part] = inner = dict(inner) if isinstance(inner, Mapping) else {}
        data = inner
    data[last] = copy.deepcopy(value)


def _canonical(x: object) -> str:
    return json.dumps(x, sort_keys=True, separators=(",", ":"))


@dataclass(frozen=True)
class Point:
    """One setting of every axis.

    Attributes:
        id: 12 hex digits of the SHA-1 of the settings (stable across axis order).
        params: axis key -> value.
        columns: axis key -> the value as stored in the rows.
        source: ``"scripted"`` or ``"sumo"``.
        sim: the :class:`~acc_fusion.sim.closed_loop.SimConfig` fields (without ``runs`` and
        ``seed``).
        sumo: the SUMO fields (``net`` or ``sumocfg``,
        :class:`~acc_fusion.truth.sumo.source.SumoConfig`
            fields) of a SUMO point, else ``{}``.
        fault: the fault types injected, e.g. ``"radar:bias+infrared:dropout"``, or ``"none"``.
    """

    id: str
    params: dict
    columns: dict
    source: str
    sim: dict
    sumo: dict
    fault: str


def _column_kinds(axes: Iterable[Axis]) -> dict[str, str]:
    """How each axis is stored: ``"int"``, ``"float"``, ``"bool"``, ``"str"`` or ``"json"``."""
    kinds = {}
    for axis in axes:
        vals = axis.possible_values()
        if all(isinstance(v, bool) for v in vals):
            kinds[axis.key] = "bool"
        elif all(isinstance(v, int) and not isinstance(v, bool) for v in vals):
            kinds[axis.key] = "int"
        elif all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
            kinds[axis.key] = "float"
        elif all(isinstance(v, str) for v in vals):
            kinds[axis.key] = "str"
        else:
            kinds[axis.key] = "json"
    return kinds


def _column_value(kind: str, value: object) -> object:
    if kind == "json":
        return _canonical(value)
    return {"int": int, "float": float, "bool": bool, "str": str}[kind](value)


def _fault_label(sim) -> str:
    kinds = [f"{s}:{f.kind}" for s in ("radar", "infrared") for f in getattr(sim, f"{s}_faults")]
    return "+".join(sorted(set(kinds))) or "none"


def _make_point(cfg: SweepConfig, params: dict, kinds: dict[str, str]) -> Point:
    from acc_fusion.sim.closed_loop import SimConfig

    sim, sumo, source = copy.deepcopy(cfg.base), copy.deepcopy(cfg.sumo), cfg.source
    for key, value in params.items():
        if key == "source":
            source = check_choice("axes 'source' value", value, SOURCES)
        elif key.startswith("sumo."):
            _set(sumo, key[5:], value)
        else:
            _set(sim, key, value)
    where = ", ".join(f"{k} = {_canonical(v)}" for k, v in params.items()) or "base"
    try:
        built = from_mapping(SimConfig, {**sim, "runs": 1, "seed": 0}, prefix="base.")
        if source == "sumo":
            _sumo_config(sumo, 0)
    except ConfigError as exc:
        raise ConfigError(f"sweep point ({where}): {exc}") from None
    sumo = sumo if source == "sumo" else {}
    pid = hashlib.sha1(_canonical({"source": source, "sim": sim, "sumo": sumo}).encode())
    columns = {k: _column_value(kinds[k], v) for k, v in params.items()}
    return Point(pid.hexdigest()[:12], params, columns, source, sim, sumo, _fault_label(built))


def _expand(cfg: SweepConfig) -> list[Point]:
    grid = [a for a in cfg.axes if not a.is_random]
    rand = [a for a in cfg.axes if a.is_random]
    rng = np.random.default_rng(np.random.SeedSequence(cfg.sample_seed))
    samples = [{a.key: a.draw(rng) for a in rand} for _ in range(cfg.n_samples)] or [{}]
    kinds = _column_kinds(cfg.axes)
    points: dict[str, Point] = {}
    for values in itertools.product(*(a.values for a in grid)):
        for sample in samples:
            params = {a.key: v for a, v in zip(grid, values, strict=True)} | sample
            point = _make_point(cfg, {a.key: params[a.key] for a in cfg.axes}, kinds)
            points.setdefault(point.id, point)
    return list(points.values())


def chunk_seed(seed: int, block: int) -> int:
    """The simulation seed of chunk ``block`` of master seed ``seed``: the ``block``-th child
    of ``numpy.random.SeedSequence(seed)``, as a whole number < 2**31 (SUMO's limit).

    >>> chunk_seed(0, 1) == chunk_seed(0, 1) != chunk_seed(0, 2)
    True
    """
    state = np.random.SeedSequence(seed, spawn_key=(block,)).generate_state(1, dtype=np.uint32)
    return int(state[0]) & 0x7FFFFFFF


@dataclass(frozen=True)
class Chunk:
    """Runs ``first .. first + n_runs - 1`` of ``point`` under master seed ``seed``: one batched
    simulation (a SUMO chunk: one SUMO run)."""

    point: Point
    seed: int
    block: int
    first: int
    n_runs: int

    @property
    def id(self) -> str:
        return f"{self.point.id}-s{self.seed}-b{self.block:06d}"

    @property
    def sim_seed(self) -> int:
        return chunk_seed(self.seed, self.block)


# --------------------------------------------------------------------------------------------
# Running a chunk (in a worker process)
# --------------------------------------------------------------------------------------------


def _sumo_config(sumo: dict, seed: int):
    from acc_fusion.studies.traffic import resolve_sumocfg
    from acc_fusion.truth.sumo.source import SumoConfig

    fields = dict(sumo)
    net, sumocfg = fields.pop("net", None), fields.pop("sumocfg", None)
    if (net is None) == (sumocfg is None):
        raise ConfigError(
            "a SUMO point needs exactly one of sumo.net (a bundled network) and sumo.sumocfg "
            f"(a .sumocfg file), got net = {net!r}, sumocfg = {sumocfg!r}"
        )
    path = resolve_sumocfg(net, sumocfg)
    return from_mapping(SumoConfig, {**fields, "sumocfg": str(path), "seed": seed}, "sumo.")


def run_chunk(chunk: Chunk) -> dict[str, list]:
    """Simulate ``chunk`` and return its rows as columns (one row per run and method)."""
    from acc_fusion.sim.closed_loop import SimConfig, simulate

    point = chunk.point
    sim = from_mapping(SimConfig, {**point.sim, "runs": chunk.n_runs, "seed": chunk.sim_seed})
    if point.source == "sumo":
        from acc_fusion.studies.traffic import _run

        run = _run(_sumo_config(point.sumo, chunk.sim_seed), sim, False, False)
        if run.error:
            raise AccFusionError(f"SUMO failed in chunk {chunk.id}: {run.error}")
        steps = run.steps
        per_run = {m: _summary_counts(s) for m, s in run.summaries.items()}
    else:
        result = simulate(sim)
        steps = result.steps
        per_run = {m: s.per_pair for m, s in result.summaries.items()}
    cols: dict[str, list] = {c: [] for c in (*ID_COLUMNS, *point.columns, "fault", "method")}
    for c in (*COUNT_COLUMNS, *SUM_COLUMNS, "steps"):
        cols[c] = []
    for i in range(chunk.n_runs):
        run_index = chunk.first + i
        for method, figures in per_run.items():
            cols["run_id"].append(f"{point.id}-s{chunk.seed}-r{run_index:07d}")
            cols["point_id"].append(point.id)
            cols["chunk_id"].append(chunk.id)
            cols["seed"].append(chunk.seed)
            cols["run"].append(run_index)
            for key, value in point.columns.items():
                cols[key].append(value)
            cols["fault"].append(point.fault)
            cols["method"].append(method)
            for c in (*COUNT_COLUMNS, *SUM_COLUMNS):
                cols[c].append(figures[c][i].item())
            cols["steps"].append(steps)
    return cols


def _summary_counts(s) -> dict[str, np.ndarray]:
    """The per-run figures of a one-run :class:`~acc_fusion.metrics.events.FCWSummary` (a SUMO run:
    all its vehicles together)."""
    lead = s.lead_time.mean * s.lead_time.finite if s.lead_time.finite else 0.0
    figures = {c: getattr(s, c) for c in (*COUNT_COLUMNS, "hours", "km")}
    return {k: np.array([v]) for k, v in {**figures, "lead_time_sum_s": lead}.items()}


# --------------------------------------------------------------------------------------------
# The resumable store
# --------------------------------------------------------------------------------------------


def _schema(cfg: SweepConfig):
    import pyarrow as pa

    types = {"int": pa.int64(), "float": pa.float64(), "bool": pa.bool_()}
    kinds = _column_kinds(cfg.axes)
    return pa.schema(
        [
            ("run_id", pa.string()),
            ("point_id", pa.string()),
            ("chunk_id", pa.string()),
            ("seed", pa.int64()),
            ("run", pa.int64()),
            *((a.key, types.get(kinds[a.key], pa.string())) for a in cfg.axes),
            ("fault", pa.string()),
            ("method", pa.string()),
            *((c, pa.int64()) for c in COUNT_COLUMNS),
            *((c, pa.float64()) for c in SUM_COLUMNS),
            ("steps", pa.int64()),
        ]
    )


def _rows_part(config: dict) -> dict:
    """What decides a sweep's rows: its config without ``report`` (which may change)."""
    return {k: v for k, v in config.items() if k != "report"}


def _parquet_bytes(table) -> bytes:
    import pyarrow.parquet as pq

    buf = io.BytesIO()
    pq.write_table(table, buf)
    return buf.getvalue()


class SweepStore:
    """The output folder of a sweep: ``sweep.json``, ``parts/`` and the consolidated results.

    Opening a folder whose ``sweep.json`` holds another sweep is refused (only the
    ``report`` settings may change between runs into the same folder).
    """

    def __init__(self, out: str | Path, config: SweepConfig) -> None:
        from acc_fusion.core.outputs import output_dir, write_json_atomic

        self.out = output_dir(out)
        self.parts = output_dir(self.out / "parts")
        self.config = config
        self.schema = _schema(config)
        meta = self.out / "sweep.json"
        want = config.as_dict()
        if meta.exists():
            try:
                have = json.loads(meta.read_text()).get("config")
            except (OSError, ValueError, AttributeError):
                have = None
            if not isinstance(have, dict) or _rows_part(have) != _rows_part(want):
                raise ConfigError(
                    f"output folder {str(self.out)!r} holds a different sweep (see its "
                    "sweep.json); use another --out or remove that folder"
                )
        write_json_atomic(meta, {"config": want})
        for stale in self.parts.glob(".*.tmp"):  # a write cut short by a kill
            stale.unlink(missing_ok=True)

    def done(self) -> set[str]:
        """Ids of the chunks whose part is written."""
        return {p.stem for p in self.parts.glob("*.parquet")}

    def write_part(self, chunk: Chunk, columns: dict) -> None:
        """Store a finished chunk's rows atomically (the unit of completion)."""
        import pyarrow as pa

        from acc_fusion.core.outputs import write_bytes_atomic

        table = pa.table(columns, schema=self.schema)
        write_bytes_atomic(self.parts / f"{chunk.id}.parquet", _parquet_bytes(table))

    def consolidate(self, chunk_ids: Iterable[str]):
        """All rows of ``chunk_ids`` as one table sorted by point, seed, run and method, also
        written atomically to ``runs.parquet``."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        from acc_fusion.core.outputs import write_bytes_atomic

        tables = [pq.read_table(self.parts / f"{c}.parquet") for c in chunk_ids]
        table = pa.concat_tables(tables) if tables else self.schema.empty_table()
        table = table.sort_by(
            [
                ("point_id", "ascending"),
                ("seed", "ascending"),
                ("run", "ascending"),
                ("method", "ascending"),
            ]
        )
        write_bytes_atomic(self.out / "runs.parquet", _parquet_bytes(table))
        return table


# --------------------------------------------------------------------------------------------
# Running a sweep
# --------------------------------------------------------------------------------------------


@dataclass
class SweepResult:
    """What :func:`run_sweep` did: the rows (a pandas DataFrame), the chunks it ran now and
    those it found done, the wall time [s] of the runs and the files written."""

    config: SweepConfig
    rows: Any
    ran_chunks: int
    skipped_chunks: int
    ran_runs: int
    seconds: float
    files: list[Path] = field(default_factory=list)

    @property
    def runs_per_s(self) -> float:
        return self.ran_runs / self.seconds if self.seconds > 0 else math.nan


def run_sweep(
    config: SweepConfig,
    out: str | Path,
    *,
    executor: str = "local",
    workers: int = 2,
    address: str | None = None,
    progress: bool = True,
    report: bool = True,
) -> SweepResult:
    """Run the chunks of ``config`` not yet stored in ``out``, then consolidate and report.

    Returns the rows of every run of the sweep (those found done included).
    """
    from acc_fusion.sweep.executors import make_executor

    run = make_executor(executor, workers, address)
    store = SweepStore(out, config)
    chunks = config.chunks()
    done = store.done()
    todo = [c for c in chunks if c.id not in done]
    total = config.total_runs
    from tqdm.auto import tqdm

    bar = tqdm(
        total=total,
        initial=total - sum(c.n_runs for c in todo),
        unit="run",
        desc=config.name,
        disable=None if progress else True,
        smoothing=0.1,
    )
    t0 = time.perf_counter()
    ran = 0
    with bar:
        for chunk, columns in run(todo):
            store.write_part(chunk, columns)
            ran += chunk.n_runs
            bar.update(chunk.n_runs)
    seconds = time.perf_counter() - t0
    rows = store.consolidate(c.id for c in chunks).to_pandas()
    result = SweepResult(
        config, rows, len(todo), len(chunks) - len(todo), ran, seconds, [store.out / "runs.parquet"]
    )
    result.files += write_tables(config, rows, store.out)
    if report:
        from acc_fusion.sweep.report import write_report

        result.files += write_report(config, rows, store.out)
    return result


# --------------------------------------------------------------------------------------------
# Aggregation
# --------------------------------------------------------------------------------------------


def aggregate(rows, by: list[str], confidence: float = 0.95):
    """Pool the runs of ``rows`` (a DataFrame of :func:`run_sweep`) by the columns ``by``.

    Returns a DataFrame with ``by``, ``runs``, the summed counts and exposure, and per group
    false alarms per hour and per 100 km (exact Poisson intervals), miss rate and false-alarm
    ratio (Wilson intervals) as ``<name>``, ``<name>_lo``, ``<name>_hi``, and the mean lead
    time [s] of the detected threats.
    """
    import pandas as pd

    sums = rows.groupby(by, sort=True, dropna=False)[[*COUNT_COLUMNS, *SUM_COLUMNS]].sum()
    sums.insert(0, "runs", rows.groupby(by, sort=True, dropna=False)["run_id"].nunique())
    out = []
    for key, g in sums.iterrows():
        counts = {c: int(g[c]) for c in COUNT_COLUMNS}
        rates = event_rates(counts, float(g["hours"]), float(g["km"]), confidence)
        rec = dict(zip(by, key if isinstance(key, tuple) else (key,), strict=True))
        rec |= {"runs": int(g["runs"]), **counts, "hours": g["hours"], "km": g["km"]}
        for name, short in _RATE_COLUMNS.items():
            r = rates[name]
            rec |= {short: r.value, f"{short}_lo": r.lo, f"{short}_hi": r.hi}
        rec["lead_time_mean_s"] = (
            g["lead_time_sum_s"] / g["detected"] if g["detected"] else math.nan
        )
        out.append(rec)
    return pd.DataFrame(out)


#: Rate of :func:`acc_fusion.metrics.events.event_rates` -> column name in :func:`aggregate`.
_RATE_COLUMNS = {
    "false_alarms_per_hour": "fa_per_hour",
    "false_alarms_per_100km": "fa_per_100km",
    "miss_rate": "miss_rate",
    "false_alarm_ratio": "false_alarm_ratio",
}


def formatted(table) -> list[dict]:
    """Rows of an :func:`aggregate` table for reading: each rate as ``"value [lo, hi]"``."""
    from acc_fusion.metrics.stats import Rate

    keep = [c for c in table.columns if not c.endswith(("_lo", "_hi"))]
    out = []
    for rec in table.to_dict("records"):
        row = {}
        for c in keep:
            if c in _RATE_COLUMNS.values():
                row[c] = Rate(rec[c], rec[f"{c}_lo"], rec[f"{c}_hi"]).format()
            elif c == "missed":
                row[c] = f"{rec['missed']}/{rec['threats']}"
            elif c not in ("threats", "detected"):
                row[c] = rec[c]
        out.append(row)
    return out


def write_tables(cfg: SweepConfig, rows, out: Path) -> list[Path]:
    """``summary.csv`` (per point and method) and ``methods.csv`` (per method, pooled)."""
    from acc_fusion.core.outputs import write_csv_atomic

    written = []
    axes = [a.key for a in cfg.axes]
    for name, by in (("summary", [*axes, "fault", "method"]), ("methods", ["method"])):
        table = aggregate(rows, by)
        written.append(
            write_csv_atomic(out / f"{name}.csv", list(table.columns), table.to_dict("records"))
        )
    return written


# --------------------------------------------------------------------------------------------
# acc-fusion sweep
# --------------------------------------------------------------------------------------------
