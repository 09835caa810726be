"""Starting SUMO for :class:`~acc_fusion.truth.sumo.source.SumoSource`: its command line, the
libsumo or TraCI module, SUMO's executables and error text,.

libsumo (the default) embeds SUMO in the process; ``gui=True`` uses TraCI and ``sumo-gui``, a
separate process, where a display exists.  Verified against eclipse-sumo / libsumo 1.28:
libsumo reports load errors on stderr (its exception only says "Process Error"), so
:func:`captured_stderr` reads them from file descriptor 2;
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
from collections.abc import Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from acc_fusion.core.errors import ConfigError
from acc_fusion.truth.sumo.config import SumoConfig


def sumo_command(
    config: SumoConfig, cfg_path: str | os.PathLike | None = None, ssm_file: str | None = None
) -> list[str]:
    """The SUMO command line of a :class:`SumoSource` with ``config``: the ``.sumocfg``
    (``cfg_path``, by default ``config.sumocfg``) with the source's seed, collision and
    step-length options, and the SSM device writing to ``ssm_file`` when ``config.ssm``.
    The run length is not on it (the source stops stepping at its end time); a benchmark
    that runs SUMO alone on the same scenario adds ``--end``.

    >>> sumo_command(SumoConfig("motorway.sumocfg", seed=3))[1:5]
    ['-c', 'motorway.sumocfg', '--seed', '3']
    """
    cmd = [
        sumo_binary(config.gui),
        "-c", os.fspath(config.sumocfg if cfg_path is None else cfg_path),
        "--seed", str(int(config.seed)),
        "--no-step-log", "true",
        "--no-warnings", "true",
        "--duration-log.disable", "true",
        "--collision.action", config.collision_action,
        "--collision.mingap-factor", "0",
        "--collision.check-junctions", "true",
    ]  # fmt: skip
    if config.step_length is not None:
        cmd += ["--step-length", repr(float(config.step_length))]
    if config.ssm:
        cmd += [
            "--device.ssm.probability", "1",
            "--device.ssm.measures", "TTC",
            "--device.ssm.file", ssm_file or os.devnull,
        ]  # fmt: skip
    if config.gui:
        cmd += ["--start", "true", "--quit-on-end", "true"]
    return cmd + list(config.extra_args)


@contextmanager
def captured_stderr(sink: list[str]):
    """Capture what SUMO writes to the process's stderr (fd 2) into ``sink``, then echo it,
    unless the block failed: its error then carries SUMO's ``Error:`` lines
    (:func:`sumo_message`), in one line."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, AttributeError, ValueError):  # no real fd 2 (embedded interpreters)
        yield
        return
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        os.dup2(tmp.fileno(), 2)
        failed = False
        try:
            yield
        except BaseException:
            failed = True
            raise
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            text = tmp.read().decode("utf-8", "replace")
            sink.append(text)
            if text and not failed:
                sys.stderr.write(text)


def sumo_message(exc: BaseException, captured: Sequence[str]) -> str:
    """SUMO's own error text: its ``Error:`` lines on stderr, else the exception's text."""
    lines = [ln.strip() for text in captured for ln in text.splitlines() if ln.strip()]
    errors = [ln.removeprefix("Error:").strip() for ln in lines if ln.startswith("Error")]
    text = " ".join(errors) or " ".join(str(exc).split()) or type(exc).__name__
    return text.rstrip(".")


def load_api(gui: bool) -> Any:
    """The libsumo module (default) or the TraCI client module (``gui``)."""
    try:
        import sumo  # noqa: F401  (the eclipse-sumo wheel: sets SUMO_HOME)

        if gui:
            import traci as api
        else:
            import libsumo as api
    except ImportError as exc:
        raise ConfigError(
            f"SUMO support needs eclipse-sumo and libsumo: pip install 'acc_fusion[sumo]' ({exc})"
        ) from None
    return api


def traci_errors(api: Any) -> tuple[type[BaseException], ...]:
    """The exception classes SUMO raises through ``api`` (libsumo's and TraCI's)."""
    import traci

    found = {
        getattr(module, name, None)
        for module in (api, traci, traci.exceptions)
        for name in ("TraCIException", "FatalTraCIError")
    }
    return tuple(c for c in found if isinstance(c, type) and issubclass(c, BaseException))


def sumo_binary(gui: bool) -> str:
    """The ``sumo`` or ``sumo-gui`` executable of the eclipse-sumo wheel."""
    import sumo

    name = "sumo-gui" if gui else "sumo"
    exe = Path(sumo.SUMO_HOME) / "bin" / (name + (".exe" if os.name == "nt" else ""))
    if not exe.is_file():
        found = shutil.which(name)
        if found is None:
            raise ConfigError(f"{name} was not found in the eclipse-sumo wheel ({exe}) nor on PATH")
        return found
    return str(exe)


def has_display() -> bool:
    """Whether a GUI can open: always on Windows/macOS, with DISPLAY or WAYLAND_DISPLAY else."""
    if sys.platform in ("win32", "darwin"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
