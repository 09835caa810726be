r"""Fusion center: Carlson's federated Kalman filter and the baselines it is judged against.

All estimators share one interface: ``step(measurements, target_id) -> Estimate``, batched
over N follower→leader pairs, one step of ``FilterConfig.dt`` seconds per call, run on either
engine (:mod:`acc_fusion.filters.engines`).  Methods (:data:`FUSION_METHODS`, plus any sensor name):

``<sensor name>`` (e.g. ``"radar"``)
    That sensor alone: one Kalman filter on its measurements (kong2011's local filter).
``"centralized"`` / ``"centralized_stacked"``
    One Kalman filter fed by every sensor: predict once, then update with each reporting
    sensor in turn (*sequential*) or with all of them stacked into one measurement vector
    (*stacked*); both are the optimal linear estimate (qa-multisensor thread).
``"federated"``
    Carlson's federated filter (Carlson 1990; hu2005 eqs. 3-10; kong2011 eqs. 1-6): one local
    filter per sensor and a master filter.  The information-sharing factors
    :math:`\beta_i` (:math:`\sum_i \beta_i = 1`) divide the process-noise and prior
    information among the locals, :math:`Q_i = \beta_i^{-1} Q`, :math:`P_i = \beta_i^{-1} P_m`,
    which removes the correlation the common process noise would otherwise create; the
    master fuses :math:`P_m = (\sum_i P_i^{-1})^{-1}`, :math:`\hat x_m = P_m\sum_i P_i^{-1}\hat
    x_i` every ``fusion_period`` steps.  Reset modes:

    * ``fusion`` (fusion-reset, :math:`\beta_m = 0`): after each fusion every local restarts from
      the fused estimate with :math:`P_i = \beta_i^{-1} P_m`.  Fused at every step this equals
      the centralized filter exactly.
    * ``zero`` (zero-reset, :math:`\beta_m = 1`): the master keeps all the process-noise and
      prior information; each local restarts from the fused estimate and reports only the
      information it gathered since, :math:`P_m^{-1} = P_m^{-,-1} + \sum_i (P_i^{-1} -
      P_m^{-,-1})` (information-increment form).  Also exact when fused every step.
    * ``none`` (no-reset): locals start with :math:`\beta_i^{-1}`-inflated prior and process
      noise and are never reset; the fused covariance is then an upper bound (conservative).

    :math:`\beta` is ``"equal"`` (:math:`1/n`), ``"trace"`` (covariance-based: the more
    precise local gets the larger share, :math:`\beta_i \propto 1/\mathrm{tr}(\beta_i P_i)`;
    hu2005's diagonal method prints the ratio the other way up and per state component, which
    breaks :math:`\sum_i P_i^{-1} = P_m^{-1}`, so acc_fusion uses its scalar, information-
    preserving form), or explicit values.  Fault detection and isolation
    (:mod:`acc_fusion.fusion.fdi`) leaves failing sensors out of the fusion.
``"plain"``
    kong2011's fusion formula without information sharing: independent full local filters
    (:math:`\beta_i = 1`, no reset) fused as if uncorrelated.  Over-confident, because the
    locals share the process noise and the initial measurement (hu2005's point).

Track management (all methods): a pair's filters (re)initialise from the first measurement
after its target id changes (a new leader, from the truth source's leader ids: the data
association of a real tracker) or after ``max_coast`` seconds without a usable measurement:
:math:`\hat x_0 = [r, \dot r, 0]`, :math:`P_0 = \mathrm{diag}(R, \sigma_{a,0}^2)`.
"""

from __future__ import annotations

from collections.abc import Sequence

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_choice
from acc_fusion.fusion.base import Estimator
from acc_fusion.fusion.baselines import CentralizedFilter, SingleSensorFilter, SteadyStateFilter
from acc_fusion.fusion.config import FUSION_METHODS, FusionConfig
from acc_fusion.fusion.federated import FederatedFilter
from acc_fusion.sensors.spec import SensorSpec


def make_estimator(
    config: FusionConfig | str,
    sensors: Sequence[str],
    n_pairs: int,
    specs: Sequence[SensorSpec] | None = None,
) -> Estimator:
    """Build the estimator named by ``config.method`` (or by a method name with defaults).

    ``specs`` (the sensors' :class:`~acc_fusion.sensors.spec.SensorSpec`, in the order of
    ``sensors``) is needed by the constant-gain filter (``local="steady"``), enables the
    federated filter's track confirmation (each sensor's range interval) and lets every
    filter evaluate a range-dependent noise at the prediction (``config.noise_at``).

    >>> est = make_estimator("federated", ("radar", "infrared"), n_pairs=4)
    >>> type(est).__name__
    'FederatedFilter'
    """
    if isinstance(config, str):
        config = FusionConfig(method=config)
    sensors = tuple(sensors)
    method = check_choice("fusion.method", config.method, sensors + FUSION_METHODS)
    if config.local == "steady":
        if method not in sensors:
            raise ConfigError(
                f"fusion.local='steady' applies to single-sensor methods "
                f"({', '.join(sensors)}), not to {method!r}"
            )
        if specs is None:
            raise ConfigError("fusion.local='steady' needs the sensors' specs (specs=...)")
        return SteadyStateFilter(sensors, n_pairs, config, spec=specs[sensors.index(method)])
    if method in sensors:
        return SingleSensorFilter(sensors, n_pairs, config, sensor=method, specs=specs)
    if method.startswith("centralized"):
        stacked = method.endswith("stacked")
        return CentralizedFilter(sensors, n_pairs, config, stacked=stacked, specs=specs)
    return FederatedFilter(sensors, n_pairs, config, plain=method == "plain", specs=specs)
