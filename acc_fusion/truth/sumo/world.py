"""A SUMO source as the truth source of the 2-D world (:class:`SumoWorld`)."""

from __future__ import annotations

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.truth.objects import ObjectFrame, SlotWorld
from acc_fusion.truth.sumo.background import BackgroundSumoSource
from acc_fusion.truth.sumo.objects import ObjectFieldConfig, SumoObjects
from acc_fusion.truth.sumo.source import SumoSource


class SumoWorld(SlotWorld):
    """A SUMO source as the truth source of :func:`acc_fusion.sim.world.simulate_world`: its
    slots are the egos, their objects :class:`SumoObjects`' frame; a slot that a new vehicle
    took (``reassigned``) starts afresh in every stage of the pipeline.  It drives as the
    source does: :meth:`advance` passes the drivers' brake requests and held vehicles on, so
    the 2-D pipeline's warnings can close the loop.

    With a :class:`~acc_fusion.truth.sumo.background.BackgroundSumoSource` opened with
    ``objects``, SUMO and the object frames run in its process, a few steps ahead of the
    pipeline (open loop only), with the same frames bit for bit.

    Args:
        source: an open :class:`~acc_fusion.truth.sumo.source.SumoSource`, or a
            :class:`~acc_fusion.truth.sumo.background.BackgroundSumoSource` opened with
            ``objects``.
        config: the :class:`ObjectFieldConfig` (``None``: the default, or the background
            source's).

    Attributes:
        source: the source; objects: its :class:`SumoObjects` (or the background source's
            :class:`~acc_fusion.truth.sumo.background.ReceivedObjects`).

    Raises:
        ConfigError: a background source without objects, or with another ``config``.
    """

    def __init__(
        self, source: SumoSource | BackgroundSumoSource, config: ObjectFieldConfig | None = None
    ) -> None:
        if isinstance(source, BackgroundSumoSource):
            received = source.objects
            if received is None:
                raise ConfigError(
                    "the BackgroundSumoSource sends no object frames; open it with "
                    "objects=ObjectFieldConfig()"
                )
            if config is not None and config != received.config:
                raise ConfigError(
                    "config differs from the ObjectFieldConfig the BackgroundSumoSource was "
                    "opened with; give it there"
                )
            self.objects = received
        else:
            self.objects = SumoObjects(source, config)
        self.source = source

    def frame(self) -> ObjectFrame:
        """The object frame of the current step."""
        return self.objects.frame()

    def head(self, k: int) -> ObjectFrame:
        """The object frame of the current step's first ``k`` slots (they hold every active
        one), made without the work on the others: ``frame().head(k)``, faster."""
        return self.objects.frame(k)

    def advance(self, ego_brake: np.ndarray | None = None, hold: np.ndarray | None = None) -> None:
        """Run one SUMO step with the drivers' brake requests and held vehicles
        (:meth:`SumoSource.advance <acc_fusion.truth.sumo.source.SumoSource.advance>`)."""
        self.source.advance(ego_brake, hold)

    @property
    def accepts_brakes(self) -> bool:
        """It takes brake requests when its source does."""
        return getattr(self.source, "accepts_brakes", True)

    @property
    def accepts_hold(self) -> bool:
        """It holds distracted drivers' vehicles when its source does."""
        return getattr(self.source, "accepts_hold", False)

    @property
    def vehicle_ids(self) -> list[str | None]:
        """The vehicle id of each slot (``None`` where empty)."""
        return self.source.vehicle_ids
