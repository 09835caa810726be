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
    source        truth source, ``"scripted"``, ``"sumo"`` or ``"world"`` (the 2-D scenes of
                  :mod:`acc_fusion.sim.world`, whose ``world.scene`` and ``world.conditions.*``
                  are axes like any other) (``"scripted"``); may also be an axis
    seeds         master seeds, whole numbers >= 0 (``[0]``)
    runs          runs per point and seed (100)
    chunk_runs    runs simulated together in one batched call, a *chunk* (2000)
    n_samples     draws of the random axes (0; required >= 1 when there are random axes)
    sample_seed   seed of those draws (0)
    base          :class:`~acc_fusion.sim.closed_loop.SimConfig` fields shared by every point (not
                  ``runs`` nor ``seed``, which the sweep sets)
    sumo          :class:`~acc_fusion.truth.sumo.config.SumoConfig` fields of SUMO points, with
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
import json
import math
import re
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from acc_fusion.core.config import from_mapping, load_mapping
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_choice
from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.sweep.points import SOURCES, Chunk, Point, _expand
from acc_fusion.truth.sumo.config import SumoConfig

DISTRIBUTIONS = ("uniform", "loguniform", "randint", "choice")


REPORT_FORMATS = ("markdown", "html")


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
        if not isinstance(self.name, str) or not re.fullmatch(r"[A-Za-z0-9][\w.-]*", self.name):
            raise ConfigError(
                "name must be a plain label (letters, digits, '_', '-', '.'; no path), "
                f"got {self.name!r}"
            )
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
