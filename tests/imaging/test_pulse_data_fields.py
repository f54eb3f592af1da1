"""PulseData's explicit radar fields are what image formation reads: range compression (sample rate, bandwidth,
pulse length, range window), the RDA (wavelength, azimuth window), back-projection (wavelength, bandwidth); the
RadarParams that simulated the data (``params``) is provenance only."""

from dataclasses import replace

import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.backprojection import backproject, data_oversampling
from sarnav.imaging.grid import GroundGrid
from sarnav.imaging.range_compression import range_compress
from sarnav.imaging.rda import range_doppler
from sarnav.radar.echoes import simulate_echoes
from sarnav.radar.presets import nav_paper_sim
from sarnav.radar.scene import point_targets

C = 299_792_458.0  # independent of sarnav.units


@pytest.fixture(scope="module")
def raw():
    p = nav_paper_sim()
    t = np.arange(64) / p.prf
    pos = np.column_stack([10.0 * t, np.zeros(t.size), np.full(t.size, -1000.0)])
    east = np.sqrt(2100.0**2 - 1000.0**2)
    return simulate_echoes(p, pos, t, point_targets([[10.0 * t.mean(), east, 0.0]]), pattern=False)


def test_simulate_echoes_fills_the_fields(raw):
    p = raw.params
    assert (raw.wavelength, raw.bandwidth, raw.sample_rate, raw.pulse_length) == (
        C / 9.75e9, 500e6, 1e9, 1e-6)
    assert raw.carrier_frequency == pytest.approx(9.75e9, rel=1e-15)
    assert raw.chirp_rate == pytest.approx(500e6 / 1e-6, rel=1e-15)
    assert raw.range_window == p.range_window and raw.azimuth_window == p.azimuth_window


def test_range_compression_reads_the_fields_not_params(raw):
    ref = range_compress(raw)
    alone = range_compress(replace(raw, params=None))  # no radar object: the same result, bit for bit
    np.testing.assert_array_equal(alone.data, ref.data)
    assert alone.wavelength == raw.wavelength and alone.bandwidth == raw.bandwidth  # carried on to image formation
    # the field is what is read: a wrong bandwidth mismatches the chirp rate, the compressed peak drops
    wrong = range_compress(replace(raw, bandwidth=0.5 * raw.bandwidth))
    assert np.abs(wrong.data[0]).max() < 0.8 * np.abs(ref.data[0]).max()
    # the default range window is the pulses' own
    hamming = range_compress(replace(raw, range_window="hamming"))
    np.testing.assert_array_equal(hamming.data, range_compress(raw, window="hamming").data)
    for name in ("sample_rate", "bandwidth", "pulse_length"):
        with pytest.raises(InputDataError, match=f"^raw.{name}: "):
            range_compress(replace(raw, **{name: None}))


def test_rda_reads_wavelength_and_azimuth_window(raw):
    rc = replace(range_compress(raw), params=None)
    img = range_doppler(rc, 10.0)
    assert img.metadata["wavelength"] == raw.wavelength and img.metadata["bandwidth"] == raw.bandwidth
    assert img.metadata["carrier_frequency"] == pytest.approx(9.75e9, rel=1e-15)
    np.testing.assert_array_equal(range_doppler(replace(rc, azimuth_window="hamming"), 10.0).data,
                                  range_doppler(rc, 10.0, window="hamming").data)
    with pytest.raises(InputDataError, match="^rc.wavelength: "):
        range_doppler(replace(rc, wavelength=None), 10.0)
    # a wrong wavelength defocuses: the azimuth matched filter's FM rate 2V^2/(lambda R) is read from the field
    blur = range_doppler(replace(rc, wavelength=2.0 * rc.wavelength), 10.0)
    assert np.abs(blur.data).max() < 0.8 * np.abs(img.data).max()


def test_backprojection_reads_wavelength_and_bandwidth(raw):
    rc = replace(range_compress(raw), params=None)
    dr = float(rc.slant_range[1] - rc.slant_range[0])
    assert data_oversampling(rc) == pytest.approx(C / (2 * dr) / 500e6, rel=1e-12)  # fs / B from the field
    assert data_oversampling(replace(rc, bandwidth=250e6)) == pytest.approx(C / (2 * dr) / 250e6, rel=1e-12)
    east = np.sqrt(2100.0**2 - 1000.0**2)
    grid = GroundGrid.centered(10.0 * rc.pulse_times.mean(), east, 0.05, (32, 32))
    img = backproject(rc, grid, interpolation="linear")
    assert img.metadata["wavelength"] == raw.wavelength
    # focused on the target (the grid's centre); without a wavelength back-projection refuses
    assert np.abs(img.data).max() == pytest.approx(np.abs(img.data[14:18, 14:18]).max())
    with pytest.raises(ConfigError, match="^wavelength: "):
        backproject(replace(rc, wavelength=None), grid, interpolation="linear")
