"""The settings of a SUMO run (:class:`SumoConfig`), the check of a `.sumocfg` before SUMO
starts (:func:`check_sumocfg`), and the error SUMO's failures become (:class:`SumoError`)."""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from acc_fusion.core.errors import AccFusionError, ConfigError
from acc_fusion.core.paths import existing_file
from acc_fusion.core.validation import check_choice, check_range

#: Collision actions allowed for :attr:`SumoConfig.collision_action` (SUMO's
#: ``--collision.action`` values that still report the collision).
COLLISION_ACTIONS = ("remove", "warn", "teleport")


#: Cap of :attr:`SumoSource.n_steps` when neither the config nor the ``.sumocfg`` gives an end
#: (the run then ends when no vehicle is left) [s of simulated time].
UNBOUNDED_END = 86400.0

#: The warm-up of the traffic commands (``acc-fusion sumo``, ``tune``) [s]: the bundled
#: motorway (4.9 km) takes its vehicles about 165 s to drive at 30 m/s, so after 200 s its
#: density is that of the demand and every vehicle in it has left its insertion behind.
TRAFFIC_WARMUP = 200.0


class SumoError(AccFusionError, RuntimeError):
    """SUMO could not start, failed during the run, or a second simulation was opened."""


@dataclass(frozen=True)
class SumoConfig:
    """Settings of a :class:`SumoSource` (validated on construction; SI units).

    Attributes:
        sumocfg: path of a ``.sumocfg`` file (any user file; bundled ones are resolved by the
            caller).
        end: simulated seconds to run from the begin time (after the warm-up); ``None``: the
            ``.sumocfg``'s end (and if it has none, until no vehicle is left, at most
            :data:`UNBOUNDED_END`).
        warmup: simulated seconds SUMO runs before the source's first frame [s]; 0.  Nothing
            is measured, equipped or perceived during it: the network fills, and vehicles
            inserted at its ends settle, before any figure counts (every figure alike).
        penetration: fraction of vehicles equipped with FCW, in [0, 1]; 1.0.
        seed: seed of SUMO (``--seed``) and of the equipped / inattentive / hazard draws; 0.
        capacity: maximum number of simultaneously tracked equipped vehicles (pair slots, the
            N of every array); 1024.
        step_length: simulation step [s], in (0, 1], overriding the ``.sumocfg``'s; ``None``
            keeps it (FCW wants 0.05-0.1 s).
        hazard_rate: injected lead-vehicle emergency braking events per vehicle-hour; 0.
        hazard_decel: deceleration of an injected emergency braking [m/s²]; 8.0.
        hazard_duration: duration of an injected emergency braking [s]; 3.0.
        inattentive: fraction of equipped drivers with a long reaction, in [0, 1]; 0.
        inattentive_action_step: SUMO action step length of inattentive drivers [s]; 1.5.
        lookahead: leaders farther than this are not reported [m]; 250 (long-range radar).
        collision_action: SUMO's ``--collision.action``: ``"remove"`` (default), ``"warn"``
            or ``"teleport"``.
        gui: run ``sumo-gui`` through TraCI (needs a display); False.
        ssm: equip vehicles with SUMO's SSM device (TTC, default 50 m range) for the
            cross-check of :meth:`SumoSource.ssm_min_ttc`; False.  SUMO builds devices when
            a vehicle is loaded, before the equipped draw, so every vehicle carries one
            (slower) and only the equipped ones are read; the dynamics are unchanged.
        extra_args: further SUMO command-line options, e.g. ``("--lateral-resolution",
            "0.8")``; ().
        native: read the vehicles with the compiled reader of :mod:`acc_fusion.truth.sumo.native`
            (built on first use; the same values, in about 0.4 of the time), falling back to
            libsumo's Python functions with a warning where it cannot be built; True.
            Without effect with ``gui`` (TraCI).
    """

    sumocfg: str
    end: float | None = None
    warmup: float = 0.0
    penetration: float = 1.0
    seed: int = 0
    capacity: int = 1024
    step_length: float | None = None
    hazard_rate: float = 0.0
    hazard_decel: float = 8.0
    hazard_duration: float = 3.0
    inattentive: float = 0.0
    inattentive_action_step: float = 1.5
    lookahead: float = 250.0
    collision_action: str = "remove"
    gui: bool = False
    ssm: bool = False
    extra_args: tuple[str, ...] = ()
    native: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.sumocfg, (str, os.PathLike)) or not str(self.sumocfg).strip():
            raise ConfigError(f"sumocfg must be the path of a .sumocfg file, got {self.sumocfg!r}")
        object.__setattr__(self, "sumocfg", os.fspath(self.sumocfg))
        if self.end is not None:
            object.__setattr__(self, "end", check_range("end", self.end, 0.0, lo_open=True))
        check_range("warmup", self.warmup, 0.0, UNBOUNDED_END)
        check_range("penetration", self.penetration, 0.0, 1.0)
        for name in ("seed", "capacity"):
            value = getattr(self, name)
            low = 1 if name == "capacity" else 0
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
                raise ConfigError(f"{name} must be an integer >= {low}, got {value!r}")
        if self.seed >= 2**31:
            raise ConfigError(f"seed must be < 2**31 (SUMO's --seed), got {self.seed!r}")
        if self.step_length is not None:
            check_range("step_length", self.step_length, 0.0, 1.0, lo_open=True)
        check_range("hazard_rate", self.hazard_rate, 0.0, math.inf, hi_open=True)
        check_range("hazard_decel", self.hazard_decel, 0.0, 100.0, lo_open=True)
        check_range(
            "hazard_duration", self.hazard_duration, 0.0, math.inf, lo_open=True, hi_open=True
        )
        check_range("inattentive", self.inattentive, 0.0, 1.0)
        check_range(
            "inattentive_action_step", self.inattentive_action_step, 0.0, 10.0, lo_open=True
        )
        check_range("lookahead", self.lookahead, 0.0, math.inf, lo_open=True, hi_open=True)
        check_choice("collision_action", self.collision_action, COLLISION_ACTIONS)
        for name in ("gui", "ssm", "native"):
            if not isinstance(getattr(self, name), bool):
                raise ConfigError(f"{name} must be true or false, got {getattr(self, name)!r}")
        args = self.extra_args
        if isinstance(args, str) or not all(isinstance(a, str) for a in args):
            raise ConfigError(f"extra_args must be a list of strings, got {args!r}")
        object.__setattr__(self, "extra_args", tuple(args))


# ---------------------------------------------------------------- checks before starting SUMO
def _option_files(root: ET.Element, option: str, base: Path) -> list[Path]:
    """Files named by a ``.sumocfg`` option (``<net-file value="a,b"/>``), relative to it."""
    files: list[Path] = []
    for node in root.iter(option):
        value = node.get("value", "")
        for name in value.replace(",", " ").split():
            path = Path(os.path.expandvars(os.path.expanduser(name)))
            files.append(path if path.is_absolute() else base / path)
    return files


def check_sumocfg(path: str | os.PathLike, extra_args: Sequence[str] = ()) -> Path:
    """Check that ``path`` is a readable SUMO configuration whose input files exist.

    Checks, each failing with one :class:`~acc_fusion.core.errors.ConfigError` naming the file:
    the file exists, is XML with a ``<configuration>`` root, names a ``net-file`` (unless
    ``extra_args`` gives ``-n``/``--net-file``), and every ``net-file``, ``route-files`` and
    ``additional-files`` entry exists.  Returns the absolute path.
    """
    cfg = existing_file(Path(path).expanduser(), "SUMO configuration")
    try:
        root = ET.parse(cfg).getroot()
    except (ET.ParseError, OSError) as exc:
        raise ConfigError(f"SUMO configuration {str(cfg)!r} is not valid XML ({exc})") from None
    if root.tag not in ("configuration", "sumoConfiguration"):
        raise ConfigError(
            f"SUMO configuration {str(cfg)!r} must have a <configuration> (or "
            f"<sumoConfiguration>) root element, got <{root.tag}>"
        )
    base = cfg.resolve().parent
    nets = _option_files(root, "net-file", base)
    if not nets and not {"-n", "--net-file"} & set(extra_args):
        raise ConfigError(f"SUMO configuration {str(cfg)!r} names no net-file")
    for option in ("net-file", "route-files", "additional-files"):
        for file in _option_files(root, option, base):
            if not file.is_file():
                raise ConfigError(
                    f"the {option} {str(file)!r} named in SUMO configuration {str(cfg)!r} "
                    "does not exist"
                )
    return cfg.resolve()
