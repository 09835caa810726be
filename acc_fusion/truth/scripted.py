r"""Scripted truth source: the standard FCW/AEB test manoeuvres, batched over N runs.

Pipeline stage 1 (**truth source** → sensors → ...).  :class:`ScenarioSource` scripts the
motion of an ego (subject) vehicle and up to two other vehicles for each of N independent runs
and yields one :class:`~acc_fusion.truth.frame.TruthFrame` per step.  It is closed-loop capable:
:meth:`ScenarioSource.advance` takes the brake request of each run's driver (see
:mod:`acc_fusion.truth.driver`).  The manoeuvres and their sources:
:mod:`acc_fusion.truth.manoeuvres`.

State (per run, shape ``(N,)``; :meth:`ScenarioSource.state`)
    Ego front-bumper position, speed, acceleration; the leader's rear-bumper position, speed,
    acceleration and length; ``gap`` = leader rear bumper - ego front bumper (bumper to
    bumper); ``leader_id`` (the vehicle's slot + 1, plus :data:`SLOTS` per restart of the run;
    ``-1`` when there is none); the leader's lateral offset (0 when in lane); ``active``.

Kinematics (exact)
    Every vehicle moves with a constant acceleration within a step; a vehicle's script is a list
    of segments "from time :math:`t_k` on, go to speed :math:`v_k` at :math:`|a| = r_k`, then
    hold it", and within a step of length :math:`\Delta t` a vehicle at speed :math:`v` reaches
    the target after :math:`\tau = \min(|v_k - v| / r_k, \Delta t)`, so

    .. math::

        v' = v + a\tau,\qquad x' = x + v\,\Delta t + \tfrac12 a\tau^2 + a\tau(\Delta t - \tau)

    exactly.  Braking has target speed 0, so a braking vehicle stops exactly and stays stopped:
    speeds are never negative.  A segment starts at the first step boundary at or after its
    time (default event times are multiples of common steps).  The ego follows its scripted
    speed (constant; in ``following`` and ``stop_and_go`` the IDM, see :class:`IDMParameters`)
    unless the run's driver requests a deceleration (it brakes with it) or looks away (it keeps
    its speed).
    Once a driver has braked, a scripted constant-speed ego no longer returns to its script:
    it keeps its speed when the driver releases (the IDM ego resumes following).

Leader and lateral offset
    A lane change moves a vehicle's lateral offset from ``from`` to ``to`` along the smooth
    step :math:`3u^2 - 2u^3`, :math:`u = (t - t_0)/T_{lc}` (lanes :data:`LANE_WIDTH` apart).
    The leader is the nearest vehicle ahead whose body overlaps the ego's laterally
    (:math:`|y| <` :data:`OVERLAP_OFFSET`): a cut-in vehicle becomes the leader (new id) when
    it crosses that line, a cut-out lead stops being the leader when it leaves it.

Collisions and the end of a run
    When the gap to the leader reaches 0 the run is marked ``collided`` at that step, the
    closing speed at the end of that step is recorded as ``collision_speed`` (exact when neither
    vehicle accelerates; within :math:`|\Delta a|\,\Delta t` otherwise), both vehicles stop
    at contact (gap 0) and the run ends.  A scripted (non-IDM) run also ends when the threat is
    resolved after its driver braked: ego stopped, or no longer closing on its leader, or no
    leader.  Every run ends at its ``duration``.  An ended run is frozen: later frames repeat
    its final state with ``leader_id = -1`` (so downstream stages ignore it) and ``active`` is
    False; frames stay valid :class:`~acc_fusion.truth.frame.TruthFrame` s.

Restarting runs (:meth:`ScenarioSource.restart`)
    The runs of a mask can start a new run of the same scenario at the current time, while the
    others continue (a vector environment whose copies reset independently).  Every run has
    its own time origin :attr:`~ScenarioSource.t0` (0 at construction, the restart time
    after a restart); its script, ``duration`` and ``end_time`` are in *run time*
    :attr:`~ScenarioSource.run_time` = ``t - t0``, so a restarted run behaves exactly like
    the same run of a fresh source, except that its leader ids are offset by
    :data:`SLOTS` per restart (ids stay unique per run, so downstream stages see a new target;
    see :attr:`~ScenarioSource.generation`) and that ``frame().t`` is the global time.

Randomness and reproducibility
    All randomness (the Monte Carlo draws of :func:`random_suite`, the phases of the lead's
    speed fluctuations and stop-and-go cycles) comes from ``numpy.random.default_rng(seed)``
    and is drawn at construction, so the same seed gives identical frames and closed-loop
    actions never change the random stream.

Example:
    >>> src = make_scenario("nhtsa_lvs", 3, seed=0)
    >>> frame = src.frame()
    >>> while not src.done:
    ...     frame = src.advance()          # no driver: every run hits the stopped POV
    >>> bool(src.collided.all()), round(float(src.collision_speed[0]) * 3.6, 1)
    (True, 72.4)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from acc_fusion.core.arrays import check_array
from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.units import TIME_TOL
from acc_fusion.core.validation import check_choice, check_range
from acc_fusion.truth import scripted_kernels as kernels
from acc_fusion.truth.frame import TruthFrame
from acc_fusion.truth.manoeuvre_params import IDM, OVERLAP_OFFSET, SLOTS, VEHICLE_LENGTH
from acc_fusion.truth.manoeuvres import SCENARIOS, Draws, _merge, _merge_into, _ranges_table


@dataclass(frozen=True)
class ScenarioState:
    """State of every run at time ``t`` (arrays ``(N,)``; leader fields NaN without a leader).

    Attributes:
        t: time [s].
        ego_position: ego front-bumper position [m] (0 at the start).
        ego_speed, ego_accel: ego speed [m/s] and mean acceleration over the step that ended
            at ``t`` [m/s²] (as SUMO reports it; 0 at a run's start).
        lead_position: leader rear-bumper position [m].
        lead_speed, lead_accel, lead_length: leader speed [m/s], acceleration [m/s²], length [m].
        gap: ``lead_position - ego_position`` [m] (bumper to bumper).
        leader_id: leader id (its slot + 1, plus :data:`SLOTS` per restart of the run), ``-1``
            without a leader or after the run ended.
        lateral_offset: leader's lateral offset [m] (0 when in lane).
        active: runs that have not ended.
    """

    t: float
    ego_position: np.ndarray
    ego_speed: np.ndarray
    ego_accel: np.ndarray
    lead_position: np.ndarray
    lead_speed: np.ndarray
    lead_accel: np.ndarray
    lead_length: np.ndarray
    gap: np.ndarray
    leader_id: np.ndarray
    lateral_offset: np.ndarray
    active: np.ndarray

    def frame(self) -> TruthFrame:
        """The :class:`~acc_fusion.truth.frame.TruthFrame` of this state (its arrays are the
        source's own, float64 and int64, finite where a leader is shown: taken unchecked)."""
        has = self.leader_id >= 0
        return TruthFrame.from_arrays(
            self.t,
            self.ego_speed,
            self.ego_accel,
            self.gap,
            self.lead_speed,
            self.lead_accel,
            self.leader_id,
            np.where(has, self.lateral_offset, 0.0),
        )


class ScenarioSource:
    """Truth source scripting a standard manoeuvre for N runs (see the module docstring).

    Args:
        name: a key of :data:`SCENARIOS`.
        n_runs: number of runs N.
        dt: simulation step [s], in (0, 1].
        seed: seed of the generator (``int``, ``numpy.random.Generator`` or ``None``).
        params: the manoeuvre's parameters (its class in :data:`SCENARIOS`); default: defaults.
        duration: length of every run [s]; default: the manoeuvre's own.

    Attributes:
        kind: ``(N,)`` manoeuvre name of each run (mixed for ``random``).
        duration: ``(N,)`` length of each run [s] (its current run after a :meth:`restart`).

    Times of a run's script, ``duration`` and :attr:`end_time` are run times (:attr:`run_time`,
    time since the run's :attr:`t0`); they equal the global time :attr:`t` until the run is
    restarted.
    """

    #: It keeps a distracted driver's speed (:meth:`advance`'s ``hold``).
    accepts_hold = True

    def __init__(
        self,
        name: str,
        n_runs: int,
        dt: float = 0.05,
        seed: int | np.random.Generator | None = None,
        params: Any = None,
        duration: float | None = None,
    ) -> None:
        manoeuvre = SCENARIOS[check_choice("scenario", name, SCENARIOS)]
        if isinstance(n_runs, bool) or not isinstance(n_runs, (int, np.integer)) or n_runs < 1:
            raise ConfigError(f"n_runs must be an integer >= 1, got {n_runs!r}")
        self.name, self.n_runs = name, int(n_runs)
        self.dt = check_range("dt", dt, 0.0, 1.0, lo_open=True)
        if params is None:
            params = manoeuvre.params()
        elif not isinstance(params, manoeuvre.params):
            raise ConfigError(
                f"params of {name!r} must be a {manoeuvre.params.__name__}, "
                f"got {type(params).__name__}"
            )
        horizon = (
            None if duration is None else check_range("duration", duration, 0.0, 1e6, lo_open=True)
        )
        self.params = params
        self._build, self._horizon = manoeuvre.build, horizon
        plan, runs, self.kind = manoeuvre.build(
            params, self.n_runs, np.random.default_rng(seed), horizon
        )
        self._params = Draws.of(plan, runs, self.kind).table()
        self._plan = plan
        self._own_plan = False  # the plan's arrays may be the run parameters' own
        self.duration = plan.duration
        self._k = 0
        self._k0 = np.zeros(self.n_runs, dtype=np.int64)  # step at which each run started
        self._run_t = np.zeros(self.n_runs)  # run time (self._k - self._k0) * dt
        self._generation = np.zeros(self.n_runs, dtype=np.int64)
        self._reassigned = np.zeros(self.n_runs, dtype=bool)
        self._ego_x = np.zeros(self.n_runs)
        self._ego_v = plan.ego_speed.astype(float)
        self._ego_a = np.zeros(self.n_runs)  # over the last step
        self._x = plan.position.astype(float)
        self._v = plan.speed.astype(float)
        self._brake = np.zeros(self.n_runs)
        self._hold = np.zeros(self.n_runs, dtype=bool)
        self._braked = np.zeros(self.n_runs, dtype=bool)
        self._end_time = np.full(self.n_runs, np.inf)
        self._collided = np.zeros(self.n_runs, dtype=bool)
        self._collision_speed = np.full(self.n_runs, np.nan)
        self._rows = np.arange(self.n_runs)
        # every run's leader: slot, whether it has one, gap, lateral offset (advance keeps them)
        self._leaders = tuple(np.zeros(self.n_runs, t) for t in (np.int64, bool, float, float))
        self._find_leaders(self._rows)
        self._frame: TruthFrame | None = None  # the frame of this step, built on demand

    # ---- public state
    @property
    def run_params(self) -> dict[str, np.ndarray]:
        """``{field: (N,) array}`` parameters of each run (NaN where a field does not apply to
        the run's kind); runs started later do not change the arrays returned."""
        return self._params.columns()

    @property
    def t(self) -> float:
        """Current time [s] (``step * dt``, so event times do not drift)."""
        return self._k * self.dt

    @property
    def t0(self) -> np.ndarray:
        """``(N,)`` start time of each run's current run [s] (0 until :meth:`restart`)."""
        return self._k0 * self.dt

    @property
    def run_time(self) -> np.ndarray:
        """``(N,)`` time since each run started [s] (``t - t0``, computed per step)."""
        return self._run_t.copy()

    @property
    def generation(self) -> np.ndarray:
        """``(N,)`` number of times each run was restarted."""
        return self._generation.copy()

    @property
    def reassigned(self) -> np.ndarray:
        """``(N,)`` runs restarted since the last :meth:`advance` or :meth:`move` (reset their
        per-run state).

        The same flag as :attr:`acc_fusion.truth.sumo.source.SumoSource.reassigned`: the current
        frame of these runs is the first frame of a new run.
        """
        return self._reassigned.copy()

    @property
    def n_steps(self) -> int:
        """Step count (from construction, like :attr:`t` / ``dt``) at which the longest current
        run reaches its duration.

        Without restarts: the number of steps of the longest run.  After a :meth:`restart` it
        is ``max(t0 + duration) / dt`` over the current runs, so ``n_steps - t / dt`` steps
        remain until every current run has timed out.
        """
        steps = np.ceil(self.duration / self.dt - TIME_TOL).astype(np.int64)
        return int(np.max(self._k0 + steps))

    @property
    def active(self) -> np.ndarray:
        """``(N,)`` runs that have not ended."""
        return np.isinf(self._end_time)

    @property
    def done(self) -> bool:
        """Every run has ended."""
        return not self.active.any()

    @property
    def end_time(self) -> np.ndarray:
        """``(N,)`` run time (:attr:`run_time`) at which each run ended [s] (``inf`` while it
        runs); the global end time is ``t0 + end_time``."""
        return self._end_time.copy()

    @property
    def collided(self) -> np.ndarray:
        """``(N,)`` runs that ended in a collision."""
        return self._collided.copy()

    @property
    def collision_speed(self) -> np.ndarray:
        """``(N,)`` relative (closing) speed at impact [m/s]; NaN where no collision."""
        return self._collision_speed.copy()

    def state(self) -> ScenarioState:
        """The full state of every run now."""
        plan = self._plan
        (position, speed, accel, length, gap, lat), ids = kernels.lead_state(
            plan.seg_t, plan.seg_v, plan.seg_rate, self._run_t, self._end_time, TIME_TOL,
            self._x, self._v, *self._leaders, self._generation, SLOTS, VEHICLE_LENGTH,
        )  # fmt: skip
        return ScenarioState(
            t=self.t,
            ego_position=self._ego_x.copy(),
            ego_speed=self._ego_v.copy(),
            ego_accel=self._ego_a.copy(),
            lead_position=position,
            lead_speed=speed,
            lead_accel=accel,
            lead_length=length,
            gap=gap,
            leader_id=ids,
            lateral_offset=lat,
            active=self.active,
        )

    def frame(self) -> TruthFrame:
        """The current truth as a :class:`~acc_fusion.truth.frame.TruthFrame` (built once per step:
        repeated calls return the same object)."""
        if self._frame is None:
            self._frame = self.state().frame()
        return self._frame

    def advance(
        self, ego_brake: np.ndarray | None = None, hold: np.ndarray | None = None
    ) -> TruthFrame:
        """Move every active run one step (:meth:`move`) and return the new frame."""
        self.move(ego_brake, hold)
        return self.frame()

    def move(self, ego_brake: np.ndarray | None = None, hold: np.ndarray | None = None) -> None:
        """Move every active run one step, without building its frame (:meth:`frame` builds
        it when first asked): for a caller that starts new runs before it reads the frame,
        which :meth:`start` would make it build again (the vector environment).

        Args:
            ego_brake: ``(N,)`` deceleration requested by each run's driver [m/s², >= 0] for
                this step; 0 or NaN (or ``None`` for all) means no request: the scripted ego.
            hold: ``(N,)`` bool, the runs whose driver looks away (``Driver.holding``): without
                a brake request the ego keeps its speed instead of its script or IDM.
        """
        n = self.n_runs
        brake = check_array(
            "ego_brake", np.zeros(n) if ego_brake is None else ego_brake, (n,), finite=False
        )
        self._brake = check_array(
            "ego_brake", np.where(np.isnan(brake), 0.0, brake), nonnegative=True
        )
        self._hold = check_array("hold", np.zeros(n) if hold is None else hold, (n,)).astype(bool)
        self._frame = None
        self._k += 1
        self._reassigned.fill(False)
        plan = self._plan
        kernels.step(
            plan.seg_t, plan.seg_v, plan.seg_rate, plan.lateral, plan.present, plan.idm,
            plan.desired_speed, plan.time_headway, self.duration,
            self._x, self._v, self._ego_x, self._ego_v, self._ego_a, self._brake, self._hold,
            self._braked, self._end_time, self._collided, self._collision_speed,
            self._run_t, self._k, self._k0, self.dt, TIME_TOL, OVERLAP_OFFSET, VEHICLE_LENGTH,
            IDM.constants, *self._leaders,
        )  # fmt: skip

    def draw(self, n: int, seed: int | np.random.Generator | None) -> Draws:
        """``n`` runs of this source's scenario, drawn exactly as a fresh
        ``ScenarioSource(name, n, dt, seed, params, duration)`` draws its runs, for
        :meth:`start`."""
        return Draws.of(*self._build(self.params, n, np.random.default_rng(seed), self._horizon))

    def restart(self, mask: np.ndarray, seed: int | np.random.Generator | None) -> None:
        """Start a new run of the scenario, now, for the runs in ``mask``; the others continue.

        The new runs are drawn exactly as a fresh
        ``ScenarioSource(name, mask.sum(), dt, seed, params, duration)`` would draw its runs
        (the i-th masked run is that source's run i; same params, duration and ``dt``):
        :meth:`start` with :meth:`draw`.  An all-False mask does nothing (and draws nothing
        from ``seed``).

        Args:
            mask: ``(N,)`` boolean array of the runs to restart.
            seed: seed of the new runs' draws (``int``, ``numpy.random.Generator`` or ``None``).

        Raises:
            InputError: ``mask`` is not a boolean array of shape ``(N,)``.
        """
        idx = self._restarted(mask)
        if idx.size:
            self._start(idx, self.draw(idx.size, seed))

    def start(self, mask: np.ndarray, draws: Draws) -> None:
        """Start the runs of ``draws`` (:meth:`draw`), in order, now, in the runs of ``mask``;
        the others continue.

        From now on each masked run follows its drawn run step for step as a fresh source
        would: its frame now is that source's first frame, ``k`` steps later its ``k``-th
        frame, in run time :attr:`run_time` (reset to 0).  Its leader ids are offset by
        :data:`SLOTS` per restart (:attr:`generation`); ``frame().t`` stays the global time.
        The run's ``kind``, ``run_params``, ``duration``, collision and end bookkeeping are
        replaced (new arrays: arrays read before stay unchanged), and :attr:`reassigned` flags
        it until the next :meth:`advance` or :meth:`move`.  Drawing runs ahead in blocks and
        starting them a few at a time (the vector environment's episodes) costs a fraction of
        a :meth:`restart` each.

        Raises:
            InputError: ``mask`` is not a boolean array of shape ``(N,)``, or ``draws`` does
                not hold one run per masked run.
        """
        idx = self._restarted(mask)
        if idx.size != draws.n_runs:
            raise InputError(
                f"draws must hold {idx.size} runs (one per masked run), got {draws.n_runs}"
            )
        if idx.size:
            self._start(idx, draws)

    def _restarted(self, mask: np.ndarray) -> np.ndarray:
        """The indices of the runs of ``mask`` (checked: boolean, shape ``(N,)``)."""
        mask = np.asarray(mask)
        if mask.shape != (self.n_runs,):
            raise InputError(f"mask must have shape ({self.n_runs},), got {mask.shape}")
        if mask.dtype != bool:
            raise InputError(f"mask must be a boolean array, got dtype {mask.dtype}")
        return np.flatnonzero(mask)

    def _start(self, idx: np.ndarray, draws: Draws) -> None:
        sub, kinds = draws.plan, draws.kind
        plan = _merge_into(self._plan, idx, sub) if self._own_plan else None
        if plan is None:  # a new plan (its arrays the source's own from now on)
            plan = _merge([(self._rows, self._plan), (idx, sub)], self.n_runs)
        self._plan, self._own_plan = plan, True
        self.duration = self._plan.duration
        kind = self.kind.astype(np.promote_types(self.kind.dtype, kinds.dtype))
        kind[idx] = kinds
        self.kind = kind
        self._params.start(idx, draws)
        # per-run state: the fresh source's initial state
        self._frame = None
        self._k0[idx] = self._k
        self._run_t = (self._k - self._k0) * self.dt
        self._generation[idx] += 1
        self._reassigned[idx] = True
        self._ego_x[idx] = 0.0
        self._ego_v[idx] = sub.ego_speed
        self._ego_a[idx] = 0.0
        self._x[idx] = sub.position
        self._v[idx] = sub.speed
        self._brake[idx] = 0.0
        self._braked[idx] = False
        self._end_time[idx] = np.inf
        self._collided[idx] = False
        self._collision_speed[idx] = np.nan
        self._find_leaders(idx)

    # ---- internals
    def _find_leaders(self, rows: np.ndarray) -> None:
        """Find the leaders of the runs ``rows`` afresh (a construction, a restart)."""
        kernels.leaders(
            rows, self._x, self._ego_x, self._run_t, self._plan.present, self._plan.lateral,
            OVERLAP_OFFSET, VEHICLE_LENGTH, *self._leaders,
        )  # fmt: skip


def make_scenario(
    name: str, n_runs: int, seed: int | np.random.Generator | None = None, **overrides: Any
) -> ScenarioSource:
    """A :class:`ScenarioSource` with parameters overridden by keyword.

    ``dt`` and ``duration`` go to the source, every other keyword to the manoeuvre's parameters
    class (unknown keys raise :class:`~acc_fusion.core.errors.ConfigError` listing the allowed
    ones).

    >>> src = make_scenario("ccrs", 3, vut_speed=(20 / 3.6, 50 / 3.6, 80 / 3.6))
    >>> [round(v * 3.6) for v in src.run_params["vut_speed"]]
    [20, 50, 80]
    """
    manoeuvre = SCENARIOS[check_choice("scenario", name, SCENARIOS)]
    dt = overrides.pop("dt", 0.05)
    duration = overrides.pop("duration", None)
    params = from_mapping(manoeuvre.params, overrides, prefix=f"{name}.")
    return ScenarioSource(name, n_runs, dt, seed, params, duration)


def random_suite(
    n_runs: int, seed: int | np.random.Generator | None, dt: float = 0.05
) -> ScenarioSource:
    """Monte Carlo mixture: each run draws a manoeuvre type and its parameters.

    The type is uniform over :data:`STANDARD`; the parameters below are uniform over their
    range (all others keep their defaults); units SI.  Draws for every type are made for all N
    runs in a fixed order, so a run's parameters depend only on the seed.  Use
    ``make_scenario("random", n, seed, kinds=(...))`` to mix a subset of the types.

    Ranges (:data:`RANDOM_RANGES`):
    """
    return ScenarioSource("random", n_runs, dt, seed)


random_suite.__doc__ = f"{(random_suite.__doc__ or '').rstrip()}\n\n{_ranges_table()}"
