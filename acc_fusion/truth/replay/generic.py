r"""Any trajectory CSV, its columns named by a mapping (:class:`CsvMapping`, from a TOML or
YAML file): one row per vehicle per time step.

Positions are road coordinates: ``position`` runs along the lane in the driving direction
(arc length, so a curved road needs nothing more), ``lateral`` across it.  The reference point
of ``position`` is the front bumper, the centre or the rear (``position_ref``); the reader
moves it to the front bumper, :math:`s = x + \ell` (rear) or :math:`x + \ell / 2` (centre).
Without a ``lane`` column the lane is :math:`\lfloor y / w + 1/2 \rfloor` for lanes of width
:math:`w` centred on :math:`y = k\,w` (an assumption: set ``lane_width`` to the road's).
Without a ``leader`` column the leaders are recomputed from lanes and positions
(:mod:`acc_fusion.truth.replay.pairs`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from acc_fusion.core.config import from_mapping, load_mapping
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_choice, check_range
from acc_fusion.truth.replay import csvfile
from acc_fusion.truth.replay.ngsim import FOOT
from acc_fusion.truth.replay.recording import Recording
from acc_fusion.truth.replay.rows import Rows, whole

#: Units of a mapped file's lengths (speeds and accelerations follow): metres or feet.
UNITS = {"m": 1.0, "ft": FOOT}
#: Where on the vehicle ``position`` is measured, as a share of its length behind the front.
POSITION_REFS = {"front": 0.0, "centre": 0.5, "rear": 1.0}


@dataclass(frozen=True)
class CsvMapping:
    """The columns of a trajectory CSV file.

    Attributes:
        id: vehicle id (a whole number).
        time: time [s] (``t`` when neither ``time`` nor ``frame`` is given).
        frame: frame index (time = frame / ``frame_rate``), instead of ``time``.
        frame_rate: rows per second per vehicle [Hz] (default 10).
        position: position along the driving direction (arc length along the lane).
        position_ref: where on the vehicle ``position`` is: front, centre or rear.
        lateral: lateral position across the road (optional with ``lane``).
        lane: lane id (a whole number; optional with ``lateral``; ``lane`` when neither is
            given).
        lane_width: lane width [m] to find the lane from ``lateral`` (default 3.5).
        speed, accel: speed [m/s] and acceleration [m/s²] along the driving direction.
        length: vehicle length.
        leader: the leader's id, 0 or negative for none (optional: recomputed if absent).
        group: carriageway or road id, vehicles of different groups never lead each other
            (optional).
        units: lengths in ``m`` or ``ft`` (speeds per second, accelerations per second²).
    """

    id: str = "id"
    time: str | None = None
    frame: str | None = None
    frame_rate: float = 10.0
    position: str = "s"
    position_ref: str = "front"
    lateral: str | None = None
    lane: str | None = None
    lane_width: float = 3.5
    speed: str = "v"
    accel: str = "a"
    length: str = "length"
    leader: str | None = None
    group: str | None = None
    units: str = "m"

    def __post_init__(self) -> None:
        if self.time is not None and self.frame is not None:
            raise ConfigError("the CSV mapping takes a time or a frame column, not both")
        if self.frame is None and self.time is None:
            object.__setattr__(self, "time", "t")
        if self.lane is None and self.lateral is None:
            object.__setattr__(self, "lane", "lane")
        check_range("frame_rate", self.frame_rate, 0.0, 1e4, lo_open=True)
        check_range("lane_width", self.lane_width, 0.0, 100.0, lo_open=True)
        check_choice("position_ref", self.position_ref, tuple(POSITION_REFS))
        check_choice("units", self.units, tuple(UNITS))

    @classmethod
    def load(cls, path: str | Path | None) -> CsvMapping:
        """The mapping of a TOML/YAML file (its keys, or those of its ``columns`` table);
        the defaults without a file."""
        if path is None:
            return cls()
        data = load_mapping(path)
        return from_mapping(cls, data.get("columns", data), prefix="columns.")

    def numbers(self) -> dict[str, str]:
        """Our names of the numeric columns read, mapped to the mapping's column names."""
        names = {
            "id": self.id, "clock": self.time or self.frame, "position": self.position,
            "lateral": self.lateral, "lane": self.lane, "speed": self.speed,
            "accel": self.accel, "length": self.length, "leader": self.leader,
            "group": self.group,
        }  # fmt: skip
        return {k: v for k, v in names.items() if v is not None}


class CsvRecording(Recording):
    """The trajectory CSV ``path`` read through ``mapping``."""

    frame_columns = ("clock",)

    def __init__(self, path: str | Path, mapping: CsvMapping) -> None:
        self.path = csvfile.existing(path, "trajectory file")
        self.mapping = mapping
        self.sources = {"frame": mapping.time or mapping.frame, "vid": mapping.id,
                        "s": mapping.position, "speed": mapping.speed, "accel": mapping.accel,
                        "length": mapping.length}  # fmt: skip
        self.label = self.path.stem
        self.dt = 1.0 / mapping.frame_rate
        wanted = mapping.numbers()
        resolved = csvfile.resolve(self.path, tuple(wanted.values()))
        self.numbers = {ours: resolved[col] for ours, col in wanted.items()}

    def _frames(self, batch: dict[str, np.ndarray]) -> np.ndarray:
        clock = batch["clock"]
        if self.mapping.time is not None:
            clock = clock * self.mapping.frame_rate
        return whole(np.rint(clock))

    def _rows(self, b: dict[str, np.ndarray], frame: np.ndarray) -> Rows:
        m = self.mapping
        unit = UNITS[m.units]
        length = unit * b["length"]
        lateral = unit * b["lateral"] if "lateral" in b else np.full(frame.size, np.nan)
        if "lane" in b:
            lane = whole(b["lane"])
        else:
            lane = whole(np.floor(lateral / m.lane_width + 0.5))
        n = frame.size
        leader = None
        if "leader" in b:
            leader = whole(b["leader"])
            leader = np.where(leader > 0, leader, -1)
        return Rows(
            frame=frame,
            vid=whole(b["id"]),
            s=unit * b["position"] + POSITION_REFS[m.position_ref] * length,
            lat=lateral,
            lane=lane,
            group=whole(b["group"]) if "group" in b else np.zeros(n, np.int64),
            speed=unit * b["speed"],
            accel=unit * b["accel"],
            length=length,
            leader=leader,
        )
