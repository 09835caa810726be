r"""A 77 GHz long-range radar over the 2-D world: every object ahead of every ego in one pass.

Model, per scan (every ``1 / rate_hz`` s from ``phase``; an empty ``online=False``
:class:`~acc_fusion.sensors.detections.Detections` between scans):

Coverage
    An object is illuminated when it is ahead (:math:`x > 0`), within ``min_range`` ..
    ``max_range`` and :math:`|\theta| \le` ``fov_deg``/2, and its lower edge is inside the
    elevation beam: :math:`e - h_r \le x \tan(\text{elevation\_fov\_deg}/2)` with :math:`e` the
    lower edge's height and :math:`h_r` the radar's mounting height.  An overhead gantry or
    bridge is therefore seen from afar and drops out of the beam close by.  The radar measures
    no elevation: it reports the gantry like any stationary object on the road ahead, the
    classic false stationary target of radar FCW.

Measured quantities
    Range to the lower edge :math:`r = \sqrt{x^2 + y^2 + \max(e - h_r, 0)^2}`, azimuth
    :math:`\theta = \operatorname{atan2}(y, x)`, and range-rate the radial Doppler of the true
    relative velocity, :math:`\dot r = (x v_x + y v_y) / r` (a stationary object closes at
    :math:`-v_{\mathrm{ego}}\cos\theta`).  Each gets independent Gaussian noise of the constant
    standard deviations ``range_std``, ``azimuth_std_deg``, ``range_rate_std``, which the radar
    also declares.

Signal-to-noise ratio and detection
    The radar equation for a point target, referred to a 10 dBsm car at ``ref_range``:

    .. math::

        \mathrm{SNR_{dB}} = \mathrm{SNR_{ref}} + (\sigma - \sigma_{\mathrm{ref}})
            + 40 \log_{10}(r_{\mathrm{ref}} / r) - L_{\mathrm{2way}}(r)

    with :math:`\sigma` the RCS [dBsm] and :math:`L_{\mathrm{2way}}` the rain and fog loss of
    :func:`~acc_fusion.sensors.propagation.radar_two_way_loss_db`.  A Swerling-1 target seen
    by a square-law detector with false-alarm probability :math:`P_{fa}` is detected with

    .. math:: P_d = P_{fa}^{1/(1 + \mathrm{SNR})}

    (Richards 2005, ch. 6; Skolnik 2001, ch. 2).  The default 29 dB at 100 m gives
    :math:`P_d` = 0.98 at 100 m (the 1-D radar's ``detection_prob``) and 0.5 at 250 m.

Multipath ghosts
    The double bounce radar → target → ego's front → target → radar travels twice the
    one-way path: a ghost at range :math:`2r`, range-rate :math:`2\dot r` and the target's
    azimuth (the multiple reflections of Buhren & Yang 2007), with the SNR of the target at
    :math:`2r` less ``ghost_loss_db`` for the extra reflection (assumption).  It is detected
    like any return, so it shows up behind close strong targets; ``origin`` :data:`GHOST`,
    ``object_id`` -1.

Resolution
    Returns of one ego closer than ``range_resolution`` in range *and*
    ``azimuth_resolution_deg`` in azimuth *and* ``range_rate_resolution`` in range-rate fall in
    one range-Doppler-beam cell and are not separated: they merge (single linkage, in order of
    range) into one return with the summed SNR at the SNR-weighted mean position and
    range-rate, credited to its strongest member.  Detection is decided on the merged SNR.
    That unresolved targets yield one measurement between them is the point of F. E. Daum and
    R. J. Fitzgerald, "Importance of resolution in multiple-target tracking", Proc. SPIE 2235
    (1994); the single linkage and the SNR-weighted centroid are our assumptions (the
    simplest rule that merges only what the three cells cannot separate).

Clutter
    A Poisson number of false detections, mean ``clutter_rate`` per ego and scan, uniform in
    range and azimuth over the coverage (the standard clutter model of target tracking:
    Y. Bar-Shalom, P. K. Willett and X. Tian, *Tracking and Data Fusion*, YBS Publishing,
    2011) and stationary (an assumption: the roadside returns that cause FCW false alarms;
    :func:`~acc_fusion.sensors.scan.stationary_clutter`), ``origin`` :data:`CLUTTER`.

Sources: M. A. Richards, *Fundamentals of Radar Signal Processing*, McGraw-Hill, 2005;
M. I. Skolnik, *Introduction to Radar Systems*, 3rd ed., McGraw-Hill, 2001; M. Buhren,
B. Yang, "Extension of automotive radar target list simulation to consider further physical
aspects", 7th Int. Conf. on ITS Telecommunications (ITST), 2007,
doi:10.1109/ITST.2007.4295847.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from acc_fusion.core.units import KMH
from acc_fusion.sensors.detections import GHOST, Detections
from acc_fusion.sensors.propagation import radar_two_way_loss_db
from acc_fusion.sensors.scan import (
    FINITE,
    NONNEGATIVE,
    POSITIVE,
    Returns,
    Scanner,
    check_spec,
    offline,
)
from acc_fusion.truth.conditions import Conditions
from acc_fusion.truth.objects import ObjectFrame

_ANGLE = {"lo": 0.0, "hi": 180.0, "lo_open": True}

_BOUNDS: dict[str, dict[str, float | bool]] = {
    "rate_hz": POSITIVE,
    "phase": NONNEGATIVE,
    "min_range": NONNEGATIVE,
    "fov_deg": {"lo": 0.0, "hi": 360.0, "lo_open": True},
    "elevation_fov_deg": _ANGLE,
    "mount_height": NONNEGATIVE,
    "range_std": POSITIVE,
    "azimuth_std_deg": POSITIVE,
    "range_rate_std": POSITIVE,
    "range_resolution": POSITIVE,
    "azimuth_resolution_deg": POSITIVE,
    "range_rate_resolution": POSITIVE,
    "snr_ref_db": FINITE,
    "ref_range": POSITIVE,
    "ref_rcs": FINITE,
    "pfa": {"lo": 0.0, "hi": 1.0, "lo_open": True, "hi_open": True},
    "ghost_loss_db": NONNEGATIVE,
    "clutter_rate": NONNEGATIVE,
}


@dataclass(frozen=True)
class Radar2DSpec:
    """Performance of the 2-D radar; every field validated (one-sentence
    :class:`~acc_fusion.core.errors.ConfigError` naming ``<name>.<field>``).

    ======================  ======  =====  ==================================================
    field                   value   unit   source
    ======================  ======  =====  ==================================================
    name                    radar   --     --
    rate_hz                 20      Hz     as :func:`~acc_fusion.sensors.spec.radar_spec`
    phase                   0       s      --
    min_range               0.5     m      Bosch LRR3 brochure (0.5-250 m)
    max_range               250     m      Bosch LRR3 brochure
    fov_deg                 30      deg    Bosch LRR3 ±15° (de Ponte Müller 2017)
    elevation_fov_deg       5       deg    assumption: the few-degree elevation beam of a
                                           long-range radar (±2.5°)
    mount_height            0.5     m      assumption: bumper-mounted
    range_std               0.25    m      as ``radar_spec`` (de Ponte Müller 2017)
    azimuth_std_deg         0.1     deg    far-range azimuth accuracy ±0.1° of the
                                           Continental ARS 408-21 data sheet
    range_rate_std          0.12    m/s    Bosch LRR3 (de Ponte Müller 2017)
    range_resolution        1.79    m      ARS 408-21 data sheet, far range
    azimuth_resolution_deg  1.6     deg    ARS 408-21 data sheet, far range
    range_rate_resolution   0.103   m/s    ARS 408-21 data sheet: 0.37 km/h, far range
    snr_ref_db              29      dB     calibrated: P_d = 0.98 at 100 m (``radar_spec``'s
                                           detection_prob) and 0.5 at 250 m (max range)
    ref_range               100     m      --
    ref_rcs                 10      dBsm   a passenger car's rear (assumption: measured
                                           car RCS at 77 GHz spreads over about 0-20 dBsm
                                           with aspect)
    pfa                     1e-6    --     a usual CFAR design value (Richards 2005, ch. 6)
    ghost_loss_db           30      dB     assumption: the extra reflection off the ego's
                                           front and the target
    clutter_rate            0.2     1/scan assumption: about :math:`P_{fa}` times the
                                           ~10⁵-10⁶ range-Doppler-beam cells, after the
                                           tracker-side clutter filters
    ======================  ======  =====  ==================================================

    Sources: Bosch Engineering, *Long-Range Radar LRR3* brochure; F. de Ponte Müller,
    "Survey on ranging sensors and cooperative techniques for relative positioning of
    vehicles", *Sensors* 17(2):271, 2017; Continental, *ARS 408-21 Long Range Radar Sensor
    77 GHz* technical data sheet, 2017; M. A. Richards, *Fundamentals of Radar Signal
    Processing*, McGraw-Hill, 2005.
    """

    name: str = "radar"
    rate_hz: float = 20.0
    phase: float = 0.0
    min_range: float = 0.5
    max_range: float = 250.0
    fov_deg: float = 30.0
    elevation_fov_deg: float = 5.0
    mount_height: float = 0.5
    range_std: float = 0.25
    azimuth_std_deg: float = 0.1
    range_rate_std: float = 0.12
    range_resolution: float = 1.79
    azimuth_resolution_deg: float = 1.6
    range_rate_resolution: float = 0.37 * KMH
    snr_ref_db: float = 29.0
    ref_range: float = 100.0
    ref_rcs: float = 10.0
    pfa: float = 1e-6
    ghost_loss_db: float = 30.0
    clutter_rate: float = 0.2

    def __post_init__(self) -> None:
        check_spec(self, _BOUNDS)

    def noise_std(self, range_m: np.ndarray) -> np.ndarray:
        """``(3, K)`` noise standard deviations of returns at range ``range_m`` ``(K,)``:
        range [m], azimuth [rad], range-rate [m/s] (constant)."""
        std = [self.range_std, math.radians(self.azimuth_std_deg), self.range_rate_std]
        return np.repeat(np.array(std)[:, None], np.size(range_m), axis=1)

    def noise_growth(self) -> tuple[float, float]:
        """The growth of the range and range-rate stds with the square of the range
        (:attr:`~acc_fusion.sensors.detections.Detections.range_std_growth`): none."""
        return 0.0, 0.0


class Radar2D(Scanner):
    """The radar of :mod:`acc_fusion.sensors.radar2d` on E egos.

    Args:
        spec: its performance (default :class:`Radar2DSpec`).
        seed: ``int``, :class:`numpy.random.SeedSequence`, :class:`numpy.random.Generator` or
            ``None`` (fresh entropy); split into a detection-and-noise and a clutter stream,
            so that switching clutter on or off leaves the other detections unchanged.

    Example:
        >>> radar = Radar2D(seed=1)
        >>> pd = radar.detection_probability(np.array([10.0]), np.array([100.0]), Conditions())
        >>> round(float(pd[0]), 2)
        0.98
    """

    spec_type = Radar2DSpec

    def snr_db(self, rcs: np.ndarray, range_m: np.ndarray, conditions: Conditions) -> np.ndarray:
        """SNR [dB] of targets of RCS ``rcs`` [dBsm] at range ``range_m`` [m] (module
        docstring)."""
        s = self.spec
        r = np.asarray(range_m, dtype=float)
        path = 40.0 * np.log10(s.ref_range / r) - radar_two_way_loss_db(r, conditions)
        return s.snr_ref_db + (np.asarray(rcs, dtype=float) - s.ref_rcs) + path

    def detection_probability(
        self, rcs: np.ndarray, range_m: np.ndarray, conditions: Conditions
    ) -> np.ndarray:
        """Swerling-1 :math:`P_d = P_{fa}^{1/(1+\\mathrm{SNR})}` of such targets."""
        return _swerling1(self.spec.pfa, self.snr_db(rcs, range_m, conditions))

    def detect(self, frame: ObjectFrame, conditions: Conditions) -> Detections:
        """The detections of every ego's objects at ``frame.t`` (empty and ``online=False``
        between scans); frames must come in increasing time."""
        s = self.spec
        if not self._due(frame, conditions):
            return offline(frame.t, s.name, frame.n_egos)
        half_fov = math.radians(s.fov_deg) / 2
        slot, x, y, r, rr = _covered(
            np.flatnonzero(frame.valid), frame.x.ravel(), frame.y.ravel(),
            frame.elevation.ravel(), frame.vx.ravel(), frame.vy.ravel(), s.mount_height,
            s.min_range, s.max_range, math.tan(math.radians(s.elevation_fov_deg) / 2),
        )  # fmt: skip
        az = np.arctan2(y, x)
        ego, z, object_id, origin, rcs, targets = _returns(
            slot, slot // max(frame.max_objects, 1), r, az, rr, np.abs(az) <= half_fov,
            frame.rcs.ravel(), frame.object_id.ravel(), frame.kind.ravel(), s.max_range,
        )  # fmt: skip
        snr = self.snr_db(rcs, z[0], conditions)
        snr[targets:] -= s.ghost_loss_db
        order = np.argsort(ego * (s.max_range + 1.0) + z[0])  # by ego, then range
        cells = (s.range_resolution, math.radians(s.azimuth_resolution_deg),
                 s.range_rate_resolution)  # fmt: skip
        merged = _resolve(order, ego, z, object_id, origin, 10.0 ** (snr[order] / 10.0), *cells)
        power = merged[-1]
        hit = self._rng.random(power.size) < _swerling1(s.pfa, 10.0 * np.log10(power))
        return self._report(frame, Returns(*merged[:-1]).take(hit), s.clutter_rate, half_fov)


def _swerling1(pfa: float, snr_db: np.ndarray) -> np.ndarray:
    """:math:`P_d = P_{fa}^{1/(1+\\mathrm{SNR})}` with the SNR in dB."""
    return pfa ** (1.0 / (1.0 + 10.0 ** (np.asarray(snr_db) / 10.0)))


@njit(cache=True)
def _covered(
    slots, x, y, elevation, vx, vy, mount_height, min_range, max_range, tan_half_elevation
):  # pragma: no cover - compiled
    """The object ``slots`` (flat indices into the frame's arrays, raveled) ahead, within
    the range limits and the elevation beam (module docstring: coverage; the azimuth test is
    the caller's), with their ``x``, ``y``, range to the lower edge and range-rate."""
    out = np.empty((4, slots.size))
    kept = np.empty(slots.size, np.int64)
    k = 0
    for s in slots:
        rise = max(elevation[s] - mount_height, 0.0)
        r = np.sqrt(x[s] * x[s] + y[s] * y[s] + rise * rise)
        if x[s] > 0 and min_range <= r <= max_range and rise <= x[s] * tan_half_elevation:
            kept[k] = s
            out[0, k], out[1, k], out[2, k] = x[s], y[s], r
            out[3, k] = (x[s] * vx[s] + y[s] * vy[s]) / max(r, 1e-9)
            k += 1
    return kept[:k], out[0, :k], out[1, :k], out[2, :k], out[3, :k]


@njit(cache=True)
def _returns(
    slot, ego, r, az, rr, in_fov, rcs, object_id, kind, max_range
):  # pragma: no cover - compiled
    """The returns of the covered slots within the field of view (:func:`_covered`; the
    frame's ``rcs``, ``object_id`` and ``kind`` raveled): the targets, then the multipath
    ghosts of those within half the maximum range (module docstring), as ``ego (K,)``,
    ``z (3, K)``, ``object_id``, ``origin`` (int8), the RCS of each (the target's for a
    ghost) and the number of targets."""
    n = 0
    for i in range(slot.size):
        n += in_fov[i] + (in_fov[i] and 2 * r[i] <= max_range)
    out_ego, z = np.empty(n, np.int64), np.empty((3, n))
    oid, origin, out_rcs = np.empty(n, np.int64), np.empty(n, np.int8), np.empty(n)
    k = 0
    for ghosts in (False, True):
        for i in range(slot.size):
            if not in_fov[i] or (ghosts and not 2 * r[i] <= max_range):
                continue
            f = 2.0 if ghosts else 1.0
            out_ego[k], out_rcs[k] = ego[i], rcs[slot[i]]
            z[0, k], z[1, k], z[2, k] = f * r[i], az[i], f * rr[i]
            oid[k] = -1 if ghosts else object_id[slot[i]]
            origin[k] = GHOST if ghosts else kind[slot[i]]
            k += 1
        if not ghosts:
            targets = k
    return out_ego, z, oid, origin, out_rcs, targets


@njit(cache=True)
def _resolve(order, ego, z, object_id, origin, power, dr, daz, drr):  # pragma: no cover
    """Merge the returns no resolution cell separates (module docstring): ``order`` sorts
    them by ego then range and ``power`` is their linear SNR in that order (:func:`_merge`).
    The merged returns' ``ego``, ``z``, ``object_id``, ``origin`` and summed SNR."""
    ego, z, object_id, origin = ego[order], z[:, order], object_id[order], origin[order]
    strongest, merged, total = _merge(ego, z, power, dr, daz, drr)
    return ego[strongest], merged, object_id[strongest], origin[strongest], total


@njit(cache=True)
def _merge(ego, z, power, dr, daz, drr):  # pragma: no cover - compiled
    """Merge returns sorted by ego then range (``z (3, K)``, linear SNR ``power (K,)``): a
    return joins the cluster of the nearest earlier return of its ego within ``dr`` in range,
    ``daz`` in azimuth and ``drr`` in range-rate (single linkage), else starts a new one.

    Returns each cluster's strongest member (an index into the K returns), its SNR-weighted
    mean ``z (3, n)`` and its summed SNR ``(n,)``.
    """
    k = ego.size
    label = np.empty(k, np.int64)
    strongest = np.empty(k, np.int64)
    total = np.zeros(k)
    weighted = np.zeros((3, k))
    n = 0
    for i in range(k):
        c = -1
        j = i - 1
        while j >= 0 and ego[j] == ego[i] and z[0, i] - z[0, j] < dr:
            if abs(z[1, i] - z[1, j]) < daz and abs(z[2, i] - z[2, j]) < drr:
                c = label[j]
                break
            j -= 1
        if c < 0:
            c = n
            n += 1
            strongest[c] = i
        elif power[i] > power[strongest[c]]:
            strongest[c] = i
        label[i] = c
        total[c] += power[i]
        for a in range(3):
            weighted[a, c] += power[i] * z[a, i]
    return strongest[:n], weighted[:, :n] / total[:n], total[:n]
