r"""How weather and light weaken what the 2-D sensors receive: the 77 GHz radar's two-way loss
in rain and fog, and the long-wave infrared (LWIR, 8-14 µm) transmittance in fog and rain.

Each effect is one function of the range and the :class:`~acc_fusion.truth.conditions.Conditions`
with its equation and source.  Darkness has no effect on either sensor: a radar illuminates its
targets itself and a thermal camera images their own emission (so no function takes
``light``).
"""

from __future__ import annotations

import math

import numpy as np

from acc_fusion.truth.conditions import Conditions

#: ITU-R P.838-3 power-law coefficients of the rain's specific attenuation at 77 GHz,
#: horizontal polarisation (``k`` [dB/km per (mm/h)^α], ``α``), from the recommendation's
#: curve-fit equations (2)-(3) with its Tables 1 and 3 (vertical polarisation: k = 1.128,
#: α = 0.707, 3 % less attenuation at 10 mm/h).
RAIN_K_77GHZ = 1.1320


RAIN_ALPHA_77GHZ = 0.7177


#: Radar carrier frequency [GHz] of the fog model.
RADAR_FREQ_GHZ = 77.0


#: Temperature of the fog's liquid water [K] in the fog model (10 °C, assumption).
FOG_TEMPERATURE_K = 283.15


#: Koschmieder's constant ln(1/0.02): the visibility is where a black object's contrast
#: against the horizon sky has fallen to the 2 % threshold of the eye.
KOSCHMIEDER = math.log(50.0)


_DB_PER_NEPER = 10.0 / math.log(10.0)


def rain_attenuation_77ghz(rain_rate: float) -> float:
    r"""Specific attenuation of rain at 77 GHz [dB/km], one way.

    .. math:: \gamma_R = k R^{\alpha},\qquad k = 1.132,\ \alpha = 0.7177

    with ``rain_rate`` :math:`R` [mm/h]: 5.9 dB/km at 10 mm/h, 11 dB/km at 25 mm/h.

    Source: ITU-R Recommendation P.838-3, *Specific attenuation model for rain for use in
    prediction methods*, 2005 (``k``, ``α`` from its equations (2)-(3) at f = 77 GHz,
    horizontal polarisation).
    """
    return RAIN_K_77GHZ * rain_rate**RAIN_ALPHA_77GHZ


def fog_liquid_water(visibility: float) -> float:
    r"""Liquid water content :math:`M` [g/m³] of a fog of visibility :math:`V` [m]:

    .. math:: M = (0.024 / V_{\mathrm{km}})^{1.54}

    (0.32 g/m³ at 50 m, 0.05 g/m³ at 200 m; 0 in clear air, ``visibility = inf``), the
    inverse of Eldridge's empirical relation :math:`V = 0.024\,M^{-0.65}` km.  The relation
    depends on the droplet sizes (Tomasi & Tampieri 1976), so it is a typical, not an exact,
    value.

    Sources: E. E. Altshuler, "A simple expression for estimating attenuation by fog at
    millimeter wavelengths", *IEEE Trans. Antennas Propag.* 32(7):757-758, 1984; R. G.
    Eldridge, "The relationship between visibility and liquid water content in fog",
    *J. Atmos. Sci.* 28:1183-1186, 1971; C. Tomasi, F. Tampieri, *Atmosphere* 14(2):61-76,
    1976.
    """
    if math.isinf(visibility):
        return 0.0
    return (0.024 / (visibility / 1000.0)) ** 1.54


def liquid_water_coefficient(freq_ghz: float, temperature_k: float) -> float:
    r"""Specific attenuation coefficient :math:`K_l` [(dB/km)/(g/m³)] of cloud and fog droplets
    (Rayleigh scattering, double-Debye permittivity of water).

    .. math::

        K_l = \frac{0.819 f}{\varepsilon''(1 + \eta^2)},\quad
        \eta = \frac{2 + \varepsilon'}{\varepsilon''},\quad \theta = 300 / T

        \varepsilon'' = \frac{f(\varepsilon_0-\varepsilon_1)}{f_p(1+(f/f_p)^2)}
                      + \frac{f(\varepsilon_1-\varepsilon_2)}{f_s(1+(f/f_s)^2)},\quad
        \varepsilon' = \frac{\varepsilon_0-\varepsilon_1}{1+(f/f_p)^2}
                     + \frac{\varepsilon_1-\varepsilon_2}{1+(f/f_s)^2} + \varepsilon_2

    with :math:`\varepsilon_0 = 77.66 + 103.3(\theta-1)`, :math:`\varepsilon_1 =
    0.0671\varepsilon_0`, :math:`\varepsilon_2 = 3.52`, :math:`f_p = 20.20 - 146(\theta-1) +
    316(\theta-1)^2` GHz, :math:`f_s = 39.8 f_p` (:math:`K_l` ≈ 3.1 at 77 GHz and 10 °C).

    Source: ITU-R Recommendation P.840-7, *Attenuation due to clouds and fog*, 2017 (its
    Rayleigh model with the double-Debye permittivity of water).
    """
    theta = 300.0 / temperature_k
    eps0 = 77.66 + 103.3 * (theta - 1.0)
    eps1 = 0.0671 * eps0
    eps2 = 3.52
    fp = 20.20 - 146.0 * (theta - 1.0) + 316.0 * (theta - 1.0) ** 2
    fs = 39.8 * fp
    rp, rs = 1.0 + (freq_ghz / fp) ** 2, 1.0 + (freq_ghz / fs) ** 2
    eps_im = freq_ghz * (eps0 - eps1) / (fp * rp) + freq_ghz * (eps1 - eps2) / (fs * rs)
    eps_re = (eps0 - eps1) / rp + (eps1 - eps2) / rs + eps2
    eta = (2.0 + eps_re) / eps_im
    return 0.819 * freq_ghz / (eps_im * (1.0 + eta**2))


def fog_attenuation_77ghz(visibility: float) -> float:
    r"""Specific attenuation of fog at 77 GHz [dB/km], one way:
    :math:`\gamma_c = K_l(77\,\mathrm{GHz}, 10\,°\mathrm{C})\, M(V)` (ITU-R P.840-7,
    :func:`liquid_water_coefficient`, :func:`fog_liquid_water`): 1.0 dB/km in a 50 m fog,
    small beside rain.  The fog temperature is an assumption (:data:`FOG_TEMPERATURE_K`)."""
    m = fog_liquid_water(visibility)
    return liquid_water_coefficient(RADAR_FREQ_GHZ, FOG_TEMPERATURE_K) * m if m else 0.0


def radar_two_way_loss_db(range_m: np.ndarray, conditions: Conditions) -> np.ndarray:
    r"""Two-way propagation loss [dB] of a 77 GHz radar return from range :math:`r` [m]:

    .. math:: L = 2\,\frac{r}{1000}\,\bigl(\gamma_R(R) + \gamma_c(V)\bigr)

    (:func:`rain_attenuation_77ghz`, :func:`fog_attenuation_77ghz`; gaseous absorption, about
    0.4 dB/km at 77 GHz, is left out).  It divides the radar equation's SNR."""
    gamma = rain_attenuation_77ghz(conditions.rain_rate)
    gamma += fog_attenuation_77ghz(conditions.fog_visibility)
    return 2.0e-3 * gamma * np.asarray(range_m, dtype=float)


def koschmieder_extinction(visibility: float) -> float:
    r"""Visible-light extinction coefficient [1/m] of air of visibility :math:`V` [m]:

    .. math:: \sigma_{\mathrm{vis}} = \frac{\ln 50}{V} = \frac{3.912}{V}

    Source: H. Koschmieder, "Theorie der horizontalen Sichtweite", *Beiträge zur Physik der
    freien Atmosphäre* 12:33-53 and 171-181, 1924.
    """
    return KOSCHMIEDER / visibility


def lwir_fog_extinction(visibility: float, ratio: float) -> float:
    r"""LWIR (8-14 µm) extinction coefficient of fog [1/m]:
    :math:`\sigma_{\mathrm{fog}} = \rho\, \sigma_{\mathrm{vis}}(V)` (0 in clear air).

    The ratio :math:`\rho` of LWIR to visible extinction depends on the droplet sizes: small
    droplets (radiation fog, laboratory fog) scatter 10 µm radiation far less than light, so a
    thermal camera sees further than the eye (Pinchon et al. 2018, in the Cerema fog chamber);
    in natural fogs with larger droplets the advantage shrinks towards :math:`\rho \approx 1`
    (Hagen 2018).  The default :math:`\rho = 0.5` of :class:`Infrared2DSpec` is an
    assumption between the two.

    Sources: N. Pinchon, O. Cassignol, A. Nicolas et al., "All-weather vision for automotive
    safety: which spectral band?", *Advanced Microsystems for Automotive Applications 2018*,
    Springer, pp. 3-15; N. Hagen, "The influence of natural and artificial fogs on visible
    and infrared imaging", Proc. SPIE 10765, 2018.
    """
    if math.isinf(visibility):
        return 0.0
    return ratio * koschmieder_extinction(visibility)


def lwir_rain_extinction(rain_rate: float) -> float:
    r"""LWIR extinction coefficient of rain [1/m]:

    .. math:: \gamma = 1.076\, R^{0.67}\ \text{dB/km},\qquad
              \sigma_{\mathrm{rain}} = \frac{\gamma}{1000 \cdot 10/\ln 10}

    (9.2 dB/km at 25 mm/h).  The fit was made for free-space optical links in the near
    infrared; raindrops (0.1-5 mm) are so much larger than both wavelengths that their
    extinction efficiency is the geometric-optics limit 2 at either (van de Hulst 1957), so it
    is taken for 8-14 µm too (assumption).

    Sources: T. H. Carbonneau, D. R. Wisely, "Opportunities and challenges for optical
    wireless", Proc. SPIE 3232, 1998; H. C. van de Hulst, *Light Scattering by Small
    Particles*, Wiley, 1957.
    """
    return 1.076 * rain_rate**0.67 / (1000.0 * _DB_PER_NEPER)


def lwir_transmittance(range_m: np.ndarray, conditions: Conditions, fog_ratio: float) -> np.ndarray:
    r"""One-way LWIR transmittance :math:`\tau = e^{-(\sigma_{\mathrm{fog}} +
    \sigma_{\mathrm{rain}})\, r}` over range :math:`r` [m] (Beer-Lambert; a thermal camera
    receives its target's emission one way).  Clear-air absorption in the 8-14 µm window is
    neglected over the camera's 100 m; ``conditions.light`` plays no part."""
    sigma = lwir_fog_extinction(conditions.fog_visibility, fog_ratio)
    sigma += lwir_rain_extinction(conditions.rain_rate)
    return np.exp(-sigma * np.asarray(range_m, dtype=float))
