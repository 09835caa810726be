r"""What the OSI encoder and reader agree on (ASAM OSI 3.8, ``osi-python``'s ``osi3``).

Frames
    OSI's global frame is ISO 8855 (x, y horizontal, z up, yaw counter-clockwise from x); an
    object's ``base.position`` is its *bounding-box centre* and ``base.orientation.yaw`` its
    heading (``osi3.BaseMoving``/``osi3.BaseStationary``, OSI 3.8).  The project's ego frame
    (:mod:`acc_fusion.truth.objects`) has its origin at the ego's front-bumper centre and gives
    an object's *nearest face*.  The two faces of a box of length :math:`\ell`, centre
    :math:`c` and heading unit vector :math:`u` (both in the ego frame) are
    :math:`c \mp (\ell/2) u`; the nearer to the origin is the rear face when :math:`c\cdot u
    \ge 0`, else the front face (the rule of :mod:`acc_fusion.truth.sumo.object_kernels`: the
    face of smaller distance, ties to the rear).  :func:`face_to_centre` inverts it
    consistently: a face :math:`q` with :math:`q\cdot u \ge 0` is taken for the rear face,
    :math:`c = q + (\ell/2)u`, else the front face, so :func:`centre_to_face` gives :math:`q`
    back.

Ids (``osi3.Identifier``, uint64)
    Objects keep their :attr:`~acc_fusion.truth.objects.ObjectFrame.object_id`.  The host of
    ego ``e`` is :data:`HOST_ID_BASE` ``+ e`` unless the source names it (above the scenes'
    actor ids, SUMO's vehicle ids and its roadside ids from :math:`2^{40}`); the lane ``k``
    lanes left of the host's (``k < 0``: right) is :func:`lane_id`
    :math:`= 2^{56} + 2^{20} + k`.

This project's extension
    Radar cross-section, thermal contrast and a few facts OSI's ground truth has no field for
    travel in each object's ``source_reference`` (``osi3.ExternalReference``) of ``type``
    :data:`EXTENSION_TYPE`, one identifier ``name=value`` each (floats as Python's ``repr``,
    exact): ``rcs`` [dBsm], ``thermal_contrast`` [K], ``lateral_speed`` [m/s], ``kind`` (an
    :class:`~acc_fusion.truth.objects.ObjectKind` name), ``index`` (the object's place in its
    ego's row) and ``lead`` (``1`` on the true in-path lead); on the host, ``ego_shift`` [m]
    where it is not 0 (:attr:`~acc_fusion.truth.objects.ObjectFrame.ego_shift`).
"""

from __future__ import annotations

import functools
import math
from types import SimpleNamespace

import numpy as np

from acc_fusion.core.errors import InputError
from acc_fusion.truth.objects import ObjectKind
from acc_fusion.truth.scenes import SIGNATURES

#: How to install what this package needs.
INSTALL = "pip install 'acc_fusion[interop]'"
#: ``osi3.ExternalReference.type`` of this project's extension (module docstring).
EXTENSION_TYPE = "urn:acc_fusion:osi:object-extension:1"
#: Id of the host of ego 0 when the source does not name it (module docstring).
HOST_ID_BASE = 1 << 48
#: Lane ids: :func:`lane_id`.
LANE_ID_BASE, LANE_ID_CENTRE = 1 << 56, 1 << 20
#: The MCAP metadata record of this project in a trace, and its ``first_step`` values: the
#: host's first message is a new vehicle in its source's slot (SUMO, highway-env: the
#: pipeline starts its ego afresh there) or the start of a run (the scripted scenes).
METADATA, NEW_VEHICLE, RUN_START = "acc_fusion", "new_vehicle", "run_start"
#: Default host size (length, width, height) [m]: the scenes' vehicle
#: (:data:`~acc_fusion.truth.scenes.SIGNATURES`, a mid-size car; assumption where the source
#: does not know its egos' size).
HOST_SIZE = SIGNATURES[ObjectKind.VEHICLE][:3]
#: Reach [m] and vertex spacing [m] of the lane centre lines written (a long-range radar's
#: 200 m, the SUMO field's ``ahead``).
CENTRELINE_RANGE, CENTRELINE_STEP = 200.0, 20.0

#: ``osi3.StationaryObject.Classification.Type`` of each stationary kind: a gantry is an
#: overhead structure, a guardrail post a barrier, a sign post a pole, and a steel plate flat on
#: the road a speed bump (OSI 3.8's one type of object lying on the lane surface that vehicles
#: drive over).  A parked car stays a ``MovingObject`` of type vehicle (OSI: vehicles are
#: moving objects whether they move or not), told apart by the extension's ``kind``.
STATIONARY_TYPE = {
    ObjectKind.GANTRY: "TYPE_OVERHEAD_STRUCTURE",
    ObjectKind.BRIDGE: "TYPE_BRIDGE",
    ObjectKind.GUARDRAIL: "TYPE_BARRIER",
    ObjectKind.SIGN: "TYPE_POLE",
    ObjectKind.PLATE: "TYPE_SPEED_BUMP",
}
#: ``osi3.StationaryObject.Classification.Material`` of each stationary kind (assumption).
MATERIAL = {ObjectKind.BRIDGE: "MATERIAL_CONCRETE"}
#: The kind of a foreign stationary object by its OSI type: the types above, overhead and
#: vertical things, and everything else as roadside (a guardrail's kind).
KIND_OF_STATIONARY = {
    **{name: kind for kind, name in STATIONARY_TYPE.items()},
    "TYPE_PYLON": ObjectKind.SIGN,
    "TYPE_VERTICAL_STRUCTURE": ObjectKind.SIGN,
    "TYPE_TREE": ObjectKind.SIGN,
    "TYPE_EMITTING_STRUCTURE": ObjectKind.GANTRY,
}
#: SUMO vehicle class (:data:`~acc_fusion.truth.sumo.objects.VCLASS_SIGNATURE`) of an OSI
#: vehicle classification type, for the signature of a vehicle without the extension (types
#: not listed: ``passenger``).
VCLASS_OF_OSI = {
    "TYPE_DELIVERY_VAN": "delivery",
    "TYPE_VAN": "delivery",
    "TYPE_HEAVY_TRUCK": "truck",
    "TYPE_SEMITRACTOR": "truck",
    "TYPE_SEMITRAILER": "trailer",
    "TYPE_TRAILER": "trailer",
    "TYPE_BUS": "bus",
    "TYPE_MOTORBIKE": "motorcycle",
    "TYPE_MOTORCYCLE": "motorcycle",
    "TYPE_BICYCLE": "bicycle",
    "TYPE_STANDUP_SCOOTER": "moped",
    "TYPE_MICROMOBILITY_DEVICE": "moped",
}


@functools.cache
def osi() -> SimpleNamespace:
    """The ``osi3`` modules and messages used here and by the sensor side
    (:mod:`acc_fusion.sim.osi_codec`), imported on first use.

    Raises:
        InputError: ``osi-python`` is not installed.
    """
    try:
        from osi3 import (
            osi_common_pb2,
            osi_featuredata_pb2,
            osi_groundtruth_pb2,
            osi_hostvehicledata_pb2,
            osi_lane_pb2,
            osi_object_pb2,
            osi_sensordata_pb2,
            osi_sensorview_pb2,
            osi_version_pb2,
        )
    except ImportError as exc:
        raise InputError(f"ASAM OSI support needs osi-python: {INSTALL} ({exc})") from None
    version = osi_version_pb2.DESCRIPTOR.GetOptions().Extensions[
        osi_version_pb2.current_interface_version
    ]
    return SimpleNamespace(
        common=osi_common_pb2,
        GroundTruth=osi_groundtruth_pb2.GroundTruth,
        Lane=osi_lane_pb2.Lane,
        MovingObject=osi_object_pb2.MovingObject,
        StationaryObject=osi_object_pb2.StationaryObject,
        SensorView=osi_sensorview_pb2.SensorView,
        SensorData=osi_sensordata_pb2.SensorData,
        HostVehicleData=osi_hostvehicledata_pb2.HostVehicleData,
        Classification=osi_featuredata_pb2.DetectionClassification,
        Qualifier=osi_featuredata_pb2.SensorDetectionHeader,
        version=version,
    )


def utilities():
    """The ``osi_utilities`` module (imported on first use).

    Raises:
        InputError: ``asam-osi-utilities`` is not installed.
    """
    try:
        import osi_utilities
    except ImportError as exc:
        raise InputError(f"OSI trace files need asam-osi-utilities: {INSTALL} ({exc})") from None
    return osi_utilities


def lane_id(k: int) -> int:
    """The OSI lane id of the lane ``k`` lanes left of the host's (module docstring)."""
    return LANE_ID_BASE + LANE_ID_CENTRE + int(k)


def wrap(angle):
    """``angle`` [rad] wrapped into :math:`[-\\pi, \\pi)`."""
    return (np.asarray(angle) + math.pi) % (2 * math.pi) - math.pi


def face_to_centre(x, y, heading, length):
    """The bounding-box centre of boxes whose nearest face's centre is ``(x, y)`` (module
    docstring; arrays in one frame, ``heading`` in it)."""
    ux, uy = np.cos(heading), np.sin(heading)
    half = np.where(x * ux + y * uy >= 0.0, 0.5, -0.5) * length
    return x + half * ux, y + half * uy


def centre_to_face(x, y, heading, length):
    """The centre of the face nearer the origin of boxes of centre ``(x, y)`` (module
    docstring)."""
    ux, uy = np.cos(heading), np.sin(heading)
    half = np.where(x * ux + y * uy >= 0.0, -0.5, 0.5) * length
    return x + half * ux, y + half * uy


def set_timestamp(timestamp, t: float) -> None:
    """Write ``t`` [s] into an ``osi3.Timestamp`` (seconds, nanos), rounded to the ns."""
    ns = round(t * 1e9)
    timestamp.seconds, timestamp.nanos = divmod(ns, 1_000_000_000)


def seconds(timestamp) -> float:
    """An ``osi3.Timestamp`` in seconds."""
    return timestamp.seconds + timestamp.nanos * 1e-9


def extension_identifiers(values: dict[str, object]) -> list[str]:
    """The extension's identifiers ``name=value`` (floats as ``repr``, exact)."""
    return [f"{name}={value!r}" if isinstance(value, float) else f"{name}={value}"
            for name, value in values.items()]  # fmt: skip


def read_extension(references) -> dict[str, str] | None:
    """The extension's ``name: value`` from an object's ``source_reference`` (repeated
    ``osi3.ExternalReference``), ``None`` without it."""
    for ref in references:
        if ref.type == EXTENSION_TYPE:
            return dict(item.split("=", 1) for item in ref.identifier if "=" in item)
    return None
