"""sarnav.units against values known independently of the code (definitions, datasheet arithmetic)."""

import math

import numpy as np
import pytest

from sarnav import units


def test_constants_are_the_definitions():
    assert units.C == 299_792_458.0  # exact by the SI definition of the metre
    assert units.G0 == 9.81  # the sources' g (thesis Table A.5), not 9.80665
    assert units.DEG == math.pi / 180 and units.HOUR == 3600.0


@pytest.mark.parametrize("fn, x, si", [
    (units.deg_to_rad, 180.0, math.pi),
    (units.rad_to_deg, math.pi / 2, 90.0),
    # 1 deg/hr = 4.8481e-6 rad/s (the usual gyro-bias conversion)
    (units.deg_per_hr_to_rad_per_s, 1.0, 4.84813681109536e-06),
    (units.rad_per_s_to_deg_per_hr, 4.84813681109536e-06, 1.0),
    # 1 deg/sqrt(hr) = pi/180/60 rad/sqrt(s) = 2.9089e-4
    (units.deg_per_sqrt_hr_to_rad_per_sqrt_s, 1.0, 2.908882086657216e-04),
    # 0.06 m/s/sqrt(hr) (tactical VRW, Table 3.2) = 0.001 m/s/sqrt(s)
    (units.m_per_s_per_sqrt_hr_to_si, 0.06, 0.001),
    (units.g_to_m_per_s2, 0.001, 0.00981),
    (units.milli_g_to_m_per_s2, 1.0, 0.00981),
    (units.micro_g_to_m_per_s2, 100.0, 0.000981),
    (units.ppm_to_ratio, 250.0, 2.5e-4),
    (units.three_sigma_to_sigma, 0.6, 0.2),
    (units.ghz_to_hz, 9.75, 9.75e9),
    (units.mhz_to_hz, 500.0, 5e8),
    (units.us_to_s, 0.2, 2e-7),
    (units.hpa_to_m, 0.4 / 3, 1.28),  # extraction seed-000 §5.2
    (units.db_to_power, 30.0, 1000.0),
    (units.power_to_db, 0.01, -20.0),
    (units.amplitude_to_db, -10.0, 20.0),  # |x|
])
def test_conversions_against_known_values(fn, x, si):
    assert float(fn(x)) == pytest.approx(si, rel=1e-12)


def test_conversions_work_on_arrays_and_invert():
    x = np.array([0.1, 1.0, 10.0])
    np.testing.assert_allclose(units.rad_to_deg(units.deg_to_rad(x)), x, rtol=1e-15)
    np.testing.assert_allclose(units.rad_per_s_to_deg_per_hr(units.deg_per_hr_to_rad_per_s(x)), x, rtol=1e-15)
    np.testing.assert_allclose(units.power_to_db(units.db_to_power(x)), x, rtol=1e-14)
    assert units.g_to_m_per_s2(1.0, g=9.80665) == 9.80665  # another g when a source uses it
