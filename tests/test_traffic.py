"""FCW in SUMO traffic: bundled networks, the study with FCW on and off, the CLI (issue 4)."""

from __future__ import annotations

import json
import re

import pytest

pytest.importorskip("libsumo")

from acc_fusion.cli.main import main  # noqa: E402
from acc_fusion.core.errors import ConfigError  # noqa: E402
from acc_fusion.truth.sumo.nets import bundled_nets, resolve_sumocfg


def test_bundled_networks_are_installed_package_data():
    nets = bundled_nets()
    assert {"motorway", "onramp", "ring", "arterial"} <= set(nets)
    assert all(p.is_file() for p in nets.values())


def test_resolve_errors_name_the_file_or_the_choices(tmp_path):
    with pytest.raises(ConfigError, match="bundled networks: .*motorway"):
        resolve_sumocfg(net="autobahn")
    with pytest.raises(ConfigError, match="does not exist"):
        resolve_sumocfg(sumocfg=str(tmp_path / "nope.sumocfg"))
    with pytest.raises(ConfigError, match="exactly one"):
        resolve_sumocfg()


def test_sumo_command_writes_the_table_and_files(tmp_path, capsys):
    args = [
        "sumo",
        "--pair",
        "--net",
        "onramp",
        "--end",
        "60",
        "--hazard-rate",
        "20",
        "--all-drives",
    ]
    args += ["--out", str(tmp_path)]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "FCW in SUMO traffic: onramp.sumocfg" in out
    assert "federated" in out and "SSM" not in out  # the cross-check is on request
    (summary,) = tmp_path.glob("sumo_onramp_seed0.json")
    data = json.loads(summary.read_text())
    assert set(data["fcw_off"]) == {"radar", "infrared", "centralized", "federated"}
    assert set(data["fcw_on"]) == {"federated"}
    assert data["ssm"] is None
    # The benefit pairs the vehicles of both runs; its crashes are the summaries' collisions.
    benefit = data["benefit"]
    assert "Crashes FCW avoids" in out
    assert benefit["crashes_off"] == data["fcw_off"]["federated"]["collisions"] > 0
    assert benefit["crashes_on"] == data["fcw_on"]["federated"]["collisions"]
    assert benefit["vehicles"] > 0
    assert {"reduction", "reduction_lo", "reduction_hi"} <= set(benefit)
    by_method = data["benefit_by_method"]
    assert set(by_method) == {"radar", "infrared", "centralized", "federated"}
    assert by_method["federated"] == benefit
    assert {b["crashes_off"] for b in by_method.values()} == {benefit["crashes_off"]}
    # The replay of every crash of the FCW-off run, with each method's warnings.
    replayed = data["benefit_replayed"]
    assert "replayed crash by crash" in out and set(replayed) == set(by_method)
    for b in replayed.values():
        assert b["crashes_off"] == benefit["crashes_off"] and b["introduced"] == 0
        assert b["avoided"] + b["crashes_on"] == b["crashes_off"]
        assert b["reduction_lo"] <= b["reduction"] <= b["reduction_hi"]
    assert (tmp_path / "sumo_onramp_seed0.png").stat().st_size > 10_000
    # Every crash-relevant situation and crash by hazard: the totals are the summary's and the
    # benefit's, and 20 injected brakings per vehicle-hour make some of them.
    rows = {(r["hazard"], r["driver"]): r for r in data["hazards"]}
    total = rows.pop(("all", "all"))
    assert total["relevant"] == data["fcw_off"]["federated"]["relevant"]
    assert total["crashes"] == benefit["crashes_off"]
    assert sum(r["relevant"] for r in rows.values()) == total["relevant"]
    assert sum(r["crashes"] for r in rows.values()) == total["crashes"]
    assert sum(r["relevant"] for (h, _), r in rows.items() if h == "lead_braking") > 0
    assert "re-weighted to naturalistic rates" in out and "nan" not in out
    assert (tmp_path / "sumo_onramp_seed0_hazards.csv").is_file()
    assert (tmp_path / "sumo_onramp_seed0_hazards.png").stat().st_size > 10_000


def test_the_oracle_ttc_agrees_with_sumos_ssm_device_when_no_driver_looks_away(capsys):
    # With distraction SSM also sees conflicts with vehicles merging ahead of a driver who
    # does not give way (not yet his leader), so its minTTC is lower: only without it are the
    # two the same quantity.
    args = ["sumo", "--pair", "--net", "onramp", "--end", "60", "--hazard-rate", "20"]
    assert main([*args, "--distraction", "0", "--ssm"]) == 0
    out = capsys.readouterr().out
    m = re.search(r"SSM minTTC: (\d+) vehicles, median relative difference (\S+)", out)
    assert m and int(m.group(1)) > 20 and float(m.group(2)) < 0.05


def test_user_sumocfg_errors_are_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.sumocfg"
    bad.write_text(
        "<configuration><input><net-file value='missing.net.xml'/></input></configuration>"
    )
    assert main(["sumo", "--sumocfg", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "missing.net.xml" in err and "Traceback" not in err


def test_gui_run_colours_vehicles_by_the_driving_methods_warning(monkeypatch):
    """``--gui``: the FCW-on run paints every equipped vehicle in the colour of its warning
    level at every step (TraCI; the plain ``sumo`` binary stands in for ``sumo-gui``)."""
    import numpy as np

    from acc_fusion.core.levels import WARNING_COLORS
    from acc_fusion.sim.closed_loop import SimConfig
    from acc_fusion.studies.traffic import _run
    from acc_fusion.truth.sumo import launch
    from acc_fusion.truth.sumo.config import SumoConfig
    from acc_fusion.truth.sumo.source import SumoSource

    real = launch.sumo_binary
    monkeypatch.setattr(launch, "sumo_binary", lambda gui: real(False))
    monkeypatch.setattr(launch, "has_display", lambda: True)
    shown = []
    paint = SumoSource.set_warning_colors

    def record(source, levels):
        paint(source, levels)
        m = len(levels)  # the prefix of slots the pipeline works on holds every vehicle
        assert not source.active[m:].any()
        for slot in np.flatnonzero(source.active):
            colour = tuple(source._api.vehicle.getColor(source.vehicle_ids[slot]))
            assert colour == WARNING_COLORS[levels[slot]]
        shown.append(np.asarray(levels)[source.active[:m]])

    monkeypatch.setattr(SumoSource, "set_warning_colors", record)
    cfg = SumoConfig(
        str(bundled_nets()["onramp"]), end=40.0, hazard_rate=300.0, capacity=128, gui=True
    )
    sim = SimConfig(runs=1, methods=("federated",), drive="federated")
    run = _run(cfg, sim, progress=False, cross_check=False)
    assert run.error is None and len(shown) == 400
    assert max(int(lv.max(initial=0)) for lv in shown) >= 1  # some vehicle was warned
