r"""SUMO truth source: ground truth for every equipped vehicle of a SUMO traffic simulation.

Pipeline stage 1 (**truth source** → sensors → ...), like
:class:`~acc_fusion.truth.scripted.ScenarioSource`, but the traffic is simulated by SUMO (Eclipse
SUMO, https://eclipse.dev/sumo) on any road network: a ``.sumocfg`` of the bundled
``sumo_nets`` or the user's own.  :class:`SumoSource` offers the interface the FCW loop
drives (``frame()``, ``advance(ego_brake)``, ``t``, ``n_steps``, ``done``, ``active``,
``collided``, ``collision_speed``) plus ``reassigned`` and ``vehicle_ids``.

Slots
    A fraction ``penetration`` of the vehicles is *equipped* with FCW (drawn per vehicle from
    the seed).  Each equipped vehicle present in the network occupies one of ``capacity``
    *slots*, the pair axis N of every array (``N = capacity``, fixed for the whole run).  A
    slot is freed when its vehicle arrives, leaves the network, is removed after a collision
    or starts a teleport; the next vehicle put in it is flagged in :attr:`SumoSource.reassigned`
    at that step, so the FCW loop resets its per-slot state (filters, warning logic,
    driver).  A slot freed at a step is reused at the next step at the earliest, so that a
    collision stays visible in :attr:`SumoSource.collided` for at least one frame.  Empty
    slots have ``leader_id = -1``, ``ego_speed = 0`` and are not :attr:`SumoSource.active`.
    When more equipped vehicles are present than slots, the extra ones wait (a warning is
    issued once) and take the first slot that frees.

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
    Per step the source asks SUMO only for what changed (departed, arrived, teleporting,
    colliding vehicles: per-vehicle Python work only for those) and, per equipped vehicle,
    its speed and its leader; the acceleration is :math:`(v_k - v_{k-1})/\Delta t` from the
    slot's previous speed, which is exactly SUMO's ``getAcceleration`` (checked to 0 on 5880
    samples), so only vehicles new to a slot and unequipped leaders need more getters.  With
    libsumo (in-process) the speeds and leaders come from the compiled reader of
    :mod:`acc_fusion.truth.sumo.native` (libsumo's C++ functions, every vehicle in one call), else
    from
    direct calls to the SWIG functions: measured on a 3-lane
    motorway with 524 vehicles (SUMO 1.28), subscribing speed, acceleration and leader cost
    about 2 ms more per SUMO step plus 0.7 ms for ``getAllSubscriptionResults``, while the
    direct calls cost about 0.5 ms.  Through TraCI (``gui``), where every call is a socket
    round trip, the same values come from subscriptions (``VAR_SPEED``, ``VAR_ACCELERATION``
    for every vehicle, ``VAR_LEADER`` with the lookahead as its parameter for the equipped
    ones) and one ``getAllSubscriptionResults`` per step.  Both paths give identical frames.

Threats (so that false-alarm and miss rates mean something)
    - *Lead-vehicle emergency braking*: events at ``hazard_rate`` per vehicle-hour (Poisson,
      :math:`\lambda = r\, n_{\text{veh}}\, \Delta t / 3600` per step); a uniformly drawn
      vehicle (equipped or not) brakes at ``hazard_decel`` for ``hazard_duration`` seconds
      (commanded speed :math:`v_{k+1} = \max(v_k - a\,\Delta t, 0)` with SUMO's
      deceleration limit lifted, its emergency deceleration raised to ``hazard_decel`` if
      lower), then control returns to SUMO.  :meth:`SumoSource.inject_hazard` starts one on a
      chosen vehicle.
    - *Inattentive drivers*: a fraction ``inattentive`` of the equipped vehicles gets SUMO's
      action step length (the driver's decision interval, SUMO's model of reaction time)
      ``inattentive_action_step`` (1.5 s, Green 2000's "surprise" brake reaction) instead of
      the simulation step.  SUMO's Krauss model assumes a reaction of ``tau`` (1 s) in its
      safe speed, so these drivers can run into a braking leader.
    - *Collisions happen*: SUMO runs with ``--collision.mingap-factor 0`` (only physical
      contact counts), ``--collision.check-junctions true`` and ``--collision.action``
      ``collision_action`` (``remove`` by default: both vehicles leave the network, which
      ends the pair).  Collisions are read with ``simulation.getCollisions()``; the slot of
      the *collider* (the vehicle that ran into another) is flagged :attr:`collided` with
      the impact speed ``colliderSpeed - victimSpeed``.  The victim's slot is not flagged (a
      vehicle rear-ended by another is no forward-collision failure).

Closed loop
    :meth:`SumoSource.advance` takes the brake request of each slot's driver [m/s²]: the
    vehicle is commanded :math:`v_{k+1} = \max(v_k - a\,\Delta t, 0)` through ``setSpeed``
    with SUMO's deceleration limit lifted (speed-mode bit 2 cleared; SUMO still never lets
    it drive faster than its safe speed), and handed back (``setSpeed(-1)`` and the original
    speed mode) at the first step without a request.

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
    superset of the vehicles of a lower one.

Sources: SUMO documentation (TraCI vehicle value retrieval and state change, speed mode bits,
``simulation.getCollisions``, collision options, action step length); M. Green, "'How long
does it take to stop?'", Transportation Human Factors 2(3):195-216, 2000 (1.5 s surprise
reaction).  Verified against eclipse-sumo / libsumo 1.28: in libsumo the ``VAR_LEADER``
subscription parameter is a plain float (TraCI's Python client expects ``("d", dist)``); the
result is ``(leader_id, gap)`` with ``("", -1.0)`` when there is no leader (``None`` from the
Python wrappers); the gap plus the follower's ``minGap`` equals the lane-position difference
minus the leader's length; ``getLeader``'s distance is a *minimum* lookahead, hence the
``lookahead`` cut; collisions with action ``remove`` list both vehicles as arrived in the same
step; ``setSpeed`` acts at every step even for a vehicle with a long action step length;
stepping past the ``.sumocfg``'s end is allowed (the end is enforced here); a second
``libsumo.start`` silently replaces the running simulation.
"""

from __future__ import annotations

import bisect
import heapq
import math
import os
import shutil
import sys
import tempfile
import warnings
import weakref
from collections.abc import Sequence
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass
from itertools import repeat
from operator import itemgetter
from pathlib import Path
from typing import Any

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.levels import WARNING_COLORS
from acc_fusion.core.units import TIME_TOL
from acc_fusion.core.validation import check_array, check_range
from acc_fusion.truth.frame import SlotSource, TruthFrame
from acc_fusion.truth.sumo.config import UNBOUNDED_END, SumoConfig, SumoError, check_sumocfg
from acc_fusion.truth.sumo.frames import FrameMaker
from acc_fusion.truth.sumo.native import sumo_reader

#: SUMO speed-mode bit 2: "regard maximum deceleration" (cleared while we command braking).
SPEED_MODE_MAX_DECEL = 0b100
#: Steps between two checks for vehicles that left without an event (bounded memory).
SWEEP_STEPS = 1000


def sumo_command(
    config: SumoConfig, cfg_path: str | os.PathLike | None = None, ssm_file: str | None = None
) -> list[str]:
    """The SUMO command line of a :class:`SumoSource` with ``config``: the ``.sumocfg``
    (``cfg_path``, by default ``config.sumocfg``) with the source's seed, collision and
    step-length options, and the SSM device writing to ``ssm_file`` when ``config.ssm``.
    The run length is not on it (the source stops stepping at its end time); a benchmark
    that runs SUMO alone on the same scenario adds ``--end``.

    >>> sumo_command(SumoConfig("motorway.sumocfg", seed=3))[1:5]
    ['-c', 'motorway.sumocfg', '--seed', '3']
    """
    cmd = [
        _sumo_binary(config.gui),
        "-c", os.fspath(config.sumocfg if cfg_path is None else cfg_path),
        "--seed", str(int(config.seed)),
        "--no-step-log", "true",
        "--no-warnings", "true",
        "--duration-log.disable", "true",
        "--collision.action", config.collision_action,
        "--collision.mingap-factor", "0",
        "--collision.check-junctions", "true",
    ]  # fmt: skip
    if config.step_length is not None:
        cmd += ["--step-length", repr(float(config.step_length))]
    if config.ssm:
        cmd += [
            "--device.ssm.probability", "1",
            "--device.ssm.measures", "TTC",
            "--device.ssm.file", ssm_file or os.devnull,
        ]  # fmt: skip
    if config.gui:
        cmd += ["--start", "true", "--quit-on-end", "true"]
    return cmd + list(config.extra_args)


@contextmanager
def _captured_stderr(sink: list[str]):
    """Capture what SUMO writes to the process's stderr (fd 2) into ``sink``, then echo it."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, AttributeError, ValueError):  # no real fd 2 (embedded interpreters)
        yield
        return
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            text = tmp.read().decode("utf-8", "replace")
            sink.append(text)
            if text:
                sys.stderr.write(text)


def _sumo_message(exc: BaseException, captured: Sequence[str]) -> str:
    """SUMO's own error text: its ``Error:`` lines on stderr, else the exception's text."""
    lines = [ln.strip() for text in captured for ln in text.splitlines() if ln.strip()]
    errors = [ln.removeprefix("Error:").strip() for ln in lines if ln.startswith("Error")]
    text = " ".join(errors) or " ".join(str(exc).split()) or type(exc).__name__
    return text.rstrip(".")


def _load_api(gui: bool) -> Any:
    """The libsumo module (default) or the TraCI client module (``gui``)."""
    try:
        import sumo  # noqa: F401  (the eclipse-sumo wheel: sets SUMO_HOME)

        if gui:
            import traci as api
        else:
            import libsumo as api
    except ImportError as exc:
        raise ConfigError(
            f"SUMO support needs eclipse-sumo and libsumo: pip install 'acc_fusion[sumo]' ({exc})"
        ) from None
    return api


def _traci_errors(api: Any) -> tuple[type[BaseException], ...]:
    """The exception classes SUMO raises through ``api`` (libsumo's and TraCI's)."""
    import traci

    found = {
        getattr(module, name, None)
        for module in (api, traci, traci.exceptions)
        for name in ("TraCIException", "FatalTraCIError")
    }
    return tuple(c for c in found if isinstance(c, type) and issubclass(c, BaseException))


def _sumo_binary(gui: bool) -> str:
    """The ``sumo`` or ``sumo-gui`` executable of the eclipse-sumo wheel."""
    import sumo

    name = "sumo-gui" if gui else "sumo"
    exe = Path(sumo.SUMO_HOME) / "bin" / (name + (".exe" if os.name == "nt" else ""))
    if not exe.is_file():
        found = shutil.which(name)
        if found is None:
            raise ConfigError(f"{name} was not found in the eclipse-sumo wheel ({exe}) nor on PATH")
        return found
    return str(exe)


def _has_display() -> bool:
    """Whether a GUI can open: always on Windows/macOS, with DISPLAY or WAYLAND_DISPLAY else."""
    if sys.platform in ("win32", "darwin"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


#: The open source of this process (libsumo holds one simulation per process).
_OPEN: weakref.ref[SumoSource] | None = None


@dataclass
class _Hazard:
    end: float
    decel: float
    emergency: float | None  # emergency deceleration to restore, None if unchanged


class SumoSource(SlotSource):
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

    def __init__(self, config: SumoConfig) -> None:
        global _OPEN
        if not isinstance(config, SumoConfig):
            raise ConfigError(f"config must be a SumoConfig, got {type(config).__name__}")
        self.config = cfg = config
        self._closed = True  # until SUMO runs
        self._tmpdir: str | None = None
        self._t = 0.0
        cfg_path = check_sumocfg(cfg.sumocfg, cfg.extra_args)
        if cfg.gui and not _has_display():
            raise ConfigError("gui needs a display (DISPLAY is not set); run without gui")
        api = self._api = _load_api(cfg.gui)
        self._errors = _traci_errors(api)
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
        cmd = sumo_command(cfg, cfg_path, ssm_file)
        captured: list[str] = []
        try:
            # libsumo reports load errors on stderr (the exception says "Process Error");
            # sumo-gui is a child process that must keep its own stderr.
            with nullcontext() if cfg.gui else _captured_stderr(captured):
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
                f"SUMO could not load {str(cfg_path)!r}: {_sumo_message(exc, captured)}"
            ) from None
        self._closed = False
        _OPEN = weakref.ref(self)
        try:
            self._guard(self._setup, cfg_path)
        except BaseException:
            self.close()
            raise

    # ---------------------------------------------------------------- set-up
    def _setup(self, cfg_path: Path) -> None:
        cfg, api = self.config, self._api
        tc = api.constants
        self._v_speed, self._v_accel = tc.VAR_SPEED, tc.VAR_ACCELERATION
        self._v_leader, self._v_param = tc.VAR_LEADER, tc.VAR_PARAMETER_WITH_KEY
        # libsumo: the compiled reader, else direct getters (both cheaper than subscriptions
        # in-process); TraCI: one subscription read per step instead of a socket round trip
        # per value.
        self._subscribed = bool(cfg.gui)
        self._native = sumo_reader() if cfg.native and not cfg.gui else None
        self._get_speed = _raw(api, "vehicle_getSpeed", api.vehicle.getSpeed)
        self._get_leader = _raw(api, "vehicle_getLeader", None) or _public_leader(api)
        dist = float(cfg.lookahead)
        self._leader_param = {tc.VAR_LEADER: ("d", dist)}  # TraCI's typed parameter
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
        self._rng_equip, self._rng_inatt, self._rng_hazard = (np.random.default_rng(s) for s in ss)
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
        self._maker = FrameMaker(n, self.dt, dist)
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
        self._hazards: dict[str, _Hazard] = {}
        self._res: dict[str, dict] = {}
        self._k = 0
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
    def advance(self, ego_brake: np.ndarray | None = None) -> TruthFrame:
        """Apply the drivers' brake requests, run one SUMO step and return the new frame.

        Args:
            ego_brake: ``(N,)`` deceleration requested by each slot's driver [m/s², >= 0];
                0 or NaN (or ``None`` for all) hands the vehicle back to SUMO.

        Raises:
            SumoError: SUMO failed (the source is closed; everything read so far is kept).
        """
        self._step(ego_brake)
        self._make()
        return self._frame

    def _step(self, ego_brake: np.ndarray | None = None) -> None:
        """:meth:`advance` without making the frame (the background source's child sends
        what it read, :meth:`_fill`, and the parent makes the frame)."""
        if self._closed:
            raise SumoError("the SUMO simulation is closed; open a new SumoSource")
        brake = None
        if ego_brake is not None:
            brake = check_array("ego_brake", ego_brake, (self.n_pairs,), finite=False)
            brake = np.where(np.isnan(brake), 0.0, brake)
            brake = check_array("ego_brake", brake, nonnegative=True)
        self._guard(self._control, brake)
        try:
            self._api.simulationStep()
        except self._errors as exc:
            self._fail(exc)
        self._k += 1
        self._guard(self._update)

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
            f"{_sumo_message(exc, captured)}"
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

    def _control(self, brake: np.ndarray | None) -> None:
        """Start hazards, then command the braking vehicles and hand back the others."""
        cfg, dt, veh = self.config, self.dt, self._api.vehicle
        if cfg.hazard_rate > 0 and self._info:
            count = self._rng_hazard.poisson(cfg.hazard_rate * len(self._info) * dt / 3600.0)
            if count:
                ids = list(veh.getIDList())  # SUMO's order: reproducible
                for pick in self._rng_hazard.integers(len(ids), size=count):
                    self.inject_hazard(ids[pick])
        targets: dict[str, float] = {}
        for vid, hz in list(self._hazards.items()):
            if self._t >= hz.end - TIME_TOL:
                self._end_hazard(vid)
            else:
                targets[vid] = max(self._speed(vid) - hz.decel * dt, 0.0)
        if brake is not None:
            speed = self._frame.ego_speed
            for slot in np.flatnonzero((brake > 0) & self._active):
                vid = self._slot_vid[slot]
                target = max(float(speed[slot]) - float(brake[slot]) * dt, 0.0)
                targets[vid] = min(targets.get(vid, math.inf), target)
        for vid in [v for v in self._ctrl if v not in targets]:
            self._release(vid)
        for vid, target in targets.items():
            if vid not in self._ctrl:
                mode = int(veh.getSpeedMode(vid))
                self._ctrl[vid] = mode
                veh.setSpeedMode(vid, mode & ~SPEED_MODE_MAX_DECEL)
            veh.setSpeed(vid, target)

    def _release(self, vid: str) -> None:
        """Hand a vehicle back to SUMO: no commanded speed, its original speed mode."""
        mode = self._ctrl.pop(vid, None)
        if mode is not None:
            veh = self._api.vehicle
            veh.setSpeed(vid, -1.0)
            veh.setSpeedMode(vid, mode)

    def _end_hazard(self, vid: str) -> None:
        """End an emergency braking: restore the emergency deceleration."""
        hz = self._hazards.pop(vid, None)
        if hz is not None and hz.emergency is not None:
            self._api.vehicle.setEmergencyDecel(vid, hz.emergency)

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

    def _set_code(self, vid: str, slot: int = -1) -> None:
        """Record the code of ``vid``'s integer id and slot (``-1``: none), ``id * (N + 1) +
        slot + 1``: :meth:`_fill` finds both for every leader with one dict lookup."""
        self._code[vid] = self._info[vid][0] * (self.n_pairs + 1) + slot + 1

    def _new_int(self) -> int:
        self._next_int += 1
        return self._next_int - 1

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

    def _fill(self) -> None:
        """Read SUMO's values of the occupied slots' vehicles, one pass over them per quantity:
        each one's speed, its leader's distance and code, and the speed and acceleration of
        every leader that holds no slot (its own getters), into :attr:`_raw`; the frame is
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
                leaders = [r[ld] or _NO_LEADER for r in rows]  # TraCI: None without
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
            ttc = np.array([_ttc(res[v].get(pk)) for v in vids])
            self._ssm_slot[slots] = np.minimum(self._ssm_slot[slots], ttc)
        self._raw = (slots, speed, dists, codes, others, accel)

    def _make(self) -> None:
        """Make the current frame of what :meth:`_fill` read."""
        slots, speed, dists, codes, others, accel = self._raw
        self._frame = self._maker.make(
            self._t, slots, speed, dists, codes, self._news, others, accel
        )


def _raw(api: Any, name: str, public: Any) -> Any:
    """libsumo's SWIG function ``name`` without its Python wrapper (a third cheaper per
    call), else the public function.  The raw ``vehicle_getLeader`` returns ``("", -1.0)``
    without a leader where the wrapper returns ``None``."""
    module = getattr(getattr(api, "libsumo", None), "_libsumo", None)
    return getattr(module, name, None) or public


def _public_leader(api: Any) -> Any:
    """The public ``getLeader``, returning :data:`_NO_LEADER` instead of ``None`` as the raw one."""
    get = api.vehicle.getLeader
    return lambda vid, dist: get(vid, dist) or _NO_LEADER


_NO_LEADER = ("", -1.0)


def _ttc(item: Any) -> float:
    """The value of a ``device.ssm.minTTC`` parameter subscription (``inf`` when empty)."""
    try:
        return float(item[1])
    except (TypeError, ValueError, IndexError):
        return math.inf
