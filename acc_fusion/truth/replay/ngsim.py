r"""NGSIM vehicle trajectories (US DOT FHWA, Next Generation SIMulation: US-101, I-80,
Lankershim, Peachtree; public domain, data.transportation.gov): 10 Hz, US customary units.

The CSV export has one row per vehicle per frame with ``Vehicle_ID``, ``Frame_ID`` (0.1 s),
``Local_X`` (lateral position of the front centre [ft]), ``Local_Y`` (longitudinal position of
the **front centre** from the entry edge of the section [ft]), ``v_Length`` [ft], ``v_Vel``
[ft/s], ``v_Acc`` [ft/s²], ``Lane_ID``, ``Preceding`` (0: none), ``Space_Headway`` (front
centre to front centre [ft]) and ``Time_Headway`` (the time to cover the space headway at the
vehicle's speed [s]; 9999.99 at standstill); the combined export adds ``Location``, one
recording per location.  Everything is converted to SI (1 ft = 0.3048 m): :math:`s = 0.3048
\, Y_{\text{local}}`, and so on.  The headway columns measure *spacing* (front to front),
so the cross-check compares them with the replay's gap plus the leader's length.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from acc_fusion.core.paths import existing_file
from acc_fusion.truth.replay import csvfile
from acc_fusion.truth.replay.recording import Recording
from acc_fusion.truth.replay.rows import ReplayError, Rows, whole

#: One foot [m].
FOOT = 0.3048
#: NGSIM's frame period [s].
NGSIM_DT = 0.1
#: ``Time_Headway`` of a vehicle at standstill (no headway).
NO_HEADWAY = 9999.99

#: The columns the replay reads.
COLUMNS = (
    "Vehicle_ID", "Frame_ID", "Local_X", "Local_Y", "v_Length", "v_Vel", "v_Acc", "Lane_ID",
    "Preceding", "Space_Headway", "Time_Headway",
)  # fmt: skip


class NgsimRecording(Recording):
    """The rows of ``path`` (of ``location`` only, if given)."""

    headway_basis = "spacing"
    frame_columns = ("Frame_ID",)
    sources = {"frame": "Frame_ID", "vid": "Vehicle_ID", "s": "Local_Y", "speed": "v_Vel",
               "accel": "v_Acc", "length": "v_Length"}  # fmt: skip

    def __init__(self, path: str | Path, location: str | None = None) -> None:
        self.path = csvfile.existing(path, "NGSIM file")
        self.dt = NGSIM_DT
        self.numbers = csvfile.resolve(self.path, COLUMNS)
        self.label = f"NGSIM {location or self.path.stem}"
        if location is not None:
            self.strings = csvfile.resolve(self.path, ("Location",))
            self.where = ("Location", location)

    def _frames(self, batch: dict[str, np.ndarray]) -> np.ndarray:
        return whole(batch["Frame_ID"])

    def _rows(self, b: dict[str, np.ndarray], frame: np.ndarray) -> Rows:
        leader = whole(b["Preceding"])
        has = leader > 0
        thw = b["Time_Headway"]
        return Rows(
            frame=frame,
            vid=whole(b["Vehicle_ID"]),
            s=FOOT * b["Local_Y"],
            lat=FOOT * b["Local_X"],
            lane=whole(b["Lane_ID"]),
            group=np.zeros(frame.size, dtype=np.int64),
            speed=FOOT * b["v_Vel"],
            accel=FOOT * b["v_Acc"],
            length=FOOT * b["v_Length"],
            leader=np.where(has, leader, -1),
            ref={
                "headway": np.where(has, FOOT * b["Space_Headway"], np.nan),
                "thw": np.where(has & (thw > 0) & (thw < NO_HEADWAY), thw, np.nan),
                "ttc": np.full(frame.size, np.nan),
            },
        )


def ngsim_recordings(path: str | Path, locations: list[str] | None = None) -> list[NgsimRecording]:
    """The recordings of the NGSIM CSV ``path``: one per name of ``locations`` (its
    ``Location`` column), or the whole file."""
    existing_file(path, "NGSIM file", ReplayError)
    if not locations:
        return [NgsimRecording(path)]
    return [NgsimRecording(path, loc) for loc in locations]
