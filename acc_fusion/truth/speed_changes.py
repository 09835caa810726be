r"""Scripted speed changes of the 2-D scenes' actors: transitions of a given shape from one
speed to another, added to an actor's base motion (:class:`acc_fusion.truth.scenes.Actors`).

A change :math:`k` starts at :math:`t_k`, lasts :math:`T_k` and changes the speed by
:math:`\Delta v_k` along a shape :math:`f` of :math:`u = (t - t_k)/T_k \in [0, 1]`
(0 before the change, 1 after).  The shapes are the ``DynamicsShape`` of an OpenSCENARIO
``TransitionDynamics`` (ASAM OpenSCENARIO XML 1.3 schema), with the constraints the standard
gives them (cubic and sinusoidal: zero gradient at both ends):

==============  =====================================  =====================================
shape           :math:`f(u)`                           :math:`F(u) = \int_0^u f`
==============  =====================================  =====================================
``step``        1 from :math:`t_k` on (:math:`T = 0`)  —
``linear``      :math:`u`                              :math:`u^2/2`
``cubic``       :math:`3u^2 - 2u^3` (zero gradient at  :math:`u^3 - u^4/2`
                both ends)
``sinusoidal``  :math:`(1 - \cos \pi u)/2` (zero       :math:`u/2 - \sin(\pi u)/(2\pi)`
                gradient at both ends)
==============  =====================================  =====================================

The changes add to the speed, distance and acceleration of the base motion:
:math:`v = v_b + \sum_k \Delta v_k f(u_k)`,
:math:`s = s_b + \sum_k \Delta v_k \left(T_k F(u_k) + \max(t - t_k - T_k, 0)\right)`,
:math:`a = a_b + \sum_k \Delta v_k f'(u_k)/T_k` inside a change (a step has no acceleration).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The shapes, by their code in :attr:`SpeedChanges.shape`.
SHAPES = ("step", "linear", "cubic", "sinusoidal")


@dataclass(frozen=True)
class SpeedChanges:
    """The speed changes of a batch's actors, arrays ``(N, A, K)`` (runs × actors × changes;
    unused entries have ``delta`` 0).

    Attributes:
        start: when each change starts [s].
        duration: how long it lasts [s] (0 for a step).
        delta: the change of speed [m/s].
        shape: the index of its shape in :data:`SHAPES`.
    """

    start: np.ndarray
    duration: np.ndarray
    delta: np.ndarray
    shape: np.ndarray

    def apply(self, t, s, v, a) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The base motion's arc length, speed and acceleration ``(N, A)`` at time ``t``
        (scalar, or ``(N, 1)`` each run's own) with the changes added (module docstring)."""
        t = np.asarray(t, dtype=float)
        elapsed = (t[..., None] if t.ndim else t) - self.start
        T = self.duration
        ramp = T > 0.0
        u = np.where(ramp, np.clip(elapsed / np.where(ramp, T, 1.0), 0.0, 1.0), elapsed >= 0.0)
        shape = self.shape
        f = np.select(
            [shape == 2, shape == 3], [3 * u**2 - 2 * u**3, 0.5 - 0.5 * np.cos(np.pi * u)], u
        )
        big_f = np.select(
            [shape == 1, shape == 2, shape == 3],
            [u**2 / 2, u**3 - u**4 / 2, u / 2 - np.sin(np.pi * u) / (2 * np.pi)],
            0.0,
        )
        slope = np.select(
            [shape == 2, shape == 3], [6 * u - 6 * u**2, 0.5 * np.pi * np.sin(np.pi * u)], 1.0
        )
        inside = ramp & (u > 0.0) & (u < 1.0)
        dv = self.delta
        ds = dv * (T * big_f + np.maximum(elapsed - T, 0.0))
        rate = np.where(inside, dv * slope / np.where(ramp, T, 1.0), 0.0)
        return s + ds.sum(axis=-1), v + (dv * f).sum(axis=-1), a + rate.sum(axis=-1)
