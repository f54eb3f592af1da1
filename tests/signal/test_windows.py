"""``signal.windows``: each window's impulse response (zero-padded transform of its taps) has the peak sidelobe of
the literature (Harris 1978; Cumming & Wong 2005 Table 2.3): rectangular -13.26 dB, Hamming -42.7 dB, Taylor at its
design level (-35 dB, nbar = 4); the frequency weights put the taps on the processed band only."""

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.signal.windows import Window, as_window, frequency_weights


def _pslr_db(taps):
    h = np.abs(np.fft.fft(taps, 64 * taps.size)) ** 2
    h /= h[0]
    k = np.argmax(np.diff(h) > 0)  # first minimum after the main lobe (positive frequencies)
    return 10 * np.log10(h[k:h.size // 2].max())


@pytest.mark.parametrize("spec, pslr, tol", [("none", -13.26, 0.05), ("hamming", -42.7, 0.6),
                                             (("taylor", 4, -35.0), -35.0, 0.5)])
def test_peak_sidelobe_of_each_window(spec, pslr, tol):
    taps = as_window(spec).samples(257)  # odd: the centre tap is the peak
    assert _pslr_db(taps) == pytest.approx(pslr, abs=tol)
    assert taps.max() == pytest.approx(1.0) and np.allclose(taps, taps[::-1])


def test_frequency_weights_cover_the_band_in_frequency_order():
    f = np.fft.fftfreq(64, 1 / 64.0)  # -32 .. 31 Hz, FFT order
    w = frequency_weights("hamming", f, bandwidth=40.0)
    band = np.abs(f) <= 20.0
    assert np.all(w[~band] == 0)
    order = np.argsort(f[band])
    np.testing.assert_allclose(w[band][order], Window("hamming").samples(band.sum()))
    assert np.all(frequency_weights(None, f, 40.0) == 1.0)


@pytest.mark.parametrize("spec, field", [("blackman", "window"), ({"name": "taylor", "nbar": 0}, "window.nbar"),
                                         (("taylor", 4, 3.0), r"window\[2\]"), (("kaiser", -1.0), r"window\[1\]"),
                                         (3.5, "window")])
def test_bad_specifications_name_what_the_user_wrote(spec, field):
    with pytest.raises(ConfigError, match=f"^{field}:"):
        as_window(spec)
