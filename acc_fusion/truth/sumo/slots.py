"""The slots of :class:`~acc_fusion.truth.sumo.source.SumoSource`: which equipped vehicle is on
which pair index.

A fraction ``penetration`` of the vehicles is *equipped* with FCW (drawn per vehicle from the seed).
Each equipped vehicle present in the network occupies one of ``capacity`` *slots*, the pair axis N
of every array (``N = capacity``, fixed for the whole run). A slot is freed when its vehicle
arrives, leaves the network, is removed after a collision or starts a teleport; the next vehicle put
in it is flagged in :attr:`~acc_fusion.truth.sumo.source.SumoSource.reassigned` at that step, so the
FCW loop resets its per-slot state (filters, warning logic, driver). A slot freed at a step is
reused at the next step at the earliest, so that a collision stays visible in
:attr:`~acc_fusion.truth.sumo.source.SumoSource.collided` for at least one frame. Empty slots have
``leader_id = -1``, ``ego_speed = 0`` and are not
:attr:`~acc_fusion.truth.sumo.source.SumoSource.active`. When more equipped vehicles are present
than slots, the extra ones wait (a warning is issued once) and take the first slot that frees."""

from __future__ import annotations

import bisect
import heapq
import math
import warnings

import numpy as np

#: Steps between two checks for vehicles that left without an event (bounded memory).
SWEEP_STEPS = 1000


class SumoSlots:
    """The slot bookkeeping of :class:`~acc_fusion.truth.sumo.source.SumoSource` (a base class of
    it: the methods use the source's SUMO module, configuration and vehicle tables)."""

    def _set_code(self, vid: str, slot: int = -1) -> None:
        """Record the code of ``vid``'s integer id and slot (``-1``: none), ``id * (N + 1) +
        slot + 1``: :meth:`_fill` finds both for every leader with one dict lookup."""
        self._code[vid] = self._info[vid][0] * (self.n_pairs + 1) + slot + 1

    def _new_int(self) -> int:
        self._next_int += 1
        return self._next_int - 1

    def _leave(self, vid: str, freed: list[int], arrived: bool) -> None:
        slot = self._slot_of.get(vid)
        if slot is not None:
            self._free_slot(slot, vid, freed)
        self._waiting.pop(vid, None)
        if arrived:  # gone: nothing to restore
            self._info.pop(vid, None)
            self._code.pop(vid, None)
            self._teleporting.discard(vid)
            self._ctrl.pop(vid, None)
            self._mode.pop(vid, None)
            self._hazards.pop(vid, None)
        else:  # teleporting: it comes back under SUMO's control
            self._teleporting.add(vid)
            self._end_hazard(vid)
            self._release(vid)

    def _free_slot(self, slot: int, vid: str, freed: list[int]) -> None:
        if self.config.ssm:
            self._ssm_min[vid] = min(self._ssm_min.get(vid, math.inf), float(self._ssm_slot[slot]))
        self._slot_vid[slot] = None
        self._slot_of.pop(vid, None)
        i = bisect.bisect_left(self._occ_list, slot)
        del self._occ_list[i], self._occ_vids[i]
        self._flips.append((slot, False))
        if vid in self._info:
            self._set_code(vid)
        freed.append(slot)

    def _assign(self) -> None:
        """Put waiting equipped vehicles into free slots (lowest slot first, FIFO)."""
        if not self._waiting:
            return
        veh = self._api.vehicle
        while self._waiting and self._free:
            vid = next(iter(self._waiting))
            del self._waiting[vid]
            slot = heapq.heappop(self._free)
            self._slot_vid[slot] = vid
            self._slot_of[vid] = slot
            i = bisect.bisect_left(self._occ_list, slot)
            self._occ_list.insert(i, slot)
            self._occ_vids.insert(i, vid)
            self._flips.append((slot, True))
            self._set_code(vid, slot)
            self._reassigned[slot] = True
            self._collided[slot] = False
            self._collision_speed[slot] = np.nan
            self._shown_level[slot] = -1
            self._ssm_slot[slot] = np.inf
            min_gap = float(veh.getMinGap(vid))
            # TraCI subscribes to every vehicle's acceleration (_fill reads them all).
            accel = math.nan if self._subscribed else float(veh.getAcceleration(vid))
            self._news[slot] = (min_gap, accel)
            self._inattentive[slot] = self._info[vid][2]
        if self._waiting and not self._capacity_warned:
            self._capacity_warned = True
            warnings.warn(
                f"more than capacity = {self.n_pairs} equipped vehicles are in the network "
                f"at t = {self._t:g} s; the others wait for a free slot (raise "
                "SumoConfig.capacity)",
                RuntimeWarning,
                stacklevel=5,
            )

    def _sweep(self) -> bool:
        """Forget vehicles that left without an event (e.g. removed by another TraCI user);
        returns whether a slot was freed."""
        in_net = set(self._api.vehicle.getIDList())
        freed: list[int] = []
        for vid in [v for v in self._info if v not in in_net and v not in self._teleporting]:
            self._leave(vid, freed, arrived=True)
        present = in_net if not self._subscribed else in_net & set(self._res)
        for vid in [v for v in self._occ_vids if v not in present and v in self._slot_of]:
            self._free_slot(self._slot_of[vid], vid, freed)
        for slot in freed:
            heapq.heappush(self._free, slot)
        return bool(freed)
