"""The 2-D world's settings (:class:`WorldConfig`), a section of the simulation's config."""

from __future__ import annotations

from dataclasses import dataclass, field

from acc_fusion.core.validation import check_range
from acc_fusion.fusion.tracking.association import AssociationConfig
from acc_fusion.fusion.tracking.tracker import TrackerConfig
from acc_fusion.sensors.suite2d import Sensors2DConfig
from acc_fusion.truth.conditions import Conditions
from acc_fusion.truth.scenes import SceneConfig
from acc_fusion.truth.sumo.objects import ObjectFieldConfig
from acc_fusion.warning.selection import SelectionConfig


@dataclass(frozen=True)
class WorldConfig:
    """The 2-D world's settings (the rest — methods, fusion, warning, alert classes, runs,
    seed, step — are the simulation's).

    Attributes:
        scene: the scripted scene (a name of :data:`acc_fusion.truth.scenes.SCENES`).
        conditions: weather and light.
        sensors: the radar's and the thermal camera's specs.
        tracker: the per-sensor multi-target trackers.
        association: the track-to-track association.
        selection: the in-path target selection.
        yaw_rate_std: noise std of the ego's yaw-rate gyro [rad/s]; 0.005 (0.3 °/s, the order
            of automotive MEMS yaw-rate sensors' noise; assumption).
    """

    scene: str = "cut_out"
    conditions: Conditions = field(default_factory=Conditions)
    sensors: Sensors2DConfig = field(default_factory=Sensors2DConfig)
    tracker: TrackerConfig = field(default_factory=TrackerConfig)
    association: AssociationConfig = field(default_factory=AssociationConfig)
    selection: SelectionConfig = field(default_factory=SelectionConfig)
    yaw_rate_std: float = 0.005

    def __post_init__(self) -> None:
        SceneConfig(scene=self.scene)  # the scene's name is checked there
        check_range("world.yaw_rate_std", self.yaw_rate_std, 0.0, 1.0)

    @property
    def map_path(self) -> bool:
        """The selection reads the map's lanes ahead (``selection.path = "map"``): the truth
        source must give them."""
        return self.selection.path == "map"

    def object_field(self) -> ObjectFieldConfig:
        """The field SUMO's object truth gives these settings (the map's lanes ahead for the
        ``"map"`` path)."""
        return ObjectFieldConfig(map_path=self.map_path)
