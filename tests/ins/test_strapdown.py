"""Strapdown INS: ideal-IMU accuracy, closed-form error growth (thesis eq. 4.20), input checks."""

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.ins import NavState, mechanize
from sarnav.rotations import attitude_error, corrupt_attitude
from sarnav.trajectory import Maneuvering, StraightLevel
from helpers import nav_at

RATE = 100.0  # IMU rate [Hz] at which the 1 mm / 60 s requirement is met (docs/navigation.md)


def _run(traj, nav, t, nu, om, chunk):
    out, hist, errs = nav, None, []
    s = traj.state(t)
    for k0 in range(0, t.size - 1, chunk):
        sl = slice(k0, k0 + chunk + 1)
        out, _, hist = mechanize(out, t[sl], nu[:, sl], om[:, sl], 3600.0, 3600.0, history=hist)
        k = k0 + chunk
        errs.append((np.abs(out.p - s.position[k]).max(), np.abs(out.v - s.velocity[k]).max(),
                     np.abs(attitude_error(s.quaternion[k], out.q)).max()))
    return out, np.max(errs, axis=0)


def test_ideal_imu_stays_within_1mm_over_60s_maneuver():
    traj = Maneuvering.s_turn_climb([0.0, -200.0, -500.0], 50.0, 0.0, 60.0)
    t = np.arange(int(60 * RATE) + 1) / RATE
    nu, om = traj.specific_force(t)[None], traj.angular_rate(t)[None]
    _, (ep, ev, eth) = _run(traj, nav_at(traj.state(t), 0), t, nu, om, chunk=10)
    assert ep < 1e-3  # requirement (measured: ~3e-7 m)
    assert ev < 1e-4 and eth < 1e-7


def test_chunked_with_history_equals_one_call():
    traj = Maneuvering.s_turn_climb([0.0, 0.0, -500.0], 50.0, 0.0, 24.0)
    t = np.arange(2401) / RATE
    nu, om = traj.specific_force(t)[None], traj.angular_rate(t)[None]
    one, _, _ = mechanize(nav_at(traj.state(t), 0), t, nu, om, 3600.0, 3600.0)
    many, _ = _run(traj, nav_at(traj.state(t), 0), t, nu, om, chunk=48)
    np.testing.assert_allclose(many.p, one.p, rtol=0, atol=1e-9)


def test_tilt_error_gives_half_g_theta_t_squared():
    """Thesis eq. 4.20 / extraction T6: dp = (nu^n x dth) t^2/2, pitch -> along-track, yaw -> nothing."""
    traj = StraightLevel([0.0, 0.0, -500.0], 50.0, 0.0, 10.0)
    t = np.arange(1001) / RATE
    s = traj.state(t)
    nu, om = np.repeat(traj.specific_force(t)[None], 3, 0), np.repeat(traj.angular_rate(t)[None], 3, 0)
    nav = nav_at(s, 0, runs=3)
    dth = np.array([[0.0, 0.02, 0.0], [0.001, 0.0, 0.0], [0.0, 0.0, 0.1]])  # pitch, roll, yaw errors
    nav.q = corrupt_attitude(nav.q, dth)  # estimate = m(truth, dth), eq. A.5
    out, _, _ = mechanize(nav, t, nu, om, 3600.0, 3600.0)
    err = s.position[-1] - out.p
    g = 9.81
    # linear theory; the nonlinear error differs by O(dth^2) relative
    np.testing.assert_allclose(err[0], [0.5 * g * 0.02 * 100.0, 0.0, 0.0], rtol=0, atol=9.81 * 0.02 * 2)
    assert err[0, 0] == pytest.approx(9.81, rel=4e-4)
    assert err[1, 1] == pytest.approx(-0.5 * g * 0.001 * 100.0, rel=1e-5)
    np.testing.assert_allclose(err[2], 0.0, atol=1e-9)


def test_known_biases_are_compensated():
    traj = StraightLevel([0.0, 0.0, -500.0], 50.0, 0.2, 5.0)
    t = np.arange(501) / RATE
    s = traj.state(t)
    tau_a, tau_g = 40.0, 70.0
    ba0, bg0 = np.array([[0.01, -0.02, 0.03]]), np.array([[1e-4, 2e-4, -3e-4]])
    decay_a, decay_g = np.exp(-t / tau_a)[None, :, None], np.exp(-t / tau_g)[None, :, None]
    nu = traj.specific_force(t)[None] + ba0[:, None] * decay_a
    om = traj.angular_rate(t)[None] + bg0[:, None] * decay_g
    nav = nav_at(s, 0)
    nav.ba, nav.bg = ba0.copy(), bg0.copy()
    out, _, _ = mechanize(nav, t, nu, om, tau_a, tau_g)
    np.testing.assert_allclose(out.p, s.position[-1:], atol=1e-8)
    np.testing.assert_allclose(out.ba, ba0 * np.exp(-5.0 / tau_a), rtol=1e-12)


def test_batch_does_not_change_a_runs_numbers():
    traj = Maneuvering.s_turn_climb([0.0, 0.0, -500.0], 50.0, 0.0, 12.0)
    t = np.arange(301) / RATE
    rng = np.random.default_rng(0)
    nu = traj.specific_force(t)[None] + 0.01 * rng.standard_normal((5, t.size, 3))
    om = traj.angular_rate(t)[None] + 1e-4 * rng.standard_normal((5, t.size, 3))
    nav = nav_at(traj.state(t), 0, runs=5)
    nav.q = corrupt_attitude(nav.q, 0.01 * rng.standard_normal((5, 3)))
    full, fm, _ = mechanize(nav, t, nu, om, 100.0, 100.0)
    for i in (0, 3):
        one = NavState(nav.p[i:i + 1], nav.v[i:i + 1], nav.q[i:i + 1], nav.ba[i:i + 1], nav.bg[i:i + 1])
        o, f1, _ = mechanize(one, t, nu[i:i + 1], om[i:i + 1], 100.0, 100.0)
        for a, b in ((o.p, full.p), (o.v, full.v), (o.q, full.q), (f1, fm)):
            np.testing.assert_array_equal(a[0], b[i])


def test_bad_samples_raise_input_data_error():
    traj = StraightLevel([0.0, 0.0, -500.0], 50.0, 0.0, 1.0)
    t = np.arange(11) / RATE
    nu, om = traj.specific_force(t)[None], traj.angular_rate(t)[None]
    nav = nav_at(traj.state(t), 0)
    bad = nu.copy()
    bad[0, 4, 2] = np.nan
    with pytest.raises(InputDataError, match="imu.specific_force"):
        mechanize(nav, t, bad, om, 1.0, 1.0)
    with pytest.raises(InputDataError, match="imu.angular_rate"):
        mechanize(nav, t, nu, om[:, :-1], 1.0, 1.0)
    gap = np.delete(t, [5, 6])  # two missing samples in a row (one is accepted: tests/ins/test_strapdown_jitter.py)
    with pytest.raises(InputDataError, match="imu.time"):
        mechanize(nav, gap, nu[:, :-2], om[:, :-2], 1.0, 1.0)
