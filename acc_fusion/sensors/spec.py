"""The radar and infrared camera specifications (:class:`SensorSpec`): rates, limits, noise,
detection probability and clutter, each default with its published source; the noise models
themselves are described in :mod:`acc_fusion.sensors.sensor`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_interval, check_range

# Bounds of the SensorSpec fields, as keyword arguments of ``check_range``.
_FINITE = {"hi": math.inf, "hi_open": True}


_ABOVE = {**_FINITE, "lo_open": True}


_SPEC_BOUNDS: dict[str, dict[str, float | bool]] = {
    "rate_hz": {"lo": 0.0, **_ABOVE},
    "range_std": {"lo": 0.0, **_ABOVE},
    "range_std_quadratic": {"lo": 0.0, **_FINITE},
    "range_rate_std": {"lo": 0.0, **_ABOVE},
    "min_range": {"lo": 0.0, **_FINITE},
    "fov_deg": {"lo": 0.0, "hi": 360.0, "lo_open": True},
    "detection_prob": {"lo": 0.0, "hi": 1.0},
    "phase": {"lo": 0.0, **_FINITE},
    "ghost_rate": {"lo": 0.0, **_FINITE},
}


@dataclass(frozen=True)
class SensorSpec:
    r"""Performance of one range/range-rate sensor (all fields validated on construction).

    Attributes:
        name: sensor name (``"radar"``, ``"infrared"``); prefixes the field names in errors.
        rate_hz: sample rate [Hz], ``> 0``.
        range_std: constant part :math:`\sigma_0` of the range noise std [m], ``> 0``.
        range_std_quadratic: :math:`q` [1/m] in :math:`\sigma_r = \sigma_0 + q r^2`, ``>= 0``.
        range_rate_std: range-rate noise std [m/s], ``> 0``.
        min_range: shortest range the sensor reports [m], ``>= 0``.
        max_range: longest range the sensor reports [m], ``> min_range``.
        fov_deg: full horizontal field of view [deg], in (0, 360].
        detection_prob: probability that a visible return is reported, in [0, 1].
        phase: time of the first sample [s], ``>= 0``.
        ghost_rate: clutter ghosts spawned per second per pair [1/s], ``>= 0`` (0: off).
        ghost_range: ``(low, high)`` uniform spawn range of a ghost [m], ``0 <= low <= high``.
        ghost_duration: ``(low, high)`` uniform lifetime of a ghost [s], ``0 < low <= high``.
    """

    name: str
    rate_hz: float
    range_std: float
    range_std_quadratic: float
    range_rate_std: float
    min_range: float
    max_range: float
    fov_deg: float
    detection_prob: float
    phase: float = 0.0
    ghost_rate: float = 0.0
    ghost_range: tuple[float, float] = (20.0, 120.0)
    ghost_duration: tuple[float, float] = (0.5, 2.0)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ConfigError(f"sensor name must be a non-empty string, got {self.name!r}")
        p = f"{self.name}."
        values = {f: check_range(p + f, getattr(self, f), **b) for f, b in _SPEC_BOUNDS.items()}
        values["max_range"] = check_range(
            p + "max_range", self.max_range, values["min_range"], **_ABOVE
        )
        values["ghost_range"] = check_interval(p + "ghost_range", self.ghost_range, lo_open=False)
        values["ghost_duration"] = check_interval(
            p + "ghost_duration", self.ghost_duration, lo_open=True
        )
        for name, value in values.items():
            object.__setattr__(self, name, value)

    def range_noise_std(self, r: np.ndarray) -> np.ndarray:
        """Range noise std [m] at range ``r`` [m]: ``range_std + range_std_quadratic * r**2``."""
        r = np.asarray(r, dtype=float)
        return self.range_std + self.range_std_quadratic * r * r


def _spec(defaults: dict[str, object], overrides: dict[str, object]) -> SensorSpec:
    """Build a :class:`SensorSpec` from defaults and overrides; unknown keys are ConfigErrors."""
    data = {**defaults, **overrides}
    return from_mapping(SensorSpec, data, prefix=f"{data['name']}.")


def radar_spec(**overrides: object) -> SensorSpec:
    """Defaults of a 77 GHz long-range ACC radar, with any field overridden by keyword.

    ===================  ========  =====  ===================================================
    parameter            value     unit   source
    ===================  ========  =====  ===================================================
    rate_hz              20        Hz     project choice; series long-range radars cycle in
                                          50-80 ms (12.5-20 Hz): Delphi ESR 50 ms, Bosch
                                          LRR3 80 ms (de Ponte Müller 2017)
    range_std            0.25      m      between the LRR3 accuracy 0.1 m (de Ponte Müller
                                          2017) and the ~0.4 m far-range accuracy typical of
                                          ARS 408-class radars
    range_std_quadratic  0         1/m    FMCW range error does not grow with range
    range_rate_std       0.12      m/s    Bosch LRR3: 0.12 m/s (de Ponte Müller 2017);
                                          the LRR3 brochure states ±0.1 m/s
    min_range            0.5       m      Bosch LRR3 brochure: distance 0.5-250 m
    max_range            250       m      Bosch LRR3 brochure
    fov_deg              30        deg    Bosch LRR3: ±15° azimuth (de Ponte Müller 2017)
    detection_prob       0.98      --     typical of a tracked vehicle target in the main
                                          lobe (assumption, not a datasheet value)
    phase                0         s      --
    ghost_rate           0         1/s    clutter off by default
    ===================  ========  =====  ===================================================

    Sources: Bosch Engineering, *Long-Range Radar LRR3* product brochure (distance
    0.5-250 m, 76-77 GHz); F. de Ponte Müller, "Survey on ranging sensors and cooperative
    techniques for relative positioning of vehicles", Sensors 17(2):271, 2017,
    doi:10.3390/s17020271 (its table of automotive radars: LRR3 250 m, ±15°, 0.1 m,
    0.12 m/s, 80 ms; Delphi ESR 50 ms cycle).
    """
    defaults: dict[str, object] = {
        "name": "radar",
        "rate_hz": 20.0,
        "range_std": 0.25,
        "range_std_quadratic": 0.0,
        "range_rate_std": 0.12,
        "min_range": 0.5,
        "max_range": 250.0,
        "fov_deg": 30.0,
        "detection_prob": 0.98,
    }
    return _spec(defaults, overrides)


#: Infrared camera geometry behind the default range-noise slope (see :func:`infrared_spec`).
IR_IMAGE_WIDTH_PX = 640


IR_HFOV_DEG = 50.0


IR_FOCAL_PX = (IR_IMAGE_WIDTH_PX / 2) / math.tan(math.radians(IR_HFOV_DEG / 2))  # ≈ 686 px


IR_CAMERA_HEIGHT_M = 1.2


IR_ROW_STD_PX = 1.0


def infrared_spec(**overrides: object) -> SensorSpec:
    r"""Defaults of a far-infrared (thermal) camera with monocular ranging, any field overridable.

    Monocular range comes from the image row :math:`y` of the target's road contact point,
    :math:`Z = f H / y` (Stein, Mano & Shashua 2003, with :math:`f` the focal length in
    pixels and :math:`H` the camera height); differentiating, an error of :math:`\sigma_y`
    pixels in :math:`y` gives the range error

    .. math::

        \sigma_Z = \frac{Z^2\, \sigma_y}{f H}

    so ``range_std_quadratic`` :math:`= \sigma_y / (f H)` with :math:`f` = 640 px /
    (2 tan 25°) ≈ 686 px (640x512 sensor, 50° HFOV), :math:`H` = 1.2 m and
    :math:`\sigma_y` = 1 px: :math:`q \approx 1.21\times10^{-3}` 1/m, i.e. 5 % of the range at
    44 m and 11 % at 90 m, close to the errors Stein et al. report for their camera (about
    5 % at 44 m, 10 % at 90 m).

    ===================  ========  =====  ===================================================
    parameter            value     unit   source
    ===================  ========  =====  ===================================================
    rate_hz              10        Hz     project choice: detector output rate; the FLIR ADK
                                          streams 30/60 Hz video
    range_std            0.3       m      small constant part (detection box jitter),
                                          assumption
    range_std_quadratic  1.21e-3   1/m    :math:`\sigma_y/(fH)` above (Stein et al. 2003)
    range_rate_std       0.5       m/s    assumption: monocular range-rate (from image
                                          scale change) is far noisier than Doppler
    min_range            1         m      assumption (closer, the target overflows the image)
    max_range            100       m      typical vehicle detection range of a 640-px thermal
                                          camera (assumption)
    fov_deg              50        deg    FLIR ADK lens options 24°/32°/50°/75° HFOV
    detection_prob       0.95      --     assumption, below the radar's
    phase                0         s      --
    ghost_rate           0         1/s    clutter off
    ===================  ========  =====  ===================================================

    Sources: G. P. Stein, O. Mano, A. Shashua, "Vision-based ACC with a single camera:
    bounds on range and range rate accuracy", IEEE Intelligent Vehicles Symposium 2003,
    pp. 120-125; FLIR ADK (Automotive Development Kit): 640x512 LWIR, HFOV options as listed
    in the Autoware reference-hardware page for thermal cameras.
    """
    defaults: dict[str, object] = {
        "name": "infrared",
        "rate_hz": 10.0,
        "range_std": 0.3,
        "range_std_quadratic": IR_ROW_STD_PX / (IR_FOCAL_PX * IR_CAMERA_HEIGHT_M),
        "range_rate_std": 0.5,
        "min_range": 1.0,
        "max_range": 100.0,
        "fov_deg": IR_HFOV_DEG,
        "detection_prob": 0.95,
    }
    return _spec(defaults, overrides)
