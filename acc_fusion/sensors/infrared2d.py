r"""A far-infrared (LWIR thermal) camera with a vehicle detector over the 2-D world.

Model, per frame (every ``1 / rate_hz`` s from ``phase``; an empty ``online=False``
:class:`~acc_fusion.sensors.detections.Detections` between frames), for a pinhole camera of
focal length :math:`f = (w_{\mathrm{px}}/2) / \tan(\mathrm{HFOV}/2)` pixels (686 px for 640 px
over 50°) at height :math:`H` with a horizontal optical axis, on a flat road:

Geometry and ranging
    An object ahead (:math:`x > 0`, :math:`|\theta| \le` HFOV/2) whose lower edge is at height
    :math:`e` images its bottom edge :math:`y = f (H - e) / x` pixels below the horizon.  The
    detector ranges a vehicle from that row, :math:`\hat Z = f H / y` (Stein, Mano & Shashua
    2003), so it measures :math:`\hat r = r\,H / (H - e)`: exact for road vehicles
    (:math:`e = 0`).  An overhead gantry or bridge (:math:`e \ge H`) has its bottom edge at or
    above the horizon: it cannot stand on the road and is never reported as a road-level
    vehicle.  Objects whose bottom edge is below the image (:math:`y > h_{\mathrm{px}}/2`,
    i.e. closer than :math:`f H / (h_{\mathrm{px}}/2)` = 3.2 m) or whose measured range
    exceeds ``max_range`` are not reported.

Noise (Gaussian, declared at the measured range)
    Range :math:`\sigma_r = \sigma_0 + r^2 \sigma_y / (f H)` (a row error of
    :math:`\sigma_y` px, Stein et al. 2003, as :func:`~acc_fusion.sensors.spec.infrared_spec`);
    azimuth from the image column, :math:`\sigma_\theta = \sigma_u / f`; range-rate from the
    scale change :math:`s = w_1 / w_0` of the vehicle's image width :math:`w = f W / r` over a
    baseline :math:`\Delta t`: :math:`\dot r = -r (s - 1) / \Delta t` with
    :math:`\sigma_s = \sqrt 2\, \sigma_w / w`, so

    .. math:: \sigma_{\dot r} = \sigma_{\dot r,0} + \frac{\sqrt 2\, \sigma_w}{f W \Delta t}\, r^2

    growing with the square of the range as Stein et al. (2003) derive; :math:`W` is a
    reference car width (the detector does not know the true one).

Detection probability
    The product of three factors:

    * size: the target's critical dimension :math:`\sqrt{W_t H_t}` spans
      :math:`N = f \sqrt{W_t H_t} / (2 r)` cycles (two pixels a cycle); the target transfer
      probability function :math:`P_N = (N/N_{50})^E / (1 + (N/N_{50})^E)`,
      :math:`E = 2.7 + 0.7 N/N_{50}`, with Johnson's recognition criterion
      :math:`N_{50}` = 4 cycles (Johnson 1958; Driggers et al. 1999);
    * contrast: the apparent thermal contrast :math:`\Delta T\, \tau(r)` (:math:`\tau` the
      one-way LWIR transmittance of :func:`~acc_fusion.sensors.propagation.lwir_transmittance`
      in fog and rain) against the camera's NETD gives :math:`\mathrm{SNR} = |\Delta T|
      \tau / \mathrm{NETD}`; a threshold detector in Gaussian noise detects with
      :math:`P_C = \Phi(\mathrm{SNR} - k)`, :math:`k` = 5 (Rose 1948);
    * the detector's best-case recall ``max_detection_prob``.

    Darkness changes nothing: the camera images the targets' own emission.

Classification
    Every detection is a vehicle report (``origin`` keeps the truth for metrics).  The
    detector reports ``VEHICLE`` and ``PARKED`` objects (a parked car's lower thermal
    contrast comes from the truth's ``thermal_contrast``).  Any other object that passes the
    detection step is mistaken for a vehicle with probability ``misclass_prob`` (assumption);
    overhead objects stay out by the geometry above.

False detections
    A Poisson number of false detections (warm road patches, reflections), mean
    ``false_rate`` per ego and frame, uniform in range and azimuth and stationary
    (:func:`~acc_fusion.sensors.scan.stationary_clutter`), ``origin`` :data:`CLUTTER`.

Sources: G. P. Stein, O. Mano, A. Shashua, "Vision-based ACC with a single camera: bounds on
range and range rate accuracy", IEEE Intelligent Vehicles Symposium 2003; J. Johnson,
"Analysis of image forming systems", Image Intensifier Symposium, Fort Belvoir, 1958;
R. G. Driggers, P. Cox, T. Edwards, *Introduction to Infrared and Electro-Optical Systems*,
Artech House, 1999; A. Rose, "The sensitivity performance of the human eye on an absolute
scale", *J. Opt. Soc. Am.* 38(2):196-208, 1948.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.special import ndtr

from acc_fusion.sensors.detections import Detections
from acc_fusion.sensors.propagation import lwir_transmittance
from acc_fusion.sensors.scan import (
    NONNEGATIVE,
    POSITIVE,
    PROBABILITY,
    Returns,
    Scanner,
    check_spec,
    offline,
)
from acc_fusion.sensors.spec import (
    IR_CAMERA_HEIGHT_M,
    IR_HFOV_DEG,
    IR_IMAGE_WIDTH_PX,
    IR_ROW_STD_PX,
)
from acc_fusion.truth.conditions import Conditions
from acc_fusion.truth.objects import ObjectFrame, ObjectKind

_BOUNDS: dict[str, dict[str, float | bool]] = {
    "rate_hz": POSITIVE,
    "phase": NONNEGATIVE,
    "image_width_px": POSITIVE,
    "image_height_px": POSITIVE,
    "hfov_deg": {"lo": 0.0, "hi": 180.0, "lo_open": True, "hi_open": True},
    "camera_height": POSITIVE,
    "range_std": POSITIVE,
    "row_std_px": POSITIVE,
    "column_std_px": POSITIVE,
    "range_rate_std": POSITIVE,
    "width_std_px": NONNEGATIVE,
    "scale_baseline": POSITIVE,
    "reference_width": POSITIVE,
    "netd": POSITIVE,
    "contrast_threshold": NONNEGATIVE,
    "n50_cycles": POSITIVE,
    "max_detection_prob": PROBABILITY,
    "misclass_prob": PROBABILITY,
    "fog_extinction_ratio": NONNEGATIVE,
    "false_rate": NONNEGATIVE,
}

#: The kinds the vehicle detector is trained to report.
VEHICLE_KINDS = (ObjectKind.VEHICLE, ObjectKind.PARKED)


@dataclass(frozen=True)
class Infrared2DSpec:
    """Performance of the 2-D thermal camera; every field validated (one-sentence
    :class:`~acc_fusion.core.errors.ConfigError` naming ``<name>.<field>``).

    ====================  ========  =====  ==================================================
    field                 value     unit   source
    ====================  ========  =====  ==================================================
    name                  infrared  --     --
    rate_hz               10        Hz     as :func:`~acc_fusion.sensors.spec.infrared_spec`
    phase                 0         s      --
    image_width_px        640       px     FLIR ADK / Boson 640x512 LWIR core
    image_height_px       512       px     FLIR ADK / Boson
    hfov_deg              50        deg    FLIR ADK lens option (24/32/50/75°)
    camera_height         1.2       m      as ``infrared_spec`` (assumption)
    max_range             100       m      as ``infrared_spec`` (assumption)
    range_std             0.3       m      as ``infrared_spec``: box jitter (assumption)
    row_std_px            1         px     as ``infrared_spec`` (Stein et al. 2003)
    column_std_px         1         px     assumption: the same 1 px as the row
    range_rate_std        0.3       m/s    assumption: the constant part; with the scale
                                           term about the 0.5 m/s of ``infrared_spec`` at
                                           30 m
    width_std_px          0.1       px     assumption: sub-pixel image alignment of the
                                           scale change
    scale_baseline        0.5       s      assumption: frames between the compared images
    reference_width       1.8       m      a passenger car's width (assumption)
    netd                  0.05      K      FLIR Boson data sheet (2021): thermal
                                           sensitivity < 50 mK (< 40 mK at best)
    contrast_threshold    5         --     Rose (1948) detection criterion SNR ≈ 5
    n50_cycles            4         cycl.  Johnson (1958): recognition, 50 %
    max_detection_prob    0.95      --     as ``infrared_spec``'s detection_prob
                                           (assumption)
    misclass_prob         0.02      --     assumption: a roadside object called a vehicle
    fog_extinction_ratio  0.5       --     assumption between Pinchon et al. 2018 and
                                           Hagen 2018 (:func:`~acc_fusion.sensors.
                                           propagation.lwir_fog_extinction`)
    false_rate            0.02      1/frm  assumption: false detections per ego and frame
    ====================  ========  =====  ==================================================

    Sources: FLIR Systems, *Boson Thermal Imaging Core* data sheet 102-2013-40, 2021
    (640x512 VOx microbolometer, < 50 mK); FLIR ADK product page (HFOV options); G. P.
    Stein, O. Mano, A. Shashua, IEEE IV 2003; J. Johnson 1958; A. Rose 1948 (full references
    in :mod:`acc_fusion.sensors.infrared2d`).
    """

    name: str = "infrared"
    rate_hz: float = 10.0
    phase: float = 0.0
    image_width_px: float = float(IR_IMAGE_WIDTH_PX)
    image_height_px: float = 512.0
    hfov_deg: float = IR_HFOV_DEG
    camera_height: float = IR_CAMERA_HEIGHT_M
    max_range: float = 100.0
    range_std: float = 0.3
    row_std_px: float = IR_ROW_STD_PX
    column_std_px: float = 1.0
    range_rate_std: float = 0.3
    width_std_px: float = 0.1
    scale_baseline: float = 0.5
    reference_width: float = 1.8
    netd: float = 0.05
    contrast_threshold: float = 5.0
    n50_cycles: float = 4.0
    max_detection_prob: float = 0.95
    misclass_prob: float = 0.02
    fog_extinction_ratio: float = 0.5
    false_rate: float = 0.02

    def __post_init__(self) -> None:
        check_spec(self, _BOUNDS)

    @property
    def focal_px(self) -> float:
        """Focal length [px]: ``(image_width_px / 2) / tan(hfov / 2)``."""
        return self.image_width_px / 2 / math.tan(math.radians(self.hfov_deg) / 2)

    @property
    def min_range(self) -> float:
        """Range [m] below which a road vehicle's bottom edge leaves the image:
        ``f H / (image_height_px / 2)``."""
        return self.focal_px * self.camera_height / (self.image_height_px / 2)

    def noise_std(self, range_m: np.ndarray) -> np.ndarray:
        """``(3, K)`` noise standard deviations at range ``range_m`` ``(K,)`` [m]: range [m],
        azimuth [rad], range-rate [m/s] (module docstring)."""
        r2 = np.square(np.asarray(range_m, dtype=float))
        q_range, q_rate = self.noise_growth()
        return np.stack([
            self.range_std + q_range * r2,
            np.full(r2.shape, self.column_std_px / self.focal_px),
            self.range_rate_std + q_rate * r2,
        ])  # fmt: skip

    def noise_growth(self) -> tuple[float, float]:
        r"""The growth :math:`q` [1/m, 1/(m s)] of the range and range-rate stds with the
        square of the range (module docstring): :math:`\sigma_y / (f H)` and
        :math:`\sqrt 2\, \sigma_w / (f W \Delta t)`."""
        f = self.focal_px
        q_rate = math.sqrt(2) * self.width_std_px / (f * self.reference_width * self.scale_baseline)
        return self.row_std_px / (f * self.camera_height), q_rate


class Infrared2D(Scanner):
    """The thermal camera of :mod:`acc_fusion.sensors.infrared2d` on E egos.

    Args:
        spec: its performance (default :class:`Infrared2DSpec`).
        seed: ``int``, :class:`numpy.random.SeedSequence`, :class:`numpy.random.Generator` or
            ``None`` (fresh entropy); see :class:`~acc_fusion.sensors.scan.Scanner`.

    Example:
        >>> camera = Infrared2D(seed=1)
        >>> pd = camera.detection_probability(
        ...     np.array([20.0, 80.0]), np.array([1.8, 1.8]), np.array([1.5, 1.5]),
        ...     np.array([8.0, 8.0]), Conditions())
        >>> bool(pd[0] > pd[1])
        True
    """

    spec_type = Infrared2DSpec

    def detection_probability(
        self,
        range_m: np.ndarray,
        width: np.ndarray,
        height: np.ndarray,
        thermal_contrast: np.ndarray,
        conditions: Conditions,
    ) -> np.ndarray:
        """Probability that the detector finds a target of ``width`` × ``height`` [m] and
        ``thermal_contrast`` [K] at range ``range_m`` [m] (module docstring)."""
        s = self.spec
        r = np.asarray(range_m, dtype=float)
        ratio = s.focal_px * np.sqrt(width * height) / (2.0 * r) / s.n50_cycles
        ratio = np.maximum(ratio, 1e-12)  # (a target at infinity)
        p_size = 1.0 / (1.0 + ratio ** -(2.7 + 0.7 * ratio))
        tau = lwir_transmittance(r, conditions, s.fog_extinction_ratio)
        snr = np.abs(thermal_contrast) * tau / s.netd
        return s.max_detection_prob * p_size * ndtr(snr - s.contrast_threshold)

    def detect(self, frame: ObjectFrame, conditions: Conditions) -> Detections:
        """The detections of every ego's objects at ``frame.t`` (empty and ``online=False``
        between frames); frames must come in increasing time."""
        s = self.spec
        if not self._due(frame, conditions):
            return offline(frame.t, s.name, frame.n_egos)
        half_fov = math.radians(s.hfov_deg) / 2
        slot, x, y, r, rr, scale = _imaged(
            np.flatnonzero(frame.valid), frame.x.ravel(), frame.y.ravel(),
            frame.elevation.ravel(), frame.vx.ravel(), frame.vy.ravel(), s.camera_height,
            s.focal_px, s.image_height_px, s.max_range,
        )  # fmt: skip
        az = np.arctan2(y, x)
        seen = np.abs(az) <= half_fov
        slot = slot[seen]
        ego, kind = slot // max(frame.max_objects, 1), frame.kind.ravel()[slot]
        p = self.detection_probability(
            r[seen], frame.width.ravel()[slot], frame.height.ravel()[slot],
            frame.thermal_contrast.ravel()[slot], conditions,
        )  # fmt: skip
        p *= np.where(np.isin(kind, VEHICLE_KINDS), 1.0, s.misclass_prob)
        hit = self._rng.random(ego.size) < p
        z = np.stack([r * scale, az, rr * scale])[:, seen]
        found = Returns(ego, z, frame.object_id.ravel()[slot], kind).take(hit)
        return self._report(frame, found, s.false_rate, math.radians(s.hfov_deg) / 2)


@njit(cache=True)
def _imaged(
    slots, x, y, elevation, vx, vy, camera_height, focal_px, image_height_px, max_range
):  # pragma: no cover - compiled
    """The object ``slots`` (flat indices into the frame's arrays, raveled) ahead whose
    bottom edge is below the horizon and inside the image and whose measured range is within
    ``max_range`` (module docstring: geometry; the azimuth test is the caller's), with their
    ``x``, ``y``, range, range-rate and range scale :math:`\\hat r / r = H / (H - e)`."""
    out = np.empty((5, slots.size))
    kept = np.empty(slots.size, np.int64)
    k = 0
    for s in slots:
        drop = camera_height - elevation[s]  # the bottom edge below the camera [m]
        if not (x[s] > 0 and drop > 0 and focal_px * drop <= x[s] * image_height_px / 2):
            continue
        r, scale = math.hypot(x[s], y[s]), camera_height / drop
        if r * scale <= max_range:
            kept[k] = s
            out[0, k], out[1, k], out[2, k], out[4, k] = x[s], y[s], r, scale
            out[3, k] = (x[s] * vx[s] + y[s] * vy[s]) / max(r, 1e-9)
            k += 1
    return kept[:k], out[0, :k], out[1, :k], out[2, :k], out[3, :k], out[4, :k]
