"""Phase history (CPHD convention) <-> range-compressed pulses on one absolute range axis."""

from __future__ import annotations

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.signal.data import PulseData
from sarnav.signal.phase_history import PhaseHistory, phase_history_to_pulses, pulses_to_phase_history

C = 299792458.0
LAM = C / 9.75e9


def _random_pulses(rng, p=32, n=200):
    r = 2000.0 + np.arange(n) * 0.8
    pos = rng.normal(0.0, 100.0, (p, 3))
    data = rng.standard_normal((p, n)) + 1j * rng.standard_normal((p, n))
    return PulseData(data, r, np.arange(p) * 1e-3, pos, None, compressed=True, wavelength=LAM)


def test_round_trip_is_exact_on_the_original_axis_with_per_pulse_reference_ranges():
    rng = np.random.default_rng(np.random.SeedSequence(11))
    rc = _random_pulses(rng)
    rref = 2080.0 + rng.uniform(-50.0, 50.0, rc.n_pulses)          # a different reference per pulse
    ph = pulses_to_phase_history(rc, rref)
    assert ph.data.shape[1] >= 1.2 * rc.data.shape[1]               # CPHD FX oversampling >= 1.2
    back = phase_history_to_pulses(ph, rc.slant_range, wavelength=LAM)
    assert np.max(np.abs(back.data - rc.data)) < 1e-8 * np.max(np.abs(rc.data))
    default = phase_history_to_pulses(ph)                  # default axis: the original one sampled 4x as finely
    np.testing.assert_allclose(default.slant_range[::4], rc.slant_range, rtol=0, atol=1e-9)
    assert default.slant_range.size == 4 * (rc.slant_range.size - 1) + 1
    assert np.max(np.abs(default.data[:, ::4] - rc.data)) < 1e-8 * np.max(np.abs(rc.data))
    assert default.params is None and default.carrier_wavelength == pytest.approx(LAM, rel=1e-12)


@pytest.mark.parametrize("sgn", [-1, 1])
def test_point_target_peaks_at_its_range_with_phase_minus_4pi_r_over_lambda(sgn):
    """Independent model: S_k(f) = exp(j 2 pi SGN f 2 (R - R_ref)/c) (CPHD signal model)."""
    rng = np.random.default_rng(np.random.SeedSequence(5))
    p, n, df = 16, 256, 0.5e6
    fx0 = 9.75e9 - 0.5 * (n - 1) * df
    pos = rng.normal(0.0, 50.0, (p, 3))
    rref = 5000.0 + rng.uniform(-30, 30, p)
    r_t = rref + rng.uniform(-20, 20, p)
    f = fx0 + np.arange(n) * df
    s = np.exp(2j * np.pi * sgn * f[None, :] * 2.0 * (r_t - rref)[:, None] / C)
    ph = PhaseHistory(s, fx0, df, pos, rref, np.arange(p) * 1e-3, None, sgn)
    axis = 4900.0 + np.arange(4000) * 0.05
    rc = phase_history_to_pulses(ph, axis, wavelength=LAM)
    for k in range(p):
        i = int(np.argmax(np.abs(rc.data[k])))
        assert abs(axis[i] - r_t[k]) <= 0.5 * 0.05 + 1e-9
        # the band is symmetric about c / lambda, so the response is real: phase exactly -4 pi R / lambda
        assert abs(np.angle(rc.data[k, i] * np.exp(4j * np.pi * r_t[k] / LAM))) < 1e-6


def test_bad_input_named_errors():
    rng = np.random.default_rng(np.random.SeedSequence(3))
    rc = _random_pulses(rng, p=4, n=32)
    ph = pulses_to_phase_history(rc, np.full(4, 2010.0))
    with pytest.raises(InputDataError, match="^phase_history.data: .*shorter than the filter"):
        phase_history_to_pulses(ph, filter=np.ones(ph.data.shape[1] + 5))
    bad = ph.positions.copy()
    bad[1, 2] = np.nan
    with pytest.raises(InputDataError, match="^phase_history.positions"):
        PhaseHistory(ph.data, ph.fx0, ph.fx_step, bad, ph.ref_range, ph.pulse_times, ph.toa)
    with pytest.raises(InputDataError, match="^range_axis"):
        phase_history_to_pulses(ph, np.array([1.0, 2.0, 2.5]))


@pytest.mark.parametrize("shape", [(), (7,), (100, 2458), (3, 4, 5)])
def test_frac_phase_is_exp_of_the_fractional_cycles(shape):
    """The numba twiddle equals numpy's exp(j 2 pi (c - round(c))) to rounding (the formula it replaced), for any
    shape, cycles of any size (the pre-twiddle's reach 1e4 cycles) and a non-contiguous input."""
    from sarnav.signal.phase_history import _frac_phase

    c = np.random.default_rng(3).uniform(-2e4, 2e4, shape)
    want = np.exp(2j * np.pi * (c - np.round(c)))
    got = _frac_phase(c)
    assert got.shape == np.shape(c) and got.dtype == np.complex128
    np.testing.assert_allclose(got, want, rtol=0, atol=4e-16)
    if c.ndim == 2:
        np.testing.assert_allclose(_frac_phase(c.T), want.T, rtol=0, atol=4e-16)


def test_ramp_multiply_is_x_times_the_exp_of_its_linear_phase():
    """The blocked ramp twiddle equals x exp(j 2 pi frac(a_k + b_k j)) of every sample (numpy) to the rounding of the
    cycles (ramps to 1e3 cycles: ~1e-12 relative), for lengths that are not a multiple of the block, and in place."""
    from sarnav.signal.phase_history import RAMP_BLOCK, _ramp_multiply

    rng = np.random.default_rng(5)
    for cols in (1, RAMP_BLOCK - 1, RAMP_BLOCK, 3 * RAMP_BLOCK + 7, 2458):
        x = rng.standard_normal((6, cols)) + 1j * rng.standard_normal((6, cols))
        a, b = rng.uniform(-1e3, 1e3, 6), rng.uniform(-0.4, 0.4, 6)
        c = a[:, None] + b[:, None] * np.arange(cols)
        want = x * np.exp(2j * np.pi * (c - np.round(c)))
        np.testing.assert_allclose(_ramp_multiply(x, a, b), want, rtol=0, atol=2e-11 * np.abs(x).max())
        y = x.copy()
        assert _ramp_multiply(y, a, b, out=y) is y
        np.testing.assert_allclose(y, want, rtol=0, atol=2e-11 * np.abs(x).max())


@pytest.mark.parametrize("n, lattice, m", [(60, 64, 50), (60, 64, 150), (64, 64, 64), (45, 48, 20)])
def test_chirp_z_on_a_dft_lattice_is_the_exact_sum(n, lattice, m, monkeypatch):
    """On alpha = 1/L (L >= N, FFT-friendly) ``_chirp_z`` takes one inverse FFT of L samples, periodic in k beyond L:
    equal to the direct float64 sum sum_n x_n exp(j 2 pi n k / L) to 1e-12, and to scipy's chirp-z, which it must not
    call; off the lattice (alpha (1 + 1e-6)) it is the chirp-z, again the exact sum."""
    import scipy.signal as ssig

    from sarnav.signal import phase_history as P

    rng = np.random.default_rng(11)
    x = rng.standard_normal((3, n)) + 1j * rng.standard_normal((3, n))
    k = np.arange(m)

    def exact(alpha):
        return x @ np.exp(2j * np.pi * alpha * np.outer(np.arange(n), k))

    want = exact(1.0 / lattice)
    czt_calls, czt = [], ssig.czt
    monkeypatch.setattr(P.ssig, "czt", lambda *a, **kw: czt_calls.append(1) or czt(*a, **kw))
    got = P._chirp_z(x, m, 1.0 / lattice)
    assert not czt_calls and got.shape == (3, m)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())
    off = 1.0 / lattice * (1.0 + 1e-6)
    np.testing.assert_allclose(P._chirp_z(x, m, off), exact(off), rtol=0, atol=1e-11 * np.abs(want).max())
    assert czt_calls  # the phase it would miss, 2 pi 1e-6 (N - 1)(m - 1) / L, is over the tolerance


def test_chirp_z_refuses_the_lattice_shortcut_below_n_or_on_a_slow_length():
    """L < N (the sum would alias), an L that is not FFT-friendly (a large prime) and an L longer than the chirp-z's
    own FFT (a fine axis over a short window: its memory would grow with L) go through the chirp-z."""
    from sarnav.signal import phase_history as P

    rng = np.random.default_rng(12)
    for n, lattice in ((80, 64), (100, 1009), (50, 2**20)):  # the last: a period far longer than N + m - 1
        x = rng.standard_normal((2, n)) + 1j * rng.standard_normal((2, n))
        want = x @ np.exp(2j * np.pi / lattice * np.outer(np.arange(n), np.arange(40)))
        np.testing.assert_allclose(P._chirp_z(x, 40, 1.0 / lattice), want, rtol=0, atol=1e-11 * np.abs(want).max())


@pytest.mark.parametrize("lattice", [True, False])
def test_a_file_read_on_its_own_axis_takes_the_lattice_and_returns_its_samples(lattice, monkeypatch):
    """``pulses_to_phase_history`` then ``phase_history_to_pulses`` on the same axis (how a recording's apertures are
    read) goes through the inverse FFT, never the chirp-z, and returns the original samples to 1e-9 (the floor is
    the twiddles' rounding of ~1e5 cycles: 1.2e-10 measured); with the shortcut disabled (tolerance -1) it is the
    chirp-z, held to the same original data."""
    import scipy.signal as ssig

    from sarnav.signal import phase_history as P

    rng = np.random.default_rng(np.random.SeedSequence(13))
    rc = _random_pulses(rng)
    ph = pulses_to_phase_history(rc, 2080.0 + rng.uniform(-50.0, 50.0, rc.n_pulses))
    calls, czt = [], ssig.czt
    monkeypatch.setattr(P.ssig, "czt", lambda *a, **kw: calls.append(1) or czt(*a, **kw))
    if not lattice:
        monkeypatch.setattr(P, "LATTICE_PHASE_TOLERANCE", -1.0)
    back = phase_history_to_pulses(ph, rc.slant_range, wavelength=LAM)
    assert bool(calls) is not lattice
    assert np.max(np.abs(back.data - rc.data)) < 1e-9 * np.max(np.abs(rc.data))

