r"""SUMO truth source: ground truth for every equipped vehicle of a SUMO traffic simulation.

Pipeline stage 1 (**truth source** → sensors → ...), like
:class:`~acc_fusion.truth.scripted.ScenarioSource`, but the traffic is simulated by SUMO (Eclipse
SUMO, https://eclipse.dev/sumo) on any road network: a ``.sumocfg`` of the bundled
``sumo_nets`` or the user's own.  :class:`SumoSource` offers the interface the FCW loop
drives (``frame()``, ``advance(ego_brake)``, ``t``, ``n_steps``, ``done``, ``active``,
``collided``, ``collision_speed``) plus ``reassigned`` and ``vehicle_ids``.

Slots
    One per equipped vehicle in the network (the pair axis N): :mod:`acc_fusion.truth.sumo.slots`.

Truth of a slot (``(N,)`` arrays of the :class:`~acc_fusion.truth.frame.TruthFrame`)
    Ego speed and acceleration (SUMO's speed and acceleration of the last step); the leader
    from SUMO's ``getLeader`` (the vehicle ahead on the ego's lane and the lanes it will
    continue on), kept when closer than ``lookahead``; its speed and acceleration; the
    bumper-to-bumper gap

    .. math::

        g = g_{\text{SUMO}} + s_0 = x_{\text{lead}} - \ell_{\text{lead}} - x_{\text{ego}}

    where :math:`g_{\text{SUMO}}` is the distance ``getLeader`` returns, which excludes the
    follower's ``minGap`` :math:`s_0` (SUMO documentation, TraCI *Vehicle Value Retrieval*,
    "leader"), and :math:`x` are lane positions of the front bumpers, :math:`\ell` the
    vehicle length (on a shared lane).  The lateral offset is 0 (lane-based model: the leader
    is in the ego's lane).  SUMO vehicle ids are mapped to integer ``leader_id`` values that
    are never reused in a run; a vehicle coming back from a teleport gets a new one (a new
    target).

Reading SUMO cheaply
    Only what changed, the compiled reader where it builds: :mod:`acc_fusion.truth.sumo.reading`.

Threats and the closed loop
    Lead-vehicle emergency braking, inattentive drivers and the drivers' brake requests are
    SUMO commands: :mod:`acc_fusion.truth.sumo.control`.  *Collisions happen*: SUMO runs with
    ``--collision.mingap-factor 0`` (only physical contact counts),
    ``--collision.check-junctions true`` and ``--collision.action`` ``collision_action``
    (``remove`` by default: both vehicles leave the network, which ends the pair).  Collisions
    are read with ``simulation.getCollisions()``; the slot of the *collider* (the vehicle that
    ran into another) is flagged :attr:`collided` with the impact speed ``colliderSpeed -
    victimSpeed``.  The victim's slot is not flagged (a vehicle rear-ended by another is no
    forward-collision failure).

One simulation per process
    libsumo embeds SUMO in the Python process and holds a single global simulation; starting
    a second one silently replaces the first.  :class:`SumoSource` therefore refuses to open
    while another one is open in the process (:class:`SumoError`).  Parallel work (seeds,
    penetration rates, networks) must use separate *processes* (``multiprocessing``,
    ``concurrent.futures.ProcessPoolExecutor``, ray), one source each.  A closed source
    frees the process for the next one.  ``gui=True`` uses TraCI and ``sumo-gui`` (a
    separate process) instead, where a display exists; the same one-at-a-time rule applies.

Reproducibility
    SUMO gets ``--seed`` ``seed``; the equipped, inattentive and hazard draws come from
    ``numpy`` generators spawned from the same seed (one per purpose, one equipped and one
    inattentive draw per departing vehicle in SUMO's departure order), so a run is
    reproducible from its config, and (for the same traffic) a higher penetration equips a
    superset of the vehicles of a lower one.  A vehicle's hazards are a function of the seed
    and its id only (:mod:`acc_fusion.truth.sumo.control`), so two runs on the same seed that
    differ in one vehicle's driving (FCW off and on) still brake the same leads at the same
    times.

Sources: SUMO documentation (TraCI vehicle value retrieval, ``simulation.getCollisions``,
collision options).  Verified against eclipse-sumo / libsumo 1.28: ``getLeader``'s result is
``(leader_id, gap)``; the gap plus the follower's ``minGap`` equals the lane-position difference
minus the leader's length; ``getLeader``'s distance is a *minimum* lookahead, hence the
``lookahead`` cut; collisions with action ``remove`` list both vehicles as arrived in the same
step; stepping past the ``.sumocfg``'s end is allowed (the end is enforced here); a second
``libsumo.start`` silently replaces the running simulation.
"""

from __future__ import annotations

import heapq
import math
import os
import shutil
import tempfile
import weakref
from collections.abc import Sequence
from contextlib import nullcontext
from pathlib import Path

import numpy as np

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.memory import release_free_heap
from acc_fusion.truth.frame import SlotSource, TruthFrame
from acc_fusion.truth.sumo import launch
from acc_fusion.truth.sumo.config import UNBOUNDED_END, SumoConfig, SumoError, check_sumocfg
from acc_fusion.truth.sumo.control import SumoControls, _Hazard
from acc_fusion.truth.sumo.frames import FrameMaker
from acc_fusion.truth.sumo.reading import SumoReads
from acc_fusion.truth.sumo.slots import SWEEP_STEPS, SumoSlots

#: The open source of this process (libsumo holds one simulation per process).
_OPEN: weakref.ref[SumoSource] | None = None
#: Simulated time between two returns of the freed heap to the system [s]
#: (:func:`acc_fusion.core.memory.release_free_heap`; a few ms each on A10KW).
TRIM_PERIOD = 60.0


class SumoSource(SumoControls, SumoReads, SumoSlots, SlotSource):
    """Ground truth of every equipped vehicle of a SUMO simulation (see the module docstring).

    Args:
        config: the :class:`SumoConfig`.

    Raises:
        ConfigError: a missing or invalid ``.sumocfg`` or input file, or no display for
            ``gui``.
        SumoError: another source is open in this process, or SUMO failed to load.

    Attributes:
        n_pairs: number of slots N (``config.capacity``).
        dt: simulation step [s]; begin, end_time: first and last simulated time [s].
        n_departed, n_equipped, n_inattentive: vehicles that entered the network so far, of
            them equipped, of those with an inattentive driver.
        n_hazards: emergency brakings injected so far.
        n_collisions: collisions SUMO reported so far (a lasting contact under action
            ``warn`` counts once).

    Use it as a context manager (or call :meth:`close`)::

        with SumoSource(SumoConfig("motorway.sumocfg", end=600, seed=1)) as src:
            frame = src.frame()
            while not src.done:
                frame = src.advance(brake)
    """

    #: It keeps a distracted driver's speed (:meth:`advance`'s ``hold``).
    accepts_hold = True

    def __init__(self, config: SumoConfig) -> None:
        global _OPEN
        if not isinstance(config, SumoConfig):
            raise ConfigError(f"config must be a SumoConfig, got {type(config).__name__}")
        self.config = cfg = config
        self._closed = True  # until SUMO runs
        self._tmpdir: str | None = None
        self._t = 0.0
        cfg_path = check_sumocfg(cfg.sumocfg, cfg.extra_args)
        if cfg.gui and not launch.has_display():
            raise ConfigError("gui needs a display (DISPLAY is not set); run without gui")
        api = self._api = launch.load_api(cfg.gui)
        self._errors = launch.traci_errors(api)
        other = _OPEN() if _OPEN is not None else None
        if other is not None and not other._closed:
            raise SumoError(
                f"a SUMO simulation ({other.config.sumocfg!r}) is already open in this process; "
                "close it first (libsumo runs one simulation per process: use one process per "
                "parallel run)"
            )
        if not cfg.gui and api.simulation.isLoaded():
            raise SumoError(
                "a libsumo simulation started outside acc_fusion is running in this process; "
                "close it first (libsumo runs one simulation per process)"
            )
        ssm_file = None
        if cfg.ssm:  # SUMO's SSM device writes a file nobody reads: a directory of our own
            self._tmpdir = tempfile.mkdtemp(prefix="acc_fusion_sumo_")
            ssm_file = os.path.join(self._tmpdir, "ssm.xml")
        cmd = launch.sumo_command(cfg, cfg_path, ssm_file)
        captured: list[str] = []
        try:
            # libsumo reports load errors on stderr (the exception says "Process Error");
            # sumo-gui is a child process that must keep its own stderr.
            with nullcontext() if cfg.gui else launch.captured_stderr(captured):
                api.start(cmd)
        except (*self._errors, OSError) as exc:
            # libsumo may hold a half-loaded simulation (e.g. a route with an unknown edge
            # fails after the net loaded): close it, or the process could not start another.
            try:
                api.close()
            except Exception:  # nothing was open
                pass
            self._cleanup()
            raise SumoError(
                f"SUMO could not load {str(cfg_path)!r}: {launch.sumo_message(exc, captured)}"
            ) from None
        self._closed = False
        _OPEN = weakref.ref(self)
        try:
            if cfg.warmup > 0:  # the network fills before the first frame (SumoConfig.warmup)
                self._guard(api.simulationStep, float(api.simulation.getTime()) + cfg.warmup)
            self._guard(self._setup, cfg_path)
        except BaseException:
            self.close()
            raise

    # ---------------------------------------------------------------- set-up
    def _setup(self, cfg_path: Path) -> None:
        cfg, api = self.config, self._api
        self._setup_reads()
        sim = api.simulation
        self.dt = float(sim.getDeltaT())
        self.begin = float(sim.getTime())
        sumo_end = float(sim.getEndTime()) if hasattr(sim, "getEndTime") else -1.0
        if cfg.end is not None:
            self.end_time, self._bounded = self.begin + cfg.end, True
        elif sumo_end >= 0:
            self.end_time, self._bounded = sumo_end, True
        else:
            self.end_time, self._bounded = self.begin + UNBOUNDED_END, False
        self._n_steps = max(0, int(math.ceil((self.end_time - self.begin) / self.dt - 1e-6)))
        n = self.n_pairs = int(cfg.capacity)
        ss = np.random.SeedSequence(int(cfg.seed)).spawn(3)
        self._rng_equip, self._rng_inatt = (np.random.default_rng(s) for s in ss[:2])
        self._hazard_key = int(np.random.default_rng(ss[2]).integers(2**63))
        self._hazard_due: list[tuple[float, str, int]] = []  # (time, vehicle, k): a heap
        # Per vehicle in the network: (integer id, equipped, inattentive), and the code of its
        # integer id and slot (_set_code; the compiled reader's table where it reads).
        self._info: dict[str, tuple[int, bool, bool]] = {}
        self._code: dict[str, int] = {} if self._native is None else self._native.Codes()
        self._teleporting: set[str] = set()
        self._next_int = 0
        self._slot_of: dict[str, int] = {}
        self._slot_vid: list[str | None] = [None] * n
        self._free = list(range(n))  # a heap: the lowest free slot first
        self._waiting: dict[str, None] = {}  # equipped vehicles without a slot, FIFO
        # The occupied slots in ascending order, with their vehicles, kept up to date as
        # slots are taken and freed; the slots taken (True) or freed (False) since the last
        # frame, applied to the (N,) arrays by _read.
        self._occ_list: list[int] = []
        self._occ_vids: list[str] = []
        self._occ_slots = np.zeros(0, dtype=np.intp)
        self._flips: list[tuple[int, bool]] = []
        self._maker = FrameMaker(n, self.dt, float(cfg.lookahead))
        # The slots taken at this step: their vehicle's minGap and acceleration (read once).
        self._news: dict[int, tuple[float, float]] = {}
        self._inattentive = np.zeros(n, dtype=bool)
        self._collided = np.zeros(n, dtype=bool)
        self._collision_speed = np.full(n, np.nan)
        self._reassigned = np.zeros(n, dtype=bool)
        self._active = np.zeros(n, dtype=bool)
        self._shown_level = np.full(n, -1, dtype=np.int64)
        self._ssm_slot = np.full(n, np.inf)
        self._ssm_min: dict[str, float] = {}
        self._ctrl: dict[str, int] = {}  # vehicles under our speed control -> original mode
        self._mode: dict[str, int] = {}  # ... -> the speed mode set now
        self._hazards: dict[str, _Hazard] = {}
        self._res: dict[str, dict] = {}
        self._k = 0
        self._trim_steps = max(1, round(TRIM_PERIOD / self.dt))
        self._t = self.begin
        self._sumo_done = False
        self.n_departed = self.n_equipped = self.n_inattentive = 0
        self.n_hazards = self.n_collisions = 0
        self._contacts: set[tuple[str, str]] = set()  # colliding pairs of the last step
        self._capacity_warned = False
        # Vehicles already in the network (e.g. a loaded state) count as departing now.
        self._update(entering=list(api.vehicle.getIDList()))
        self._make()

    # ---------------------------------------------------------------- public state
    @property
    def t(self) -> float:
        """Current simulation time [s]."""
        return self._t

    @property
    def n_steps(self) -> int:
        """Number of steps from the begin time to the end time."""
        return self._n_steps

    @property
    def done(self) -> bool:
        """The end time is reached (or, without an end time, no vehicle is left), or closed."""
        if self._closed or self._k >= self._n_steps:
            return True
        return not self._bounded and self._sumo_done

    @property
    def inattentive(self) -> np.ndarray:
        """``(N,)`` slots whose vehicle has an inattentive driver."""
        return self._inattentive & self._active

    @property
    def vehicle_ids(self) -> list[str | None]:
        """SUMO id of each slot's vehicle (``None`` for an empty slot)."""
        return list(self._slot_vid)

    @property
    def closed(self) -> bool:
        """Whether SUMO has been closed (by :meth:`close` or a failure)."""
        return self._closed

    def slot_of(self, vehicle_id: str) -> int | None:
        """The slot of an equipped vehicle, or ``None``."""
        return self._slot_of.get(vehicle_id)

    def leader_of(self, vehicle_id: str) -> str | None:
        """SUMO id of the vehicle ahead of ``vehicle_id`` (SUMO's ``getLeader`` within
        ``lookahead``), or ``None`` (no leader, the vehicle is absent, or SUMO is closed)."""
        if self._closed or vehicle_id not in self._info or vehicle_id in self._teleporting:
            return None
        try:
            found = self._api.vehicle.getLeader(vehicle_id, self.config.lookahead)
        except self._errors:
            return None
        return found[0] if found and found[0] else None

    def ssm_min_ttc(self) -> dict[str, float]:
        """Per equipped vehicle seen so far, the smallest TTC [s] reported by SUMO's SSM device
        (its ``device.ssm.minTTC`` parameter, followed at every step; ``inf`` when it never
        had an encounter with a TTC).  Empty unless ``ssm`` is set."""
        out = dict(self._ssm_min)
        for slot, vid in zip(self._occ_list, self._occ_vids, strict=True):
            out[vid] = min(out.get(vid, math.inf), float(self._ssm_slot[slot]))
        return out

    # ---------------------------------------------------------------- stepping
    def advance(
        self, ego_brake: np.ndarray | None = None, hold: np.ndarray | None = None
    ) -> TruthFrame:
        """Apply the drivers' brake requests, run one SUMO step and return the new frame.

        Args:
            ego_brake: ``(N,)`` deceleration requested by each slot's driver [m/s², >= 0];
                0 or NaN (or ``None`` for all) hands the vehicle back to SUMO.
            hold: ``(N,)`` bool, the slots whose driver is distracted
                (:attr:`acc_fusion.truth.driver.Driver.holding`): their speed is kept, minus
                their brake request, whatever SUMO's car following says; ``None``: none.

        Raises:
            SumoError: SUMO failed (the source is closed; everything read so far is kept).
        """
        self._step(ego_brake, hold)
        self._make()
        return self._frame

    def _step(self, ego_brake: np.ndarray | None = None, hold: np.ndarray | None = None) -> None:
        """:meth:`advance` without making the frame (the background source's child sends
        what it read, :meth:`_fill`, and the parent makes the frame)."""
        if self._closed:
            raise SumoError("the SUMO simulation is closed; open a new SumoSource")
        brake = None
        if ego_brake is not None:
            brake = check_array("ego_brake", ego_brake, (self.n_pairs,), finite=False)
            brake = np.where(np.isnan(brake), 0.0, brake)
            brake = check_array("ego_brake", brake, nonnegative=True)
        if hold is not None:
            hold = check_array("hold", hold, (self.n_pairs,)).astype(bool)
            if brake is None:
                brake = np.zeros(self.n_pairs)
        self._guard(self._control, brake, hold)
        try:
            self._api.simulationStep()
        except self._errors as exc:
            self._fail(exc)
        self._k += 1
        self._guard(self._update)
        if self._k % self._trim_steps == 0:
            release_free_heap()

    def close(self) -> None:
        """Close SUMO (idempotent); the last frame and the counters stay readable."""
        global _OPEN
        if not self._closed:
            self._closed = True
            try:
                self._api.close()
            except Exception:  # already failed or closed: nothing left to release
                pass
            if _OPEN is not None and _OPEN() is self:
                _OPEN = None
        self._cleanup()

    # ---------------------------------------------------------------- internals
    def _cleanup(self) -> None:
        if self._tmpdir is not None:
            shutil.rmtree(self._tmpdir, ignore_errors=True)
            self._tmpdir = None

    def _fail(self, exc: BaseException, captured: Sequence[str] = ()) -> None:
        t = self._t
        self.close()
        raise SumoError(
            f"SUMO failed at t = {t:g} s running {self.config.sumocfg!r}: "
            f"{launch.sumo_message(exc, captured)}"
        ) from exc

    def _guard(self, func, *args) -> None:
        """Run a step of TraCI calls; a failure of SUMO becomes a :class:`SumoError`."""
        try:
            func(*args)
        except self._errors as exc:
            self._fail(exc)

    def _speed(self, vid: str) -> float:
        """Current speed of any vehicle in the network [m/s]."""
        if self._subscribed:
            return float(self._res[vid][self._v_speed])
        return float(self._api.vehicle.getSpeed(vid))

    def _update(self, entering: Sequence[str] | None = None) -> None:
        """Read the step's events into the slots, then the vehicles' state into the frame."""
        sim = self._api.simulation
        self._t = float(sim.getTime())
        self._reassigned = np.zeros(self.n_pairs, dtype=bool)
        self._news = {}
        freed: list[int] = []
        back: Sequence[str] = ()
        if entering is None:
            contacts = set()
            for c in sim.getCollisions():
                contacts.add((c.collider, c.victim))
                if (c.collider, c.victim) not in self._contacts:  # "warn": reported each step
                    self.n_collisions += 1
                slot = self._slot_of.get(c.collider)
                if slot is not None and not self._collided[slot]:
                    self._collided[slot] = True
                    self._collision_speed[slot] = float(c.colliderSpeed) - float(c.victimSpeed)
            self._contacts = contacts
            for vid in sim.getArrivedIDList():
                self._leave(vid, freed, arrived=True)
            for vid in sim.getStartingTeleportIDList():
                self._leave(vid, freed, arrived=False)
            entering = sim.getDepartedIDList()
            back = sim.getEndingTeleportIDList()
        for vid in entering:
            self._depart(vid)
        for vid in back:  # back from a teleport: a new target with a fresh integer id
            self._teleporting.discard(vid)
            if vid in self._info:
                _, equipped, inatt = self._info[vid]
                self._info[vid] = (self._new_int(), equipped, inatt)
                self._set_code(vid)
                if equipped:
                    self._waiting[vid] = None
        self._assign()
        for slot in freed:  # reusable from the next step on
            heapq.heappush(self._free, slot)
        if self._k % SWEEP_STEPS == 0 and self._k:
            self._sweep()
        self._read()
        if not self._bounded:
            self._sumo_done = self._k > 0 and sim.getMinExpectedNumber() <= 0

    def _depart(self, vid: str) -> None:
        cfg, veh = self.config, self._api.vehicle
        if vid in self._info:
            return
        # One draw of each kind per vehicle, in departure order: reproducible, and a higher
        # penetration equips a superset of the vehicles.
        equipped = bool(self._rng_equip.random() < cfg.penetration)
        inatt = bool(self._rng_inatt.random() < cfg.inattentive) and equipped
        self._info[vid] = (self._new_int(), equipped, inatt)
        self._set_code(vid)
        self.n_departed += 1
        if cfg.hazard_rate > 0:
            self._schedule_hazard(vid, 0)
        if self._subscribed:
            if equipped:
                variables = [self._v_speed, self._v_accel, self._v_leader]
                veh.subscribe(vid, variables, parameters=self._leader_param)
            else:
                veh.subscribe(vid, [self._v_speed, self._v_accel])
        if equipped:
            if cfg.ssm:
                veh.subscribeParameterWithKey(vid, "device.ssm.minTTC")
            if inatt:
                veh.setActionStepLength(vid, cfg.inattentive_action_step)
                self.n_inattentive += 1
            self.n_equipped += 1
            self._waiting[vid] = None
