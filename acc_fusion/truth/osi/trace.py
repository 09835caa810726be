"""OSI trace files: writing an MCAP trace of any OSI messages atomically (:class:`TraceFile`)
and reading the GroundTruth of an MCAP or single-channel ``.osi`` trace
(:func:`read_ground_truth`), with ``asam-osi-utilities`` (its ``MultiTraceWriter``,
``MultiTraceReader`` and ``SingleTraceReader``; the trace formats of OSI 3.8).
"""

from __future__ import annotations

import os
from pathlib import Path

from acc_fusion.core.errors import InputError
from acc_fusion.core.outputs import temporary_beside
from acc_fusion.core.paths import existing_file
from acc_fusion.truth.osi.convention import osi, utilities

#: The message types a ground truth can be read from, by their ``MessageType`` value.
TRUTH_TYPES = ("GroundTruth", "SensorView")


def _version_text() -> str:
    v = osi().version
    return f"{v.version_major}.{v.version_minor}.{v.version_patch}"


class TraceFile:
    """An MCAP trace file being written: channels of OSI messages, written to a temporary name
    beside ``path`` and renamed onto it by :meth:`close` (so ``path`` is either absent, or the
    previous file, or the whole new trace; after an error nothing is left behind).  A context
    manager: leaving it normally closes, leaving it by an exception discards.

    Args:
        path: the trace, ending in ``.mcap``.
        description: the file's ``net.asam.osi.trace`` description.

    Attributes:
        topics: the channels added, topic → message class.

    Example::

        with TraceFile("run.mcap") as trace:
            trace.add_channel("ground_truth", GroundTruth)
            for message in messages:
                trace.write("ground_truth", message)
    """

    def __init__(self, path: str | Path, description: str = "acc_fusion") -> None:
        self.path = Path(path)
        if self.path.suffix.lower() != ".mcap":
            raise InputError(f"an OSI trace is written as .mcap, got {str(self.path)!r}")
        utils = utilities()
        from osi_utilities.tracefile.writers.multi import prepare_required_file_metadata

        fd, tmp = temporary_beside(self.path, suffix=".mcap")
        os.close(fd)
        self._tmp = Path(tmp)
        self._writer = utils.MultiTraceWriter()
        self.topics: dict[str, type] = {}
        version = _version_text()
        meta = {**prepare_required_file_metadata(), "min_osi_version": version,
                "max_osi_version": version, "description": description}  # fmt: skip
        self.written_messages = 0
        if not self._writer.open(self._tmp, meta):
            self._tmp.unlink(missing_ok=True)
            raise InputError(f"cannot write the OSI trace {str(self.path)!r}")

    def add_channel(self, topic: str, message_class: type, description: str = "") -> None:
        """A channel ``topic`` of ``message_class`` messages (an ``osi3`` class)."""
        import google.protobuf

        key = "net.asam.osi.trace.channel."
        meta = {f"{key}osi_version": _version_text(),
                f"{key}protobuf_version": google.protobuf.__version__}  # fmt: skip
        if description:
            meta[f"{key}description"] = description
        try:
            self._writer.add_channel(topic, message_class, meta)
        except RuntimeError as exc:
            raise InputError(f"cannot add channel {topic!r} to the trace: {exc}") from None
        self.topics[topic] = message_class

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """A file-level metadata record ``name`` of ``data`` (MCAP metadata)."""
        if not self._writer.add_file_metadata(name, data):
            raise InputError(f"cannot write metadata to the trace {str(self.path)!r}")

    def write(self, topic: str, message) -> None:
        """Write ``message`` to the channel ``topic`` (at its ``timestamp``)."""
        if topic not in self.topics:
            raise InputError(f"the trace has no channel {topic!r}; add it first (add_channel)")
        if not isinstance(message, self.topics[topic]):
            raise InputError(
                f"channel {topic!r} takes {self.topics[topic].__name__} messages, "
                f"got {type(message).__name__}"
            )
        if not self._writer.write_message(message, topic):
            raise InputError(f"cannot write a message to channel {topic!r} of {self.path}")
        self.written_messages += 1

    def close(self) -> Path:
        """Finish the file and move it onto ``path``."""
        self._writer.close()
        os.replace(self._tmp, self.path)
        return self.path

    def discard(self) -> None:
        """Drop what was written (``path`` untouched)."""
        self._writer.close()
        self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> TraceFile:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.discard()


def write_ground_truth_trace(path: str | Path, messages, topic: str = "ground_truth") -> Path:
    """Write ``messages`` (``osi3.GroundTruth``) as the channel ``topic`` of the MCAP trace
    ``path`` (atomically: :class:`TraceFile`)."""
    with TraceFile(path) as trace:
        trace.add_channel(topic, osi().GroundTruth, "ground truth, one message per step")
        for message in messages:
            trace.write(topic, message)
    return trace.path


def read_ground_truth(
    path: str | Path, *, topic: str | None = None, message_type: str | None = None
) -> list:
    """The ``osi3.GroundTruth`` messages of a trace: an MCAP file's channel ``topic`` of
    GroundTruth or SensorView messages (default: the first GroundTruth channel, else the first
    SensorView channel, whose ``global_ground_truth`` is read), or a single-channel ``.osi``
    file of GroundTruth or SensorView (``message_type``, default from the OSI file-name
    convention, e.g. ``..._gt_...osi``).  A SensorView's ``host_vehicle_id`` fills in its
    ground truth's where that has none.

    Raises:
        InputError: in one sentence: the file is missing, not an OSI trace, or has no
            GroundTruth or SensorView, or ``topic`` or ``message_type`` is not one of them.
    """
    p = existing_file(path, "OSI trace", InputError)
    suffix = p.suffix.lower()
    if suffix not in (".mcap", ".osi"):
        raise InputError(f"OSI trace {str(p)!r} must be a .mcap or .osi file")
    utils = utilities()
    if message_type is not None and message_type not in TRUTH_TYPES:
        raise InputError(f"message_type must be one of {TRUTH_TYPES}, got {message_type!r}")
    reader = utils.create_reader(p)
    if suffix == ".mcap":
        kind = _open_mcap(reader, p, topic)
    else:
        kind = message_type or utils.infer_message_type_from_filename(p.name).value
        if kind not in TRUTH_TYPES:
            raise InputError(
                f"cannot tell the message type of {str(p)!r}: name it by the OSI file-name "
                "convention (_gt_ or _sv_) or give message_type GroundTruth or SensorView"
            )
        reader.set_message_type(utils.MessageType(kind))
        if not reader.open(p):
            raise InputError(f"cannot open OSI trace {str(p)!r}")
    messages = []
    with reader:
        while (result := reader.read_message()) is not None:
            if result.status != utils.ReadStatus.OK:
                raise InputError(
                    f"{str(p)!r} is not a readable OSI {kind} trace at message "
                    f"{len(messages)}: {result.error_message}"
                )
            messages.append(_truth_of(result.message, kind))
    if not messages:
        raise InputError(f"OSI trace {str(p)!r} holds no {kind} message")
    return messages


def _open_mcap(reader, path: Path, topic: str | None) -> str:
    """Open ``reader`` on the MCAP ``path`` at the channel to read; its message type."""
    try:  # the mcap reader's parse errors are of several kinds (struct, McapError, ...)
        opened = reader.open(path)
    except Exception as exc:  # noqa: BLE001 - any of them means: not an MCAP file
        raise InputError(
            f"{str(path)!r} is not an MCAP file (an OSI multi-channel trace): {exc}"
        ) from None
    if not opened:
        raise InputError(f"{str(path)!r} is not an MCAP file (an OSI multi-channel trace)")
    kinds = {s.topic: s.message_type.value for s in reader.list_channel_specifications()}
    if topic is None:
        found = [t for k in TRUTH_TYPES for t, v in kinds.items() if v == k]
        if not found:
            reader.close()
            raise InputError(f"OSI trace {str(path)!r} has no GroundTruth or SensorView channel")
        topic = found[0]
    elif kinds.get(topic) not in TRUTH_TYPES:
        reader.close()
        have = ", ".join(f"{t} ({v})" for t, v in kinds.items()) or "none"
        raise InputError(
            f"channel {topic!r} of {str(path)!r} is not GroundTruth or SensorView; its OSI "
            f"channels: {have}"
        )
    reader.set_topics([topic])
    return kinds[topic]


def _truth_of(message, kind: str):
    """The GroundTruth of a GroundTruth or SensorView message."""
    if kind == "GroundTruth":
        return message
    gt = message.global_ground_truth
    if not gt.HasField("host_vehicle_id") and message.HasField("host_vehicle_id"):
        gt.host_vehicle_id.CopyFrom(message.host_vehicle_id)
    if not gt.HasField("timestamp") and message.HasField("timestamp"):
        gt.timestamp.CopyFrom(message.timestamp)
    return gt


def file_metadata(path: str | Path) -> dict[str, dict[str, str]]:
    """The file-level metadata records of the MCAP trace ``path`` by name (none for a
    single-channel ``.osi`` trace, which has no metadata)."""
    p = Path(path)
    if p.suffix.lower() != ".mcap":
        return {}
    reader = utilities().MultiTraceReader()
    if not reader.open(p):
        raise InputError(f"{str(p)!r} is not an MCAP file (an OSI multi-channel trace)")
    with reader:
        return {m["name"]: m["data"] for m in reader.get_file_metadata()}
