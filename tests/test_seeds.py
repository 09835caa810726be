"""Many seeds pooled (``acc-fusion sumo --seeds``): the seeds' parser, the pooling of summaries
and runs, the store that lets an interrupted study resume, and the command."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from acc_fusion.cli.main import main
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.metrics.events import FCWMetrics
from acc_fusion.metrics.summary import pool_summaries
from acc_fusion.sweep.seeds import parse_seeds

pytest.importorskip("libsumo")


def test_seeds_parse_ranges_and_lists_in_order_without_repeats():
    assert parse_seeds("0-3") == (0, 1, 2, 3)
    assert parse_seeds("5, 1,4-6") == (5, 1, 4, 6)
    for bad, match in (("a", "whole numbers"), ("3-1", "lo <= hi"), ("0-99999", "at most"),
                       ("", "whole numbers"), ("1-", "whole numbers")):  # fmt: skip
        with pytest.raises(ConfigError, match=match):
            parse_seeds(bad)


def _metrics(gaps: list[float], seed: int) -> FCWMetrics:
    """A finished metrics of one scripted pair closing on its lead (warnings from the rule on
    a noisy estimate), so that summaries of different seeds differ."""
    rng = np.random.default_rng(seed)
    n = len(gaps)
    m = FCWMetrics(n, dt=0.1)
    gap = np.array(gaps, dtype=float)
    for k in range(200):
        t = 0.1 * k
        gap = np.maximum(gap - 0.5, 0.5)
        truth = (gap < 15.0).astype(np.int64)
        est = ((gap + rng.normal(0.0, 3.0, n)) < 15.0).astype(np.int64)
        ttc = gap / 5.0
        m.update(t, est, truth, ttc, np.full(n, 20.0), np.ones(n, bool), relevant=gap < 10.0)
    m.finish(20.0)
    return m


def test_pooled_summary_is_the_summary_of_the_runs_merged():
    """Pooling summaries gives what merging the runs' metrics gives: counts, exposure, rates
    and intervals, distributions, confusion."""
    a, b = _metrics([60.0, 90.0], 1), _metrics([70.0, 40.0, 120.0], 2)
    pooled = pool_summaries([a.summary(), b.summary()])
    a.merge(b)
    merged = a.summary()
    assert pooled == merged  # every compared field (per_pair and histograms are not)
    assert pooled.per_pair["warnings"].size == 5
    with pytest.raises(InputError, match="at least one"):
        pool_summaries([])


def test_pooling_refuses_summaries_of_other_rules():
    from dataclasses import replace

    s = _metrics([50.0], 3).summary()
    with pytest.raises(InputError, match="one warning rule"):
        pool_summaries([s, replace(s, tolerance=s.tolerance + 1.0)])
    with pytest.raises(InputError, match="histograms"):
        pool_summaries([s, replace(s, histograms=None)])


ARGS = ["sumo", "--pair", "--net", "ring", "--end", "20", "--warmup", "0", "--hazard-rate", "30"]


def test_many_seeds_pool_and_an_interrupted_study_resumes(tmp_path, capsys):
    """``--seeds 0-1 --out DIR``: the pooled figures are the seeds' figures added up; the
    runs are kept in DIR/runs; run again, nothing is simulated; a damaged run file is run
    again, the others kept; a store of other settings is refused."""
    out = tmp_path / "pooled"
    assert main([*ARGS, "--seeds", "0-1", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "2 seeds pooled" in text
    pooled = json.loads((out / "sumo_ring_seeds.json").read_text())
    assert pooled["seed"] == [0, 1]
    singles = []
    for seed in (0, 1):
        assert main([*ARGS, "--seed", str(seed), "--out", str(tmp_path / f"s{seed}")]) == 0
        singles.append(
            json.loads((tmp_path / f"s{seed}" / f"sumo_ring_seed{seed}.json").read_text())
        )
    for run in ("fcw_off", "fcw_on"):
        for m, s in pooled[run].items():
            for key in ("warnings", "nuisance", "sensing_false", "relevant", "collisions"):
                assert s[key] == sum(single[run][m][key] for single in singles), (run, m, key)
            assert s["km"] == pytest.approx(sum(single[run][m]["km"] for single in singles))
    crashes = sum(single["benefit"]["crashes_off"] for single in singles)
    assert pooled["benefit"]["crashes_off"] == crashes
    stored = sorted(p.name for p in (out / "runs").iterdir())
    assert stored == ["run_0_off.pkl", "run_0_on.pkl", "run_1_off.pkl", "run_1_on.pkl",
                      "seeds.json"]  # fmt: skip

    # Resumed: only the damaged run runs again; the intact files are not rewritten.
    kept = {p.name: p.stat().st_mtime_ns for p in (out / "runs").glob("run_*.pkl")}
    (out / "runs" / "run_1_on.pkl").write_bytes(b"\x80\x04truncated")
    capsys.readouterr()
    assert main([*ARGS, "--seeds", "0-1", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "run_1_on.pkl is damaged" in text and "resuming: 3 runs of 4" in text
    again = json.loads((out / "sumo_ring_seeds.json").read_text())
    assert again["fcw_off"] == pooled["fcw_off"] and again["fcw_on"] == pooled["fcw_on"]
    for name, mtime in kept.items():
        assert (name == "run_1_on.pkl") == ((out / "runs" / name).stat().st_mtime_ns != mtime)

    # Other settings, same folder: refused in one sentence.
    assert main([*ARGS[:-1], "40", "--seeds", "0-1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "holds the runs of a different study" in err and err.count("\n") == 1


def test_too_few_crashes_are_said_in_words():
    from acc_fusion.metrics.benefit import Benefit
    from acc_fusion.studies.compare import reduction_text

    def benefit(off: int, on: int) -> Benefit:
        r = 1 - on / off if off else math.nan
        return Benefit(10, off, on, r, -3.0, 1.0, 0.0, 0.0, 0, 0, 0, math.nan, math.nan, 0.95)

    assert reduction_text(benefit(0, 0)) == "no crash with FCW off"
    assert reduction_text(benefit(2, 1)) == "0.5 (too few crashes for an interval: 2)"
    assert reduction_text(benefit(10, 5)) == "0.5 [-3, 1]"
