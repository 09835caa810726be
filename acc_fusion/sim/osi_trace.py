"""OSI traces of the 2-D world, out and back in.

Out: :class:`OsiRecorder`, an ``on_step`` hook of :func:`~acc_fusion.sim.world.simulate_world`,
writes one trace per ego vehicle — an MCAP file (``asam-osi-utilities``) whose channels are the
ground truth the sensors saw (``ground_truth``, :mod:`acc_fusion.truth.osi`), the ego's own
readings (``host``), each sensor's detections and tracks (``sensor/radar``,
``sensor/infrared``) and every method's estimates of the associated objects
(``estimate/<method>``), :mod:`acc_fusion.sim.osi_codec`.

In: :class:`RecordedPerception` is the 2-D world's perception with the sensors' detections and
the ego's readings read from such a trace instead of drawn; trackers, association, estimators,
selection, warning and the truth's judgement run as in the recorded run, so a trace of ours
replayed (:func:`replay_trace`) gives that ego's alerts again — the draws of a run are shared
by all its egos, so re-drawing one ego's sensors alone could not.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.sensors.detections import Detections
from acc_fusion.sensors.suite import SENSOR_NAMES
from acc_fusion.sensors.suite2d import sensors_2d
from acc_fusion.sim.closed_loop import SimConfig, SimResult, StepView
from acc_fusion.sim.osi_codec import (
    ESTIMATE_TOPIC,
    HOST_TOPIC,
    SENSOR_TOPIC,
    decode_detections,
    decode_host,
    encode_estimates,
    encode_host,
    encode_sensor,
)
from acc_fusion.sim.world import WorldPerception, simulate_world
from acc_fusion.truth.frame import TruthFrame
from acc_fusion.truth.objects import ObjectFrame
from acc_fusion.truth.osi.convention import (
    HOST_SIZE,
    METADATA,
    NEW_VEHICLE,
    RUN_START,
    osi,
    utilities,
)
from acc_fusion.truth.osi.ground_truth import GroundTruthEncoder
from acc_fusion.truth.osi.source import OsiTruth
from acc_fusion.truth.osi.trace import TraceFile

#: The sensors' ids in the traces (``SensorData.sensor_id``), in ``SENSOR_NAMES`` order.
SENSOR_IDS = {name: i + 1 for i, name in enumerate(SENSOR_NAMES)}
#: The fewest steps a trace keeps (a reader takes the step from the timestamps).
MIN_STEPS = 2
#: The ground truth's topic.
GROUND_TRUTH_TOPIC = "ground_truth"
#: The front bumper's centre in the host's vehicle frame [m], x forward: the sensors' mounting
#: point.  The host has no rear axle here, so the vehicle frame's origin is its bounding-box
#: centre (OSI's is the rear axle's centre; ``vehicle_attributes.bbcenter_to_rear`` unset).
HOST_FRONT = HOST_SIZE[0] / 2


def topics(path: str | Path) -> list[str]:
    """The channels (topics) of the MCAP trace ``path``."""
    reader = utilities().MultiTraceReader()
    if not reader.open(Path(path)):
        raise InputError(f"{str(path)!r} is not an MCAP file (an OSI multi-channel trace)")
    with reader:
        return reader.get_available_topics()


def read_channels(path: str | Path, wanted: Sequence[str]) -> dict[str, list]:
    """The messages of the channels ``wanted`` of the MCAP trace ``path``, by topic.

    Raises:
        InputError: the file is not an MCAP trace or lacks one of the channels.
    """
    utils = utilities()
    missing = sorted(set(wanted) - set(topics(path)))
    if missing:
        raise InputError(f"the OSI trace {str(path)!r} has no channel {missing[0]!r}")
    reader = utils.MultiTraceReader()
    reader.open(Path(path))
    reader.set_topics(list(wanted))
    out: dict[str, list] = {t: [] for t in wanted}
    with reader:
        while (result := reader.read_message()) is not None:
            if result.status != utils.ReadStatus.OK:
                raise InputError(f"{str(path)!r}: unreadable OSI message: {result.error_message}")
            out[result.channel_name].append(result.message)
    return out


def ego_row(frame: ObjectFrame, e: int) -> ObjectFrame:
    """The frame of ego ``e`` alone (views of ``frame``'s arrays)."""
    return frame.egos(e, e + 1)


class OsiRecorder:
    """Writes one OSI trace per ego vehicle into ``folder`` (module docstring), named
    ``<prefix><vehicle>.mcap``: the vehicle is the source's id of the slot's vehicle
    (``vehicle_ids``, e.g. SUMO's; a slot without one holds none) or ``run<NNN>``, the run of
    a scripted scene.  A slot that takes another vehicle starts another trace; ``limit``
    records only the first that many vehicles to appear (a trace costs about 4 MB per minute
    of a vehicle in motorway traffic: some 20 objects ahead, lanes, four estimators).  Call
    :meth:`close` (or use it as a context manager) when the run ends: each trace is written
    to a temporary name and appears whole."""

    def __init__(
        self,
        folder: str | Path,
        config: SimConfig,
        prefix: str = "",
        vehicle_ids: Callable[[], Sequence[str]] | None = None,
        limit: int | None = None,
    ) -> None:
        self.folder, self.prefix, self.config = Path(folder), prefix, config
        self.folder.mkdir(parents=True, exist_ok=True)
        self._vehicle_ids, self._limit, self._seen = vehicle_ids, limit, set()
        self._open: dict[int, tuple[str, TraceFile, GroundTruthEncoder]] = {}
        self.written: list[Path] = []
        radar, camera = (s.spec for s in sensors_2d(config.world.sensors, 0))
        self._mounting = {  # both at the front bumper's centre (the ego frame's origin)
            radar.name: (HOST_FRONT, 0.0, radar.mount_height),
            camera.name: (HOST_FRONT, 0.0, camera.camera_height),
        }

    def _names(self, n: int) -> list[str]:
        """The vehicle of each of the first ``n`` slots recorded now ("": none)."""
        if self._vehicle_ids is None:
            names = [f"run{e:03d}" for e in range(n)]
        else:
            ids = list(self._vehicle_ids())[:n]
            names = [str(v) if v else "" for v in ids] + [""] * (n - len(ids))
        for i, name in enumerate(names):
            if name and name not in self._seen:
                if self._limit is not None and len(self._seen) >= self._limit:
                    names[i] = ""
                else:
                    self._seen.add(name)
        return names

    def _trace(self, e: int, name: str, new: bool) -> tuple[TraceFile, GroundTruthEncoder]:
        """The trace of slot ``e``'s vehicle ``name``, opened if need be (``new``: the vehicle
        took the slot at this step, which its metadata tells a replay)."""
        held = self._open.get(e)
        if held is not None and held[0] == name:
            return held[1], held[2]
        if held is not None:
            self._finish(e)
        o = osi()
        path = self.folder / re.sub(r"[^A-Za-z0-9_.-]+", "-", f"{self.prefix}{name}.mcap")
        trace = TraceFile(path)
        trace.add_metadata(METADATA, {"first_step": NEW_VEHICLE if new else RUN_START})
        trace.add_channel(GROUND_TRUTH_TOPIC, o.GroundTruth, "the ground truth")
        trace.add_channel(HOST_TOPIC, o.HostVehicleData, "the ego's own readings")
        for s in SENSOR_NAMES:
            trace.add_channel(SENSOR_TOPIC.format(s), o.SensorData, f"{s} detections, tracks")
        for m in self.config.methods:
            trace.add_channel(ESTIMATE_TOPIC.format(m), o.SensorData, f"{m} estimates")
        encoder = GroundTruthEncoder(1)
        self._open[e] = (name, trace, encoder)
        return trace, encoder

    def _finish(self, e: int) -> None:
        """Close the trace of slot ``e``; one of a single step (a vehicle that left as it came,
        with no step to move over) is dropped."""
        _, trace, _ = self._open.pop(e)
        if trace.written_messages < MIN_STEPS * len(trace.topics):
            trace.discard()
        else:
            trace.close()
            self.written.append(trace.path)

    def __call__(self, view: StepView) -> None:
        sensed = getattr(view.perceived, "sensed", None)
        if sensed is None:
            raise ConfigError("an OSI trace records the 2-D world: run it with the world on")
        frame = sensed.objects
        names = self._names(frame.n_egos)
        for e in [e for e in self._open if e >= frame.n_egos or not names[e]]:
            self._finish(e)
        tracks = tuple(sensed.tracks)
        per_object = {m: sensed.per_object(est) for m, est in sensed.estimates.items()}
        for e, name in enumerate(names):
            if not name:
                continue
            new = sensed.reassigned is not None and bool(sensed.reassigned[e])
            trace, encoder = self._trace(e, name, new)
            (truth,) = encoder.encode(ego_row(frame, e), np.zeros(1, np.int64))
            trace.write(GROUND_TRUTH_TOPIC, truth)
            host = truth.host_vehicle_id.value
            trace.write(HOST_TOPIC, encode_host(frame.t, host, sensed.accel[e], sensed.wheel[e],
                                                sensed.yaw_rate[e]))  # fmt: skip
            for det, tr in zip(sensed.detections, tracks, strict=True):
                data = encode_sensor(det, tr, e, SENSOR_IDS[det.sensor], self._mounting[det.sensor])
                trace.write(SENSOR_TOPIC.format(det.sensor), data)
            for m, est in per_object.items():
                data = encode_estimates(est, sensed.fused, tracks, e, frame.t)
                trace.write(ESTIMATE_TOPIC.format(m), data)

    def close(self) -> list[Path]:
        """Close every open trace; the paths of all the traces written."""
        for e in list(self._open):
            self._finish(e)
        return self.written

    def __enter__(self) -> OsiRecorder:
        return self

    def __exit__(self, *exc) -> None:
        if exc[0] is None:
            self.close()
        else:  # nothing half-written: the open traces are dropped
            for _, trace, _ in self._open.values():
                trace.discard()
            self._open.clear()


@dataclass(frozen=True)
class OsiOutput:
    """Where a run writes its OSI traces: ``folder``, and at most ``limit`` vehicles (the
    first to appear; ``None``: all)."""

    folder: Path
    limit: int | None = None

    def recorder(
        self,
        config: SimConfig,
        prefix: str = "",
        vehicle_ids: Callable[[], Sequence[str]] | None = None,
    ) -> OsiRecorder:
        """The :class:`OsiRecorder` of a run of ``config`` (its traces named ``prefix`` +
        vehicle)."""
        return OsiRecorder(self.folder, config, prefix, vehicle_ids, self.limit)


def traced_world(
    config: SimConfig,
    source=None,
    osi: OsiOutput | None = None,
    prefix: str = "",
    vehicle_ids: Callable[[], Sequence[str]] | None = None,
) -> tuple[SimResult, list[Path]]:
    """:func:`~acc_fusion.sim.world.simulate_world` on ``source`` (``None``: ``config``'s
    scene), with ``osi`` an OSI trace of its egos written (named ``prefix`` + vehicle): the
    result and the traces written."""
    if osi is None:
        return simulate_world(config, source=source), []
    with osi.recorder(config, prefix, vehicle_ids) as recorder:
        result = simulate_world(config, source=source, on_step=recorder)
    return result, recorder.written


class RecordedSensors:
    """The ego's readings and each sensor's detections of a trace written by
    :class:`OsiRecorder`, step by step (its channels hold one message each per step).

    Raises:
        InputError: the trace lacks a channel, or its channels disagree on the steps.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.topics = [HOST_TOPIC, *(SENSOR_TOPIC.format(s) for s in SENSOR_NAMES)]
        channels = read_channels(path, self.topics)
        stamps = {
            topic: [(m.timestamp.seconds, m.timestamp.nanos) for m in received]
            for topic, received in channels.items()
        }
        first = stamps[HOST_TOPIC]
        for topic, own in stamps.items():
            if own != first:
                raise InputError(
                    f"{str(self.path)!r}: the channel {topic!r} has other steps than "
                    f"{HOST_TOPIC!r}, so its detections cannot be replayed"
                )
        self.steps = [dict(zip(self.topics, step, strict=True))
                      for step in zip(*channels.values(), strict=True)]  # fmt: skip


def _merged(parts: list[tuple[int, Detections]], n: int, sensor: str, t: float,
            online: bool, growth: tuple[float, float]) -> Detections:  # fmt: skip
    """One sensor's detections of ``n`` egos from each ego's own (``parts``: ego, detections
    of that ego alone), sorted by ego as :class:`Detections` wants."""
    ego = np.concatenate([np.full(d.count, e, np.int64) for e, d in parts] or [np.zeros(0, int)])

    def joined(name: str, dtype) -> np.ndarray:
        return np.concatenate([getattr(d, name) for _, d in parts] or [np.zeros(0, dtype)])

    floats = [joined(name, float) for name in ("range", "azimuth", "range_rate", "range_std",
                                               "azimuth_std", "range_rate_std")]  # fmt: skip
    return Detections(t, sensor, n, online, ego, *floats, joined("object_id", np.int64),
                      joined("origin", np.int8), *growth)  # fmt: skip


class RecordedPerception(WorldPerception):
    """The 2-D world's perception of egos whose readings and detections are their traces'
    (:class:`RecordedSensors`, ego ``e`` the ``e``-th) rather than drawn: everything
    downstream is the same code.  Step ``k`` of the run takes each trace's ``k``-th step; an
    ego whose trace has ended reads nothing (and its source has it inactive)."""

    recorded: list[RecordedSensors]

    def _sense(self, frame: ObjectFrame, lead: TruthFrame):
        k, n = getattr(self, "_k", 0), frame.n_egos
        self._k = k + 1
        accel, wheel, yaw = np.zeros(n), np.zeros(n), np.zeros(n)
        parts: dict[str, list] = {s.spec.name: [] for s in self.sensors}
        online = dict.fromkeys(parts, False)
        for e, rec in enumerate(self.recorded[:n]):
            if k >= len(rec.steps):
                continue
            step = rec.steps[k]
            accel[e], wheel[e], yaw[e] = decode_host(step[HOST_TOPIC])
            row = frame.valid[e]
            kind_of = dict(zip(frame.object_id[e][row].tolist(), frame.kind[e][row].tolist(),
                               strict=True))  # fmt: skip
            for s in self.sensors:
                name = s.spec.name
                det = decode_detections(step[SENSOR_TOPIC.format(name)], name, frame.t,
                                        kind_of, s.spec.noise_growth())  # fmt: skip
                parts[name].append((e, det))
                online[name] |= det.online
        detections = [
            _merged(
                parts[s.spec.name],
                n,
                s.spec.name,
                frame.t,
                online[s.spec.name],
                s.spec.noise_growth(),
            )  # fmt: skip
            for s in self.sensors
        ]
        return accel, wheel, yaw, detections


def has_sensors(path: str | Path) -> bool:
    """The trace carries this project's sensor channels (an MCAP trace of
    :class:`OsiRecorder`)."""
    if Path(path).suffix.lower() != ".mcap":
        return False
    return {HOST_TOPIC, *(SENSOR_TOPIC.format(s) for s in SENSOR_NAMES)} <= set(topics(path))


def recorded_perception(paths: Sequence[str | Path]):
    """The ``perception`` of :func:`~acc_fusion.sim.world.simulate_world` that reads the
    traces ``paths`` (one ego each, in order; written by :class:`OsiRecorder`) rather than
    drawing sensors: the run's config must be the recorded run's."""
    recorded = [RecordedSensors(p) for p in paths]

    def perception(cfg: SimConfig, n: int, seed: np.random.SeedSequence) -> RecordedPerception:
        if n != len(recorded):
            raise InputError(f"{len(recorded)} recorded traces for a source of {n} egos")
        made = RecordedPerception(cfg, n, seed)
        made.recorded = recorded
        return made

    return perception


def replay_trace(
    config: SimConfig, path: str | Path, *, on_step=None, progress: bool = False
) -> SimResult:
    """The 2-D world on one trace of :class:`OsiRecorder` (its ground truth the truth, its
    detections and readings the sensors'), with ``config`` the recorded run's."""
    return simulate_world(config, source=OsiTruth(path), perception=recorded_perception([path]),
                          on_step=on_step, progress=progress)  # fmt: skip
