"""The pipeline's outputs, fingerprinted: a fixed scripted suite, a fixed 2-D scene and a fixed
SUMO run give these warning levels and oracle levels, step by step, for every method; the
vector env, whose copies restart, its flags, ends, oracle and collisions.

A speed-up must leave them bit for bit (issue "The speed back and forward").  A change of
behaviour changes them: update the digest in the same commit and say why in its message.
Only integer outputs are hashed (levels flip only where a value lies within rounding of a
threshold), so the fingerprints do not depend on the CPU's floating-point paths."""

from __future__ import annotations

import hashlib
from dataclasses import replace

import pytest

from acc_fusion.sim.closed_loop import SimConfig, simulate
from acc_fusion.sim.world import simulate_world


class Digest:
    """The sha256 of every step's warning levels (methods in name order) and oracle."""

    def __init__(self) -> None:
        self.hash = hashlib.sha256()
        self.steps = 0

    def __call__(self, view) -> None:
        for m in sorted(view.levels):
            self.hash.update(view.levels[m].astype("int8").tobytes())
        self.hash.update(view.oracle.astype("int8").tobytes())
        self.steps += 1

    def hexdigest(self) -> str:
        return self.hash.hexdigest()[:16]


def test_the_scripted_suite_fingerprint():
    digest = Digest()
    result = simulate(SimConfig(runs=300, seed=7, scenario="random"), on_step=digest)
    assert result.steps == digest.steps > 0
    assert digest.hexdigest() == "1fdf58778ef7c060"


def test_the_2d_scene_fingerprint():
    digest = Digest()
    cfg = SimConfig(runs=20, seed=7)
    simulate_world(replace(cfg, world=replace(cfg.world, scene="cut_in")), on_step=digest)
    assert digest.hexdigest() == "eede94f469bdff06"


def test_the_sumo_fingerprint():
    pytest.importorskip("libsumo")
    from acc_fusion.truth.sumo.config import SumoConfig
    from acc_fusion.truth.sumo.nets import bundled_nets
    from acc_fusion.truth.sumo.source import SumoSource
    from acc_fusion.truth.sumo.world import SumoWorld

    digest = Digest()
    config = SumoConfig(str(bundled_nets()["motorway"]), end=20.0, seed=2, capacity=256)
    with SumoSource(config) as source:
        simulate_world(SimConfig(runs=1, dt=source.dt), source=SumoWorld(source), on_step=digest)
    assert digest.steps > 0
    assert digest.hexdigest() == "d126bd5a965f2789"


def test_the_vector_env_fingerprint():
    """The vector env's copies end and restart many times over 300 steps: its flags (a track,
    each sensor reporting and isolated, the episode's end), the oracle and the collisions."""
    import gymnasium as gym
    import numpy as np

    import acc_fusion  # noqa: F401  (registers the environment)
    from acc_fusion.envs.observation import OBS_FIELDS

    flags = [OBS_FIELDS.index(f) for f in OBS_FIELDS if f.endswith(("valid", "ing", "isolated"))]
    env = gym.make_vec(
        "acc_fusion/CollisionWarning-v0", num_envs=256, vectorization_mode="vector_entry_point"
    )
    env.reset(seed=3)
    actions, digest, ends = np.random.default_rng(5), hashlib.sha256(), 0
    for _ in range(300):
        obs, _, term, trunc, info = env.step(actions.integers(0, 3, 256))
        for a in (obs[:, flags], term, trunc, info["oracle"], info["collided"]):
            digest.update(np.asarray(a).astype("int8").tobytes())
        ends += int((term | trunc).sum())
    env.close()
    assert ends > 256 and len(flags) == 5
    assert digest.hexdigest()[:16] == "c4543da720b1ae46"
