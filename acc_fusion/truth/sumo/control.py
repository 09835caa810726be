r"""What :class:`~acc_fusion.truth.sumo.source.SumoSource` commands SUMO to do: the drivers'
braking (the closed loop), emergency braking of a lead (the injected threats) and the warning
colours.

Closed loop
    :meth:`~acc_fusion.truth.sumo.source.SumoSource.advance` takes the brake request of each slot's
    driver [m/s²]: the vehicle is commanded :math:`v_{k+1} = \max(v_k - a\,\Delta t, 0)` through
    ``setSpeed`` with SUMO's deceleration limit lifted (speed-mode bit 2 cleared; SUMO still never
    lets it drive faster than its safe speed), and handed back (``setSpeed(-1)`` and the original
    speed mode) at the first step without a request.  A *held* slot (a distracted driver,
    :attr:`acc_fusion.truth.driver.Driver.holding`) is commanded the same speed law, with a
    request of 0 keeping its speed, and its safe speed ignored too (bit 0 cleared): SUMO's
    car-following model, which would see the lead for the driver, is out of the loop.

Threats (so that false-alarm and miss rates mean something)
    - *Lead-vehicle emergency braking*: events at ``hazard_rate`` per vehicle-hour, a
      Poisson process of its own for every vehicle (equipped or not) while it is in the
      network: its k-th event comes :math:`\Delta t_k \sim \operatorname{Exp}(3600 / r)`
      after its departure or its previous event, drawn from a generator keyed by the seed,
      the vehicle's id (:func:`acc_fusion.core.slots.unit_key`) and k.  So two runs on the
      same seed (FCW off and on) brake the same vehicles at the same times, however their
      traffic differs elsewhere: common random numbers for the paired comparison
      (:mod:`acc_fusion.metrics.benefit`).  The vehicle brakes at ``hazard_decel`` for
      ``hazard_duration`` seconds (commanded speed :math:`v_{k+1} = \max(v_k - a\,\Delta t,
      0)` with SUMO's deceleration limit lifted, its emergency deceleration raised to
      ``hazard_decel`` if lower), then control returns to SUMO (an event that falls while it
      brakes or teleports is skipped).  :meth:`SumoControls.inject_hazard` starts one on a
      chosen vehicle.
    - *Inattentive drivers*: a fraction ``inattentive`` of the equipped vehicles gets SUMO's
      action step length (the driver's decision interval, SUMO's model of reaction time)
      ``inattentive_action_step`` (1.5 s, Green 2000's "surprise" brake reaction) instead of
      the simulation step (set by the source when the vehicle departs).  SUMO's Krauss model
      assumes a reaction of ``tau`` (1 s) in its safe speed, so these drivers can run into a
      braking leader.

Sources: SUMO documentation (TraCI vehicle state change, speed mode bits, action step length);
M. Green, "'How long does it take to stop?'", Transportation Human Factors 2(3):195-216, 2000
(1.5 s surprise reaction).  Verified against libsumo 1.28: ``setSpeed`` acts at every step even
for a vehicle with a long action step length.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.levels import WARNING_COLORS
from acc_fusion.core.slots import unit_key
from acc_fusion.core.units import TIME_TOL
from acc_fusion.core.validation import check_range

#: SUMO speed-mode bit 2: "regard maximum deceleration" (cleared while we command braking).
SPEED_MODE_MAX_DECEL = 0b100
#: SUMO speed-mode bit 0: "regard safe speed" (cleared while a distracted driver is held).
SPEED_MODE_SAFE_SPEED = 0b1


@dataclass
class _Hazard:
    end: float
    decel: float
    emergency: float | None  # emergency deceleration to restore, None if unchanged


class SumoControls:
    """The commands of :class:`~acc_fusion.truth.sumo.source.SumoSource` (a base class of it:
    the methods use the source's SUMO module, configuration, slots and vehicle tables)."""

    def inject_hazard(
        self, vehicle_id: str, decel: float | None = None, duration: float | None = None
    ) -> bool:
        """Make ``vehicle_id`` brake at ``decel`` [m/s²] for ``duration`` [s] from the next
        step (defaults: the config's).  Returns False if it is absent or already braking."""
        present = vehicle_id in self._info and vehicle_id not in self._teleporting
        if self._closed or not present or vehicle_id in self._hazards:
            return False
        decel = (
            self.config.hazard_decel
            if decel is None
            else check_range("decel", decel, 0.0, 100.0, lo_open=True)
        )
        duration = (
            self.config.hazard_duration
            if duration is None
            else check_range("duration", duration, 0.0, math.inf, lo_open=True, hi_open=True)
        )
        veh = self._api.vehicle
        emergency = float(veh.getEmergencyDecel(vehicle_id))
        restore = None
        if emergency < decel:
            veh.setEmergencyDecel(vehicle_id, decel)
            restore = emergency
        self._hazards[vehicle_id] = _Hazard(self._t + duration, decel, restore)
        self.n_hazards += 1
        return True

    def braking_leaders(self) -> np.ndarray:
        """The integer ids (as in a frame's ``leader_id``) of the vehicles under an injected
        emergency braking now."""
        info = self._info
        return np.array([info[v][0] for v in self._hazards if v in info], dtype=np.int64)

    def _schedule_hazard(self, vehicle_id: str, k: int) -> None:
        """Start the clock of ``vehicle_id``'s ``k``-th hazard now (module docstring)."""
        rng = np.random.default_rng([self._hazard_key, unit_key(vehicle_id), k])
        gap = rng.exponential(3600.0 / self.config.hazard_rate)
        heapq.heappush(self._hazard_due, (self._t + gap, vehicle_id, k))

    def set_warning_colors(self, levels: np.ndarray) -> None:
        """Colour each slot's vehicle by its warning level (0 green, 1 amber, 2 red); only
        changed colours are sent.  ``levels`` covers every slot or the first ones (the prefix
        a pipeline works on, :mod:`acc_fusion.core.slots`; the slots beyond it are empty).  Meant
        for ``gui``; harmless without."""
        if self._closed:
            return
        lv = np.clip(np.asarray(levels, dtype=np.int64).reshape(-1), 0, len(WARNING_COLORS) - 1)
        m = lv.shape[0]
        if not 1 <= m <= self.n_pairs:
            raise ConfigError(f"levels must hold 1 to {self.n_pairs} slots' levels, got {m}")
        changed = np.flatnonzero(self._active[:m] & (lv != self._shown_level[:m]))
        set_color, vids = self._api.vehicle.setColor, self._slot_vid

        def paint() -> None:
            for slot in changed:
                set_color(vids[slot], WARNING_COLORS[lv[slot]])

        self._guard(paint)
        self._shown_level[changed] = lv[changed]

    def _control(self, brake: np.ndarray | None, hold: np.ndarray | None = None) -> None:
        """Start hazards, then command the braking and held vehicles and hand back the
        others."""
        dt, veh, due = self.dt, self._api.vehicle, self._hazard_due
        while due and due[0][0] <= self._t + TIME_TOL:
            _, vid, k = heapq.heappop(due)
            if vid in self._info:  # a vehicle that left: its clock stops
                self.inject_hazard(vid)
                self._schedule_hazard(vid, k + 1)
        targets: dict[str, float] = {}
        for vid, hz in list(self._hazards.items()):
            if self._t >= hz.end - TIME_TOL:
                self._end_hazard(vid)
            else:
                targets[vid] = max(self._speed(vid) - hz.decel * dt, 0.0)
        held: set[str] = set()
        if brake is not None:
            speed = self._frame.ego_speed
            commanded = brake > 0 if hold is None else (brake > 0) | hold
            for slot in np.flatnonzero(commanded & self._active):
                vid = self._slot_vid[slot]
                target = max(float(speed[slot]) - float(brake[slot]) * dt, 0.0)
                targets[vid] = min(targets.get(vid, math.inf), target)
                if hold is not None and hold[slot]:
                    held.add(vid)
        for vid in [v for v in self._ctrl if v not in targets]:
            self._release(vid)
        for vid, target in targets.items():
            if vid not in self._ctrl:
                self._ctrl[vid] = int(veh.getSpeedMode(vid))
            mode = self._ctrl[vid] & ~SPEED_MODE_MAX_DECEL
            if vid in held:
                mode &= ~SPEED_MODE_SAFE_SPEED
            if self._mode.get(vid) != mode:
                veh.setSpeedMode(vid, mode)
                self._mode[vid] = mode
            veh.setSpeed(vid, target)

    def _release(self, vid: str) -> None:
        """Hand a vehicle back to SUMO: no commanded speed, its original speed mode."""
        mode = self._ctrl.pop(vid, None)
        self._mode.pop(vid, None)
        if mode is not None:
            veh = self._api.vehicle
            veh.setSpeed(vid, -1.0)
            veh.setSpeedMode(vid, mode)

    def _end_hazard(self, vid: str) -> None:
        """End an emergency braking: restore the emergency deceleration."""
        hz = self._hazards.pop(vid, None)
        if hz is not None and hz.emergency is not None:
            self._api.vehicle.setEmergencyDecel(vid, hz.emergency)
