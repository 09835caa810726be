r"""highway-env truth source: ground truth of follower→leader pairs in highway-env traffic.

Pipeline stage 1 (**truth source** → sensors → ...), like
:class:`~acc_fusion.truth.sumo.source.SumoSource`,
but the traffic is simulated by highway-env (E. Leurent, *An environment for autonomous
driving decision-making*, https://github.com/Farama-Foundation/HighwayEnv): the environments
of :data:`SUPPORTED`, whose road carries traffic.  :class:`HighwaySource` offers the interface
the FCW loop drives (``frame()``, ``advance(ego_brake)``, ``t``, ``dt``, ``n_steps``,
``done``, ``active``, ``collided``, ``collision_speed``, ``reassigned``), plus what a
single-ego gymnasium environment needs (:meth:`HighwaySource.restart`,
:attr:`~HighwaySource.terminated`, :attr:`~HighwaySource.truncated`,
:meth:`~HighwaySource.render`).

Slots
    ``pairs="controlled"``: one slot per controlled vehicle (highway-env's
    ``controlled_vehicles``, 1 by default).  ``pairs="all"``: one slot per vehicle on the road,
    the controlled ones first, so one simulation yields many pairs.  N (the number of slots)
    is fixed by the first episode; a later episode with fewer vehicles leaves the last slots
    inactive, one with more tracks only the first N (a warning is issued once).  Episodes
    and reproducibility: see :mod:`acc_fusion.truth.highway.config`.

Stepping at the simulation frequency
    highway-env's ``env.step`` advances ``simulation_frequency / policy_frequency`` simulation
    steps (15 by default) per policy step.  The source instead does one simulation step per
    :meth:`~HighwaySource.advance`, exactly as ``AbstractEnv._simulate`` does: ``road.act()``
    (every vehicle decides; the controlled vehicles keep their highway-env controller's action,
    i.e. the ``IDLE`` meta-action: hold the lane and the target speed), then ``road.step(dt)``
    (kinematics and collisions), with :math:`\Delta t` = 1 / ``simulation_frequency``.  The
    controlled vehicle holds its speed whatever is ahead (highway-env's ``MDPVehicle`` has no
    car-following model): an inattentive driver, so threats arise from the traffic itself.

Truth of a slot (``(N,)`` arrays of the :class:`~acc_fusion.truth.frame.TruthFrame`)
    The leader is the nearest vehicle ahead on the ego's lane, as highway-env's own
    ``Road.neighbour_vehicles`` defines it: every vehicle whose position, in the local
    coordinates :math:`(s, r)` of the ego's lane (``lane.local_coordinates``), lies on that
    lane (:math:`|r| \le w/2 + 1` m, :math:`-5 \le s < \ell_{\text{lane}} + 5` m), with
    :math:`s \ge s_{\text{ego}}`; road objects (``merge-v0``'s end-of-ramp obstacle) are not
    targets.  Vehicle positions are their centres, so the bumper-to-bumper gap is

    .. math::

        g = s_{\text{lead}} - s_{\text{ego}} - \tfrac12 (\ell_{\text{lead}} + \ell_{\text{ego}})

    with :math:`\ell` the vehicles' ``LENGTH``; leaders farther than ``lookahead`` are not
    reported.  Speeds are along the ego's lane, :math:`u = v \cos(\psi - \psi_{\text{lane}})`
    (``psi`` the vehicle's heading, :math:`\psi_{\text{lane}}` the lane's direction), so that
    the range-rate :math:`u_{\text{lead}} - u_{\text{ego}}` is :math:`\dot g` (highway-env's
    ``velocity`` likewise ignores the slip angle); accelerations are
    :math:`(v_k - v_{k-1}) / \Delta t`, which is highway-env's commanded acceleration exactly
    (0 at an episode's first frame, before any step).  The lateral offset is
    :math:`r_{\text{lead}} - r_{\text{ego}}`.  Every vehicle gets an integer id per episode,
    never reused in the run, so a new leader (a lane change, a cut-in, a new episode) is a new
    target.

Collisions
    highway-env marks both vehicles of a contact ``crashed``.  A slot is flagged
    :attr:`~HighwaySource.collided` when its vehicle crashes into its leader: it is newly
    crashed, its leader is crashed and the gap is at most :data:`CONTACT_GAP` (highway-env
    separates the two polygons on impact, leaving a gap of 0), with the impact speed
    :math:`u_{\text{ego}} - u_{\text{lead}}`.  A vehicle rear-ended by another is crashed but
    not flagged (no forward-collision failure), as in :mod:`acc_fusion.truth.sumo.source`.  A
    crashed
    vehicle's slot is inactive from the next step on.  ``highway-fast-v0`` checks collisions
    of the controlled vehicles only, so there other vehicles never crash.

Closed loop
    :meth:`~HighwaySource.advance` takes each slot's brake request :math:`a` [m/s²] (from
    :class:`acc_fusion.truth.driver.Driver`, which models the reaction time): after ``road.act()``
    the vehicle's longitudinal action is overridden by :math:`-\min(a, v/\Delta t)` (it stops,
    never reverses); its steering is unchanged.  At the first step without a request the
    vehicle's own controller acts again, with its target speed (highway-env's cruise set point
    of the controlled vehicle, the desired speed of the IDM ones) lowered to the speed the
    driver braked to: a driver who braked for a warning does not speed up into the same
    leader again (our assumption; highway-env's controlled vehicle would otherwise return to
    its target speed and close in again, warning after warning).  A *held* slot (a distracted
    driver, :attr:`acc_fusion.truth.driver.Driver.holding`) without a brake request gets a
    longitudinal action of 0: it keeps its speed whatever is ahead, its IDM out of the loop
    (as :mod:`acc_fusion.truth.sumo.control` holds a SUMO vehicle); its steering, lane changes
    included, is its own, as SUMO's lane-changing model keeps a held vehicle's.

Sources: highway-env 1.12 (``AbstractEnv._simulate``, ``Road.neighbour_vehicles``,
``Vehicle.step``, ``RoadObject.handle_collisions``, ``EnvViewer``), verified against the
installed package: gaps at impact are 0 in all three environments, the rendered frame is
``screen_height × screen_width × 3`` and its viewer's ``sim_surface.vec2pix`` maps world
coordinates [m] to its pixels.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.truth.frame import SlotSource, TruthFrame
from acc_fusion.truth.highway.config import DEFAULT_DURATION, HighwayConfig, HighwayError, make_env
from acc_fusion.truth.highway.lanes import LaneRows

#: Largest gap [m] at which a newly crashed vehicle counts as having hit its leader.
CONTACT_GAP = 0.5
#: highway-env's lane tolerances of ``Road.neighbour_vehicles``: lateral margin [m] and
#: longitudinal overhang [m] (``AbstractLane.VEHICLE_LENGTH``).
LANE_MARGIN, LANE_OVERHANG = 1.0, 5.0


class HighwaySource(SlotSource):
    """Ground truth of follower→leader pairs in highway-env traffic (see the module docstring).

    Args:
        config: the :class:`HighwayConfig`.
        render: build highway-env's ``rgb_array`` renderer (for :meth:`render`).
        progress: show a progress bar over the episodes.

    Raises:
        ConfigError: highway-env is not installed, or a bad config override.

    Attributes:
        env: the unwrapped highway-env environment.
        n_pairs: number of slots N.
        dt: simulation step [s] (1 / ``simulation_frequency``).
        duration: seconds per episode [s].
        episode: index of the current episode.
        n_crashes: vehicles that crashed so far (any, slotted or not).
        n_collisions: slot vehicles that ran into their leader so far.

    Use it as a context manager (or call :meth:`close`)::

        with HighwaySource(HighwayConfig("highway-v0", episodes=3)) as src:
            frame = src.frame()
            while not src.done:
                frame = src.advance(brake)
    """

    #: It holds a distracted driver's vehicle (:meth:`advance`).
    accepts_hold = True

    def __init__(
        self, config: HighwayConfig, *, render: bool = False, progress: bool = False
    ) -> None:
        if not isinstance(config, HighwayConfig):
            raise ConfigError(f"config must be a HighwayConfig, got {type(config).__name__}")
        self.config = cfg = config
        self.env = make_env(cfg, render)
        self._render = render
        self.dt = 1.0 / float(self.env.config["simulation_frequency"])
        own = self.env.config.get("duration")
        self.duration = float(cfg.duration or own or DEFAULT_DURATION)
        self._ep_steps = max(1, int(math.ceil(self.duration / self.dt - 1e-6)))
        self._next_int = 0
        self._t = 0.0
        self.n_crashes = self.n_collisions = 0
        self._done = self._closed = False
        self._warned = False
        self._bar = tqdm(
            total=cfg.episodes,
            disable=None if progress else True,
            desc=cfg.env,
            unit="episode",
            leave=False,
        )
        self.n_pairs = 0  # set by the first episode
        self._start(cfg.seed, 0, first=True)

    # ---------------------------------------------------------------- public state
    @property
    def t(self) -> float:
        """Simulation time since the first episode began [s] (runs on across episodes)."""
        return self._t

    @property
    def n_steps(self) -> int:
        """Upper bound of the steps of the run: every episode's steps plus one reset each
        (episodes that end early make the run shorter; see :attr:`done`)."""
        return self.config.episodes * (self._ep_steps + 1)

    @property
    def done(self) -> bool:
        """Every episode has ended (or the source is closed)."""
        return self._done

    @property
    def terminated(self) -> bool:
        """highway-env terminated the current episode at this step (crash, merge passed)."""
        return self._terminated

    @property
    def truncated(self) -> bool:
        """The current episode reached ``duration`` at this step (and was not terminated)."""
        return self._truncated

    @property
    def vehicles(self) -> list:
        """The highway-env vehicle of each occupied slot, in slot order."""
        return list(self._slot_vehicles)

    @property
    def closed(self) -> bool:
        """The run was closed (:meth:`close`)."""
        return self._closed

    @property
    def road_ids(self) -> np.ndarray:
        """``(V,)`` the integer id (``leader_id``) of each vehicle of ``env.road.vehicles``,
        in its order (read-only view)."""
        view = self._vint.view()
        view.flags.writeable = False
        return view

    @property
    def slot_vehicle_index(self) -> np.ndarray:
        """The index in ``env.road.vehicles`` of each occupied slot's vehicle, in slot order
        (read-only view)."""
        view = self._slot_vi.view()
        view.flags.writeable = False
        return view

    def id_of(self, vehicle: Any) -> int:
        """The integer id (``leader_id``) of a highway-env vehicle of the current episode."""
        for j, v in enumerate(self.env.road.vehicles):
            if v is vehicle:
                return int(self._vint[j])
        raise InputError("the vehicle is not on the current episode's road")

    # ---------------------------------------------------------------- stepping
    def advance(
        self, ego_brake: np.ndarray | None = None, hold: np.ndarray | None = None
    ) -> TruthFrame:
        """Apply the brake requests, run one highway-env simulation step, return the frame.

        After an episode's end frame, the step starts the next episode instead (its first
        frame, slots :attr:`reassigned`); after the last episode, :attr:`done` turns true and
        every slot is inactive.

        Args:
            ego_brake: ``(N,)`` deceleration requested by each slot's driver [m/s², >= 0];
                0 or NaN (or ``None`` for all): no request.
            hold: ``(N,)`` slots whose driver is distracted (module docstring): without a
                brake request their vehicle keeps its speed; ``None``: none.

        Raises:
            HighwayError: the run is over (use :meth:`restart`) or closed.
        """
        if self._done:
            what = "closed" if self._closed else "over; restart() it or open a new source"
            raise HighwayError(f"the highway-env run is {what}")
        brake = None
        if ego_brake is not None:
            brake = check_array("ego_brake", ego_brake, (self.n_pairs,), finite=False)
            brake = check_array("ego_brake", np.nan_to_num(brake, nan=0.0), nonnegative=True)
        self._t += self.dt
        self._reassigned = np.zeros(self.n_pairs, dtype=bool)
        if self._terminated or self._truncated:
            self._bar.update(1)
            if self.episode + 1 < self.config.episodes:
                self._start(self.config.seed + self.episode + 1, self.episode + 1)
            else:
                self._finish()
            return self._frame
        if hold is not None:
            hold = check_array("hold", hold, (self.n_pairs,)).astype(bool)
        env, dt = self.env, self.dt
        braking = np.zeros(self.n_pairs, dtype=bool) if brake is None else brake > 0
        braking &= self._active
        for slot in np.flatnonzero(self._braking & ~braking & self._occupied):
            v = self._slot_vehicles[slot]  # released: the driver keeps the speed he braked to
            v.target_speed = min(v.target_speed, max(v.speed, 0.0))
        self._braking = braking
        env.road.act()
        for slot in np.flatnonzero(braking):
            v = self._slot_vehicles[slot]
            v.action["acceleration"] = -min(float(brake[slot]), max(v.speed, 0.0) / dt)
        if hold is not None:
            for slot in np.flatnonzero(hold & self._active & ~braking):
                self._slot_vehicles[slot].action["acceleration"] = 0.0
        env.road.step(dt)
        env.steps += 1
        self._ep_k += 1
        env.time = self._ep_k * dt
        self._read()
        self._terminated = bool(env._is_terminated())
        self._truncated = not self._terminated and self._ep_k >= self._ep_steps
        return self._frame

    def restart(self, mask: np.ndarray, seed: int | np.random.Generator | None) -> None:
        """Start a new episode now, reset with ``seed`` (an ``int``, or an integer drawn from
        a ``numpy.random.Generator``), whether or not the run was :attr:`done`.

        The signature of :meth:`acc_fusion.truth.scripted.ScenarioSource.restart`, for the
        gymnasium environment.  All slots share one highway-env simulation, so ``mask`` must
        select all of them (restart) or none (nothing happens, nothing is drawn).

        Raises:
            InputError: ``mask`` is not a boolean ``(N,)`` array selecting all or no slots.
            HighwayError: the source is closed.
        """
        mask = np.asarray(mask)
        if mask.shape != (self.n_pairs,) or mask.dtype != bool:
            raise InputError(f"mask must be a boolean array of shape ({self.n_pairs},)")
        if not mask.any():
            return
        if not mask.all():
            raise InputError("the slots share one highway-env simulation: restart all or none")
        if self._closed:
            raise HighwayError("the highway-env run is closed; open a new source")
        if isinstance(seed, np.random.Generator):
            seed = int(seed.integers(2**63))
        self._done = False
        self._start(seed, self.episode + 1)

    def render(self) -> np.ndarray:
        """highway-env's ``rgb_array`` frame of the current state, ``(H, W, 3)`` uint8,
        centred on the first controlled vehicle (slot 0)."""
        if not self._render:
            raise HighwayError("render() needs HighwaySource(..., render=True)")
        return self.env.render()

    def pixel_ahead(self, slot: int, distance: float) -> tuple[int, int]:
        """Pixel of the last :meth:`render` frame at ``distance`` [m] ahead of the front
        bumper of ``slot``'s vehicle, along its heading."""
        v = self._slot_vehicles[slot]
        ahead = 0.5 * v.LENGTH + distance
        point = v.position + ahead * np.array([math.cos(v.heading), math.sin(v.heading)])
        return self.env.viewer.sim_surface.vec2pix(point)

    def close(self) -> None:
        """Close highway-env (and its renderer); idempotent."""
        self._done = self._closed = True
        self._bar.close()
        self.env.close()

    # ---------------------------------------------------------------- internals
    def _start(self, seed: int | None, episode: int, first: bool = False) -> None:
        """Reset highway-env to episode ``episode`` and put its vehicles into the slots (the
        ``first`` episode fixes the number of slots)."""
        env = self.env
        env.reset(seed=seed)
        self.episode = episode
        env.time = 0.0
        self._ep_k = 0
        road = env.road
        controlled = list(env.controlled_vehicles)
        if self.config.pairs == "all":
            chosen = set(map(id, controlled))
            egos = controlled + [v for v in road.vehicles if id(v) not in chosen]
        else:
            egos = controlled
        if first:
            self.n_pairs = len(egos)
        n = self.n_pairs
        if len(egos) > n and not self._warned:
            self._warned = True
            warnings.warn(
                f"episode {self.episode} of {self.config.env} has {len(egos)} egos but the "
                f"source has {n} slots (set by the first episode); the extra ones are not "
                "tracked",
                RuntimeWarning,
                stacklevel=3,
            )
        self._slot_vehicles = egos[:n]
        index = {id(v): j for j, v in enumerate(road.vehicles)}
        self._slot_vi = np.array([index[id(v)] for v in self._slot_vehicles], dtype=np.intp)
        m = len(road.vehicles)
        self._vint = np.arange(self._next_int, self._next_int + m, dtype=np.int64)
        self._next_int += m
        self._m = m
        self._was_crashed = np.zeros(m, dtype=bool)
        self._prev_speed: np.ndarray | None = None
        self._lanes = LaneRows(road.network)  # the new road's lanes
        occupied = np.zeros(n, dtype=bool)
        occupied[: len(self._slot_vehicles)] = True
        self._occupied = occupied
        self._active = occupied.copy()
        self._reassigned = occupied.copy()
        self._collided = np.zeros(n, dtype=bool)
        self._collision_speed = np.full(n, np.nan)
        self._braking = np.zeros(n, dtype=bool)
        self._terminated = self._truncated = False
        self._read()

    def _finish(self) -> None:
        """After the last episode: every slot inactive, an empty frame."""
        self._done = True
        self._bar.close()
        self._active = np.zeros(self.n_pairs, dtype=bool)
        n = self.n_pairs
        self._frame = TruthFrame(
            t=self._t,
            ego_speed=np.zeros(n),
            ego_accel=np.zeros(n),
            gap=np.full(n, np.nan),
            lead_speed=np.full(n, np.nan),
            lead_accel=np.full(n, np.nan),
            leader_id=np.full(n, -1, dtype=np.int64),
        )

    def _lane_coordinates(self, lanes: list, pos: np.ndarray) -> tuple[np.ndarray, ...]:
        """For each ego lane (``lanes``, K lane indices) and every vehicle position ``pos``
        ``(M, 2)``: the local coordinates ``s``, ``r`` on that lane, whether the vehicle is on
        it (``Road.neighbour_vehicles``' rule) and the lane's direction [rad] there, all
        ``(K, M)`` (:class:`~acc_fusion.truth.highway.lanes.LaneRows`: straight and sine lanes
        as arrays, their base's direction; other lanes by highway-env's own methods)."""
        rows = np.array([self._lanes.row(li) for li in lanes], dtype=np.intp)
        s, r = self._lanes.local(rows[:, None], pos[None, :, 0], pos[None, :, 1])
        k, m = s.shape
        half = np.repeat(0.5 * self._lanes.width(rows)[:, None] + LANE_MARGIN, m, axis=1)
        psi = np.repeat(self._lanes.base_heading(rows)[:, None], m, axis=1)
        for i in np.flatnonzero(self._lanes.other(rows)):
            lane = self._lanes.lanes[rows[i]]
            half[i] = [0.5 * lane.width_at(x) + LANE_MARGIN for x in s[i]]
            psi[i] = [lane.heading_at(x) for x in s[i]]
        length = self._lanes.length(rows)[:, None]
        on = (np.abs(r) <= half) & (s >= -LANE_OVERHANG) & (s < length + LANE_OVERHANG)
        return s, r, on, psi

    def _read(self) -> None:
        """Fill the frame from highway-env's vehicles (one pass over them, then arrays over
        ego lanes × vehicles)."""
        road, n, dt = self.env.road, self.n_pairs, self.dt
        vs = road.vehicles
        if len(vs) != self._m:
            raise HighwayError(
                f"{self.config.env} changed its number of vehicles within an episode "
                f"({self._m} -> {len(vs)}), which the supported environments never do"
            )
        state = np.array(
            [(v.position[0], v.position[1], v.speed, v.heading, v.LENGTH, v.crashed) for v in vs]
        )
        pos, speed, heading, length = state[:, :2], state[:, 2], state[:, 3], state[:, 4]
        crashed = state[:, 5].astype(bool)
        accel = np.zeros(len(vs)) if self._prev_speed is None else (speed - self._prev_speed) / dt
        self._prev_speed = speed
        new_crash = crashed & ~self._was_crashed
        self.n_crashes += int(new_crash.sum())

        slots = np.flatnonzero(self._occupied)
        vi = self._slot_vi[slots]
        # One row per distinct ego lane: each slot reads its lane's row.
        lane_row: dict[Any, int] = {}
        rows = np.array(
            [lane_row.setdefault(self._slot_vehicles[i].lane_index, len(lane_row)) for i in slots],
            dtype=np.intp,
        )
        s, r, on, psi = self._lane_coordinates(list(lane_row), pos)
        u = speed * np.cos(heading - psi)  # (K, M) speeds along each ego lane
        ar = np.arange(len(slots))
        ahead = s[rows] - s[rows, vi][:, None]  # (S, M) distance of every vehicle ahead
        ok = on[rows] & (ahead >= 0.0)
        ok[ar, vi] = False
        ahead = np.where(ok, ahead, np.inf)
        j = np.argmin(ahead, axis=1)
        d = ahead[ar, j] - 0.5 * (length[vi] + length[j])
        has = np.isfinite(d) & (d <= self.config.lookahead)
        hs, hj, hr = slots[has], j[has], rows[has]

        ego_v, ego_a = np.zeros(n), np.zeros(n)
        gap, lead_v, lead_a = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
        lat = np.zeros(n)
        leader = np.full(n, -1, dtype=np.int64)
        lead_vi = np.full(n, -1, dtype=np.intp)
        ego_v[slots] = np.maximum(u[rows, vi], 0.0)
        ego_a[slots] = accel[vi]
        gap[hs] = d[has]
        lead_v[hs] = u[hr, hj]
        lead_a[hs] = accel[hj]
        lat[hs] = r[hr, hj] - r[hr, vi[has]]
        leader[hs] = self._vint[hj]
        lead_vi[hs] = hj
        # Collisions: a newly crashed slot vehicle whose leader crashed at contact.
        hit = np.zeros(n, dtype=bool)
        hit[slots] = new_crash[vi]
        hit &= (lead_vi >= 0) & (np.nan_to_num(gap, nan=np.inf) <= CONTACT_GAP)
        hit[hit] &= crashed[lead_vi[hit]]
        hit &= ~self._collided
        if hit.any():
            self._collided |= hit
            self._collision_speed[hit] = ego_v[hit] - lead_v[hit]
            self.n_collisions += int(hit.sum())
        # A vehicle that crashed before this step no longer drives.
        self._active = self._occupied.copy()
        self._active[slots] &= ~self._was_crashed[vi]
        self._was_crashed = crashed
        self._frame = TruthFrame.from_arrays(
            t=self._t,
            ego_speed=ego_v,
            ego_accel=ego_a,
            gap=gap,
            lead_speed=lead_v,
            lead_accel=lead_a,
            leader_id=leader,
            lateral_offset=lat,
        )
