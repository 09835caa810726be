"""The SUMO networks bundled with acc_fusion (package data `acc_fusion.sumo_nets`), and the
resolution of a network name or a `.sumocfg` path to the configuration file to run."""

from __future__ import annotations

from importlib.resources import as_file, files
from pathlib import Path

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.paths import existing_file


def bundled_nets() -> dict[str, Path]:
    """The networks shipped in ``sumo_nets/``: name -> path of its ``.sumocfg``."""
    root = files("acc_fusion.sumo_nets")
    nets = {}
    for entry in root.iterdir():
        if entry.is_dir():
            for cfg in entry.iterdir():
                if cfg.name.endswith(".sumocfg"):
                    with as_file(cfg) as path:
                        nets[entry.name] = Path(path)
    return dict(sorted(nets.items()))


def resolve_sumocfg(net: str | None = None, sumocfg: str | None = None) -> Path:
    """The ``.sumocfg`` of a bundled network (``net``) or a user's file (``sumocfg``)."""
    if (net is None) == (sumocfg is None):
        raise ConfigError("give exactly one of --net NAME and --sumocfg PATH")
    if net is not None:
        nets = bundled_nets()
        if net not in nets:
            raise ConfigError(f"unknown network {net!r}; bundled networks: {', '.join(nets)}")
        return nets[net]
    return existing_file(sumocfg, "SUMO config file")
