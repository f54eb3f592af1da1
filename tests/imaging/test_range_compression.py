"""Range compression against theory: peak at tau = 2R/c, carrier phase -4 pi R / lambda,
IRW 0.886 c/(2B), PSLR -13.26 dB, ISLR -10.11 dB (10 sidelobes), and weighted windows.
"""

import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.signal.metrics import impulse_response, interpolate_value, peak_location
from sarnav.imaging.range_compression import range_compress
from sarnav.signal.metrics import PUBLISHED_IRF
from sarnav.radar.echoes import simulate_echoes
from sarnav.radar.presets import flexsar, nav_paper_sim
from sarnav.radar.scene import point_targets

C = 299_792_458.0  # independent of sarnav.units


def _one_target(params, slant_range, n_pulses=4, speed=10.0, altitude=1000.0, amplitude=1.0):
    t = np.arange(n_pulses) / params.prf
    pos = np.column_stack([speed * t, np.zeros(n_pulses), -altitude * np.ones(n_pulses)])
    # target broadside to the mid-aperture position, on the right (east) at ground level
    east = np.sqrt(slant_range**2 - altitude**2)
    tgt = np.array([[speed * t.mean(), east, 0.0]])
    raw = simulate_echoes(params, pos, t, point_targets(tgt, amplitude))
    ranges = np.sqrt(((tgt[0] - pos) ** 2).sum(axis=1))  # independent per-pulse range
    return raw, ranges


@pytest.fixture(scope="module")
def sim_raw():
    return _one_target(nav_paper_sim(), 2100.0371)


def test_peak_at_tau_and_carrier_phase(sim_raw):
    raw, ranges = sim_raw
    p = raw.params
    rc = range_compress(raw)
    lam = C / 9.75e9
    dr = C / (2 * p.sample_rate)
    for i in range(rc.n_pulses):
        pk = peak_location(rc.data[i])[0]
        r_meas = p.near_range + pk * dr
        assert abs(r_meas - ranges[i]) < dr / 20
        v = interpolate_value(rc.data[i], pk)
        dphi = np.angle(v * np.exp(4j * np.pi * ranges[i] / lam))
        assert abs(dphi) < 1e-3
        assert abs(v) == pytest.approx(1.0, abs=0.01)  # normalised filter: peak = amplitude


def test_on_grid_sample_has_exact_carrier_phase():
    """A target exactly on a range bin: the sample there is a exp(-j 4 pi R/lambda) (no interpolation)."""
    p = nav_paper_sim(pulse_length=1.0005e-6)  # T fs not an integer: no sample on the rect edge
    k = 1000
    r0 = p.near_range + k * C / (2 * p.sample_rate)
    tgt = np.array([[0.0, r0, 0.0]])  # two pulses 2 mm apart, target abeam
    pos = np.array([[-1e-3, 0.0, 0.0], [1e-3, 0.0, 0.0]])
    raw = simulate_echoes(p, pos, np.array([0.0, 1e-2]), point_targets(tgt, 2.0 - 1.0j), pattern=False)
    rc = range_compress(raw)
    r = np.linalg.norm(tgt[0] - pos[0])
    k_exact = (r - p.near_range) / (C / (2 * p.sample_rate))
    assert abs(k_exact - k) < 1e-6
    expected = (2.0 - 1.0j) * np.exp(-4j * np.pi * r * 9.75e9 / C)
    assert rc.data[0, k] == pytest.approx(expected, abs=2e-6)
    assert np.argmax(np.abs(rc.data[0])) == k


def test_unweighted_range_irf(sim_raw):
    raw, _ = sim_raw
    p = raw.params
    rc = range_compress(raw)
    ir = impulse_response(rc.data[1])
    irw_m = ir.irw * C / (2 * p.sample_rate)
    assert irw_m == pytest.approx(0.886 * C / (2 * 500e6), rel=0.03)
    assert ir.pslr_db == pytest.approx(-13.26, abs=0.3)
    assert ir.islr_db == pytest.approx(PUBLISHED_IRF["none"]["islr10_db"], abs=0.5)


@pytest.mark.parametrize("window,key,pslr_tol", [
    ("hamming", "hamming", 0.3),
    (("taylor", 4, -35), "taylor(nbar=4,sll=-35)", 0.3),
    (("kaiser", 2.5), "kaiser(beta=2.5)", 0.3),
])
def test_weighted_range_irf_equalized(sim_raw, window, key, pslr_tol):
    """Equalised filter: output spectrum = window, so the published window figures hold."""
    raw, _ = sim_raw
    p = raw.params
    rc = range_compress(raw, window, mode="equalized")
    ir = impulse_response(rc.data[0])
    res = C / (2 * 500e6)
    pub = PUBLISHED_IRF[key]
    assert ir.irw * C / (2 * p.sample_rate) / res == pytest.approx(pub["irw_factor"], rel=0.01)
    assert ir.pslr_db == pytest.approx(pub["pslr_db"], abs=pslr_tol)
    assert abs(interpolate_value(rc.data[0], peak_location(rc.data[0]))) == pytest.approx(1.0, abs=0.01)


def test_weighted_range_irf_matched(sim_raw):
    """Matched filter + Hamming at TB = 500: broadening 1.30 within 1 %, PSLR within 1.2 dB of
    -42.7 dB (Fresnel ripple of the finite time-bandwidth chirp raises the sidelobes; docs/radar.md)."""
    raw, _ = sim_raw
    ir = impulse_response(range_compress(raw, "hamming").data[0])
    none = impulse_response(range_compress(raw, "none").data[0])
    assert ir.irw / none.irw == pytest.approx(1.306 / 0.886, rel=0.01)
    assert -42.7 - 0.3 < ir.pslr_db < -42.7 + 1.2


def test_flexsar_oversample_one():
    """fs = B (equality allowed): peak position and IRW still hold (equalised filter)."""
    p = flexsar()
    raw, ranges = _one_target(p, 2030.123, speed=60.0)
    rc = range_compress(raw, mode="equalized")
    dr = C / (2 * p.sample_rate)
    pk = peak_location(rc.data[0])[0]
    assert abs(p.near_range + pk * dr - ranges[0]) < dr / 20
    ir = impulse_response(rc.data[0])
    assert ir.irw * dr == pytest.approx(0.886 * C / (2 * 500e6), rel=0.03)
    assert ir.pslr_db == pytest.approx(-13.26, abs=0.3)


def test_window_from_params_and_metadata():
    p = nav_paper_sim(range_window="hamming")
    raw, _ = _one_target(p, 2100.0)
    rc = range_compress(raw)
    assert rc.compressed and rc.metadata["range_window"] == "hamming"
    np.testing.assert_array_equal(rc.slant_range, raw.slant_range)
    rc64 = range_compress(simulate_echoes(p, raw.positions, raw.pulse_times,
                                          point_targets([[0.0, 1800.0, 0.0]]), dtype=np.complex64))
    assert rc64.data.dtype == np.complex64
    with pytest.raises(InputDataError, match="raw.compressed"):
        range_compress(rc)
    with pytest.raises(ConfigError, match="mode"):
        range_compress(raw, mode="inverse")
    with pytest.raises(ConfigError, match="window"):
        range_compress(raw, "blackman")


def test_compressing_only_some_columns_gives_the_full_compressions_values(sim_raw):
    """``columns=(a, b)`` transforms only the samples those outputs read; they equal the whole swath's compression
    to FFT rounding, and the input cropped to ``compression_reach`` gives the same bits again (the receiver-noise
    model draws and copies only those samples)."""
    from dataclasses import replace

    from sarnav.imaging.range_compression import compression_reach

    raw, _ = sim_raw
    full = range_compress(raw).data
    n = full.shape[1]
    for a, b in ((0, 7), (n // 2 - 40, n // 2 + 41), (n - 9, n)):
        part = range_compress(raw, columns=(a, b))
        peak = np.max(np.abs(full))
        assert np.max(np.abs(part.data - full[:, a:b])) < 1e-12 * peak
        np.testing.assert_array_equal(part.slant_range, raw.slant_range[a:b])
        lo, hi = compression_reach(raw, (a, b))
        assert 0 <= lo <= a < b <= hi <= n and (lo, hi) != (0, n)
        crop = replace(raw, data=raw.data[:, lo:hi].copy(), slant_range=raw.slant_range[lo:hi])
        np.testing.assert_array_equal(range_compress(crop, columns=(a - lo, b - lo)).data, part.data)
    with pytest.raises(InputDataError, match=r"columns: must be 0 <= a < b <= \d+"):
        compression_reach(raw, (5, 5))
