"""acc_fusion: forward-collision-warning research by simulation.

Importing the package registers the gymnasium environment ``acc_fusion/CollisionWarning-v0``
(gymnasium 1.x has no plugin entry points).
"""

__version__ = "0.1.0"


def _register_envs() -> None:
    import gymnasium

    if "acc_fusion/CollisionWarning-v0" not in gymnasium.registry:
        gymnasium.register(
            id="acc_fusion/CollisionWarning-v0",
            entry_point="acc_fusion.envs.collision_warning:CollisionWarningEnv",
            vector_entry_point="acc_fusion.envs.collision_warning:CollisionWarningVectorEnv",
        )


_register_envs()

from acc_fusion.envs.evaluation import evaluate  # noqa: E402

__all__ = ["evaluate"]
