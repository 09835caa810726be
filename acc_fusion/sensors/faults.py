r"""Sensor faults: what a failing radar or infrared sensor reports instead of the truth.

A :class:`Fault` is active for ``start <= t < end`` and acts on every pair of the batch.
:func:`apply_faults` is the whole fault model: a pure function that turns the sensor's clean
report and its noise draw into what the faulty sensor outputs.  With :math:`z^\star` the true
``[range, range-rate]`` of the reported object and :math:`w` the nominal noise draw, a report is

.. math::

    z = z^\star + m_{\mathrm{burst}}\, w + b + s

where, for the faults active at ``t``:

===========  ===============================================================================
kind         effect
===========  ===============================================================================
dropout      no report at all (``valid`` False for every pair).
stuck        the sensor repeats the last value it output before the fault began (frozen
             output: same value, same declared R, same ghost flag, ``valid`` True where it
             ever reported); pairs that never reported stay silent.
bias         :math:`b = [\,\mathrm{magnitude},\ \mathrm{rate\_magnitude}\,]` added to every
             report.
spikes       with ``probability`` per report an outlier
             :math:`s_j = \pm\,a_j\,(1 + U_j)` on each component ``j`` (independent random sign
             and :math:`U_j \sim U(0, 1)`), with :math:`a = [\mathrm{magnitude},\
             \mathrm{rate\_magnitude}]`: an outlier is between one and two times its stated
             size.
noise_burst  :math:`m_{\mathrm{burst}} = \mathrm{magnitude}` multiplies the noise; the declared
             covariance R is unchanged (the sensor does not know it got worse).
===========  ===============================================================================

Several active faults compose in this order: noise burst, then bias and spikes (added), then
stuck (freezes the output), then dropout (removes it).  Two active noise bursts multiply.
These are the usual sensor-fault classes of the fault-diagnosis literature (offset, stuck-at,
outliers, loss of signal, excess noise; see e.g. Isermann, *Fault-Diagnosis Systems*,
Springer, 2006).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from acc_fusion.core.validation import check_choice, check_range

FAULT_KINDS = ("dropout", "stuck", "bias", "spikes", "noise_burst")
#: Smallest allowed ``magnitude`` per kind (other kinds: any finite number).
_MAGNITUDE_MIN = {"spikes": 0.0, "noise_burst": 1.0}


def _finite(name: str, value: float, lo: float | None = None) -> float:
    """``value`` as a finite float, and ``>= lo`` when ``lo`` is given (else ConfigError)."""
    if lo is None:
        return check_range(name, value, -math.inf, math.inf, lo_open=True, hi_open=True)
    return check_range(name, value, lo, math.inf, hi_open=True)


@dataclass(frozen=True)
class Fault:
    """One sensor fault, active for ``start <= t < end`` (see the module docstring for effects).

    Attributes:
        kind: one of :data:`FAULT_KINDS`.
        start: time the fault begins [s], ``>= 0``.
        end: time the fault ends [s], ``> start`` (``inf``: never ends).
        magnitude: bias: range offset [m]; spikes: outlier size [m] (``>= 0``);
            noise_burst: noise standard-deviation multiplier (``>= 1``); unused otherwise.
        rate_magnitude: bias: range-rate offset [m/s]; spikes: range-rate outlier size
            [m/s] (``>= 0``); unused otherwise.
        probability: spikes: probability in [0, 1] that a report is an outlier.
    """

    kind: str
    start: float
    end: float = math.inf
    magnitude: float = 0.0
    rate_magnitude: float = 0.0
    probability: float = 1.0

    def __post_init__(self) -> None:
        check_choice("fault.kind", self.kind, FAULT_KINDS)
        start = check_range("fault.start", self.start, 0.0, math.inf, hi_open=True)
        rate_lo = 0.0 if self.kind == "spikes" else None
        values = {
            "start": start,
            "end": check_range("fault.end", self.end, start, lo_open=True),
            "magnitude": _finite("fault.magnitude", self.magnitude, _MAGNITUDE_MIN.get(self.kind)),
            "rate_magnitude": _finite("fault.rate_magnitude", self.rate_magnitude, rate_lo),
            "probability": check_range("fault.probability", self.probability, 0.0, 1.0),
        }
        for name, value in values.items():
            object.__setattr__(self, name, value)

    def active(self, t: float) -> bool:
        """Whether the fault acts at time ``t`` [s]: ``start <= t < end``."""
        return self.start <= t < self.end


class Report(NamedTuple):
    """What a sensor outputs for N pairs at one sample time (before R is attached).

    Attributes:
        z: ``(N, 2)`` [range m, range-rate m/s]; meaningful only where ``valid``.
        valid: ``(N,)`` bool, the sensor reports a return for the pair.
        ghost: ``(N,)`` bool, the return is a clutter ghost.
    """

    z: np.ndarray
    valid: np.ndarray
    ghost: np.ndarray


def apply_faults(
    faults: Sequence[Fault],
    t: float,
    clean: Report,
    noise: np.ndarray,
    held: Report,
    rng: np.random.Generator,
    draws: int | None = None,
) -> Report:
    """Return the report of a sensor with ``faults`` at time ``t`` (module docstring: effects).

    Args:
        faults: the sensor's faults; those not active at ``t`` are ignored.
        t: sample time [s].
        clean: the noise-free report (true range and range-rate of the reported object).
        noise: ``(N, 2)`` nominal measurement noise draw, added to ``clean.z``.
        held: the last value the sensor output for each pair (``held.valid`` False where it
            never reported); what a stuck sensor repeats.
        rng: generator for the spike draws; drawn from only while a spikes fault is active,
            with fixed shapes ``(N,)`` and ``(N, 2)``, so that faults never change the
            nominal noise stream.
        draws: the pairs the spike draws are made for (>= N, the first N are used; default N),
            so that a pair's draws do not depend on how many pairs are held.
    """
    active = [f for f in faults if f.active(t)]
    burst = math.prod(f.magnitude for f in active if f.kind == "noise_burst")
    z = clean.z + burst * noise
    n = z.shape[0]
    m = n if draws is None else draws
    for f in active:
        size = np.array([f.magnitude, f.rate_magnitude])
        if f.kind == "bias":
            z = z + size
        elif f.kind == "spikes":
            hit = rng.random(m)[:n] < f.probability
            sign = np.where(rng.random((m, 2))[:n] < 0.5, -1.0, 1.0)
            z = z + hit[:, None] * sign * size * (1.0 + rng.random((m, 2))[:n])
    out = Report(z, clean.valid, clean.ghost)
    if any(f.kind == "stuck" for f in active):
        out = held
    if any(f.kind == "dropout" for f in active):
        out = Report(out.z, np.zeros(n, dtype=bool), out.ghost)
    return out
