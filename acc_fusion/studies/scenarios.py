"""The test protocols as scenario files (:mod:`acc_fusion.truth.openscenario`): their test
points (:func:`protocol_points`), written and checked (:func:`export_protocol`); the study of
``acc-fusion scenarios export``.  Here, not in the truth layer, because Euro NCAP's grid is
defined with its scoring (:mod:`acc_fusion.metrics.euroncap`)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from acc_fusion.core.validation import check_choice
from acc_fusion.metrics.euroncap import CCRPoint, ccr_grid
from acc_fusion.studies.aeb_tests import ccr_test_point
from acc_fusion.truth.openscenario.check import check_folder
from acc_fusion.truth.openscenario.export import Written, write_points
from acc_fusion.truth.procedures import TestPoint, fmvss127_points, nhtsa_fcw_points

#: The protocols that can be exported, as ``acc-fusion conformance --protocol`` names them.
PROTOCOLS = ("nhtsa-fcw", "fmvss127", "euroncap-aeb")


def ccr_label(point: CCRPoint) -> str:
    """A Euro NCAP grid point's label, e.g. ``"Euro NCAP CCRs AEB 20 km/h overlap -50%"``,
    ``"Euro NCAP CCRb 50 km/h 12 m 2 m/s²"``."""
    if point.scenario == "CCRb":
        return (f"Euro NCAP CCRb {point.speed_kmh} km/h {point.headway:g} m "
                f"{point.target_deceleration:g} m/s²")  # fmt: skip
    mode = f" {point.mode.upper()}" if point.scenario == "CCRs" else ""
    return (f"Euro NCAP {point.scenario}{mode} {point.speed_kmh} km/h overlap "
            f"{round(point.overlap * 100):d}%")  # fmt: skip


def protocol_points(protocol: str) -> list[TestPoint]:
    """The test points of ``protocol`` (:data:`PROTOCOLS`), labelled: NHTSA's three FCW
    tests, FMVSS 127's matrix, Euro NCAP's Car-to-Car rear grid."""
    check_choice("protocol", protocol, PROTOCOLS)
    if protocol == "nhtsa-fcw":
        return nhtsa_fcw_points()
    if protocol == "fmvss127":
        return fmvss127_points()
    return [replace(ccr_test_point(p), label=ccr_label(p)) for p in ccr_grid()]


def export_protocol(protocol: str, folder: str | Path, *, check: bool = False) -> Written:
    """Write ``protocol``'s test points as OpenSCENARIO files with their road into ``folder``
    (:func:`~acc_fusion.truth.openscenario.export.write_points`); with ``check``, ASAM's
    checkers run on them before they are moved there (``Written.check``, a
    :class:`~acc_fusion.truth.openscenario.check.CheckReport`)."""
    return write_points(protocol_points(protocol), Path(folder), check_folder if check else None)
