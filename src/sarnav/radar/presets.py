"""Radar presets from the sources, with documented gap fills (see docs/radar.md).

* :func:`nav_paper_sim`: simulation radar of Lindstrom et al. (NAVIGATION 69(3)) Table 3 / thesis
  Table 5.1: 9.75 GHz, 500 MHz, range over-sample 2 (fs = 1 GHz complex), PRF 100 Hz, imaged
  slant ranges 2000-2210 m.
* :func:`flexsar`: FlexSAR real-data radar, paper Table 6 / thesis Table 5.3: 9.75 GHz, 500 MHz,
  over-sample 1 (fs = B = 500 MHz, equality allowed), PRF 5000 Hz decimated to 1667 Hz, imaged
  slant ranges 1948-2112 m.
* :func:`sun_ku_cart`: Ku-band ground-cart radar of Sun (2022) §6.2: 16.6 GHz, 300 MHz, PRF 3 kHz, reflectors
  20 m away (its gap fills in the function's docstring).

Gap fills (not in the sources; thesis extraction §18, paper note §6 G7):

* pulse length T = 1 us (thesis §18 suggests 1-10 us), K = B/T = 5e14 Hz/s;
* antenna length L = 0.2 m (sim; "ideal azimuth resolution 0.1 m" = L/2) and 0.0756 m (FlexSAR;
  0.0378 m = L/2), giving -3 dB Doppler bandwidths 88.6 Hz < 100 Hz at 10 m/s and 1406 Hz < 1667 Hz
  at 60 m/s;
* right-looking (thesis §18);
* no weighting (the sources do not mention any);
* the *receive window* is the imaged interval widened by the pulse half-extent cT/4 = 75 m on both
  sides, so that every target in the imaged interval has its whole chirp in the window
  (``target_range_limits`` then equals the imaged interval, to within one bin):
  :func:`sarnav.radar.params.window_over`.
"""

from __future__ import annotations

from sarnav.radar.params import RadarParams, window_over
from sarnav.units import ghz_to_hz, mhz_to_hz, us_to_s

#: imaged slant-range intervals of the sources [m]
NAV_PAPER_SIM_RANGES = (2000.0, 2210.0)
FLEXSAR_RANGES = (1948.0, 2112.0)


def _preset(overrides: dict, imaged, pulse_length: float, sample_rate: float, fields: dict) -> RadarParams:
    """A preset's RadarParams: its ``fields``, right looking, no windows, the receive window over the ``imaged``
    slant ranges widened by cT/4 (``window_over``) for the pulse length and sample rate in force, then ``overrides``
    (which may set the window themselves)."""
    pulse_length = overrides.pop("pulse_length", pulse_length)
    sample_rate = overrides.pop("sample_rate", sample_rate)
    window = window_over(imaged, pulse_length, sample_rate)  # the imaged interval +- cT/4
    kw = dict(fields, pulse_length=pulse_length, sample_rate=sample_rate, **window, look_side="right",
              range_window="none", azimuth_window="none")
    kw.update(overrides)
    return RadarParams(**kw)


def nav_paper_sim(**overrides) -> RadarParams:
    """Simulation radar of paper Table 3 / thesis Table 5.1 (keyword arguments override fields).

    The receive window is recomputed from the imaged interval 2000-2210 m unless ``near_range`` /
    ``n_range_samples`` are overridden.
    """
    return _preset(overrides, NAV_PAPER_SIM_RANGES, us_to_s(1.0), 2.0 * mhz_to_hz(500.0),
                   dict(carrier_frequency=ghz_to_hz(9.75), bandwidth=mhz_to_hz(500.0), prf=100.0, antenna_length=0.2))


def flexsar(**overrides) -> RadarParams:
    """FlexSAR radar of paper Table 6 / thesis Table 5.3 after PRF decimation (overrides as above)."""
    return _preset(overrides, FLEXSAR_RANGES, us_to_s(1.0), mhz_to_hz(500.0),
                   dict(carrier_frequency=ghz_to_hz(9.75), bandwidth=mhz_to_hz(500.0), prf=5000.0 / 3.0,
                        antenna_length=0.0756))


#: slant ranges imaged by the ground-cart test of Sun (2022) §6.2 (reflectors 20 m from the radar, L1322) [m]
SUN_KU_CART_RANGES = (17.0, 24.0)


def sun_ku_cart(imaged: tuple[float, float] = SUN_KU_CART_RANGES, **overrides) -> RadarParams:
    """Ku-band cart radar of Sun (2022) §6.2 (L1313-1322): 16.6 GHz, LFM B = 300 MHz (range resolution c/2B =
    0.4997 m, eq. 4.4), PRF 3 kHz, no window (L1332). Not given (gap G25), chosen here: complex sampling
    fs = 2B = 600 MHz, pulse length T = 0.2 us (TB = 60), horn antennas of 0.5 rad one-way beamwidth, right
    looking; the receive window covers the ``imaged`` slant ranges widened by cT/4 (as the other presets)."""
    return _preset(overrides, tuple(imaged), us_to_s(0.2), 2.0 * mhz_to_hz(300.0),
                   dict(carrier_frequency=ghz_to_hz(16.6), bandwidth=mhz_to_hz(300.0), prf=3000.0, azimuth_beamwidth=0.5))


#: the presets by name (the vocabulary of a scenario's ``radar.preset``)
PRESETS = {"nav-paper-sim": nav_paper_sim, "flexsar": flexsar, "sun-ku-cart": sun_ku_cart}
