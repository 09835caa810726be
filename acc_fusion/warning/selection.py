r"""In-path target selection: which of the objects ahead the warning judges.

Among the fused objects of each ego, the selected one is the nearest object ahead whose
lateral position lies within a corridor around the ego's *predicted path*; the warning sees
that object's gap, range-rate and acceleration.  Choosing the wrong object — an adjacent-lane
car on the straight extension of the path before a curve, a parked car on the shoulder, an
overhead gantry, a cut-in taken late — is the main source of false and nuisance alerts in
the field, and this module is where the tool reproduces it.

Path prediction (``path``)
    The path is a circular arc of curvature :math:`\kappa` through the ego, tangent to its
    heading; at longitudinal distance :math:`x` its lateral offset is, for
    :math:`|\kappa x| \ll 1`,

    .. math::

        y_p(x) = \tfrac12\,\kappa\,x^2 .

    ``"straight"``: :math:`\kappa = 0`; ``"yaw_rate"``: :math:`\kappa = \dot\psi / v` from the
    yaw-rate gyro and the speed — the classic FCW/ACC path estimate, which assumes that the
    present curvature continues, so it is wrong at curve entry and exit (the limitation that
    motivates path prediction from more sources in Polychronopoulos, Tsogas, Amditis &
    Andreone, "Sensor fusion for predicting vehicles' path for collision avoidance systems",
    IEEE Trans. Intelligent Transportation Systems 8(3), 2007);
    ``"lane"``: :math:`\kappa` of the ego lane at the ego (a lane-aware system that knows the
    road ahead, e.g. from a camera's lane model or a map; it still assumes constant curvature
    over the field).

Corridor (``half_width``)
    An object is in path when :math:`|y - y_p(x)| \le w/2`; the default :math:`w/2` = 1.75 m
    is half a 3.5 m lane (an assumption: ISO 15623:2013, the FVCWS standard, asks the system to
    discriminate targets in the subject vehicle's lane without fixing a corridor width).

Stationary objects (``stationary``)
    A track whose estimated ground speed is below ``stationary_speed`` is stationary.
    ``"all"``: stationary objects are selectable like any other; ``"ignore"``: never (the
    policy of early radar-only ACC/FCW, which therefore misses a stopped car); ``"confirmed"``
    (default): selectable only when a classifying sensor (the thermal camera's vehicle
    detector) confirms the object, or when the object was seen moving since it was first
    tracked — the radar alone then ignores gantries, bridges and parked cars, and with them a
    car revealed standing still.

Oncoming objects (``oncoming``)
    A track whose estimated ground speed is below :math:`-`\ ``stationary_speed`` comes
    toward the ego.  An FCW warns of rear-end collisions with vehicles ahead (ISO 15623:2013,
    scope: "a potential rear-end collision with other vehicles ahead of the subject
    vehicle"), so by default (``oncoming = False``) such a track is never selected; ``True``
    makes it selectable, to study what the scope leaves out.  Without the rule, a path
    predicted from a noisy yaw rate swept the other carriageway's traffic, well ahead and
    closing at both speeds, into the corridor: most of the 2-D pipeline's sensing-false
    alerts on the bundled motorway (2026-11-27, docs/guide/world.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from acc_fusion.core.errors import InputError
from acc_fusion.core.slots import PairState
from acc_fusion.core.validation import broadcast, check_choice, check_range

#: Path models (see the module docstring).
PATHS = ("straight", "yaw_rate", "lane")
#: Policies for stationary objects.
STATIONARY_POLICIES = ("all", "confirmed", "ignore")
#: The stationary policies as the compiled selection takes them.
_CONFIRMED, _IGNORE = STATIONARY_POLICIES.index("confirmed"), STATIONARY_POLICIES.index("ignore")
#: Widest half corridor the selection accepts [m].
MAX_HALF_WIDTH = 20.0


@dataclass(frozen=True)
class SelectionConfig:
    """In-path selection settings (see the module docstring for the sources).

    Attributes:
        path: ``"straight"``, ``"yaw_rate"`` (default) or ``"lane"``.
        half_width: half the in-path corridor [m]; 1.75 (half a 3.5 m lane; assumption).
        stationary: ``"all"``, ``"confirmed"`` (default) or ``"ignore"``.
        stationary_speed: ground speed below which a track is stationary [m/s]; 2.0
            (assumption: above the speed noise of a converged track).
        oncoming: select tracks coming toward the ego (ground speed below
            ``-stationary_speed``); False (ISO 15623's rear-end scope).
        min_speed: speed below which the yaw-rate curvature is not formed [m/s]; 1.0.
    """

    path: str = "yaw_rate"
    half_width: float = 1.75
    stationary: str = "confirmed"
    stationary_speed: float = 2.0
    oncoming: bool = False
    min_speed: float = 1.0

    def __post_init__(self) -> None:
        check_choice("selection.path", self.path, PATHS)
        check_choice("selection.stationary", self.stationary, STATIONARY_POLICIES)
        check_range("selection.half_width", self.half_width, 0.0, MAX_HALF_WIDTH, lo_open=True)
        check_range("selection.stationary_speed", self.stationary_speed, 0.0, 50.0)
        check_range("selection.min_speed", self.min_speed, 0.0, 50.0, lo_open=True)


def path_curvature(
    config: SelectionConfig, speed: np.ndarray, yaw_rate: np.ndarray, road_curvature: np.ndarray
) -> np.ndarray:
    """``(E,)`` curvature [1/m] of each ego's predicted path under ``config.path``."""
    if config.path == "straight":
        return np.zeros_like(speed)
    if config.path == "lane":
        return np.array(road_curvature, dtype=float)
    return np.where(speed >= config.min_speed, yaw_rate / np.maximum(speed, config.min_speed), 0.0)


class InPathSelector(PairState):
    """Selects the in-path object of E egos among F object slots each, step by step.

    It remembers, per slot, whether the object in it has been seen moving (a slot's memory
    starts afresh when its object id changes).  After each :meth:`step` it holds that step's
    path and corridor for observers (the world environment's observation): ``curvature (E,)``
    of the predicted path [1/m], ``offset (E, F)`` each object's lateral offset from it,
    :math:`y - y_p(x)` [m], ``in_path (E, F)`` the objects it could select and ``selected
    (E,)`` the slot it returned.
    """

    _PAIR_AXES = {"_ids": 0, "_moved": 0}

    def __init__(self, config: SelectionConfig, n_egos: int, n_slots: int) -> None:
        self.config = config
        self._ids = np.full((n_egos, n_slots), -1, dtype=np.int64)
        self._moved = np.zeros((n_egos, n_slots), dtype=bool)
        self.curvature = np.zeros(n_egos)
        self.offset = np.zeros((n_egos, n_slots))
        self.in_path = np.zeros((n_egos, n_slots), dtype=bool)
        self.selected = np.full(n_egos, -1, dtype=np.int64)

    def forget(self, egos: np.ndarray) -> None:
        """Forget what was seen of the objects of ``egos`` (a boolean mask ``(E,)``), e.g. a
        slot that a new vehicle took."""
        self._ids[egos] = -1
        self._moved[egos] = False

    def step(
        self,
        object_id: np.ndarray,
        x: np.ndarray,
        y: np.ndarray,
        ground_speed: np.ndarray,
        confirmed: np.ndarray,
        speed: np.ndarray,
        yaw_rate: np.ndarray,
        road_curvature: np.ndarray,
    ) -> np.ndarray:
        """The selected slot of each ego, ``(E,)`` int64, ``-1`` where none is in path.

        Args:
            object_id: ``(E, F)`` id of the object in each slot, ``-1`` for an empty slot.
            x, y: ``(E, F)`` estimated position in the ego frame [m].
            ground_speed: ``(E, F)`` estimated ground speed of the object [m/s].
            confirmed: ``(E, F)`` a classifying sensor confirms the object as a vehicle.
            speed, yaw_rate, road_curvature: ``(E,)`` ego speed [m/s], measured yaw rate
                [rad/s] and the ego lane's curvature [1/m] (used by ``path="lane"`` only).
        """
        cfg = self.config
        object_id = np.asarray(object_id)
        if object_id.shape != self._ids.shape:
            raise InputError(f"object_id must have shape {self._ids.shape}, got {object_id.shape}")
        n, f = object_id.shape
        grid = {name: broadcast(name, a, (n, f), t) for name, a, t in (
            ("x", x, float), ("y", y, float), ("ground_speed", ground_speed, float),
            ("confirmed", confirmed, bool))}  # fmt: skip
        kappa = path_curvature(cfg, speed, yaw_rate, road_curvature)
        self.curvature = broadcast("the path curvature", kappa, (n,), float)
        self.offset, self.in_path = np.empty((n, f)), np.empty((n, f), dtype=bool)
        self.selected = np.empty(n, dtype=np.int64)
        _select(
            object_id.astype(np.int64, copy=False), *grid.values(), self.curvature,
            cfg.half_width, cfg.stationary_speed, cfg.oncoming,
            STATIONARY_POLICIES.index(cfg.stationary), self._ids, self._moved, self.offset,
            self.in_path, self.selected,
        )  # fmt: skip
        return self.selected


@njit(cache=True)
def _select(
    object_id, x, y, ground, confirmed, kappa, half_width, still, oncoming, policy, ids, moved,
    offset, in_path, selected,
):  # pragma: no cover - compiled  # fmt: skip
    r""":meth:`InPathSelector.step` of every ego, one pass over its slots: the memory ``ids``,
    ``moved`` in place; ``offset`` :math:`= y - \kappa x^2/2`, ``in_path`` and ``selected``
    (the nearest in-path slot, the first of equals; -1 for none) written.  ``policy``: the
    index of the stationary policy in :data:`STATIONARY_POLICIES`."""
    n, f = object_id.shape
    for e in range(n):
        best, nearest = -1, np.inf
        for k in range(f):
            oid = object_id[e, k]
            used = oid >= 0
            if oid != ids[e, k]:  # a new object in the slot: not yet seen moving
                moved[e, k] = False
            ids[e, k] = oid
            stationary = abs(ground[e, k]) < still
            moved[e, k] = moved[e, k] or (used and not stationary)
            xk = x[e, k]
            off = y[e, k] - 0.5 * kappa[e] * xk * xk
            offset[e, k] = off
            ok = used and xk > 0.0 and abs(off) <= half_width
            if not oncoming:
                ok = ok and ground[e, k] > -still
            if policy == _IGNORE:
                ok = ok and not stationary
            elif policy == _CONFIRMED:
                ok = ok and (not stationary or confirmed[e, k] or moved[e, k])
            in_path[e, k] = ok
            if ok and xk < nearest:
                best, nearest = k, xk
        selected[e] = best
