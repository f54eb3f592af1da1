"""The navigator on a jittered IMU clock with a missing sample: steps of a fixed number of samples, each step's
covariance over its actual span (P <- Phi P Phi^T + Q_d written out here from the error model), the step epochs the
samples' own times, and the INS on the truth."""

from __future__ import annotations

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.filters import ErrorStateLayout
from sarnav.frames.ned import GRAVITY_NED
from sarnav.ins import NavState
from sarnav.navigation import Navigator, error_model
from sarnav.rotations import quat_to_dcm
from sarnav.sensors.imu import IMU_GRADES, ImuSpec
from sarnav.trajectory import StraightLevel

LAYOUT = ErrorStateLayout(("b_alt",), scalar_units=("m",))
RUNS = 2


def _jittered_times(rate=100.0, intervals=200, seed=3):
    """``intervals`` + 1 sample times at ``rate`` [Hz], +-10 % jitter, sample 57 missing."""
    rng = np.random.default_rng(seed)
    t = np.arange(intervals + 2) / rate
    t[1:] += 0.1 / rate * rng.uniform(-1.0, 1.0, intervals + 1)
    return np.delete(t, 57)


def _navigator(traj, t0):
    st = traj.state(np.array([t0]))
    nav = NavState(p=np.repeat(st.position, RUNS, 0), v=np.repeat(st.velocity, RUNS, 0),
                   q=np.repeat(st.quaternion, RUNS, 0), ba=np.zeros((RUNS, 3)), bg=np.zeros((RUNS, 3)),
                   bm=np.zeros((RUNS, 1)))
    model = error_model(LAYOUT, ImuSpec(IMU_GRADES["tactical"], 3600.0, 3600.0), np.array([0.1]), np.array([300.0]))
    P0 = np.broadcast_to(np.diag(np.linspace(0.5, 2.0, LAYOUT.n) ** 2), (RUNS, LAYOUT.n, LAYOUT.n)).copy()
    return Navigator(nav, P0, model, LAYOUT, tau_accel=3600.0, tau_gyro=3600.0, bias_tau=np.array([300.0]),
                     covariance_attitude="start")


@pytest.mark.parametrize("step_seconds", [None, 0.1])
def test_jittered_blocks_propagate_the_covariance_over_each_steps_actual_span(step_seconds):
    traj = StraightLevel(start=np.array([0.0, 0.0, -1000.0]), speed=50.0, heading=0.3, duration=3.0)
    t = _jittered_times()
    st = traj.state(t)
    nu = np.broadcast_to(traj.specific_force(t), (RUNS, t.size, 3)).copy()
    om = np.broadcast_to(traj.angular_rate(t), (RUNS, t.size, 3)).copy()
    nv = _navigator(traj, t[0])
    P, P_nominal = nv.P[0].copy(), nv.P[0].copy()
    ivs = [nv.propagate(t[a:a + 101], nu[:, a:a + 101], om[:, a:a + 101], 10, step_seconds=step_seconds)
           for a in (0, 100)]  # two blocks, the three-point history across them
    spans = np.diff(t[::10])
    assert np.ptp(spans) > 0.01  # the step with the missing sample is ~0.11 s, the others 0.1 +- 0.002 s
    for s, span in enumerate(spans):
        Phi, Qd = nv.model.discretize(quat_to_dcm(st.quaternion[10 * s][None]), -GRAVITY_NED[None], span)
        P = Phi[0] @ P @ Phi[0].T + Qd[0]
        Phi, Qd = nv.model.discretize(quat_to_dcm(st.quaternion[10 * s][None]), -GRAVITY_NED[None], 0.1)
        P_nominal = Phi[0] @ P_nominal @ Phi[0].T + Qd[0]
    np.testing.assert_allclose(nv.P[0], P, rtol=1e-6, atol=1e-12)
    assert not np.allclose(nv.P[0], P_nominal, rtol=1e-4)  # a uniform clock's steps would be visibly wrong
    for a, iv in zip((0, 100), ivs):
        np.testing.assert_array_equal(iv.t, t[a:a + 101:10])  # step epochs: the samples' own times
        np.testing.assert_allclose(iv.p[0], st.position[a:a + 101:10], atol=1e-6)  # the INS stays on the truth
        np.testing.assert_allclose(iv.v[1], st.velocity[a:a + 101:10], atol=1e-8)


def test_a_block_with_two_missing_samples_in_a_row_is_refused_before_anything_moves():
    traj = StraightLevel(start=np.array([0.0, 0.0, -1000.0]), speed=50.0, heading=0.3, duration=3.0)
    t = np.delete(_jittered_times(intervals=103), [80, 81])[:101]
    nv = _navigator(traj, t[0])
    p0 = nv.nav.p.copy()
    nu = np.broadcast_to(traj.specific_force(t), (RUNS, t.size, 3)).copy()
    om = np.broadcast_to(traj.angular_rate(t), (RUNS, t.size, 3)).copy()
    with pytest.raises(InputDataError, match=r"^imu.time: gap of .* after sample 79 "):
        nv.propagate(t, nu, om, 10)
    np.testing.assert_array_equal(nv.nav.p, p0)
    nv.propagate(t, nu, om, 10, max_gap=0.05)  # a stated longer limit passes it
