r"""What the 2-D world's sensors and estimators made of one step, as ASAM OSI 3.8 messages, and
back: the sensor half of the OSI traces (:mod:`acc_fusion.sim.osi_trace`; the ground truth is
:mod:`acc_fusion.truth.osi`'s).

Per ego and step (field names are osi-python 3.8's; the mapping is tabulated in the OSI guide):

``sensor/radar`` — ``osi3.SensorData``
    ``feature_data.radar_sensor[0]``: one ``RadarDetection`` per detection, ``position`` the
    measured range and azimuth (``Spherical3d.distance``, ``.azimuth``; elevation 0: the radar
    measures none), ``position_rmse`` the declared standard deviations, ``radial_velocity``
    and its ``_rmse`` the range-rate.  ``object_id`` is the ground-truth object that caused
    the detection (this project's convention: no detected-object layer precedes detections
    here); a multipath ghost has none and ``classification`` ``INVALID``, clutter
    ``CLUTTER``, a detection of an object ``UNKNOWN`` (the radar does not classify).
    ``header.data_qualifier``: ``AVAILABLE`` when the sensor delivered a frame,
    ``NOT_AVAILABLE`` between its samples and in a dropout.
    ``moving_object``: the radar tracker's tracks as ``DetectedMovingObject`` — ``header``
    ``tracking_id``, ``ground_truth_id`` (the truth of the track's last detection),
    ``existence_probability`` 1 for a confirmed track and 0.5 for a tentative one
    (assumption: the tracker's M-of-N test gives no probability), ``age``; ``base``
    position and relative velocity in the ego frame, ``base_rmse`` the square roots of the
    covariance's diagonal (OSI 3.8 carries no full covariance).
``sensor/infrared`` — ``osi3.SensorData``
    the thermal camera's detections as ``logical_detection_data`` (``LogicalDetection``:
    ``object_id``, ``classification`` as the radar's, ``position`` the Cartesian point of the
    measured range and azimuth, ``velocity`` the measured range-rate along the line of sight,
    ``velocity_rmse`` its declared std along it), and, because OSI's camera detections carry
    no velocity, the same detections' range and azimuth exactly as
    ``feature_data.camera_sensor[0]`` ``CameraDetection``\ s with one ``CameraPoint`` each
    (``point``/``point_rmse`` as the radar's ``position``).  ``moving_object``: the camera
    tracker's tracks, as the radar's.
``estimate/<method>`` — ``osi3.SensorData``
    every associated object as ``DetectedMovingObject``: ``header.tracking_id`` the fused
    object's id, ``ground_truth_id`` its tracks' truth; ``base.position.x``,
    ``velocity.x``, ``acceleration.x`` the method's estimate of gap, range-rate and the
    lead's acceleration, ``position.y``/``velocity.y`` the fused lateral state, ``base_rmse``
    the square roots of the covariances' diagonals.
``host`` — ``osi3.HostVehicleData``
    the ego's own readings: ``vehicle_motion.velocity.x`` the wheel speed,
    ``acceleration.x`` the accelerometer, ``orientation_rate.yaw`` the gyro.

Decoding (:func:`decode_detections`, :func:`decode_host`) rebuilds what the trackers read —
range, azimuth and their stds exactly (IEEE doubles both ways), the camera's range-rate and its
std within a few ulps (a dot product with the line of sight) — so a trace replayed through the
same trackers, fusion and warning gives the same alerts (:mod:`acc_fusion.sim.osi_trace`).
"""

from __future__ import annotations

import math

import numpy as np

from acc_fusion.core.errors import InputError
from acc_fusion.fusion.base import Estimate
from acc_fusion.fusion.tracking.association import FusedObjects
from acc_fusion.fusion.tracking.tracker import Tracks
from acc_fusion.sensors.detections import CLUTTER, GHOST, Detections
from acc_fusion.truth.osi.convention import osi, set_timestamp

#: The topic of each channel of a trace (the ground truth's: :mod:`acc_fusion.truth.osi`).
HOST_TOPIC = "host"
SENSOR_TOPIC = "sensor/{}"
ESTIMATE_TOPIC = "estimate/{}"

#: ``existence_probability`` of a tentative track (assumption: see the module docstring).
TENTATIVE_EXISTENCE = 0.5


def _stamp(message, t: float) -> None:
    """``message``'s OSI version and timestamp (``t`` [s])."""
    message.version.CopyFrom(osi().version)
    set_timestamp(message.timestamp, t)


def _classification(origin: int) -> int:
    c = osi().Classification
    if origin == GHOST:
        return c.DETECTION_CLASSIFICATION_INVALID
    return c.DETECTION_CLASSIFICATION_CLUTTER if origin == CLUTTER else 0


def encode_sensor(
    det: Detections,
    tracks: Tracks,
    e: int,
    sensor_id: int,
    mounting: tuple[float, float, float],
):
    """One ego's ``osi3.SensorData`` of one sensor at one step: its detections and tracks
    (module docstring); ``mounting`` the sensor's position in the host's vehicle frame [m]."""
    o = osi()
    data = o.SensorData()
    _stamp(data, det.t)
    data.sensor_id.value = sensor_id
    data.mounting_position.position.x, data.mounting_position.position.y = mounting[:2]
    data.mounting_position.position.z = mounting[2]
    lo, hi = det.rows()[e : e + 2]
    k = np.arange(lo, hi)
    qualifier = o.Qualifier
    radar = det.sensor == "radar"
    if radar:
        block = data.feature_data.radar_sensor.add()
    else:
        block = data.feature_data.camera_sensor.add()
        logical = data.logical_detection_data
        logical.header.number_of_valid_logical_detections = int(k.size)
        logical.header.sensor_id.add().value = sensor_id
    header = block.header
    header.measurement_time.CopyFrom(data.timestamp)
    header.sensor_id.value = sensor_id
    header.number_of_valid_detections = int(k.size)
    header.mounting_position.CopyFrom(data.mounting_position)
    header.data_qualifier = (
        qualifier.DATA_QUALIFIER_AVAILABLE if det.online else qualifier.DATA_QUALIFIER_NOT_AVAILABLE
    )
    for i in k:
        r, az, rr = float(det.range[i]), float(det.azimuth[i]), float(det.range_rate[i])
        oid, cls = int(det.object_id[i]), _classification(int(det.origin[i]))
        if radar:
            d = block.detection.add()
            d.position.distance, d.position.azimuth = r, az
            d.position_rmse.distance = float(det.range_std[i])
            d.position_rmse.azimuth = float(det.azimuth_std[i])
            d.radial_velocity, d.radial_velocity_rmse = rr, float(det.range_rate_std[i])
        else:
            d = block.detection.add()
            d.first_point_index, d.number_of_points = len(block.point), 1
            point = block.point.add()
            point.point.distance, point.point.azimuth = r, az
            point.point_rmse.distance = float(det.range_std[i])
            point.point_rmse.azimuth = float(det.azimuth_std[i])
            ld = logical.logical_detection.add()
            c, s = math.cos(az), math.sin(az)
            ld.position.x, ld.position.y = r * c, r * s
            ld.velocity.x, ld.velocity.y = rr * c, rr * s
            std = float(det.range_rate_std[i])
            ld.velocity_rmse.x, ld.velocity_rmse.y = std * abs(c), std * abs(s)
            ld.classification = cls
            ld.sensor_id.add().value = sensor_id
            if oid >= 0:
                ld.object_id.value = oid
        d.existence_probability = 1.0
        if oid >= 0:
            d.object_id.value = oid
        if radar:
            d.classification = cls
    _tracks(data, tracks, e, sensor_id)
    return data


def _tracks(data, tracks: Tracks, e: int, sensor_id: int) -> None:
    for j in np.flatnonzero(tracks.valid[e]):
        m = data.moving_object.add()
        m.header.tracking_id.value = int(tracks.track_id[e, j])
        if tracks.object_id[e, j] >= 0:
            m.header.ground_truth_id.add().value = int(tracks.object_id[e, j])
        m.header.existence_probability = 1.0 if tracks.confirmed[e, j] else TENTATIVE_EXISTENCE
        m.header.age = float(tracks.age[e, j])
        m.header.sensor_id.add().value = sensor_id
        x, vx, y, vy = (float(v) for v in tracks.state[e, j])
        sd = np.sqrt(np.maximum(np.diagonal(tracks.cov[e, j]), 0.0))
        m.base.position.x, m.base.position.y, m.base.velocity.x, m.base.velocity.y = x, y, vx, vy
        m.base_rmse.position.x, m.base_rmse.velocity.x = float(sd[0]), float(sd[1])
        m.base_rmse.position.y, m.base_rmse.velocity.y = float(sd[2]), float(sd[3])


def encode_estimates(
    estimate: Estimate,
    fused: FusedObjects,
    tracks: tuple[Tracks, Tracks],
    e: int,
    t: float,
):
    """One ego's ``osi3.SensorData`` of one method at one step: its estimate of every
    associated object (``estimate`` laid out over the E·F object slots; module docstring)."""
    data = osi().SensorData()
    _stamp(data, t)
    f_slots = fused.valid.shape[1]
    for f in np.flatnonzero(fused.valid[e]):
        i = e * f_slots + f
        if not estimate.valid[i]:
            continue
        m = data.moving_object.add()
        m.header.tracking_id.value = int(fused.object_id[e, f])
        for s, tr in enumerate(tracks):
            j = fused.track[e, f, s]
            if j >= 0 and tr.object_id[e, j] >= 0:
                m.header.ground_truth_id.add().value = int(tr.object_id[e, j])
        m.header.existence_probability = 1.0
        gap, rate, accel = (float(v) for v in estimate.x[i])
        sd = np.sqrt(np.maximum(np.diagonal(estimate.p[i]), 0.0))
        lat_sd = np.sqrt(np.maximum(np.diagonal(fused.lateral_cov[e, f]), 0.0))
        m.base.position.x, m.base.velocity.x, m.base.acceleration.x = gap, rate, accel
        m.base.position.y, m.base.velocity.y = (float(v) for v in fused.lateral[e, f])
        m.base_rmse.position.x, m.base_rmse.velocity.x = float(sd[0]), float(sd[1])
        m.base_rmse.acceleration.x = float(sd[2])
        m.base_rmse.position.y, m.base_rmse.velocity.y = float(lat_sd[0]), float(lat_sd[1])
    return data


def encode_host(t: float, host_id: int, accel: float, wheel: float, yaw_rate: float):
    """The ego's own readings at one step as ``osi3.HostVehicleData`` (module docstring)."""
    data = osi().HostVehicleData()
    _stamp(data, t)
    data.host_vehicle_id.value = host_id
    motion = data.vehicle_motion
    motion.velocity.x, motion.acceleration.x = float(wheel), float(accel)
    motion.orientation_rate.yaw = float(yaw_rate)
    return data


def decode_host(data) -> tuple[float, float, float]:
    """``(accel, wheel, yaw_rate)`` of a ``HostVehicleData`` written by :func:`encode_host`."""
    motion = data.vehicle_motion
    return motion.acceleration.x, motion.velocity.x, motion.orientation_rate.yaw


def decode_detections(
    data,
    sensor: str,
    t: float,
    kind_of: dict[int, int],
    growth: tuple[float, float],
) -> Detections:
    """The :class:`Detections` of one ego (``n_egos`` 1) in a ``SensorData`` written by
    :func:`encode_sensor` for ``sensor``; ``kind_of`` maps the ground truth's object ids to
    their :class:`~acc_fusion.truth.objects.ObjectKind` (a detection's ``origin``),
    ``growth`` is the sensor's noise growth (:attr:`Detections.range_std_growth`)."""
    radar = sensor == "radar"
    blocks = data.feature_data.radar_sensor if radar else data.feature_data.camera_sensor
    if len(blocks) != 1:
        raise InputError(
            f"the {sensor} SensorData at t = {t:.3f} s holds {len(blocks)} detection blocks, "
            "not one"
        )
    block = blocks[0]
    o = osi()
    online = block.header.data_qualifier == o.Qualifier.DATA_QUALIFIER_AVAILABLE
    logical = None if radar else data.logical_detection_data.logical_detection
    c = o.Classification
    rows = []
    for i, d in enumerate(block.detection):
        if radar:
            pos, rmse, cls = d.position, d.position_rmse, d.classification
            rr, rr_std = d.radial_velocity, d.radial_velocity_rmse
        else:
            point, ld = block.point[d.first_point_index], logical[i]
            pos, rmse, cls = point.point, point.point_rmse, ld.classification
            cos, sin = math.cos(pos.azimuth), math.sin(pos.azimuth)
            rr = ld.velocity.x * cos + ld.velocity.y * sin
            rr_std = math.hypot(ld.velocity_rmse.x, ld.velocity_rmse.y)
        oid = d.object_id.value if d.HasField("object_id") else -1
        if cls == c.DETECTION_CLASSIFICATION_INVALID:
            origin = GHOST
        elif cls == c.DETECTION_CLASSIFICATION_CLUTTER:
            origin = CLUTTER
        elif oid in kind_of:
            origin = kind_of[oid]
        else:
            raise InputError(
                f"the {sensor} detection {i} at t = {t:.3f} s names object {oid}, which is not "
                "in the ground truth"
            )
        rows.append((pos.distance, pos.azimuth, rr, rmse.distance, rmse.azimuth, rr_std,
                     oid, origin))  # fmt: skip
    cols = list(zip(*rows, strict=True)) if rows else [()] * 8
    floats = [np.asarray(col, dtype=float) for col in cols[:6]]
    return Detections(
        t, sensor, 1, online, np.zeros(len(rows), np.int64), *floats,
        np.asarray(cols[6], np.int64), np.asarray(cols[7], np.int8), *growth,
    )  # fmt: skip
