r"""The public test protocols' FCW requirements and pass rules, per standard manoeuvre.

A :class:`Requirement` says how early the forward collision warning must come in one
manoeuvre of :mod:`acc_fusion.truth.scripted` and how many trials must meet that: a trial passes
when the warning's onset comes at a time to collision of at least ``required_ttc``,

.. math::

    \mathrm{TTC} = \frac{g}{v_{\text{ego}} - v_{\text{lead}}}\quad\text{(gap over closing speed,
    at the warning onset)},

and no warning (NaN) fails the trial; the manoeuvre passes when at least ``min_passes`` of
``n_trials`` valid trials pass.

=========  ==========================  ============  ======  ===========================
scenario   test                        required TTC  trials  status
=========  ==========================  ============  ======  ===========================
nhtsa_lvs  NHTSA test 1, LVS           2.1 s         5 of 7  TTC verified (secondary)
nhtsa_lvd  NHTSA test 2, LVD           2.4 s         5 of 7  not verified here
nhtsa_lvm  NHTSA test 3, LVM           2.0 s         5 of 7  not verified here
ccrs       Euro NCAP CCRs              2.1 s         5 of 7  ASSUMPTION (NHTSA LVS rule)
=========  ==========================  ============  ======  ===========================

The Euro NCAP manoeuvres ``ccrm`` and ``ccrb`` have no FCW requirement: Euro NCAP tests
them with automatic braking only (below).

What was verified and what is assumed
    NHTSA, *Forward Collision Warning System Confirmation Test*, Office of Vehicle Safety,
    February 2013 (the NCAP FCW test procedure; "Test execution and test requirements" is its
    §12.0).  Only the document's title page and table of contents could be read here.  The
    2.1 s LVS requirement is confirmed by a secondary source quoting NHTSA (Racelogic VBOX ADAS
    user manual, "Forward Collision Warning Testing": systems "must activate before the time
    to collision reaches a minimum of 2.1 seconds").  The test set-ups (LVS: SV 45 mph toward
    a stopped POV; LVD: both at 45 mph, 30 m apart, POV braking at 0.3 g; LVM: SV 45 mph, POV
    20 mph), the LVD 2.4 s and LVM 2.0 s thresholds and the "at least 5 of 7 trials" rule are
    the widely cited values of that procedure, not checked against its text here; nor is
    NHTSA's TTC formula for the decelerating lead (we use gap over closing speed throughout).

    Euro NCAP, *Test Protocol - AEB Car-to-Car systems*, v4.3.1, February 2024, and
    *Assessment Protocol - Safety Assist - Collision Avoidance*, v10.4.1, February 2024 (read
    here in full).  The forward collision warning is tested only in CCRs, at 55-80 km/h: a
    braking robot reacts to the warning "with a delay time of 1.2 seconds" and brakes at
    4 m/s² (test protocol §8.4.6 and annex A.4), and the score is the impact speed (safety
    assist §3.3.1), not a TTC at the warning; the FCW counts only with dynamic brake support
    (§3.1).  CCRm and CCRb are scored for automatic emergency braking only (§3.3.2), so an
    FCW requirement for them would be invented and there is none here.  For CCRs we apply the
    NHTSA rule of the matching manoeuvre (LVS: 2.1 s, 5 of 7 trials), an ASSUMPTION marked
    ``verified=False``; the manoeuvres themselves (speeds, headways, decelerations) are the
    protocol's, checked against BeamNG's implementation of v3.0.2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import bdtrc

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import InputError
from acc_fusion.core.validation import check_choice

_NHTSA = "NHTSA FCW System Confirmation Test (Feb. 2013)"
_EURO_NCAP = "Euro NCAP AEB Car-to-Car test protocol v4.3.1 (FCW rule assumed)"
_NHTSA_SOURCE = (
    "NHTSA, Forward Collision Warning System Confirmation Test, Office of Vehicle Safety, "
    "Feb. 2013, §12"
)
_ASSUMED = (
    "ASSUMPTION: Euro NCAP scores the FCW by impact speed after a robot's braking 1.2 s later, "
    "not by a TTC; the NHTSA rule of the matching manoeuvre ({}) is applied"
)


@dataclass(frozen=True)
class Requirement:
    """The FCW requirement of one standard manoeuvre.

    Attributes:
        protocol: the protocol (and version) it comes from.
        scenario: the manoeuvre's name in :data:`acc_fusion.truth.manoeuvres.SCENARIOS`.
        test: the protocol's name of the test.
        required_ttc: the warning onset must come at a TTC of at least this [s].
        n_trials: number of valid trials the protocol runs.
        min_passes: trials that must pass for the manoeuvre to pass.
        verified: True when the values were checked against a source here.
        source: where the values come from (or the assumption made).
    """

    protocol: str
    scenario: str
    test: str
    required_ttc: float
    n_trials: int
    min_passes: int
    verified: bool
    source: str

    def trial_passes(self, ttc_at_warning: np.ndarray) -> np.ndarray:
        """Per-trial pass: warning at a TTC >= ``required_ttc`` (NaN = no warning = fail)."""
        ttc = check_array("ttc_at_warning", ttc_at_warning, (None,), finite=False)
        return np.nan_to_num(ttc, nan=-np.inf) >= self.required_ttc

    def passes(self, ttc_at_warning: np.ndarray) -> bool:
        """Whether ``n_trials`` trials (their TTCs at warning [s]) pass the protocol's rule."""
        ok = self.trial_passes(ttc_at_warning)
        if ok.size != self.n_trials:
            raise InputError(
                f"ttc_at_warning must hold the {self.n_trials} trials of {self.scenario}, "
                f"got {ok.size}"
            )
        return bool(ok.sum() >= self.min_passes)

    def pass_probability(self, trial_pass_rate: float) -> float:
        """Probability of passing the protocol when each trial passes with this probability."""
        p = float(np.clip(trial_pass_rate, 0.0, 1.0))
        return float(bdtrc(self.min_passes - 1, self.n_trials, p))  # P(passes >= min_passes)


def _nhtsa(scenario: str, test: str, ttc: float, verified: bool) -> Requirement:
    return Requirement(_NHTSA, scenario, test, ttc, 7, 5, verified, _NHTSA_SOURCE)


def _euro_ncap(scenario: str, test: str, like: Requirement) -> Requirement:
    source = _ASSUMED.format(like.scenario)
    return Requirement(_EURO_NCAP, scenario, test, like.required_ttc, 7, 5, False, source)


_LVS = _nhtsa("nhtsa_lvs", "Test 1: lead vehicle stopped", 2.1, True)
_LVD = _nhtsa("nhtsa_lvd", "Test 2: lead vehicle decelerating", 2.4, False)
_LVM = _nhtsa("nhtsa_lvm", "Test 3: lead vehicle moving", 2.0, False)

#: The FCW requirement of every standard manoeuvre that has one: scenario -> Requirement.
REQUIREMENTS: dict[str, Requirement] = {
    r.scenario: r
    for r in (
        _LVS,
        _LVD,
        _LVM,
        _euro_ncap("ccrs", "Car-to-Car Rear stationary", _LVS),
    )
}


def requirement(scenario_name: str) -> Requirement:
    """The FCW requirement of a manoeuvre (``ConfigError`` listing those that have one)."""
    return REQUIREMENTS[check_choice("scenario", scenario_name, REQUIREMENTS)]
