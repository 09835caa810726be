r"""A per-sensor multi-target tracker (:class:`Tracker`): one converted-measurement Kalman filter
per track, global-nearest-neighbour association, M-of-N confirmation, over E egos at once.

State and motion model
    Each track holds :math:`\mathbf x = [x,\ v_x,\ y,\ v_y]^\top` in the ego frame
    (:mod:`acc_fusion.truth.objects`: origin at the front bumper's centre, ``x`` forward, ``y``
    left; SI units), the velocity relative to the ego (the object's ground velocity minus the
    ego's, both in the ego frame).  Between frames the object moves with the continuous
    white-noise-acceleration (constant-velocity) model of Bar-Shalom, Li & Kirubarajan,
    *Estimation with Applications to Tracking and Navigation* (2001), §6.2.2, per axis

    .. math::

        F_1 = \begin{bmatrix} 1 & T \\ 0 & 1 \end{bmatrix},\qquad
        Q_1 = q \begin{bmatrix} T^3/3 & T^2/2 \\ T^2/2 & T \end{bmatrix},\qquad
        F = \operatorname{diag}(F_1, F_1),\quad Q = \operatorname{diag}(Q_1, Q_1),

    with :math:`q` [m²/s³] the power spectral density of the acceleration noise (Stone Soup's
    ``ConstantVelocity(q)`` on each axis, combined as ``[x, vx, y, vy]``).

Ego-motion compensation
    The ego frame moves and turns.  Before each prediction a track is carried into the frame of
    the step's end, assuming that over the step of :math:`T` seconds the ego drives on an arc
    of constant yaw rate :math:`\omega` at the mean :math:`\bar s` of its speeds :math:`s_0,
    s_1` at the step's start and end, so that it turns by :math:`\varphi = \omega T` and moves
    by :math:`\mathbf d = \bar s T\,[\sin\varphi/\varphi,\ (1-\cos\varphi)/\varphi]^\top`.
    With :math:`R = R(-\varphi)` the rotation by :math:`-\varphi` and :math:`\mathbf u_i =
    [s_i, 0]^\top` the ego's velocity,

    .. math::

        \mathbf p_c = R\,(\mathbf p - \mathbf d) + \mathbf u_1 T,\qquad
        \mathbf v_c = R\,(\mathbf v + \mathbf u_0) - \mathbf u_1,

    i.e. :math:`\mathbf x_c = \mathcal T \mathbf x + \mathbf c` with :math:`\mathcal T` the
    rotation of position and velocity, and :math:`P_c = \mathcal T P \mathcal T^\top`.  The CV
    prediction :math:`\mathbf p_c + \mathbf v_c T` then equals :math:`R(\mathbf p + \mathbf w T
    - \mathbf d)` with :math:`\mathbf w = \mathbf v + \mathbf u_0` the object's ground velocity:
    exact for an object of constant ground velocity and an ego on such an arc.  An ego that
    also moved sideways by :math:`\delta` over the step without turning (SUMO's lane change
    within one step, :attr:`ObjectFrame.ego_shift
    <acc_fusion.truth.objects.ObjectFrame.ego_shift>`) has :math:`\mathbf d + [0,
    \delta]^\top` for :math:`\mathbf d`: the jump its odometry would have followed over a
    real lane change.  ``Q`` is the
    same in every rotated frame (equal on both axes), so its order does not matter.  The
    approximations: the ego's speed and yaw rate are known exactly (their errors do not enter
    :math:`P`), the ego's path over a step is a circular arc, the speed changes linearly, and a
    manoeuvring object's acceleration is white noise of density :math:`q`.  On a straight road
    at constant ego speed and without a shift the compensation is the identity.

Measurement: converted-measurement Kalman filter
    A detection :math:`(r, \theta)` (range, azimuth left positive) with declared standard
    deviations :math:`\sigma_r, \sigma_\theta` becomes the Cartesian position
    :math:`\mathbf z = [r\cos\theta,\ r\sin\theta]^\top` with covariance

    .. math::

        R_z = J\,\operatorname{diag}(\sigma_r^2, \sigma_\theta^2)\,J^\top,\qquad
        J = \begin{bmatrix} \cos\theta & -r\sin\theta \\ \sin\theta & r\cos\theta
        \end{bmatrix},

    evaluated at the measured :math:`r, \theta` — but where the sensor's range noise grows
    with range (the camera's :math:`\sigma_r = \sigma_0 + q r^2`), the range std is taken at
    the track's predicted range: declared at the measured range it is correlated with the
    measurement's error, and the weight :math:`\sigma_r^{-2} \propto \hat r^{-4}` favours
    short measurements (the camera's tracks of cars 70-120 m ahead came out 3.4 m short on
    average, and one in ten failed the association with the radar's; Bordonaro, Willett &
    Bar-Shalom, "Decorrelated unbiased converted measurement Kalman filter", *IEEE Trans.
    AES* 50(2), 2014, evaluate the whole covariance at the prediction for the same reason) —
    and updates the track linearly with
    :math:`H = \begin{bmatrix} 1&0&0&0 \\ 0&0&1&0 \end{bmatrix}` (Lerro & Bar-Shalom, "Tracking
    with debiased consistent converted measurements versus EKF", *IEEE Trans. AES* 29(3), 1993;
    Bar-Shalom, Li & Kirubarajan 2001, §10.4.3).  The conversion's bias is neglected: it is
    small when :math:`r\sigma_\theta^2/\sigma_r < 0.4` (Lerro & Bar-Shalom 1993), which holds for
    automotive radars and cameras (0.1 m at 100 m for :math:`\sigma_\theta = 0.3°`).  The
    range-rate is not used in the update; it initialises the velocity (below) and is carried to
    the 1-D filter (:mod:`acc_fusion.fusion.tracking.association`).

Association: global nearest neighbour
    Per ego, the squared Mahalanobis distance :math:`d^2 = \boldsymbol\nu^\top S^{-1}
    \boldsymbol\nu` of every track-detection pair (:math:`\boldsymbol\nu = \mathbf z - H\hat
    {\mathbf x}^-`, :math:`S = H P^- H^\top + R_z`) is gated by the chi-square gate
    :math:`\gamma` (:math:`\gamma = -2\ln(1 - P_G)` for the 2 degrees of freedom of a position,
    the gate probability :math:`P_G`), and the detections are assigned to the tracks by the
    optimal 2-D assignment with a missed-detection cost :math:`\gamma`
    (:mod:`acc_fusion.fusion.tracking.assignment`).  All tracks, tentative and confirmed,
    compete in the same assignment.

Track management (Blackman & Popoli, *Design and Analysis of Modern Tracking Systems*, 1999,
§3.3 and §6.5)
    * Birth: a detection assigned to no track starts a *tentative* track in a free slot (none
      when all ``max_tracks`` slots of the ego are used), with
      :math:`\hat{\mathbf x} = [z_x,\ \dot r\cos\theta,\ z_y,\ \dot r\sin\theta]` (the range-rate
      along the line of sight) and the covariance :math:`R_z` on the position and
      :math:`\sigma_{\dot r}^2\mathbf e\mathbf e^\top + \sigma_{v,0}^2\mathbf e_\perp\mathbf
      e_\perp^\top` on the velocity (:math:`\mathbf e` the line of sight,
      :math:`\mathbf e_\perp` across it, :math:`\sigma_{v,0}` the ``init_velocity_std``).
    * A *scan* is a frame at which the sensor is online; a track's first scan is its birth.
      M-of-N confirmation: a tentative track is confirmed once it has :math:`M` hits (frames
      with an assigned detection), and deleted as soon as it can no longer have them within
      its first :math:`N` scans (hits :math:`+ N -` scans :math:`< M`).
    * Deletion of a confirmed track after ``delete_misses`` scans in a row without a
      detection; any track is deleted after ``max_coast`` seconds without one.
    * Between the sensor's samples (``online`` false) tracks are predicted only: no miss is
      counted.
    * Every track gets an integer id that is never reused (over all egos of the tracker).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.slots import PairState, pair_mask
from acc_fusion.core.threads import blocks
from acc_fusion.core.validation import check_range
from acc_fusion.fusion.tracking.kernels import DIM, track_step, track_step_parallel
from acc_fusion.sensors.detections import Detections


@dataclass(frozen=True)
class GateConfig:
    """A chi-square gate of 2 degrees of freedom, given by its probability or its value.

    Attributes:
        gate_probability: probability :math:`P_G` that a true pair falls in the gate (default
            0.99: :math:`\\gamma = 9.21`).
        gate: the gate :math:`\\gamma` itself; when given it replaces ``gate_probability``.
    """

    #: How an error names the config.
    _NAME: ClassVar[str] = "gate"

    gate_probability: float = 0.99
    gate: float | None = None

    def __post_init__(self) -> None:
        check_range(f"{self._NAME}.gate_probability", self.gate_probability, 0.0, 1.0,
                    lo_open=True, hi_open=True)  # fmt: skip
        if self.gate is not None:
            check_range(f"{self._NAME}.gate", self.gate, 0.0, 1e6, lo_open=True)

    @property
    def gate_value(self) -> float:
        r"""The gate :math:`\gamma` in use: ``gate``, or the quantile of :math:`\chi^2_2` at
        ``gate_probability``, :math:`\gamma = -2\ln(1 - P_G)`."""
        if self.gate is not None:
            return float(self.gate)
        return -2.0 * math.log1p(-self.gate_probability)


@dataclass(frozen=True)
class TrackerConfig(GateConfig):
    """Settings of a per-sensor :class:`Tracker` (the model: module docstring), besides the
    gate of :class:`GateConfig`.

    Attributes:
        q: power spectral density of the constant-velocity model's acceleration noise per axis
            [m²/s³] (default 4.0: a relative acceleration of about ±2 m/s² over a second).
        confirm_m: hits that confirm a tentative track (M of M-of-N, default 3).
        confirm_n: scans within which a tentative track must reach ``confirm_m`` hits (N,
            default 5; Blackman & Popoli 1999, §3.3).
        delete_misses: scans in a row without a detection after which a confirmed track is
            deleted (default 3).
        max_coast: seconds without a detection after which any track is deleted (default 1.0;
            it ends tracks through a sensor dropout).
        max_tracks: track slots per ego (default 32).
        init_velocity_std: standard deviation of a new track's velocity across the line of sight
            [m/s] (default 5.0; along it the range-rate's declared std).
    """

    _NAME: ClassVar[str] = "tracker"

    q: float = 4.0
    confirm_m: int = 3
    confirm_n: int = 5
    delete_misses: int = 3
    max_coast: float = 1.0
    max_tracks: int = 32
    init_velocity_std: float = 5.0

    def __post_init__(self) -> None:
        super().__post_init__()
        check_range("tracker.q", self.q, 0.0, 1e4)
        for name, hi in (("confirm_m", 64), ("confirm_n", 64), ("delete_misses", 1000),
                         ("max_tracks", 4096)):  # fmt: skip
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or not 1 <= value <= hi:
                raise ConfigError(f"tracker.{name} must be a whole number in [1, {hi}], got "
                                  f"{value!r}")  # fmt: skip
        if self.confirm_m > self.confirm_n:
            raise ConfigError(
                f"tracker.confirm_m must be <= confirm_n, got {self.confirm_m} of {self.confirm_n}"
            )
        check_range("tracker.max_coast", self.max_coast, 0.0, 1e6, lo_open=True)
        check_range("tracker.init_velocity_std", self.init_velocity_std, 0.0, 1e3, lo_open=True)


@dataclass(frozen=True)
class Tracks:
    """A tracker's tracks of E egos after one frame, in ``(E, T)`` slots (``T`` =
    ``max_tracks``; a track keeps its slot for life; nothing is meaningful where not ``valid``).

    Attributes:
        t: frame time [s].
        sensor: the sensor's name.
        valid: ``(E, T)`` bool, the slot holds a track (tentative or confirmed).
        confirmed: ``(E, T)`` bool, the track passed the M-of-N test.
        track_id: ``(E, T)`` int64, the track's id, unique over the tracker's life.
        state: ``(E, T, 4)`` ``[x, vx, y, vy]`` in the ego frame [m, m/s] (relative velocity).
        cov: ``(E, T, 4, 4)`` its covariance.
        detection: ``(E, T)`` int64, the index into this frame's
            :class:`~acc_fusion.sensors.detections.Detections` of the detection that updated
            (or started) the track at this frame, -1 if none.
        hits: ``(E, T)`` int64, frames with a detection since birth (the birth included).
        misses: ``(E, T)`` int64, scans in a row without a detection.
        age: ``(E, T)`` seconds since birth.
        object_id: ``(E, T)`` int64, the truth object id of the last detection the track took
            (-1 for ghosts and clutter): diagnostics and metrics only.
    """

    t: float
    sensor: str
    valid: np.ndarray
    confirmed: np.ndarray
    track_id: np.ndarray
    state: np.ndarray
    cov: np.ndarray
    detection: np.ndarray
    hits: np.ndarray
    misses: np.ndarray
    age: np.ndarray
    object_id: np.ndarray


#: Egos from which a frame's tracks are updated on all of numba's threads
#: (:func:`~acc_fusion.fusion.tracking.kernels.track_step_parallel`).  On two cores, with
#: A10KW's egos at 250 s (about 20 tracks each), the threads saved nothing at 16 egos and a
#: third of the time at 64 (a throwaway probe, 2026-11-27); the association uses it too.
PARALLEL_EGOS = 64


#: The integer per-track arrays of a :class:`Tracker`, in the order of its ``_int`` rows.
_INTS = ("track_id", "detection", "hits", "misses", "scans", "object_id")


class Tracker(PairState):
    """A multi-target tracker of one sensor over E egos (the model: module docstring).

    :meth:`forget` drops the tracks of some egos (a slot that got a new vehicle);
    :meth:`resize` makes it track the first m egos only (:mod:`acc_fusion.core.slots`).

    Args:
        sensor: the sensor's name (the :class:`Detections` it takes must carry it).
        config: the :class:`TrackerConfig`.
        n_egos: number of egos E.

    Example:
        >>> import numpy as np
        >>> from acc_fusion.sensors.detections import Detections
        >>> tracker = Tracker("radar", TrackerConfig(), n_egos=1)
        >>> one = np.ones(1)
        >>> det = Detections(0.0, "radar", 1, True, np.zeros(1, np.int64), 40 * one, 0 * one,
        ...                  -2 * one, 0.2 * one, 0.005 * one, 0.1 * one,
        ...                  np.array([7]), np.zeros(1, np.int8))
        >>> tracks = tracker.step(det, ego_speed=np.array([20.0]), ego_yaw_rate=np.zeros(1),
        ...                       dt=0.05)
        >>> int(tracks.valid.sum()), bool(tracks.confirmed.any()), float(tracks.state[0, 0, 0])
        (1, False, 40.0)
    """

    _PAIR_AXES = {"_x": 0, "_p": 0, "_valid": 0, "_confirmed": 0, "_int": 1, "_age": 0,
                  "_coast": 0, "_speed": 0}  # fmt: skip

    def __init__(self, sensor: str, config: TrackerConfig, n_egos: int) -> None:
        if not isinstance(config, TrackerConfig):
            raise ConfigError(f"config must be a TrackerConfig, got {type(config).__name__}")
        if not isinstance(n_egos, (int, np.integer)) or n_egos < 1:
            raise ConfigError(f"n_egos must be a whole number >= 1, got {n_egos!r}")
        self.sensor = str(sensor)
        self.config = config
        self.n_egos = int(n_egos)
        c = config
        self._params = (
            float(c.q), c.gate_value, c.confirm_m, c.confirm_n, c.delete_misses,
            float(c.max_coast), float(c.init_velocity_std) ** 2,
        )  # fmt: skip
        self.reset()

    def reset(self) -> None:
        """Forget every track (ids continue to count up, so they are never reused)."""
        e, t = self.n_egos, self.config.max_tracks
        self._x, self._p = np.zeros((e, t, DIM)), np.zeros((e, t, DIM, DIM))
        self._valid, self._confirmed = np.zeros((e, t), bool), np.zeros((e, t), bool)
        self._int = np.full((len(_INTS), e, t), -1, np.int64)
        self._age, self._coast = np.zeros((e, t)), np.zeros((e, t))
        self._speed = np.full(e, np.nan)  # the last step's ego speed (NaN: none yet)
        self._next_id = getattr(self, "_next_id", np.zeros(1, np.int64))
        self.__dict__.pop("_parked", None)

    def forget(self, egos: np.ndarray) -> None:
        """Drop every track of ``egos`` (a boolean mask ``(E,)`` or indices), e.g. a slot that
        a new vehicle took; their ids are never reused."""
        egos = pair_mask(egos, self.n_egos)
        self._valid[egos] = self._confirmed[egos] = False
        self._int[:, egos] = -1
        self._x[egos], self._p[egos], self._age[egos], self._coast[egos] = 0.0, 0.0, 0.0, 0.0
        self._speed[egos] = np.nan

    def _resized(self, m: int) -> None:
        self.n_egos = m

    def step(
        self,
        detections: Detections,
        ego_speed: np.ndarray,
        ego_yaw_rate: np.ndarray,
        dt: float,
        copy: bool = True,
        ego_shift: np.ndarray | None = None,
    ) -> Tracks:
        """Advance every ego's tracks by ``dt`` seconds to ``detections.t`` and take the frame.

        ``ego_speed (E,)`` [m/s] and ``ego_yaw_rate (E,)`` [rad/s, left positive] are the ego's
        at the frame's time (the speed of the previous call is the step's start), and
        ``ego_shift (E,)`` [m, left positive] its sideways jump over the step (module
        docstring; default none); call it at every frame, also when the sensor is offline.
        The :class:`Tracks` are a copy, or with ``copy`` false views of the tracker's arrays,
        which its next step changes (for a caller that reads them before: the 2-D pipeline).
        """
        det = self._check(detections)
        e = self.n_egos
        speed = check_array("ego_speed", ego_speed, (e,))
        yaw = check_array("ego_yaw_rate", ego_yaw_rate, (e,))
        shift = np.zeros(e) if ego_shift is None else check_array("ego_shift", ego_shift, (e,))
        dt = check_range("dt", dt, 0.0, 1e3)
        speed0 = np.where(np.isnan(self._speed), speed, self._speed)
        self._speed = speed.copy()
        rows = det.rows()
        widest = int(np.diff(rows).max()) if det.count else 0
        i = self._int
        args = (
            self._x, self._p, self._valid, self._confirmed, *i, self._age, self._coast, rows,
            det.range, det.azimuth, det.range_rate, det.range_std, det.azimuth_std,
            det.range_rate_std, det.range_std_growth, det.object_id, bool(det.online),
            np.ascontiguousarray(speed0),
            np.ascontiguousarray(speed), np.ascontiguousarray(yaw),
            np.ascontiguousarray(shift), dt, self._params,
            self._next_id, widest,
        )  # fmt: skip
        chunks = blocks(e, PARALLEL_EGOS)
        track_step_parallel(*args, chunks) if chunks else track_step(*args)
        arrays = {"valid": self._valid, "confirmed": self._confirmed, "track_id": i[0],
                  "state": self._x, "cov": self._p, "detection": i[1], "hits": i[2],
                  "misses": i[3], "age": self._age, "object_id": i[5]}  # fmt: skip
        if copy:
            arrays = {name: a.copy() for name, a in arrays.items()}
        return Tracks(t=float(det.t), sensor=self.sensor, **arrays)

    def _check(self, detections: Detections) -> Detections:
        if not isinstance(detections, Detections):
            raise InputError(f"step() needs Detections, got {type(detections).__name__}")
        if detections.sensor != self.sensor or detections.n_egos != self.n_egos:
            raise InputError(
                f"the {self.sensor} tracker of {self.n_egos} egos got the {detections.sensor} "
                f"detections of {detections.n_egos}"
            )
        return detections
