"""The 2-D pipeline on a source of slots (``simulate_world`` with ``reassigned`` and
``slotted``): an inactive slot counts for nothing, a reassigned slot starts afresh, and the
other slots are untouched."""

from dataclasses import replace

import numpy as np

from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.sim.world import simulate_world
from acc_fusion.truth.scenes import SceneConfig, SceneSource

RUNS = 4


class Slots:
    """A scripted scene as slots: slot 3 never holds a vehicle, slot 0 gets a new one at
    ``new_at`` (the same scene run goes on: only the pipeline's memory is wiped)."""

    slotted = True

    def __init__(self, config: SimConfig, new_at: int) -> None:
        seed = np.random.SeedSequence(config.seed).spawn(2)[0]  # as simulate_world seeds it
        scene = SceneConfig(scene=config.world.scene, runs=config.runs, dt=config.dt)
        self._scene = SceneSource(scene, np.random.default_rng(seed))
        self._k, self._new_at = 0, new_at
        self.active = np.array([True, True, True, False])

    def frame(self):
        return self._scene.frame()

    def advance(self) -> None:
        self._scene.advance()
        self._k += 1

    @property
    def reassigned(self) -> np.ndarray:
        return np.array([self._k == self._new_at, False, False, False])

    @property
    def collided(self) -> np.ndarray:
        return self._scene.collided

    @property
    def t(self) -> float:
        return self._scene.t

    @property
    def done(self) -> bool:
        return self._scene.done

    @property
    def n_steps(self) -> int:
        return self._scene.n_steps


def test_inactive_slots_count_for_nothing_and_a_reassigned_one_starts_afresh():
    config = SimConfig(runs=RUNS, seed=2)
    config = replace(config, world=replace(config.world, scene="lead_brakes"))
    plain = simulate_world(config).summaries
    slots = simulate_world(config, source=Slots(config, new_at=10**9)).summaries
    wiped = simulate_world(config, source=Slots(config, new_at=40)).summaries
    for m in config.methods:
        a, b, c = plain[m].per_pair, slots[m].per_pair, wiped[m].per_pair
        assert b["km"][3] == 0 and b["warnings"][3] == 0 and b["relevant"][3] == 0
        for key in ("km", "warnings", "crash_relevant", "nuisance", "relevant"):
            np.testing.assert_array_equal(b[key][:3], a[key][:3], err_msg=f"{m} {key}")
            np.testing.assert_array_equal(c[key][1:3], a[key][1:3], err_msg=f"{m} {key}")
        assert c["km"][0] == a["km"][0]  # still driven; only its pipeline started afresh
