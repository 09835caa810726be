"""SUMO and the object frames in a background process (``BackgroundSumoSource`` opened with
``objects``): the same object frames and the same 2-D pipeline results as in process."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import fields

import numpy as np
import pytest

pytest.importorskip("libsumo")

from acc_fusion.core.errors import ConfigError, InputError  # noqa: E402
from acc_fusion.core.slots import Extent  # noqa: E402
from acc_fusion.sim.closed_loop import SimConfig  # noqa: E402
from acc_fusion.sim.world import simulate_world  # noqa: E402
from acc_fusion.truth.objects import ObjectFrame  # noqa: E402
from acc_fusion.truth.sumo import background as background_mod  # noqa: E402
from acc_fusion.truth.sumo.background import BackgroundSumoSource  # noqa: E402
from acc_fusion.truth.sumo.config import SumoConfig, SumoError  # noqa: E402
from acc_fusion.truth.sumo.nets import bundled_nets  # noqa: E402
from acc_fusion.truth.sumo.object_arrays import object_frame  # noqa: E402
from acc_fusion.truth.sumo.objects import ObjectFieldConfig, SumoObjects  # noqa: E402
from acc_fusion.truth.sumo.source import SumoSource  # noqa: E402
from acc_fusion.truth.sumo.world import SumoWorld  # noqa: E402

pytestmark = pytest.mark.filterwarnings("ignore:more than capacity")
NAMES = [f.name for f in fields(ObjectFrame)]


def motorway(end: float, capacity: int = 64) -> SumoConfig:
    return SumoConfig(str(bundled_nets()["motorway"]), end=end, seed=2, capacity=capacity)


def trace(src, objects) -> list[dict]:
    """Per step, the object frames of the pipeline's prefix (:class:`Extent`), of every slot
    and of the slots up to the last active one, copied."""
    out, extent = [], Extent(src.n_pairs)
    while True:
        active = src.active
        top = int(np.flatnonzero(active)[-1]) + 1 if active.any() else 0
        for k in (extent.fit(active), src.n_pairs, top):
            frame = objects.frame(k)
            out.append({name: np.copy(getattr(frame, name)) for name in NAMES})
        if src.done:
            return out
        src.advance()


def test_the_background_sends_the_object_frames_of_the_in_process_source():
    """Bit for bit, for prefixes shorter and longer than the slots the child sends (it sends
    those up to the last one holding a vehicle), across many wraps of the ring; with the
    map's path of each ego."""
    config, field = motorway(end=40.0), ObjectFieldConfig(map_path=True)
    with SumoSource(config) as src:
        inline = trace(src, SumoObjects(src, field))
    with BackgroundSumoSource(config, objects=field) as src:
        background = trace(src, src.objects)
        assert src._returned > 3 * src._ring.size
    assert len(inline) == len(background) == 3 * 401
    for a, b in zip(inline, background, strict=True):
        for name in NAMES:
            assert a[name].dtype == b[name].dtype
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    assert sum(int(f["valid"].sum()) for f in inline) > 10_000
    assert any(f["valid"].shape[0] == 64 and f["valid"].any() for f in inline)


def test_the_2d_pipeline_on_the_background_source_gives_the_in_process_results():
    config = motorway(end=30.0)
    runs = {}
    opens = {"inline": lambda: SumoSource(config),
             "background": lambda: BackgroundSumoSource(config, ObjectFieldConfig())}  # fmt: skip
    for key, opened in opens.items():
        steps = []

        def keep(view, steps=steps):
            steps.append({m: (e.x.copy(), e.valid.copy(), view.levels[m].copy())
                          for m, e in view.estimates.items()})  # fmt: skip

        with opened() as source:
            sim = SimConfig(runs=1, dt=source.dt)
            runs[key] = (simulate_world(sim, source=SumoWorld(source), on_step=keep), steps)
    (a, steps_a), (b, steps_b) = runs["inline"], runs["background"]
    assert a.steps == b.steps == 300 and a.summaries == b.summaries
    for one, other in zip(steps_a, steps_b, strict=True):
        for m in one:
            for x, y in zip(one[m], other[m], strict=True):
                np.testing.assert_array_equal(x, y)
    assert any(e[1].any() for s in steps_a for e in s.values())


def test_background_objects_are_open_loop_and_checked():
    config = motorway(end=3.0, capacity=16)
    with pytest.raises(ConfigError, match="objects must be an ObjectFieldConfig"):
        BackgroundSumoSource(config, objects={"ahead": 100.0})
    with BackgroundSumoSource(config) as plain:
        with pytest.raises(ConfigError, match="sends no object frames"):
            SumoWorld(plain)
    with BackgroundSumoSource(config, ObjectFieldConfig(ahead=120.0)) as src:
        with pytest.raises(ConfigError, match="config differs"):
            SumoWorld(src, ObjectFieldConfig())
        world = SumoWorld(src)  # the source's config
        assert world.objects.config.ahead == 120.0
        with pytest.raises(ConfigError, match="cannot hold a distracted driver's vehicle"):
            src.advance(hold=np.ones(src.n_pairs, dtype=bool))
        with pytest.raises(ConfigError, match="cannot run a closed loop"):
            simulate_world(SimConfig(runs=1, dt=src.dt, drive="federated"), source=world)
        with pytest.raises(InputError, match="egos must be an integer"):
            src.objects.frame(17)
        # The pipeline's side has the cores first: SUMO's process runs at the lowest priority.
        mine = os.getpriority(os.PRIO_PROCESS, 0)
        expected = min(mine + background_mod.OBJECTS_NICE, 19)
        assert os.getpriority(os.PRIO_PROCESS, src.pid) == expected


def test_an_object_frame_larger_than_the_ring_is_a_sumo_error_at_that_frame(monkeypatch):
    monkeypatch.setattr(background_mod, "OBJECT_RING_SLOTS", 0)  # room for a few bare frames
    with BackgroundSumoSource(motorway(end=60.0), ObjectFieldConfig()) as src:
        match = r"object slots an ego\) is more than a quarter of the ring.*in process"
        with pytest.raises(SumoError, match=match):
            while not src.done:
                src.advance()
        assert src.closed and src.t > 0


def test_a_frame_cut_to_fewer_slots_than_sent_is_the_in_process_frame():
    """The parent may ask for fewer slots than the child sent (those after the last active
    one: a slot that lost its vehicle or was flagged): the arrays of more slots, cut, are the
    frame of fewer, bit for bit."""
    config = SumoConfig(str(bundled_nets()["ring"]), end=20.0, seed=4, capacity=256)
    checked = 0
    with SumoSource(config) as src:
        objects = SumoObjects(src)
        while not src.done:
            src.advance()
            active = src.active
            top = int(np.flatnonzero(active)[-1]) + 1 if active.any() else 0
            more = objects.arrays(min(top + 5, src.n_pairs))
            for n in range(top, min(top + 5, src.n_pairs)):
                cut, frame = object_frame(src.frame(), more.resized(n)), objects.frame(n)
                for name in NAMES:
                    np.testing.assert_array_equal(getattr(cut, name), getattr(frame, name))
                checked += 1
    assert checked > 500


def test_importing_the_kernels_shortens_openmp_s_spin_unless_the_user_set_it():
    code = "import os, acc_fusion.core.threads; print(os.environ['GOMP_SPINCOUNT'])"
    env = {k: v for k, v in os.environ.items() if k != "GOMP_SPINCOUNT"}
    for given, expected in ((None, "10000"), ("123", "123")):
        run_env = env if given is None else {**env, "GOMP_SPINCOUNT": given}
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             env=run_env, check=True)  # fmt: skip
        assert out.stdout.strip() == expected


def test_the_pipeline_s_process_returns_its_free_heap_as_the_in_process_source_does(
    monkeypatch,
):
    """The 2-D pipeline's heap is in the parent: it is trimmed there every ``TRIM_PERIOD``."""
    calls = []
    monkeypatch.setattr(background_mod, "TRIM_PERIOD", 1.0)
    monkeypatch.setattr(background_mod, "release_free_heap", lambda: calls.append(1) or True)
    with BackgroundSumoSource(motorway(end=5.0, capacity=16)) as src:
        while not src.done:
            src.advance()
    assert src.t == pytest.approx(5.0) and len(calls) == 5
