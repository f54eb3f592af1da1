"""The signal containers (``sarnav.signal.data``): the radar fields a ``PulseData`` derives, re-referencing to other
antenna positions, and the axes of a ``SarImage``."""

from __future__ import annotations

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.signal.data import PulseData, SarImage

C = 299_792_458.0


def _pulses(**kw):
    rng = np.random.default_rng(1)
    data = rng.standard_normal((4, 6)) + 1j * rng.standard_normal((4, 6))
    return PulseData(data, 1000.0 + 0.75 * np.arange(6), np.arange(4) / 100.0, rng.normal(0, 5, (4, 3)), **kw)


def test_derived_radar_fields_follow_their_definitions():
    """f_c = c / lambda, K = B / T, the range spacing and the pulse count; None where a field is missing."""
    pd = _pulses(wavelength=0.03, bandwidth=150e6, pulse_length=2e-6)
    assert pd.carrier_frequency == pytest.approx(C / 0.03, rel=1e-15)
    assert pd.chirp_rate == pytest.approx(150e6 / 2e-6, rel=1e-15)
    assert pd.range_spacing == pytest.approx(0.75) and pd.n_pulses == 4
    bare = _pulses()
    assert bare.carrier_frequency is None and bare.carrier_wavelength is None and bare.chirp_rate is None
    assert _pulses(bandwidth=1e6).chirp_rate is None


def test_with_positions_keeps_the_data_and_checks_the_new_track():
    """Re-referencing changes the positions only (a navigation estimate); a wrong shape or a NaN is refused."""
    pd = _pulses(wavelength=0.03)
    new = pd.positions + 0.5
    moved = pd.with_positions(new)
    assert np.array_equal(moved.positions, new) and moved.data is pd.data and moved.wavelength == 0.03
    assert not np.array_equal(pd.positions, new)  # the original is untouched
    with pytest.raises(InputDataError, match="positions"):
        pd.with_positions(new[:3])
    bad = new.copy()
    bad[2, 1] = np.nan
    with pytest.raises(InputDataError, match="finite"):
        pd.with_positions(bad)


def test_sar_image_axes():
    """Pixel spacings are the axes' steps and the shape is the data's."""
    img = SarImage(np.zeros((3, 5), complex), 2.0 + 0.25 * np.arange(3), -1.0 + 0.5 * np.arange(5))
    assert img.dy == pytest.approx(0.25) and img.dx == pytest.approx(0.5) and img.shape == (3, 5)
    assert (img.y_name, img.x_name) == ("along_track", "slant_range")
