"""Raw echo simulator against an independent evaluation of the signal model, the two-way pattern,
the look side, the noise power and input errors."""

import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.signal.metrics import interpolate_value, peak_location
from sarnav.imaging.range_compression import range_compress
from sarnav.radar.echoes import add_receiver_noise, simulate_echoes
from sarnav.radar.presets import nav_paper_sim
from sarnav.radar.scene import Scene, point_targets

C = 299_792_458.0


def _track(p, n=6, speed=10.0, altitude=1000.0):
    t = np.arange(n) / p.prf
    return np.column_stack([speed * t, np.zeros(n), -altitude * np.ones(n)]), t


def _direct_model(p, pos, targets, amps, gains):
    """s(t) = a G rect((t-tau)/T) exp(-j4pi fc R/c) exp(j pi K (t-tau)^2), evaluated with numpy."""
    t = 2 * p.near_range / C + np.arange(p.n_range_samples) / p.sample_rate
    out = np.zeros((pos.shape[0], t.size), complex)
    for i, x in enumerate(pos):
        for k, y in enumerate(targets):
            r = np.sqrt(((y - x) ** 2).sum())
            dt = t - 2 * r / C
            out[i] += np.where(np.abs(dt) <= p.pulse_length / 2,
                               amps[k] * gains[i, k] * np.exp(-4j * np.pi * 9.75e9 * r / C)
                               * np.exp(1j * np.pi * (500e6 / p.pulse_length) * dt**2), 0)
    return out


def test_matches_direct_model_without_pattern():
    p = nav_paper_sim(pulse_length=0.3e-6)
    pos, t = _track(p, n=3)
    tg = np.array([[0.3, 1800.0, 0.0], [-2.0, 1850.0, 5.0], [1.0, 1900.0, -3.0]])
    amps = np.array([1.0, 0.5j, -0.2 + 0.1j])
    raw = simulate_echoes(p, pos, t, point_targets(tg, amps), pattern=False)
    ref = _direct_model(p, pos, tg, amps, np.ones((3, 3)))
    assert raw.data.dtype == np.complex128 and not raw.compressed
    np.testing.assert_allclose(raw.data, ref, atol=1e-9)


def test_two_way_pattern_attenuation():
    """Target at azimuth angle theta off boresight: echo amplitude sinc^2(L sin(theta)/lambda)."""
    p = nav_paper_sim()
    pos, t = _track(p, n=5)
    mid = pos[2]
    lam = C / 9.75e9
    ground = 1900.0
    r_b = np.hypot(ground, 1000.0)
    thetas = [0.0, 0.5 * p.beamwidth, 0.04]
    for th in thetas:
        along = r_b * np.tan(th)
        tgt = np.array([[mid[0] + along, ground, 0.0]])
        raw = simulate_echoes(p, pos, t, point_targets(tgt))
        d = tgt[0] - mid
        sin_th = d[0] / np.linalg.norm(d)
        expected = np.sinc(0.2 * sin_th / lam) ** 2
        rc = range_compress(raw).data[2]
        peak = abs(interpolate_value(rc, peak_location(rc)))  # normalised filter: peak = a G
        assert peak == pytest.approx(expected, rel=0.005)
        # raw sample magnitude is exactly the gain (constant-envelope chirp)
        nz = np.abs(raw.data[2])[np.abs(raw.data[2]) > 0]
        np.testing.assert_allclose(nz, expected, rtol=1e-9)
    # half-beamwidth: one-way -3 dB means two-way amplitude 0.5 (-6 dB)
    d = np.array([r_b * np.tan(0.5 * p.beamwidth), ground, 1000.0])
    assert np.sinc(0.2 * d[0] / np.linalg.norm(d) / lam) ** 2 == pytest.approx(0.5, abs=0.01)


def test_look_side():
    p_right = nav_paper_sim()
    p_left = nav_paper_sim(look_side="left")
    pos, t = _track(p_right, n=4)
    right = point_targets([[0.0, 1800.0, 0.0]])  # flying north, east is on the right
    left = point_targets([[0.0, -1800.0, 0.0]])
    assert np.abs(simulate_echoes(p_right, pos, t, right).data).max() > 0.99
    assert np.abs(simulate_echoes(p_right, pos, t, left).data).max() == 0.0
    assert np.abs(simulate_echoes(p_left, pos, t, left).data).max() > 0.99
    assert np.abs(simulate_echoes(p_left, pos, t, right).data).max() == 0.0
    # flying east: the right side is south (look direction from the trajectory, not fixed axes)
    east_track = pos[:, [1, 0, 2]]
    south = point_targets([[-1800.0, 0.0, 0.0]])
    north = point_targets([[1800.0, 0.0, 0.0]])
    assert np.abs(simulate_echoes(p_right, east_track, t, south).data).max() > 0.99
    assert np.abs(simulate_echoes(p_right, east_track, t, north).data).max() == 0.0


def test_noise_power_and_reproducibility():
    p = nav_paper_sim()
    pos, t = _track(p, n=40)
    sc = point_targets([[1.0, 1850.0, 0.0], [2.0, 1900.0, 0.0]], [2.0, 0.5])
    snr_db = 7.0
    clean = simulate_echoes(p, pos, t, sc)
    a = simulate_echoes(p, pos, t, sc, snr_db=snr_db, rng=np.random.default_rng(np.random.SeedSequence(5)))
    b = simulate_echoes(p, pos, t, sc, snr_db=snr_db, rng=np.random.default_rng(np.random.SeedSequence(5)))
    np.testing.assert_array_equal(a.data, b.data)
    n = (a.data - clean.data).ravel()
    sigma2 = 2.0**2 / 10 ** (snr_db / 10)  # strongest target |a|^2 = 4
    se = sigma2 / np.sqrt(n.size)  # |n|^2 is exponential: std = mean
    assert abs(np.mean(np.abs(n) ** 2) - sigma2) < 4 * se
    assert abs(np.mean(n.real**2) - sigma2 / 2) < 4 * sigma2 / 2 * np.sqrt(2 / n.size)
    assert abs(np.mean(n)) < 4 * np.sqrt(sigma2 / n.size)
    assert a.metadata["noise_power"] == pytest.approx(sigma2)
    # compressed noise power: sigma^2 / M for the normalised unweighted matched filter
    m = 2 * int(np.floor(p.pulse_length * p.sample_rate / 2)) + 1
    rc_noise = range_compress(a).data - range_compress(clean).data
    inner = rc_noise[:, m:-m].ravel()  # away from the edges of the window
    assert np.mean(np.abs(inner) ** 2) == pytest.approx(sigma2 / m, rel=0.1)


def test_add_receiver_noise_is_a_second_acquisition_of_the_same_echoes():
    p = nav_paper_sim()
    pos, t = _track(p, n=40)
    sc = point_targets([[1.0, 1850.0, 0.0], [2.0, 1900.0, 0.0]], [2.0, 0.5])
    clean = simulate_echoes(p, pos, t, sc)
    before = clean.data.copy()
    # same generator state -> exactly what simulate_echoes adds (amplitude 2 = the strongest scatterer)
    a = add_receiver_noise(clean, 2.0, 7.0, np.random.default_rng(np.random.SeedSequence(5)))
    ref = simulate_echoes(p, pos, t, sc, snr_db=7.0, rng=np.random.default_rng(np.random.SeedSequence(5)))
    np.testing.assert_array_equal(a.data, ref.data)
    assert a.metadata["noise_power"] == ref.metadata["noise_power"]
    np.testing.assert_array_equal(clean.data, before)  # the clean echoes are not modified
    # a second acquisition: independent noise of the same power (the correlation of the two noises ~ 0)
    b = add_receiver_noise(clean, 2.0, 7.0, np.random.default_rng(np.random.SeedSequence(6)))
    na, nb = (a.data - clean.data).ravel(), (b.data - clean.data).ravel()
    rho = abs(np.vdot(na, nb)) / np.sqrt(np.vdot(na, na).real * np.vdot(nb, nb).real)
    assert rho < 4 / np.sqrt(na.size)
    # the SNR refers to the given amplitude: 0.5 at 7 dB is 16x less noise power than 2.0 at 7 dB
    c = add_receiver_noise(clean, 0.5, 7.0, np.random.default_rng(1))
    assert c.metadata["noise_power"] == pytest.approx(ref.metadata["noise_power"] / 16)
    with pytest.raises(ConfigError, match="^snr_db"):
        add_receiver_noise(clean, 2.0, np.inf, np.random.default_rng(0))
    with pytest.raises(ConfigError, match="^amplitude"):
        add_receiver_noise(clean, 0.0, 7.0, np.random.default_rng(0))
    with pytest.raises(ConfigError, match="^rng"):
        add_receiver_noise(clean, 2.0, 7.0, None)
    with pytest.raises(InputDataError, match="^raw"):
        add_receiver_noise(range_compress(clean), 2.0, 7.0, np.random.default_rng(0))


def test_complex64_output():
    p = nav_paper_sim()
    pos, t = _track(p)
    sc = point_targets([[0.0, 1800.0, 0.0]])
    a = simulate_echoes(p, pos, t, sc, dtype=np.complex64)
    b = simulate_echoes(p, pos, t, sc)
    assert a.data.dtype == np.complex64
    np.testing.assert_allclose(a.data, b.data, atol=1e-6)


def test_target_outside_window_raises():
    p = nav_paper_sim()
    pos, t = _track(p)
    lo, hi = p.target_range_limits
    ground_far = np.sqrt((hi + 1.0) ** 2 - 1000.0**2)
    with pytest.raises(ConfigError, match="^near_range"):
        simulate_echoes(p, pos, t, point_targets([[0.0, ground_far, 0.0]]))
    ground_near = np.sqrt((lo - 0.5) ** 2 - 1000.0**2)
    with pytest.raises(ConfigError, match="receive window"):
        simulate_echoes(p, pos, t, point_targets([[0.0, ground_near, 0.0]]))


def test_prf_below_doppler_bandwidth_raises():
    p = nav_paper_sim()  # B_D = 88.5 Hz at 10 m/s
    pos, t = _track(p, speed=12.0)  # B_D = 106 Hz > 100 Hz
    with pytest.raises(ConfigError, match="^prf: must be >= the Doppler bandwidth"):
        simulate_echoes(p, pos, t, point_targets([[0.0, 1800.0, 0.0]]))


def test_bad_arrays():
    p = nav_paper_sim()
    pos, t = _track(p)
    sc = point_targets([[0.0, 1800.0, 0.0]])
    with pytest.raises(InputDataError, match="^positions"):
        simulate_echoes(p, pos[:, :2], t, sc)
    bad = pos.copy()
    bad[1, 0] = np.nan
    with pytest.raises(InputDataError, match="^positions: contains NaN"):
        simulate_echoes(p, bad, t, sc)
    with pytest.raises(InputDataError, match="^pulse_times"):
        simulate_echoes(p, pos, t[:-1], sc)
    with pytest.raises(InputDataError, match="^pulse_times: must be strictly increasing"):
        simulate_echoes(p, pos, t[::-1], sc)
    with pytest.raises(InputDataError, match="^scene"):
        simulate_echoes(p, pos, t, np.zeros((1, 3)))
    with pytest.raises(ConfigError, match="^rng"):
        simulate_echoes(p, pos, t, sc, snr_db=10.0)
    with pytest.raises(ConfigError, match="^snr_db"):
        simulate_echoes(p, pos, t, sc, snr_db=np.nan, rng=np.random.default_rng(0))
    with pytest.raises(InputDataError, match="^scene.positions"):
        Scene(np.zeros((2, 2)), np.ones(2))


def test_empty_scene_gives_zeros():
    p = nav_paper_sim()
    pos, t = _track(p)
    raw = simulate_echoes(p, pos, t, Scene(np.zeros((0, 3)), np.zeros(0)))
    assert raw.data.shape == (pos.shape[0], p.n_range_samples)
    assert not np.any(raw.data)
