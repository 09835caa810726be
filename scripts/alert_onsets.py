"""What the 2-D world's false imminent alerts were at their onsets, in SUMO traffic, FCW off.

Runs ``acc-fusion sumo``'s closed loop in the 2-D world (the same arguments; nobody hears a
warning) and records every onset of one method's imminent alert while the rule on truth (the
oracle) is below imminent. Of the onsets on another vehicle than the true lead (cause
``adjacent``) it prints the median range and, where the source gives the map's path
(``--set world.selection.path=map``), how far the vehicle truly was from that path: outside the
corridor, the track's lateral estimate put it in; inside, the path is right but SUMO's leader is
another vehicle; where the path does not reach the vehicle's range (the ego on no lane, or its
lane turning back before), neither. It sorts the same onsets by where the true lead was at that
step: none ahead in the ego's lane; not among the fused objects; off the predicted path (its
offset over :data:`OFF_PATH` and its in-path probability below the selector's
``enter_probability``), with the range and probability of the vehicle taken instead; near the
path but not selectable, with how many of those leads held one sensor's track only and how many
had no valid estimate of the method; or selectable, another vehicle taken before it. Of the
onsets on the true lead it prints the estimated
minus the true lead acceleration and the lead's true jerk over the last 0.5 s (one step at
least): lag at a brake release shows as a positive jerk, noise at the rule's threshold as a
jerk about 0. Onsets are
counted per step of the alert level, so a flickering alert counts each time it rises (the
alert classes merge them into alerts). The last line is ``adjacent=<k> on_lead=<m>``.

    python scripts/alert_onsets.py --net motorway --end 300
    python scripts/alert_onsets.py --sumocfg A10KW.sumocfg --end 300 --set world.selection.path=map
"""

from __future__ import annotations

import sys
from dataclasses import replace

import numpy as np

from acc_fusion.cli.common import traffic_config, traffic_sim_config
from acc_fusion.cli.main import build_parser
from acc_fusion.core.errors import AccFusionError
from acc_fusion.core.levels import IMMINENT
from acc_fusion.metrics.summary import CAUSES
from acc_fusion.sim.world import WorldPerception, seen_id, simulate_world
from acc_fusion.truth.objects import PATH_STATIONS
from acc_fusion.truth.sumo.nets import resolve_sumocfg
from acc_fusion.truth.sumo.source import SumoSource
from acc_fusion.truth.sumo.world import SumoWorld

#: Time back over which the lead's true jerk is taken [s] (at least one step).
JERK_TIME = 0.5

#: Offset from the predicted path beyond which the true lead counts as off it [m].
OFF_PATH = 1.0

#: Where the true lead was at an onset on another vehicle, in :meth:`Onsets.lead_place` order.
PLACES = ("no lead", "not fused", "off the path", "near the path, not selectable", "selectable")


class Onsets:
    """The ``on_step`` hook that records the onsets of ``method``'s imminent alert, at steps of
    ``dt`` [s]."""

    def __init__(self, method: str, dt: float) -> None:
        self.method, self._level, self._accel = method, None, []
        self._back = max(1, round(JERK_TIME / dt))
        self.span = self._back * dt  # the jerk's time span [s]
        self.adjacent: list[tuple[float, float]] = []  # range, offset from the map's path
        self.lead: list[tuple[float, float]] = []  # estimated - true accel, true jerk
        # per adjacent onset: the lead's place, the taken object's range and in-path
        # probability, whether the lead held one track only and whether its estimate was valid
        self.places: list[tuple[int, float, float, bool, bool]] = []
        self.perception = None  # the WorldPerception, set by :meth:`build`

    def build(self, *args, **kwargs) -> WorldPerception:
        """The run's :class:`WorldPerception`, kept so that the hook reads its selector."""
        self.perception = WorldPerception(*args, **kwargs)
        return self.perception

    def __call__(self, view) -> None:
        p, level = view.perceived, view.levels[self.method]
        n, truth, objects = level.size, p.frame, p.sensed.objects
        same_egos = self._level is not None and self._level.size == n
        last = self._level if same_egos else np.zeros_like(level)
        onset = (level >= IMMINENT) & (last < IMMINENT) & (np.asarray(view.oracle)[:n] < IMMINENT)
        self._level = level.copy()
        self._accel.append((truth.leader_id[:n].copy(), truth.lead_accel[:n].copy()))
        self._accel = self._accel[-(self._back + 1) :]
        cause, chosen, est = (
            p.causes[self.method],
            p.truth_id[self.method],
            p.estimates[self.method],
        )
        for e in np.flatnonzero(onset[:n] & (cause[:n] == CAUSES.index("adjacent"))).tolist():
            k = np.flatnonzero(objects.object_id[e] == chosen[e])
            if k.size:
                x, y = objects.x[e, k[0]], objects.y[e, k[0]]
                path = objects.road_path[e]
                off = y - np.interp(x, PATH_STATIONS, path) if path.size else np.nan
                self.adjacent.append((x, off))
            self.places.append(self.lead_place(view, e, x if k.size else np.nan))
        for e in np.flatnonzero(onset[:n] & (cause[:n] == CAUSES.index("lead"))).tolist():
            ids, before = self._accel[0]
            same = len(self._accel) > self._back and ids[e] == truth.leader_id[e]
            jerk = (truth.lead_accel[e] - before[e]) / self.span
            self.lead.append((est.x[e, 2] - truth.lead_accel[e], jerk if same else np.nan))

    def lead_place(self, view, e: int, x: float) -> tuple[int, float, float, bool, bool]:
        """Where ego ``e``'s true lead was at an onset on another object at range ``x`` [m]:
        its index in :data:`PLACES`, ``x``, the taken object's in-path probability, whether the
        lead's fused object held one sensor's track only and whether the method's estimate of
        it was valid."""
        p, sel = view.perceived, self.perception.selectors[self.method]
        fused, tracks = p.sensed.fused, p.sensed.tracks
        taken = sel.selected[e]
        prob = sel.probability[e, taken] if taken >= 0 else np.nan
        leader = p.frame.leader_id[e]
        if leader < 0:
            return 0, x, prob, False, False
        ids = (fused.track, tracks[0].object_id, tracks[1].object_id)
        k = [j for j in np.flatnonzero(fused.valid[e]) if seen_id(*ids, e, j) == leader]
        if not k:
            return 1, x, prob, False, False
        k = k[0]
        one = bool((fused.track[e, k] < 0).any())
        pair = self.perception.pool.pair_of[e * self.perception.slots + k]
        valid = bool(pair >= 0 and p.sensed.estimates[self.method].valid[pair])
        if sel.in_path[e, k]:
            return 4, x, prob, one, valid
        off = (
            abs(sel.offset[e, k]) > OFF_PATH
            and sel.probability[e, k] < sel.config.enter_probability
        )
        return (2 if off else 3), x, prob, one, valid


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(["sumo", *(sys.argv[1:] if argv is None else argv)])
    try:
        path = resolve_sumocfg(args.net, args.sumocfg)
        config = traffic_config(args, path, seed=args.seed or 0, gui=False,
                                step_length=args.step_length)  # fmt: skip
        sim = traffic_sim_config(args)
        method = sim.methods[-1]
        with SumoSource(config) as source:
            run, hook = replace(sim, dt=source.dt), Onsets(method, source.dt)
            world = SumoWorld(source, sim.world.object_field())
            simulate_world(run, source=world, warnings_on=False, on_step=hook, progress=True,
                           perception=hook.build)  # fmt: skip
    except AccFusionError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    half = sim.world.selection.half_width
    print(f"{path.name}, seed {config.seed}, {method}, path {sim.world.selection.path}, FCW off")
    adjacent, lead = np.array(hook.adjacent).reshape(-1, 2), np.array(hook.lead).reshape(-1, 2)
    if len(adjacent):
        print(f"on another vehicle: {len(adjacent)} onsets, median range "
              f"{np.median(adjacent[:, 0]):.1f} m")  # fmt: skip
        off = np.abs(adjacent[:, 1])
        if np.isfinite(off).any():
            out, known = off > half, np.isfinite(off)
            median = np.median(off[out]) if out.any() else 0.0
            print(f"  truly outside the corridor (|offset from the map's path| > {half} m): "
                  f"{int(out.sum())}, median offset {median:.1f} m; "
                  f"inside: {int((known & ~out).sum())}; where the map's path does not reach: "
                  f"{int((~known).sum())}")  # fmt: skip
        print_places(np.array(hook.places, dtype=float).reshape(-1, 5))
    if len(lead):
        jerk = lead[:, 1]
        print(f"on the true lead: {len(lead)} onsets; estimated - true lead acceleration, median "
              f"{np.median(lead[:, 0]):.2f} m/s²; true jerk over {hook.span:.1f} s, median "
              f"{np.nanmedian(jerk):.2f} m/s³, releasing (> 0.5 m/s³) "
              f"{np.nanmean(jerk > 0.5):.0%}")  # fmt: skip
    print(f"adjacent={len(adjacent)} on_lead={len(lead)}")
    return 0


def print_places(places: np.ndarray) -> None:
    """Print the adjacent onsets by where the true lead was (rows of :meth:`Onsets.lead_place`)."""
    print("  where the true lead was:")
    for i, name in enumerate(PLACES):
        rows = places[places[:, 0] == i]
        line = f"    {name}: {len(rows)}"
        if len(rows) and i == 2:
            line += (f"; the object taken at a median {np.nanmedian(rows[:, 1]):.0f} m, in-path "
                     f"probability median {np.nanmedian(rows[:, 2]):.2f}")  # fmt: skip
        if len(rows) and i >= 3:
            line += (f"; one sensor's track only {int(rows[:, 3].sum())}, no valid estimate "
                     f"{int((rows[:, 4] == 0).sum())}")  # fmt: skip
        print(line)


if __name__ == "__main__":
    sys.exit(main())
