"""The points of a sweep (one setting of every axis) and its chunks (runs of a point under one
master seed): expansion of a :class:`~acc_fusion.sweep.config.SweepConfig`, each point named by a
stable hash of its settings."""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.schema import set_path
from acc_fusion.core.validation import check_choice
from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.truth.sumo.config import SumoConfig
from acc_fusion.truth.sumo.nets import resolve_sumocfg

if TYPE_CHECKING:
    from acc_fusion.sweep.config import Axis, SweepConfig

#: Truth sources a point may use.
SOURCES = ("scripted", "sumo", "world")


def _canonical(x: object) -> str:
    return json.dumps(x, sort_keys=True, separators=(",", ":"))


@dataclass(frozen=True)
class Point:
    """One setting of every axis.

    Attributes:
        id: 12 hex digits of the SHA-1 of the settings (stable across axis order).
        params: axis key -> value.
        columns: axis key -> the value as stored in the rows.
        source: ``"scripted"``, ``"sumo"`` or ``"world"`` (the scripted 2-D scenes).
        sim: the :class:`~acc_fusion.sim.closed_loop.SimConfig` fields (without ``runs`` and
            ``seed``).
        sumo: the SUMO fields (``net`` or ``sumocfg``,
            :class:`~acc_fusion.truth.sumo.config.SumoConfig`
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
    kinds += [
        f"{s}:{f.kind}"
        for s in ("radar", "infrared")
        for f in getattr(sim.world.sensors, f"{s}_faults")
    ]
    return "+".join(sorted(set(kinds))) or "none"


def _make_point(cfg: SweepConfig, params: dict, kinds: dict[str, str]) -> Point:

    sim, sumo, source = copy.deepcopy(cfg.base), copy.deepcopy(cfg.sumo), cfg.source
    for key, value in params.items():
        if key == "source":
            source = check_choice("axes 'source' value", value, SOURCES)
        elif key.startswith("sumo."):
            set_path(sumo, key[5:], value)
        else:
            set_path(sim, key, value)
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


def _sumo_config(sumo: dict, seed: int):

    fields = dict(sumo)
    net, sumocfg = fields.pop("net", None), fields.pop("sumocfg", None)
    if (net is None) == (sumocfg is None):
        raise ConfigError(
            "a SUMO point needs exactly one of sumo.net (a bundled network) and sumo.sumocfg "
            f"(a .sumocfg file), got net = {net!r}, sumocfg = {sumocfg!r}"
        )
    path = resolve_sumocfg(net, sumocfg)
    return from_mapping(SumoConfig, {**fields, "sumocfg": str(path), "seed": seed}, "sumo.")
