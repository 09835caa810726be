"""Making a :class:`~acc_fusion.truth.frame.TruthFrame` from what was read of SUMO
(:class:`FrameMaker`): bumper-to-bumper gaps (SUMO's leader gap plus the follower's minGap),
the leaders' speeds and accelerations, new vehicles' slots."""

from __future__ import annotations

import numpy as np
from numba import njit

from acc_fusion.truth.frame import TruthFrame


class FrameMaker:
    r"""The :class:`TruthFrame` of each step of a SUMO source, from the values read at that
    step for the occupied slots (:meth:`SumoSource._fill`) and what the frames need from
    earlier steps: each slot's ``minGap`` and SUMO's acceleration of its vehicle, read once
    when the vehicle takes the slot, and each slot's speed at the previous step.  A
    :class:`SumoSource` makes its frames with one; the parent process of a
    :class:`~acc_fusion.truth.sumo.background.BackgroundSumoSource` makes them with another, of
    the values SUMO's process sends (so that process does not make frames).

    Args:
        n_pairs: number of slots N.
        dt: simulation step [s].
        lookahead: leaders farther than this are not reported [m].
    """

    def __init__(self, n_pairs: int, dt: float, lookahead: float) -> None:
        self.n_pairs, self.dt, self.lookahead = n_pairs, dt, lookahead
        self._min_gap = np.zeros(n_pairs)
        self._new_accel = np.full(n_pairs, np.nan)  # SUMO's, for the slots taken at this step
        self._prev_speed = np.zeros(n_pairs)

    def make(
        self,
        t: float,
        slots: np.ndarray,
        speed: np.ndarray,
        dists: np.ndarray,
        codes: np.ndarray,
        news: dict[int, tuple[float, float]],
        others: dict[int, tuple[float, float]],
        accel: np.ndarray | None = None,
    ) -> TruthFrame:
        """The frame at time ``t`` of the vehicles in ``slots`` (ascending), of their
        ``speed``, their leader's distance ``dists`` and code ``codes``
        (:meth:`SumoSource._set_code`; ``-1``: none) as :func:`_frame_arrays` takes them, the
        slots taken at this step (``news``: slot to the vehicle's minGap and acceleration)
        and the speed and acceleration of the leaders that hold no slot (``others``, by
        position in ``slots``).  ``accel``: ``(N,)`` accelerations read for every vehicle
        (TraCI), instead of those of ``news`` and the speeds' differences."""
        for slot, (min_gap, new_accel) in news.items():  # usually none
            self._min_gap[slot], self._new_accel[slot] = min_gap, new_accel
        block, leader, other = _frame_arrays(
            self.n_pairs,
            slots,
            speed,
            self._new_accel if accel is None else accel,
            self._prev_speed,
            self.dt,
            dists,
            codes,
            self._min_gap,
            self.lookahead,
        )
        if other.size:
            lead = [others[i] for i in other.tolist()]
            at = slots[other]
            block[3, at] = [v for v, _ in lead]
            block[4, at] = [a for _, a in lead]
        self._prev_speed = block[0].copy()
        if news:
            self._new_accel[list(news)] = np.nan
        return TruthFrame.from_arrays(t, *block[:5], leader, lateral_offset=block[5])


@njit(cache=True)
def _frame_arrays(
    n, slots, speed, accel, prev_speed, dt, dists, codes, min_gap, lookahead
):  # pragma: no cover - compiled
    r"""The ``(N,)`` arrays of a frame from the values read for the vehicles in ``slots``.

    Per vehicle ``i`` in slot ``s = slots[i]``: its ``speed[i]``; its acceleration
    ``accel[s]`` where SUMO's was read (NaN elsewhere), else
    :math:`(v_k - v_{k-1})/\Delta t` from ``prev_speed[s]`` (SUMO's ``getAcceleration``
    exactly); its leader, of code ``codes[i]`` (:meth:`SumoSource._set_code`: integer id and
    slot; ``-1``: none), at the bumper-to-bumper gap ``dists[i] + min_gap[s]``
    (``getLeader``'s distance plus the follower's ``minGap``), kept up to ``lookahead``,
    whose speed and acceleration are those of its slot.  Empty slots: speed and
    acceleration 0, the rest NaN and leader ``-1``.  Returns the rows ``ego_speed,
    ego_accel, gap, lead_speed, lead_accel, lateral_offset`` (0) of one ``(6, N)`` block, the
    ``leader_id`` and the positions ``i`` whose kept leader has no slot (an unequipped
    vehicle, whose speed and acceleration the caller fills in).
    """
    block = np.empty((6, n))
    block[:2] = 0.0
    block[2:5] = np.nan
    block[5] = 0.0
    ego_v, ego_a, gap, lead_v, lead_a = block[0], block[1], block[2], block[3], block[4]
    leader = np.full(n, -1, dtype=np.int64)
    for i in range(slots.size):
        s = slots[i]
        ego_v[s] = speed[i]
        a = accel[s]
        ego_a[s] = a if not np.isnan(a) else (speed[i] - prev_speed[s]) / dt
    other = np.empty(slots.size, dtype=np.intp)
    k = 0
    for i in range(slots.size):
        s, g, code = slots[i], dists[i] + min_gap[slots[i]], codes[i]
        if code >= 0 and g <= lookahead:
            leader[s], gap[s] = code // (n + 1), g
            j = code % (n + 1) - 1
            if j >= 0:
                lead_v[s], lead_a[s] = ego_v[j], ego_a[j]
            else:
                other[k] = i
                k += 1
    return block, leader, other[:k]
