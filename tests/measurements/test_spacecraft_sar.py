"""Spacecraft SAR measurement (measurements.spacecraft; paper eqs. 16-34; claims T3, T4; gaps G8, G10)."""

import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.filters.mekf import reset
from sarnav.frames.earth import ecef_to_geodetic
from sarnav.ins.orbital import OrbitalNavState
from sarnav.measurements.spacecraft import (CenterPixelMeasurement, SarMeasurementNoise, boresight_intersection,
                                            simulate_image)
from sarnav.rotations import quat_normalize, rotvec_to_quat
from sarnav.trajectory.orbit import antenna_dcm, initial_ecef_state, lvlh_dcm, table2_elements

RNG = np.random.default_rng(21)
T_BS = antenna_dcm(math.radians(34.3))


@pytest.fixture(scope="module")
def scene():
    r, v = initial_ecef_state(table2_elements())
    truth = OrbitalNavState(r[None], v[None], np.array([[1.0, 0, 0, 0]]))
    return truth, lvlh_dcm(r, v)


def test_boresight_hits_houston_on_the_ellipsoid(scene):
    """G1 geometry (extraction §6): boresight at 31.0 N, 95.0 W, slant range ~861 km; h = 0 on WGS-84."""
    truth, T_eb = scene
    r_f = boresight_intersection(truth.r, (T_BS @ T_eb)[None])
    lat, lon, h = ecef_to_geodetic(r_f)
    assert abs(h[0]) < 1e-3
    assert math.degrees(lat[0]) == pytest.approx(31.0, abs=0.1) and math.degrees(lon[0]) == pytest.approx(-95.0, abs=0.15)
    assert np.linalg.norm(r_f - truth.r) == pytest.approx(861e3, rel=0.01)
    meas = CenterPixelMeasurement(T_eb, T_BS, r_f, SarMeasurementNoise())
    assert np.allclose(meas.predict(truth).z_hat[0, :2], 0.0, atol=1e-15)  # on the boresight: angles are zero


def test_look_that_misses_the_earth_is_a_config_error(scene):
    truth, T_eb = scene
    with pytest.raises(ConfigError, match=r"^antenna\.look_angle_deg: "):  # the user's key
        boresight_intersection(truth.r, (antenna_dcm(math.radians(70.0)) @ T_eb)[None])


def _perturbed_estimate(truth):
    q = quat_normalize(rotvec_to_quat(np.radians([0.1, -0.08, 0.05])))[None]
    return OrbitalNavState(truth.r + [[800.0, -600.0, 900.0]], truth.v + [[5.0, -8.0, 3.0]], q)


def test_t3_jacobian_against_central_differences(scene):
    truth, T_eb = scene
    r_f = boresight_intersection(truth.r, (T_BS @ T_eb)[None]) + [[12.0, -7.0, 4.0]]
    meas = CenterPixelMeasurement(T_eb, T_BS, r_f, SarMeasurementNoise())
    est = _perturbed_estimate(truth)
    z0, H, Ht = meas.jacobians(est)
    assert np.all(np.abs(z0[0, :2]) > 1e-4)  # a generic point: the angle rows are not trivially zero
    steps = [1.0] * 3 + [1e-2] * 3 + [1e-6] * 3
    H_num = np.zeros((4, 9))
    for j, h in enumerate(steps):
        e = np.zeros((1, 9))
        e[0, j] = h
        H_num[:, j] = (meas.predict(reset(est, e)).z_hat - meas.predict(reset(est, -e)).z_hat)[0] / (2 * h)
    for block in (slice(0, 3), slice(3, 6), slice(6, 9)):  # T3: rel. err <~ 1e-6 per row and block
        ref = np.abs(H[0, :, block]).max(axis=1)
        err = np.abs(H_num[:, block] - H[0, :, block]).max(axis=1)
        assert np.all(err <= 1e-6 * ref + 1e-14), (block, err, ref)
    # H~ = dh/dr_f by central differences, and T4: H~ = -[H_r; 0]
    Ht_num = np.zeros((4, 3))
    for j in range(3):
        e = np.zeros(3)
        e[j] = 1.0
        plus = CenterPixelMeasurement(T_eb, T_BS, r_f + e, meas.noise).predict(est).z_hat
        minus = CenterPixelMeasurement(T_eb, T_BS, r_f - e, meas.noise).predict(est).z_hat
        Ht_num[:, j] = (plus - minus)[0] / 2.0
    assert np.allclose(Ht_num, Ht[0], rtol=1e-6, atol=1e-15)
    assert np.array_equal(Ht[0, :3], -H[0, :3, :3]) and np.all(Ht[0, 3] == 0)


def test_geolocation_covariance_maps_into_B(scene):
    truth, T_eb = scene
    noise = SarMeasurementNoise(D=np.diag([4.0, 9.0, 16.0]))
    r_f = boresight_intersection(truth.r, (T_BS @ T_eb)[None])
    meas = CenterPixelMeasurement(T_eb, T_BS, r_f, noise)
    pred = meas.predict(truth)
    _, _, Ht = meas.jacobians(truth)
    assert np.allclose(pred.R[0], noise.R + Ht[0] @ noise.D @ Ht[0].T)
    # the angle noise is all geolocation: sigma_tan ~ sqrt(D) / slant range
    M = T_BS @ T_eb
    rho = np.linalg.norm(r_f - truth.r)
    assert math.sqrt(pred.R[0, 0, 0]) == pytest.approx(math.sqrt(M[0] @ noise.D @ M[0]) / rho, rel=1e-9)
    assert math.sqrt(pred.R[0, 1, 1]) == pytest.approx(math.sqrt(M[1] @ noise.D @ M[1]) / rho, rel=1e-9)
    assert pred.R[0, 3, 3] == pytest.approx(0.54**2) and np.all(np.linalg.eigvalsh(pred.R[0]) > 0)


def test_simulated_measurement_statistics(scene):
    """Open loop (L484): y = [0, 0, rho + N(0, 1), |v| + N(0, 0.54^2)], r_f,geo - r_f ~ N(0, D)."""
    truth, T_eb = scene
    n = 4000
    many = OrbitalNavState(np.repeat(truth.r, n, 0), np.repeat(truth.v, n, 0), np.tile([1.0, 0, 0, 0], (n, 1)))
    noise = SarMeasurementNoise(D=np.array([[25.0, 5.0, 0.0], [5.0, 16.0, 0.0], [0.0, 0.0, 4.0]]))
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(5).spawn(n)]
    meas, y, r_f = simulate_image(many, T_eb, T_BS, noise, rngs)
    geo = meas.r_f - r_f
    C = np.cov(geo.T)
    assert np.allclose(C, noise.D, atol=4 * 25.0 * math.sqrt(2 / n) + 0.5)
    rho = np.linalg.norm(r_f - many.r, axis=1)
    assert np.all(y[:, :2] == 0.0)
    assert np.std(y[:, 2] - rho) == pytest.approx(1.0, rel=0.05) and abs(np.mean(y[:, 2] - rho)) < 4 / math.sqrt(n)
    assert np.std(y[:, 3] - np.linalg.norm(many.v, axis=1)) == pytest.approx(0.54, rel=0.05)
    # a run alone draws the same numbers as inside the batch
    one, y1, _ = simulate_image(many.select([7]), T_eb, T_BS, noise,
                                [np.random.default_rng(np.random.SeedSequence(5).spawn(n)[7])])
    assert np.array_equal(y1[0], y[7]) and np.array_equal(one.r_f[0], meas.r_f[7])


@pytest.mark.parametrize("kwargs,field", [({"sigma_range": 0.0}, "sigma_range"), ({"sigma_vic": -1.0}, "sigma_vic"),
                                          ({"D": -np.eye(3)}, "noise.D"), ({"D": np.eye(2)}, "noise.D")])
def test_bad_noise(kwargs, field):
    with pytest.raises(ConfigError, match=field):
        SarMeasurementNoise(**kwargs)
