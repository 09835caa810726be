"""Scripted 2-D scenes for the tracking tests: objects of constant ground velocity seen from egos
that drive (and turn), turned into one sensor's :class:`Detections` per frame."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from acc_fusion.sensors.detections import CLUTTER, Detections


@dataclass
class Scene:
    """Objects in a world frame and egos driving at constant yaw rate, and at constant speed
    or, on a straight road, constant acceleration.

    ``objects[e]`` rows: ``(object_id, X0, Y0, VX, VY)`` (world position at t = 0 and ground
    velocity) for ego ``e``, which starts at the world origin heading along X.
    """

    objects: list[np.ndarray]
    speed: np.ndarray
    yaw_rate: np.ndarray
    appear: dict[int, float] = field(default_factory=dict)  # object id -> first time seen
    accel: np.ndarray | None = None  # (E,) [m/s²], egos with a zero yaw rate only

    def speed_at(self, t: float) -> np.ndarray:
        """``(E,)`` the egos' speeds at ``t``."""
        return self.speed if self.accel is None else self.speed + self.accel * t

    @property
    def n_egos(self) -> int:
        return len(self.objects)

    def ego_pose(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(E,)`` world X, Y and heading of each ego's bumper at ``t`` (an arc)."""
        w, s = self.yaw_rate, self.speed
        h = w * t
        safe = np.where(w == 0, 1.0, w)
        a = np.zeros_like(s) if self.accel is None else self.accel
        assert not np.any((a != 0) & (w != 0)), "a turning ego keeps its speed"
        x = np.where(w == 0, s * t + a * t * t / 2, s * np.sin(h) / safe)
        y = np.where(w == 0, 0.0, s * (1 - np.cos(h)) / safe)
        return x, y, h

    def truth(self, t: float, e: int) -> tuple[np.ndarray, ...]:
        """Ego ``e``'s visible objects at ``t`` in its frame: ids, x, y, vx, vy (relative)."""
        ex, ey, h = (a[e] for a in self.ego_pose(t))
        o = self.objects[e]
        seen = np.array([self.appear.get(int(i), -np.inf) <= t for i in o[:, 0]], bool)
        o = o[seen]
        px, py = o[:, 1] + o[:, 3] * t - ex, o[:, 2] + o[:, 4] * t - ey
        c, s = np.cos(h), np.sin(h)
        speed = self.speed_at(t)[e]
        vx = o[:, 3] - speed * c
        vy = o[:, 4] - speed * s
        rot = (c * px + s * py, -s * px + c * py, c * vx + s * vy, -s * vx + c * vy)
        return (o[:, 0].astype(np.int64), *rot)

    def world(self, t: float, e: int, x: np.ndarray) -> np.ndarray:
        """Ego-frame positions ``x (..., 2)`` of ego ``e`` at ``t`` in world coordinates."""
        ex, ey, h = (a[e] for a in self.ego_pose(t))
        c, s = np.cos(h), np.sin(h)
        return np.stack(
            [ex + c * x[..., 0] - s * x[..., 1], ey + s * x[..., 0] + c * x[..., 1]], -1
        )


STD = (0.3, 0.003, 0.1)  # range [m], azimuth [rad], range-rate [m/s]


def detect(
    scene: Scene,
    t: float,
    sensor: str,
    rng: np.random.Generator,
    online: bool = True,
    p_detect: float = 1.0,
    clutter: int = 0,
    std: tuple[float, float, float] = STD,
    noise: bool = True,
) -> Detections:
    """One frame of ``sensor``: each visible object detected with ``p_detect`` plus ``clutter``
    false detections per ego, uniform in 10-80 m and ±0.3 rad."""
    cols = {k: [] for k in ("ego", "r", "a", "rr", "obj", "origin")}
    if online:
        for e in range(scene.n_egos):
            ids, x, y, vx, vy = scene.truth(t, e)
            r = np.hypot(x, y)
            keep = rng.random(ids.size) < p_detect
            n = int(keep.sum())
            scale = np.asarray(std) if noise else np.zeros(3)
            eps = rng.standard_normal((3, n)) * scale[:, None]
            cols["r"].append(r[keep] + eps[0])
            cols["a"].append(np.arctan2(y, x)[keep] + eps[1])
            cols["rr"].append(((x * vx + y * vy) / r)[keep] + eps[2])
            cols["obj"].append(ids[keep])
            cols["origin"].append(np.zeros(n, np.int8))
            cols["r"].append(rng.uniform(10, 80, clutter))
            cols["a"].append(rng.uniform(-0.3, 0.3, clutter))
            cols["rr"].append(rng.uniform(-30, 5, clutter))
            cols["obj"].append(np.full(clutter, -1, np.int64))
            cols["origin"].append(np.full(clutter, CLUTTER, np.int8))
            cols["ego"].append(np.full(n + clutter, e, np.int64))
    flat = {k: np.concatenate(v) if v else np.zeros(0) for k, v in cols.items()}
    k = flat["r"].size
    return Detections(
        t, sensor, scene.n_egos, online, flat["ego"].astype(np.int64), flat["r"], flat["a"],
        flat["rr"], np.full(k, std[0]), np.full(k, std[1]), np.full(k, std[2]),
        flat["obj"].astype(np.int64), flat["origin"].astype(np.int8),
    )  # fmt: skip
