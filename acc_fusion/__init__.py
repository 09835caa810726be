"""acc_fusion: forward-collision-warning research by simulation.

Importing the package registers the gymnasium environments ``acc_fusion/CollisionWarning-v0``,
``acc_fusion/CollisionAvoidance-v0`` and ``acc_fusion/CollisionWarningWorld-v0`` (gymnasium
1.x has no plugin entry points).  The package is laid out by pipeline stage: ``core`` <
``truth`` < ``sensors`` < ``filters`` < ``fusion`` < ``warning`` < ``metrics`` | ``braking`` <
``sim`` < ``studies`` < ``envs`` | ``sweep`` <
``cli``; a stage imports only the stages below it (checked by ``lint-imports``).
"""

import importlib.abc
import importlib.util
import sys

__version__ = "0.1.0"

__all__ = ["evaluate"]


def _register_envs(gymnasium) -> None:
    if "acc_fusion/CollisionWarning-v0" not in gymnasium.registry:
        gymnasium.register(
            id="acc_fusion/CollisionWarning-v0",
            entry_point="acc_fusion.envs.collision_warning:CollisionWarningEnv",
            vector_entry_point="acc_fusion.envs.collision_warning:CollisionWarningVectorEnv",
        )
    if "acc_fusion/CollisionAvoidance-v0" not in gymnasium.registry:
        gymnasium.register(
            id="acc_fusion/CollisionAvoidance-v0",
            entry_point="acc_fusion.envs.braking:CollisionAvoidanceEnv",
            vector_entry_point="acc_fusion.envs.braking:CollisionAvoidanceVectorEnv",
        )
    if "acc_fusion/CollisionWarningWorld-v0" not in gymnasium.registry:
        gymnasium.register(
            id="acc_fusion/CollisionWarningWorld-v0",
            entry_point="acc_fusion.envs.world:CollisionWarningWorldEnv",
        )


class _RegisterWithGymnasium(importlib.abc.MetaPathFinder):
    """Registers the environments the moment gymnasium is imported, so that importing
    acc_fusion does not import gymnasium (a quarter of a second the command line does not
    need) and ``import acc_fusion`` still makes ``gymnasium.make`` find them."""

    def find_spec(self, name, path, target=None):
        if name != "gymnasium":
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.loader is not None:
            load = spec.loader.exec_module

            def exec_module(module) -> None:
                load(module)
                _register_envs(module)

            spec.loader.exec_module = exec_module
        return spec


if "gymnasium" in sys.modules:
    _register_envs(sys.modules["gymnasium"])
else:
    sys.meta_path.insert(0, _RegisterWithGymnasium())


def __getattr__(name: str):
    """``acc_fusion.evaluate`` is loaded on first use, so that importing a lower stage (as SUMO's
    background process does) does not import the whole pipeline."""
    if name == "evaluate":
        from acc_fusion.envs.evaluation import evaluate

        return evaluate
    raise AttributeError(f"module 'acc_fusion' has no attribute {name!r}")
