"""Loading a warning policy from a spec: a baseline's name, ``MODULE:CALLABLE`` (a function, a
class or an object with ``predict``), or a Stable-Baselines3 model ``[ALGO:]model.zip``
(:func:`load_policy`)."""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import os
import sys

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.paths import existing_file
from acc_fusion.envs.policies import BASELINES

#: Stable-Baselines3 algorithms with a discrete action space, for ``[ALGO:]model.zip`` specs.
SB3_ALGORITHMS = ("PPO", "A2C", "DQN")


_SPEC_HELP = (
    "--policy must be MODULE:CALLABLE (e.g. my_rules:policy or path/to/rules.py:policy), a "
    "Stable-Baselines3 model file [PPO|A2C|DQN:]MODEL.zip, or a baseline name ({baselines}), "
    "got {spec!r}"
)


def _import_module(module_name: str, spec: str):
    """Import ``module_name`` (a dotted name, from the current folder too, or a ``.py`` file)."""
    if module_name.endswith(".py"):
        path = existing_file(module_name, f"--policy {spec!r}: file")
        mod_spec = importlib.util.spec_from_file_location(f"_acc_fusion_policy_{path.stem}", path)
        module = importlib.util.module_from_spec(mod_spec)
        try:
            mod_spec.loader.exec_module(module)
        except Exception as exc:
            raise ConfigError(
                f"--policy {spec!r}: importing {module_name!r} failed: {type(exc).__name__}: {exc}"
            ) from None
        return module
    cwd = os.getcwd()
    added = cwd not in sys.path
    if added:
        sys.path.insert(0, cwd)
    try:
        return importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name and (module_name == exc.name or module_name.startswith(exc.name + ".")):
            raise ConfigError(
                f"--policy {spec!r}: no module named {exc.name!r} (not in the current folder "
                "nor on PYTHONPATH)"
            ) from None
        raise ConfigError(
            f"--policy {spec!r}: importing {module_name!r} failed: {type(exc).__name__}: {exc}"
        ) from None
    except Exception as exc:
        raise ConfigError(
            f"--policy {spec!r}: importing {module_name!r} failed: {type(exc).__name__}: {exc}"
        ) from None
    finally:
        if added and cwd in sys.path:
            sys.path.remove(cwd)


def _positional(obj: object) -> tuple[int, int] | None:
    """``(positional parameters, required ones)`` of a callable, or ``None`` if unknown."""
    try:
        params = inspect.signature(obj).parameters.values()
    except (TypeError, ValueError):
        return None
    kinds = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    positional = [p for p in params if p.kind in kinds or p.kind == p.VAR_POSITIONAL]
    required = [p for p in positional if p.kind in kinds and p.default is p.empty]
    return len(positional), len(required)


def _as_policy(obj: object, spec: str) -> object:
    """A policy from the object a spec names: a policy itself, or a class/factory to call."""
    if isinstance(obj, type) or (
        callable(obj) and not hasattr(obj, "predict") and (_positional(obj) or (1, 1))[0] == 0
    ):
        what = "class" if isinstance(obj, type) else "factory"
        try:
            obj = obj()
        except TypeError as exc:
            raise ConfigError(
                f"--policy {spec!r}: the {what} must be callable with no arguments: {exc}"
            ) from None
        except Exception as exc:
            raise ConfigError(
                f"--policy {spec!r}: the {what} failed: {type(exc).__name__}: {exc}"
            ) from None
    if callable(getattr(obj, "predict", None)):
        return obj
    if not callable(obj):
        raise ConfigError(
            f"--policy {spec!r} is not a policy (a callable obs -> action, an object with "
            f".predict, or a class or factory making one), got a {type(obj).__name__} value"
        )
    shape = _positional(obj)
    if shape is not None and (shape[0] == 0 or shape[1] > 1):
        raise ConfigError(
            f"--policy {spec!r} must take one argument (the observation), "
            f"its signature is {inspect.signature(obj)}"
        )
    return obj


def _load_sb3(spec: str) -> object:
    algo, sep, path = spec.partition(":")
    if not sep or algo.upper() not in SB3_ALGORITHMS:
        algo, path = "PPO", spec
    existing_file(path, "--policy model file")
    try:
        import stable_baselines3
    except ImportError:
        raise ConfigError(
            f"--policy {spec!r} needs Stable-Baselines3, which is not installed "
            "(pip install 'acc_fusion[rl]')"
        ) from None
    cls = getattr(stable_baselines3, algo.upper())
    try:
        return cls.load(path, device="cpu")
    except Exception as exc:
        raise ConfigError(
            f"--policy {spec!r}: cannot load it as a Stable-Baselines3 {algo.upper()} model: "
            f"{type(exc).__name__}: {exc}"
        ) from None


def load_policy(spec: str) -> object:
    """The policy a ``--policy`` spec names.

    ``spec`` is one of:

    * ``MODULE:CALLABLE`` — ``MODULE`` a dotted module name (importable, or in the current
      folder) or a ``.py`` file path, ``CALLABLE`` an attribute path in it.  A callable that
      takes one argument is the policy; a class, or a function without parameters, is a
      factory called once to make it.  Objects with ``predict`` are used as they are.
    * ``[PPO|A2C|DQN:]MODEL.zip`` — a Stable-Baselines3 model file (default PPO), loaded
      with ``<ALGO>.load`` on the CPU (needs the ``rl`` extra).
    * a baseline name of :data:`acc_fusion.envs.policies.BASELINES`.

    Raises :class:`~acc_fusion.core.errors.ConfigError`, one line naming the spec, when it is
    malformed, the module or attribute does not exist, importing fails or the object is not
    a policy.
    """

    help_ = _SPEC_HELP.format(baselines=", ".join(BASELINES), spec=spec)
    if not isinstance(spec, str) or not spec.strip():
        raise ConfigError(help_)
    spec = spec.strip()
    if spec in BASELINES:
        return BASELINES[spec]
    if spec.lower().endswith(".zip"):
        return _load_sb3(spec)
    module_name, sep, attr = spec.rpartition(":")
    if not sep or not module_name or not attr or not all(attr.split(".")):
        raise ConfigError(help_)
    obj = _import_module(module_name, spec)
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise ConfigError(
                f"--policy {spec!r}: {module_name!r} has no attribute {attr!r} "
                f"({part!r} is missing)"
            )
        obj = getattr(obj, part)
    return _as_policy(obj, spec)
