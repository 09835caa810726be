r"""How :class:`~acc_fusion.truth.sumo.source.SumoSource` reads SUMO at every step.

Per step the source asks SUMO only for what changed (departed, arrived, teleporting, colliding
vehicles: per-vehicle Python work only for those) and, per equipped vehicle, its speed and its
leader; the acceleration is :math:`(v_k - v_{k-1})/\Delta t` from the slot's previous speed, which
is exactly SUMO's ``getAcceleration`` (checked to 0 on 5880 samples), so only vehicles new to a slot
and unequipped leaders need more getters. With libsumo (in-process) the speeds and leaders come from
the compiled reader of :mod:`acc_fusion.truth.sumo.native` (libsumo's C++ functions, every vehicle
in one call), else from direct calls to the SWIG functions: measured on a 3-lane motorway with 524
vehicles (SUMO 1.28), subscribing speed, acceleration and leader cost about 2 ms more per SUMO step
plus 0.7 ms for ``getAllSubscriptionResults``, while the direct calls cost about 0.5 ms. Through
TraCI (``gui``), where every call is a socket round trip, the same values come from subscriptions
(``VAR_SPEED``, ``VAR_ACCELERATION`` for every vehicle, ``VAR_LEADER`` with the lookahead as its
parameter for the equipped ones) and one ``getAllSubscriptionResults`` per step. Both paths give
identical frames.

Verified against libsumo 1.28: the raw SWIG ``vehicle_getLeader`` returns ``("", -1.0)``
without a leader where the Python wrapper returns ``None``; in libsumo the ``VAR_LEADER``
subscription parameter is a plain float (TraCI's Python client expects ``("d", dist)``).
"""

from __future__ import annotations

import math
from itertools import repeat
from operator import itemgetter
from typing import Any

import numpy as np

from acc_fusion.truth.sumo.native import sumo_reader


class SumoReads:
    """The reads of :class:`~acc_fusion.truth.sumo.source.SumoSource` (a base class of it: the
    methods use the source's SUMO module, configuration and slots)."""

    def _setup_reads(self) -> None:
        """Choose how to read: the compiled reader, direct getters or subscriptions."""
        cfg, api = self.config, self._api
        tc = api.constants
        self._v_speed, self._v_accel = tc.VAR_SPEED, tc.VAR_ACCELERATION
        self._v_leader, self._v_param = tc.VAR_LEADER, tc.VAR_PARAMETER_WITH_KEY
        # libsumo: the compiled reader, else direct getters (both cheaper than subscriptions
        # in-process); TraCI: one subscription read per step instead of a socket round trip
        # per value.
        self._subscribed = bool(cfg.gui)
        self._native = sumo_reader() if cfg.native and not cfg.gui else None
        self._get_speed = raw_function(api, "vehicle_getSpeed", api.vehicle.getSpeed)
        self._get_leader = raw_function(api, "vehicle_getLeader", None) or public_leader(api)
        self._leader_param = {tc.VAR_LEADER: ("d", float(cfg.lookahead))}  # TraCI's typed parameter

    def _read(self) -> None:
        """Fill the frame from SUMO; a vehicle that left unannounced frees its slot."""
        if self._flips:  # a new array: the frames handed out keep theirs
            active = self._active.copy()
            for slot, taken in self._flips:
                active[slot] = taken
            self._flips.clear()
            self._active, self._occ_slots = active, np.flatnonzero(active)
        if self._subscribed or self.config.ssm:
            self._res = self._api.vehicle.getAllSubscriptionResults()
        try:
            self._fill()
        except (KeyError, *self._errors):
            if not self._sweep():
                raise
            self._read()

    def _fill(self) -> None:
        """Read SUMO's values of the occupied slots' vehicles, one pass over them per quantity:
        each one's speed, its leader's distance and code, and the speed and acceleration of
        every leader that holds no slot (its own getters), into :attr:`raw_function`; the frame is
        made of them by :meth:`_make` (by the background source's parent process instead)."""
        slots, vids = self._occ_slots, self._occ_vids
        veh, res = self._api.vehicle, self._res
        sp, ac, ld = self._v_speed, self._v_accel, self._v_leader
        m, n = len(vids), self.n_pairs
        lookahead = float(self.config.lookahead)
        accel = None  # SUMO's accelerations where read for every vehicle (TraCI)
        if self._native is not None:  # one call for every vehicle
            speed, dists, codes = np.empty(m), np.empty(m), np.empty(m, dtype=np.int64)
            lead_ids = self._native.read(vids, slots, lookahead, self._code, n, speed, dists, codes)
        else:
            if self._subscribed:
                rows = [res[v] for v in vids]
                speed = np.array([r[sp] for r in rows], dtype=float).reshape(m)
                accel = np.full(n, np.nan)
                accel[slots] = [r[ac] for r in rows]
                leaders = [r[ld] or NO_LEADER for r in rows]  # TraCI: None without
            else:  # map over C functions: no Python frame per vehicle
                speed = np.fromiter(map(self._get_speed, vids), float, m)
                leaders = list(map(self._get_leader, vids, repeat(lookahead)))
            ids = list(map(itemgetter(0), leaders))
            dists = np.fromiter(map(itemgetter(1), leaders), float, m)
            codes = np.fromiter(map(self._code.get, ids, repeat(-1)), np.int64, m)
            slotless = np.flatnonzero((codes >= 0) & (codes % (n + 1) == 0))
            lead_ids = {i: ids[i] for i in slotless.tolist()}
        others = {}  # the leaders without a slot (an unequipped vehicle): their own getters
        if lead_ids and self._subscribed:
            others = {i: (res[x][sp], res[x][ac]) for i, x in lead_ids.items()}
        elif lead_ids:
            others = {i: (veh.getSpeed(x), veh.getAcceleration(x)) for i, x in lead_ids.items()}
        if m and self.config.ssm:
            pk = self._v_param
            ttc = np.array([ssm_ttc(res[v].get(pk)) for v in vids])
            self._ssm_slot[slots] = np.minimum(self._ssm_slot[slots], ttc)
        self._raw = (slots, speed, dists, codes, others, accel)

    def _make(self) -> None:
        """Make the current frame of what :meth:`_fill` read."""
        slots, speed, dists, codes, others, accel = self._raw
        self._frame = self._maker.make(
            self._t, slots, speed, dists, codes, self._news, others, accel
        )


def raw_function(api: Any, name: str, public: Any) -> Any:
    """libsumo's SWIG function ``name`` without its Python wrapper (a third cheaper per
    call), else the public function.  The raw ``vehicle_getLeader`` returns ``("", -1.0)``
    without a leader where the wrapper returns ``None``."""
    module = getattr(getattr(api, "libsumo", None), "_libsumo", None)
    return getattr(module, name, None) or public


def public_leader(api: Any) -> Any:
    """The public ``getLeader``, returning :data:`NO_LEADER` instead of ``None`` as the raw one."""
    get = api.vehicle.getLeader
    return lambda vid, dist: get(vid, dist) or NO_LEADER


NO_LEADER = ("", -1.0)


def ssm_ttc(item: Any) -> float:
    """The value of a ``device.ssm.minTTC`` parameter subscription (``inf`` when empty)."""
    try:
        return float(item[1])
    except (TypeError, ValueError, IndexError):
        return math.inf
