"""ASAM's quality checkers on scenario files: the OpenSCENARIO XML checker bundle
(``asam-qc-openscenarioxml``, bundle ``xoscBundle``) on every ``.xosc`` and the OpenDRIVE one
(``asam-qc-opendrive``, ``xodrBundle``) on every ``.xodr`` of a folder.

The checkers run as libraries, in this process, one file at a time (their configuration takes
one ``InputFile``): the same ``run_checks(Configuration, Result)`` their command lines
``qc_openscenario -c CONFIG`` and ``qc_opendrive -c CONFIG`` call, with the result read
through ``qc_baselib.Result`` (what they would write to a ``.xqar`` file).  Their modules
configure the root logger on import; it is put back as it was.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

from acc_fusion.core.errors import ConfigError
from acc_fusion.truth.openscenario.document import INSTALL


@dataclass(frozen=True)
class Finding:
    """One issue (or a checker that ended in error): the file, the checker, what it says."""

    file: str
    checker: str
    description: str


@dataclass(frozen=True)
class CheckReport:
    """The checkers' verdict on a set of files.

    Attributes:
        files: files checked, by suffix (``{".xosc": 39, ".xodr": 1}``).
        completed: checks that ran to completion (over all files).
        skipped: checks skipped (their rule is for another version of the standard, or a
            precondition failed).
        findings: the issues and checker errors; none: the files pass.
    """

    files: dict[str, int]
    completed: int
    skipped: int
    findings: tuple[Finding, ...]

    @property
    def passed(self) -> bool:
        """No issue and no checker error."""
        return not self.findings


def _bundles():
    """(suffix -> (run_checks, bundle constants)) with the checkers imported, or one
    ConfigError naming the install command."""
    root = logging.getLogger()
    level, handlers = root.level, list(root.handlers)
    try:
        from qc_baselib import Configuration, Result, StatusType
        from qc_opendrive import constants as xodr_constants
        from qc_opendrive import main as xodr_main
        from qc_openscenario import constants as xosc_constants
        from qc_openscenario import main as xosc_main
    except ImportError:
        raise ConfigError(f"checking scenario files needs ASAM's quality checkers: {INSTALL} "
                          "(and asam-qc-opendrive, see the Makefile)") from None  # fmt: skip
    finally:
        root.setLevel(level)
        root.handlers[:] = handlers
    bundles = {".xosc": (xosc_main.run_checks, xosc_constants),
               ".xodr": (xodr_main.run_checks, xodr_constants)}  # fmt: skip
    return Configuration, Result, StatusType, bundles


def check_files(paths: list[Path]) -> CheckReport:
    """Run the checker bundle of each file's kind on ``paths`` (``.xosc``, ``.xodr``)."""
    configuration, result_type, status, bundles = _bundles()
    counts: dict[str, int] = {}
    completed = skipped = 0
    findings: list[Finding] = []
    for path in paths:
        run, constants = bundles[path.suffix]
        counts[path.suffix] = counts.get(path.suffix, 0) + 1
        config = configuration()
        config.set_config_param("InputFile", str(path))
        config.register_checker_bundle(constants.BUNDLE_NAME)
        result = result_type()
        result.register_checker_bundle(name=constants.BUNDLE_NAME, description="",
                                       version=constants.BUNDLE_VERSION, summary="")  # fmt: skip
        result.set_result_version(version=constants.BUNDLE_VERSION)
        run(config, result)
        for checker in result.get_checker_results(constants.BUNDLE_NAME):
            completed += checker.status == status.COMPLETED
            skipped += checker.status == status.SKIPPED
            if checker.status == status.ERROR:
                findings.append(Finding(path.name, checker.checker_id, checker.summary))
            for issue in checker.issues:
                findings.append(Finding(path.name, checker.checker_id, issue.description))
    return CheckReport(counts, completed, skipped, tuple(findings))


def check_folder(folder: Path) -> CheckReport:
    """:func:`check_files` on every ``.xosc`` and ``.xodr`` file in ``folder`` (sorted)."""
    folder = Path(folder)
    return check_files(sorted(p for p in folder.iterdir() if p.suffix in (".xosc", ".xodr")))
