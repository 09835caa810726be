r"""Every vehicle of a SUMO scenario at every step, read through libsumo's subscriptions.

:func:`sumo_trajectories` runs a ``.sumocfg`` with SUMO's own drivers (nothing injected,
nobody warned or distracted: ordinary driving) and returns the
:class:`~acc_fusion.truth.trajectories.Trajectories` of all its vehicles after a warm-up, for
the traffic realism check (:mod:`acc_fusion.metrics.realism`).

Reading fast
    Each vehicle is subscribed once, when it departs, to its speed, acceleration, lane index,
    edge, odometer and leader (``VAR_LEADER`` with the lookahead as its parameter, a plain
    float in libsumo); its length and minGap, fixed, are read then too. Every step then costs
    one ``vehicle.getAllSubscriptionResults()`` (a dict of every vehicle's values) and a pass
    over it, instead of a Python call per value per vehicle.  The leader's gap is SUMO's
    ``getLeader`` distance plus the follower's minGap (which ``getLeader`` leaves out: DESIGN.md),
    so it is bumper to bumper; the leader's speed is its own subscribed value.  Vehicles
    teleporting (no edge) are left out of the samples.

Verified against libsumo 1.28: a subscription made after a step is answered by the next
``getAllSubscriptionResults`` of that same step (libsumo evaluates it at once).
"""

from __future__ import annotations

from collections.abc import Callable
from operator import itemgetter
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from acc_fusion.truth.sumo.config import SumoConfig, SumoError
from acc_fusion.truth.sumo.launch import (
    captured_stderr,
    load_api,
    sumo_command,
    sumo_message,
    traci_errors,
)
from acc_fusion.truth.trajectories import COLUMNS, Trajectories


def sumo_trajectories(
    config: SumoConfig,
    end: float,
    warmup: float = 0.0,
    *,
    setup: Callable[[Any], None] | None = None,
    progress: bool = True,
    label: str = "",
) -> Trajectories:
    """Every vehicle's samples of SUMO's run of ``config.sumocfg`` from ``warmup`` to ``end``
    [s after the begin time], at SUMO's step.

    Args:
        config: the scenario (its ``sumocfg``, ``seed``, ``step_length``, ``lookahead`` and
            ``extra_args`` are used; hazards, equipment and distraction are not: SUMO's own
            drivers only).
        end: simulated seconds to run [s].
        warmup: seconds before the samples start [s], in [0, ``end``).
        setup: called with the libsumo module once SUMO has started, before the first step
            (e.g. to set a vehicle type's ``decel``).
        progress: show a progress bar over the steps.
        label: the :attr:`Trajectories.label` (default: the ``.sumocfg``'s name).

    Raises:
        SumoError: SUMO could not start or failed during the run.
    """
    if not 0 <= warmup < end:
        raise SumoError(f"warmup must be in [0, end), got {warmup:g} with end {end:g}")
    api = load_api(False)
    errors = traci_errors(api)
    captured: list[str] = []
    try:
        with captured_stderr(captured):
            api.start(sumo_command(config))
    except errors as exc:
        raise SumoError(
            f"SUMO could not start {config.sumocfg}: {sumo_message(exc, captured)}"
        ) from None
    try:
        if setup is not None:
            setup(api)
        return _collect(api, config, end, warmup, progress, label)
    except errors as exc:
        raise SumoError(f"SUMO failed: {sumo_message(exc, captured)}") from None
    finally:
        api.close()


def _collect(
    api: Any, config: SumoConfig, end: float, warmup: float, progress: bool, label: str
) -> Trajectories:
    """Step SUMO and gather the samples (see :func:`sumo_trajectories`)."""
    tc, veh, sim = api.constants, api.vehicle, api.simulation
    variables = [
        tc.VAR_SPEED, tc.VAR_ACCELERATION, tc.VAR_LANE_INDEX, tc.VAR_ROAD_ID, tc.VAR_DISTANCE,
        tc.VAR_LEADER,
    ]  # fmt: skip
    values = itemgetter(*variables)
    parameters = {tc.VAR_LEADER: float(config.lookahead)}
    dt, begin = float(sim.getDeltaT()), float(sim.getTime())
    code: dict[str, int] = {}  # vehicle id -> integer id
    length: dict[str, float] = {}
    min_gap: dict[str, float] = {}
    roads: dict[str, int] = {}
    columns: dict[str, list[np.ndarray]] = {name: [] for name in COLUMNS}

    def depart(vid: str) -> None:
        veh.subscribe(vid, variables, parameters=parameters)
        code[vid] = len(code)
        length[vid], min_gap[vid] = veh.getLength(vid), veh.getMinGap(vid)

    for vid in veh.getIDList():  # vehicles already in the network (a loaded state)
        depart(vid)
    steps = int(round(end / dt))
    for k in tqdm(range(1, steps + 1), disable=None if progress else True, desc="SUMO"):
        sim.step()
        for vid in sim.getDepartedIDList():
            depart(vid)
        if k * dt < warmup - 1e-9:
            continue
        res = veh.getAllSubscriptionResults()
        ids = [vid for vid, r in res.items() if r[tc.VAR_ROAD_ID]]  # not teleporting
        m = len(ids)
        if m:
            _append(columns, ids, [values(res[v]) for v in ids], res, tc, code, length, min_gap)
            columns["road"][-1] = np.fromiter(
                (roads.setdefault(r, len(roads)) for r in columns["road"][-1]), np.int64, m
            )
            columns["time"].append(np.full(m, sim.getTime() - begin))
        if sim.getMinExpectedNumber() <= 0:
            break
    if not columns["vehicle"]:
        return Trajectories(
            *(np.zeros(0) for _ in COLUMNS), dt=dt, label=label or _name(config.sumocfg)
        )
    return Trajectories.from_columns(columns, dt, label or _name(config.sumocfg))


def _append(
    columns: dict[str, list],
    ids: list[str],
    rows: list[tuple],
    res: dict[str, dict],
    tc: Any,
    code: dict[str, int],
    length: dict[str, float],
    min_gap: dict[str, float],
) -> None:
    """Append one step's samples of the vehicles ``ids`` (their subscribed ``rows``)."""
    m = len(ids)
    speed, accel, lane, road, odo, leaders = zip(*rows, strict=True)
    lead = [ld[0] if ld and ld[0] else "" for ld in leaders]
    has = np.fromiter((bool(x) for x in lead), bool, m)
    dist = np.fromiter((ld[1] if ld else np.nan for ld in leaders), float, m)
    columns["vehicle"].append(np.fromiter(map(code.__getitem__, ids), np.int64, m))
    columns["speed"].append(np.asarray(speed, dtype=float))
    columns["accel"].append(np.asarray(accel, dtype=float))
    columns["lane"].append(np.asarray(lane, dtype=np.int64))
    columns["road"].append(list(road))  # coded by the caller
    columns["odometer"].append(np.asarray(odo, dtype=float))
    gap = dist + np.fromiter(map(min_gap.__getitem__, ids), float, m)
    columns["gap"].append(np.where(has, gap, np.nan))
    sp = tc.VAR_SPEED
    columns["lead_speed"].append(
        np.fromiter((res[x][sp] if x in res else np.nan for x in lead), float, m)
    )
    columns["lead_length"].append(np.fromiter((length.get(x, np.nan) for x in lead), float, m))
    for name in ("lead_speed", "lead_length"):
        columns[name][-1][~has] = np.nan


def _name(path: str) -> str:
    """The file name of ``path`` without its folder."""
    return str(path).replace("\\", "/").rsplit("/", 1)[-1]
