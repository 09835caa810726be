"""A user's config files and flags: one-line errors for bad input, nothing written; the config
command; output files that respect the umask."""

from __future__ import annotations

import json
import os
import re
import stat

import pytest

from acc_fusion.cli.main import main
from acc_fusion.core.config import from_mapping, load_mapping
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.outputs import json_text, write_text_atomic
from acc_fusion.core.schema import json_schema
from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.sweep.config import SweepConfig


def run_cli(argv, capsys):
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def one_line_error(code, err, *words):
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("acc-fusion: error: "), err
    for w in words:
        assert w in lines[0], (w, lines[0])


@pytest.mark.parametrize(
    "text, words",
    [
        ('radar: "yes"\n', ("radar", "table/mapping", "'yes'")),
        ("runs: 2.5\n", ("runs", "whole number", "2.5")),
        ("runs: true\n", ("runs", "whole number", "True")),
        ("dt: fast\n", ("dt", "number", "'fast'")),
        ("methods: radar\n", ("methods", "list", "'radar'")),
        ("fusion:\n  reset: [zero]\n", ("fusion.reset", "string")),
        ("driver:\n  reaction_time_range: [1.0]\n", ("reaction_time_range", "2 values")),
    ],
)
def test_a_value_of_the_wrong_type_is_one_line(tmp_path, capsys, text, words):
    cfg = tmp_path / "bad.yaml"
    cfg.write_text(text)
    out = tmp_path / "out"
    code, _, err = run_cli(
        ["run", "--scenario", "nhtsa_lvs", "--config", str(cfg), "--out", str(out)], capsys
    )
    one_line_error(code, err, *words)
    assert not out.exists()


def test_ints_are_numbers_but_bools_are_not():
    assert from_mapping(SimConfig, {"dt": 1}).dt == 1.0
    with pytest.raises(ConfigError, match="dt must be a number, got True"):
        from_mapping(SimConfig, {"dt": True})


def test_a_config_of_random_bytes_is_one_line(tmp_path, capsys):
    cfg = tmp_path / "noise.yaml"
    cfg.write_bytes(bytes(range(128, 256)) * 4)
    code, _, err = run_cli(["compare", "--config", str(cfg), "--runs", "2"], capsys)
    one_line_error(code, err, "not UTF-8")
    with pytest.raises(ConfigError, match="not UTF-8"):
        load_mapping(cfg)


def test_a_negative_seed_is_one_line(tmp_path, capsys):
    out = tmp_path / "out"
    code, _, err = run_cli(
        ["run", "--scenario", "nhtsa_lvs", "--seed", "-1", "--out", str(out)], capsys
    )
    one_line_error(code, err, "--seed", "-1")
    code, _, err = run_cli(
        ["run", "--scenario", "nhtsa_lvs", "--set", "seed=-1", "--out", str(out)], capsys
    )
    one_line_error(code, err, "seed", "-1")
    assert not out.exists()


def test_a_bad_method_names_the_flag(tmp_path, capsys):
    out = tmp_path / "out"
    code, _, err = run_cli(
        ["run", "--scenario", "nhtsa_lvs", "--method", "bogus", "--out", str(out)], capsys
    )
    one_line_error(code, err, "--method", "'bogus'", "federated")
    assert not out.exists()


def test_set_checks_the_key(tmp_path, capsys):
    code, _, err = run_cli(["config", "show", "--set", "fusion.bogus=1"], capsys)
    one_line_error(code, err, "fusion.bogus", "reset")
    code, _, err = run_cli(["config", "show", "--set", "runs"], capsys)
    one_line_error(code, err, "KEY=VALUE")
    # Below a mapping-valued field (a model's params) any key passes to the model to check.
    code, out, _ = run_cli(
        [
            "config",
            "show",
            "--set",
            "warning.model=ttc",
            "--set",
            "warning.params.lead_braking=true",
        ],
        capsys,
    )
    assert code == 0 and "lead_braking" in out


def test_a_sweep_name_cannot_leave_its_folder():
    for name in ("../../../x", "a/b", "/abs", "", ".hidden"):
        with pytest.raises(ConfigError, match="name must be a plain label"):
            SweepConfig.from_mapping({"name": name, "runs": 1, "axes": {"warning.z": [0.0]}})


def test_the_run_command_and_its_summaries_agree_on_collisions(tmp_path, capsys):
    code, out, _ = run_cli(["run", "--scenario", "nhtsa_lvs", "--out", str(tmp_path)], capsys)
    assert code == 0
    per_method = [int(n) for n in re.findall(r"^collisions\s+(\d+)$", out, flags=re.M)]
    total = re.search(r"^collisions: (\d+) of 1 runs(?: \(run (\d+)\))?$", out, flags=re.M)
    assert total and len(per_method) == 3
    # The closed loop's run collides or not; every method's summary says the same.
    assert per_method == [int(total.group(1))] * 3
    if int(total.group(1)):
        assert total.group(2) == "0"


def test_config_show_gives_value_unit_and_origin(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text("runs = 7\n[fusion]\nreset = 'zero'\n")
    code, out, _ = run_cli(
        ["config", "show", "--config", str(cfg), "--set", "warning.hysteresis=0.2", "--json"],
        capsys,
    )
    assert code == 0
    rows = {r["key"]: r for r in json.loads(out)}
    assert rows["runs"]["value"] == 7 and rows["runs"]["origin"].startswith("file ")
    assert rows["fusion.reset"]["value"] == "zero"
    assert rows["warning.hysteresis"]["value"] == 0.2
    assert rows["dt"]["unit"] == "s" and rows["dt"]["origin"].startswith("default: ")
    assert rows["dt"]["origin"].endswith("SimConfig")


def test_config_schema_describes_every_field(tmp_path, capsys):
    target = tmp_path / "schema.json"
    code, _, _ = run_cli(["config", "schema", "--out", str(target)], capsys)
    assert code == 0
    schema = json.loads(target.read_text())
    assert schema == json.loads(json_text(json_schema(SimConfig, "acc_fusion config file")))
    props = schema["properties"]
    assert props["runs"]["type"] == "integer" and props["runs"]["default"] == 200
    assert props["fusion"]["properties"]["filter"]["properties"]["jerk_std"]["type"] == "number"
    assert "[s]" in props["dt"]["description"]
    assert schema["additionalProperties"] is False


@pytest.mark.parametrize("mask", [0o022, 0o077])
def test_output_files_respect_the_umask(tmp_path, mask):
    old = os.umask(mask)
    try:
        path = write_text_atomic(tmp_path / "f.txt", "x")
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~mask


def test_the_filters_step_is_derived_from_dt():
    cfg = from_mapping(SimConfig, {"dt": 0.1})
    assert cfg.fusion.filter.dt == 0.1
    with pytest.raises(ConfigError, match="fusion.filter.dt is the simulation step dt"):
        from_mapping(SimConfig, {"dt": 0.1, "fusion": {"filter": {"dt": 0.2}}})


def test_numbers_in_exponent_form_are_numbers_in_yaml_files_and_set_flags(tmp_path, capsys):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("fusion:\n  fdi:\n    alpha: 1e-4\n")
    code, out, err = run_cli(
        ["config", "show", "--config", str(cfg), "--set", "alert_classes.ttc_threshold=2e0",
         "--json"],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    rows = {r["key"]: r for r in json.loads(out)}
    assert rows["fusion.fdi.alpha"]["value"] == 1e-4
    assert rows["alert_classes.ttc_threshold"]["value"] == 2.0
