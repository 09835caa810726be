"""acc_fusion: forward-collision-warning research by simulation.

Importing the package registers the gymnasium environments ``acc_fusion/CollisionWarning-v0``
and ``acc_fusion/CollisionWarningWorld-v0`` (gymnasium 1.x has no plugin entry points).  The
package is laid out by pipeline stage: ``core`` < ``truth`` < ``sensors`` < ``filters`` <
``fusion`` < ``warning`` < ``metrics`` < ``sim`` < ``studies`` < ``envs`` | ``sweep`` <
``cli``; a stage imports only the stages below it (checked by ``lint-imports``).
"""

__version__ = "0.1.0"

__all__ = ["evaluate"]


def _register_envs() -> None:
    import gymnasium

    if "acc_fusion/CollisionWarning-v0" not in gymnasium.registry:
        gymnasium.register(
            id="acc_fusion/CollisionWarning-v0",
            entry_point="acc_fusion.envs.collision_warning:CollisionWarningEnv",
            vector_entry_point="acc_fusion.envs.collision_warning:CollisionWarningVectorEnv",
        )
    if "acc_fusion/CollisionWarningWorld-v0" not in gymnasium.registry:
        gymnasium.register(
            id="acc_fusion/CollisionWarningWorld-v0",
            entry_point="acc_fusion.envs.world:CollisionWarningWorldEnv",
        )


_register_envs()


def __getattr__(name: str):
    """``acc_fusion.evaluate`` is loaded on first use, so that importing a lower stage (as SUMO's
    background process does) does not import the whole pipeline."""
    if name == "evaluate":
        from acc_fusion.envs.evaluation import evaluate

        return evaluate
    raise AttributeError(f"module 'acc_fusion' has no attribute {name!r}")
