"""Point-target metrics tested on analytic responses with known IRW, PSLR and ISLR.

Reference numbers are closed forms or published values (anchors-sar §3.1; Harris 1978):
uniform spectrum: IRW 0.886/B (the -3 dB half-width of sinc^2 is the root of sinc^2(x) = 1/2,
x = 0.44295), PSLR -13.26 dB (first sidelobe of sinc at x = 1.4303: 20 log10|sinc(1.4303)|),
ISLR -10.11 dB with 10 sidelobes (isce3 benchmark), -9.68 dB with all sidelobes.
"""

import numpy as np
import pytest
from scipy.optimize import brentq

from sarnav.errors import InputDataError
from sarnav.signal.data import SarImage
from sarnav.signal.metrics import (
    impulse_response,
    interpolate_value,
    irf_from_fine_cut,
    peak_location,
    point_target_metrics,
)
from sarnav.signal.metrics import PUBLISHED_IRF, irf_theory

# closed forms for sinc computed independently of the package
HALF_POWER_X = brentq(lambda x: np.sinc(x) ** 2 - 0.5, 0.1, 0.9)  # 0.44295
FIRST_SIDELOBE_X = brentq(lambda x: np.cos(np.pi * x) * np.pi * x - np.sin(np.pi * x), 1.1, 1.49)
SINC_IRW = 2 * HALF_POWER_X  # 0.8859
SINC_PSLR = 20 * np.log10(abs(np.sinc(FIRST_SIDELOBE_X)))  # -13.26


def _islr_sinc(n_sidelobes):
    """ISLR of sinc^2 with mainlobe |x|<1 and sidelobes 1<|x|<=n+1, by quadrature."""
    from scipy.integrate import quad

    main = quad(lambda x: np.sinc(x) ** 2, 0, 1)[0]
    side = sum(quad(lambda x: np.sinc(x) ** 2, k, k + 1)[0] for k in range(1, n_sidelobes + 1))
    return 10 * np.log10(side / main)


def test_closed_forms_are_the_published_ones():
    assert SINC_IRW == pytest.approx(0.886, abs=5e-4)
    assert SINC_PSLR == pytest.approx(-13.26, abs=0.01)
    assert _islr_sinc(10) == pytest.approx(-10.11, abs=0.01)


def test_fine_cut_metrics_on_sampled_sinc():
    x = np.arange(-40, 40, 1 / 64)
    ir = irf_from_fine_cut(np.sinc(x) ** 2, spacing=1 / 64, n_sidelobes=10)
    assert ir.irw == pytest.approx(SINC_IRW, rel=1e-3)
    assert ir.pslr_db == pytest.approx(SINC_PSLR, abs=0.02)
    assert ir.islr_db == pytest.approx(_islr_sinc(10), abs=0.02)
    assert ir.null_left == pytest.approx(1.0, abs=1 / 64)
    assert ir.peak == pytest.approx(40.0, abs=1e-9)


@pytest.mark.parametrize("samples_per_res", [1.25, 2.0, 3.3])
@pytest.mark.parametrize("offset", [0.0, 0.37, -0.21])
def test_1d_sinc_sampled_coarsely(samples_per_res, offset):
    """A band-limited sinc sampled at fs/B = samples_per_res: metrics in cells scale with it."""
    n = np.arange(300)
    x0 = 150 + offset
    b = 1.0 / samples_per_res  # band in cycles/sample
    sig = np.sinc(b * (n - x0)) * np.exp(1j * (0.4 + 0.3 * n))  # carrier: tests the demodulation
    ir = impulse_response(sig)
    assert ir.irw == pytest.approx(SINC_IRW * samples_per_res, rel=0.01)
    assert ir.pslr_db == pytest.approx(SINC_PSLR, abs=0.1)
    assert ir.islr_db == pytest.approx(_islr_sinc(10), abs=0.1)
    assert peak_location(sig)[0] == pytest.approx(x0, abs=0.005)
    assert ir.peak == pytest.approx(x0, abs=0.005)


def test_2d_separable_sinc_and_phase_interpolation():
    ny, nx = 160, 200
    y0, x0 = 70.37, 90.71
    by, bx = 0.5, 0.8
    phase = 0.3 + 0.02 * np.arange(nx)[None, :] - 0.05 * np.arange(ny)[:, None]
    img = np.outer(np.sinc(by * (np.arange(ny) - y0)), np.sinc(bx * (np.arange(nx) - x0))) * np.exp(1j * phase)
    pk = peak_location(img)
    assert pk[0] == pytest.approx(y0, abs=0.005)
    assert pk[1] == pytest.approx(x0, abs=0.005)
    ir0 = impulse_response(img, axis=0)
    ir1 = impulse_response(img, axis=1)
    assert ir0.irw == pytest.approx(SINC_IRW / by, rel=0.01)
    assert ir1.irw == pytest.approx(SINC_IRW / bx, rel=0.01)
    for ir in (ir0, ir1):
        assert ir.pslr_db == pytest.approx(SINC_PSLR, abs=0.1)
        assert ir.islr_db == pytest.approx(_islr_sinc(10), abs=0.1)
    v = interpolate_value(img, (y0, x0))
    expected_phase = 0.3 + 0.02 * x0 - 0.05 * y0
    assert abs(v) == pytest.approx(1.0, abs=2e-3)
    assert np.angle(v * np.exp(-1j * expected_phase)) == pytest.approx(0.0, abs=2e-3)


def test_point_target_metrics_on_sar_image_in_metres():
    ny, nx = 128, 128
    dy, dx = 0.25, 0.15
    y = 100.0 + dy * np.arange(ny)
    x = 2000.0 + dx * np.arange(nx)
    yt, xt = 100.0 + 60.3 * dy, 2000.0 + 70.6 * dx
    res_y, res_x = 1.0, 0.5  # 1/B in metres along each axis
    img = np.outer(np.sinc((y - yt) / res_y), np.sinc((x - xt) / res_x)).astype(np.complex128)
    img[10, 10] = 0.2  # a weaker neighbour far away
    out = point_target_metrics(SarImage(img, y, x))
    assert out["peak_position"][0] == pytest.approx(yt, abs=0.005 * dy)
    assert out["peak_position"][1] == pytest.approx(xt, abs=0.005 * dx)
    assert out["y"]["irw_m"] == pytest.approx(SINC_IRW * res_y, rel=0.01)
    assert out["x"]["irw_m"] == pytest.approx(SINC_IRW * res_x, rel=0.01)
    assert out["x"]["irw_cells"] == pytest.approx(SINC_IRW * res_x / dx, rel=0.01)
    assert out["y"]["pslr_db"] == pytest.approx(SINC_PSLR, abs=0.1)
    # near= selects the weaker point
    out2 = point_target_metrics(SarImage(img, y, x), near=(y[10], x[10]), search_radius=3, half_width=8,
                                n_sidelobes=None)
    assert out2["peak_index"][0] == pytest.approx(10, abs=0.2)


def test_metric_detects_a_wider_response():
    """A response of twice the width must give twice the IRW (the metric is not a constant)."""
    n = np.arange(256)
    a = impulse_response(np.sinc(0.5 * (n - 128.2)))
    b = impulse_response(np.sinc(0.25 * (n - 128.2)))
    assert b.irw / a.irw == pytest.approx(2.0, rel=0.01)


@pytest.mark.parametrize("name", ["none", "hamming", "taylor(nbar=4,sll=-35)", "taylor(nbar=5,sll=-40)",
                                  "kaiser(beta=2.5)"])
def test_window_theory_matches_published(name):
    spec = {"none": "none", "hamming": "hamming", "taylor(nbar=4,sll=-35)": ("taylor", 4, -35),
            "taylor(nbar=5,sll=-40)": ("taylor", 5, -40), "kaiser(beta=2.5)": ("kaiser", 2.5)}[name]
    pub = PUBLISHED_IRF[name]
    th = irf_theory(spec)
    assert th.irw_factor == pytest.approx(pub["irw_factor"], rel=0.006)
    assert th.pslr_db == pytest.approx(pub["pslr_db"], abs=0.15)
    th_all = irf_theory(spec, n_sidelobes=None)
    assert th_all.islr_db == pytest.approx(pub["islr_inf_db"], abs=0.35 if name == "none" else 1.0)


def test_bad_inputs():
    with pytest.raises(InputDataError, match="data"):
        peak_location(np.full((4, 4), np.nan))
    with pytest.raises(InputDataError, match="power"):
        irf_from_fine_cut(np.sinc(np.linspace(-0.3, 0.3, 50)) ** 2)  # no -3 dB crossing
    with pytest.raises(InputDataError, match="too short"):
        impulse_response(np.sinc(0.5 * (np.arange(256) - 128)), half_width=6)
