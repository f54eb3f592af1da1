"""One contract test over every measurement model (Stone Soup's practice): shapes of the Prediction, H against
central differences, Hessians against second differences, and ``simulate``'s noise statistics.

Add a model to ``MODELS`` and it is checked like the others. dx = truth - estimate: the truth is the estimate
corrected by dx (``filters.apply_feedback``), so z(truth) - z_hat = H dx + dx^T A dx / 2 + ...
"""

from __future__ import annotations

import numpy as np
import pytest

from sarnav.filters import ErrorStateLayout, Prediction, apply_feedback
from sarnav.ins import NavState
from sarnav.measurements.base import Measurement
from sarnav.measurements.focus import FocusVelocityMeasurement
from sarnav.measurements.gnss import GnssFix
from sarnav.measurements.sar import SarCrossRangeMeasurement, SarRangeMeasurement
from sarnav.measurements.telemetry import AltimeterMeasurement, RangeMeasurement, RangeRateMeasurement
from sarnav.rotations import quat_normalize

TELEMETRY = ErrorStateLayout(("b_alt", "b_range", "b_rate"))
SAR = ErrorStateLayout(("b_alt", "b_range", "b_cross"))
TARGET = np.array([1000.0, 0.0, 0.0])
SAR_TARGET = np.array([120.0, 1850.0, 0.0])  # 1.85 km east of a north track, on the ground


def _telemetry_nav(rng, runs):
    p = np.array([0.0, -200.0, -500.0]) + rng.uniform(-300, 300, (runs, 3))
    v = np.array([50.0, 0.0, 0.0]) + rng.uniform(-10, 10, (runs, 3))
    return NavState(p, v, quat_normalize(rng.standard_normal((runs, 4))), 0.01 * rng.standard_normal((runs, 3)),
                    1e-5 * rng.standard_normal((runs, 3)), 0.1 * rng.standard_normal((runs, 3)))


def _overflight_nav(rng, runs):
    """Near the closest approach to a target under the track (cross-track offset and velocity near zero): the
    geometry where the telemetry Hessians matter (docs/scenarios/telemetry.md, "Target under the track")."""
    p = np.array([TARGET[0], TARGET[1], -500.0]) + rng.uniform(-20, 20, (runs, 3)) * [1.0, 0.3, 0.1]
    v = np.array([50.0, 0.0, 0.0]) + rng.uniform(-0.5, 0.5, (runs, 3))
    return NavState(p, v, quat_normalize(rng.standard_normal((runs, 4))), 0.01 * rng.standard_normal((runs, 3)),
                    1e-5 * rng.standard_normal((runs, 3)), 0.1 * rng.standard_normal((runs, 3)))


def _sar_nav(rng, runs):
    p = np.array([118.0, 3.0, -1000.0]) + rng.uniform(-5, 5, (runs, 3))
    v = np.array([10.0, 0.07, -0.02]) + rng.uniform(-0.5, 0.5, (runs, 3))
    return NavState(p, v, np.tile([1.0, 0, 0, 0], (runs, 1)), np.zeros((runs, 3)), np.zeros((runs, 3)),
                    0.1 * rng.standard_normal((runs, 3)))


#: name -> (factory(runs) -> model, layout, nav factory, finite-difference step)
MODELS = {
    "altimeter": (lambda runs: AltimeterMeasurement(0.07, TELEMETRY), TELEMETRY, _telemetry_nav, 1e-2),
    "range": (lambda runs: RangeMeasurement(TARGET, 0.07, TELEMETRY), TELEMETRY, _telemetry_nav, 1e-2),
    "range-rate": (lambda runs: RangeRateMeasurement(TARGET, 0.07, TELEMETRY), TELEMETRY, _telemetry_nav, 1e-2),
    "range-overflight": (lambda runs: RangeMeasurement(TARGET, 0.07, TELEMETRY), TELEMETRY, _overflight_nav, 1e-2),
    "range-rate-overflight": (lambda runs: RangeRateMeasurement(TARGET, 0.07, TELEMETRY), TELEMETRY, _overflight_nav,
                              1e-2),
    "sar-range": (lambda runs: SarRangeMeasurement(SAR_TARGET, 0.25, SAR), SAR, _sar_nav, 1e-2),
    "sar-cross-zero-doppler": (lambda runs: SarCrossRangeMeasurement(SAR_TARGET, 0.25, SAR), SAR, _sar_nav, 1e-3),
    "sar-cross-paper": (lambda runs: SarCrossRangeMeasurement(
        SAR_TARGET, 0.25, SAR, model="paper", u_c=np.tile([10.0, 0.1, 0.0], (runs, 1)),
        r_orig=np.tile([113.0, 3.0, -1000.0], (runs, 1))), SAR, _sar_nav, 1e-2),
    # the best-focus along-track velocity (Hathaway 2023 / docs/quality.md §7): e from a slightly turned track
    "focus-velocity": (lambda runs: FocusVelocityMeasurement(SAR, [0.995, 0.0998, 0.0], np.full(runs, 0.05)), SAR,
                       _sar_nav, 1e-2),
    # with the line-of-sight acceleration coupling (lever R / 2V = 17 s, right-looking, level flight's f)
    "focus-velocity-accel": (lambda runs: FocusVelocityMeasurement(
        SAR, [1.0, 0.0, 0.0], 0.05, los=[0.0, 0.87, 0.49], lever=17.0, f_body=[0.05, -0.02, -9.81],
        f_ref=[0.03, 0.01, -9.80]), SAR, _sar_nav, 1e-3),
    # a GNSS fix (recorded flights, docs/navigate.md): position only, and position + velocity
    "gnss-position": (lambda runs: GnssFix(SAR, [1.5, 2.0, 3.0]), SAR, _sar_nav, 1e-2),
    "gnss-position-velocity": (lambda runs: GnssFix(SAR, [1.5, 2.0, 3.0], [0.05, 0.05, 0.1]), SAR, _sar_nav, 1e-2),
}


def _stack_runs(nav: NavState, k: int) -> NavState:
    """Each run of ``nav`` repeated k times (run-major): perturbations become runs of one batched call."""
    return NavState(*(np.repeat(getattr(nav, f), k, axis=0) for f in ("p", "v", "q", "ba", "bg", "bm")))


@pytest.fixture(params=sorted(MODELS))
def case(request):
    make, layout, nav_of, step = MODELS[request.param]
    runs = 3
    nav = nav_of(np.random.default_rng(len(request.param)), runs)
    return request.param, make, layout, nav, step


def test_prediction_shapes_and_names(case):
    name, make, layout, nav, _ = case
    m = make(nav.runs)
    assert isinstance(m, Measurement) and m.dim == len(m.names) == len(m.units)
    pred = m.predict(nav)
    assert isinstance(pred, Prediction)
    assert pred.z_hat.shape == (nav.runs, m.dim) and pred.H.shape == (nav.runs, m.dim, layout.n)
    assert pred.R.shape == (nav.runs, m.dim, m.dim) and np.all(np.linalg.eigvalsh(pred.R) > 0)
    assert pred.hessians.shape == (nav.runs, m.dim, layout.n, layout.n)
    assert pred.names == m.names


def test_jacobian_matches_central_differences(case):
    name, make, layout, nav, step = case
    n, runs = layout.n, nav.runs
    m = make(runs)
    H = m.predict(nav).H
    # all 2n perturbations of every run in one batched call: run r, state j, sign s at row (r * n + j) * 2 + s
    big = _stack_runs(nav, 2 * n)
    dx = np.zeros((runs * 2 * n, n))
    for j in range(n):
        dx[j * 2::2 * n, j] = step
        dx[j * 2 + 1::2 * n, j] = -step
    z = make(runs * 2 * n).predict(apply_feedback(big, dx, layout)).z_hat.reshape(runs, n, 2, m.dim)
    J = np.moveaxis((z[:, :, 0] - z[:, :, 1]) / (2 * step), 1, 2)  # (runs, m, n)
    scale = np.max(np.abs(H), axis=-1, keepdims=True)
    np.testing.assert_allclose(J / scale, H / scale, atol=1e-5)


def test_hessian_matches_second_differences(case):
    name, make, layout, nav, step = case
    n, runs = layout.n, nav.runs
    m = make(runs)
    A = m.predict(nav).hessians
    assert np.allclose(A, np.swapaxes(A, -1, -2))
    idx = [layout.slice("p").start + k for k in range(3)] + [layout.slice("v").start + k for k in range(3)]
    # everything outside the position and velocity blocks is linear (biases) or absent (attitude)
    others = [j for j in range(n) if j not in idx]
    assert np.all(A[..., others, :] == 0) and np.all(A[..., :, others] == 0)
    h = 10 * step
    pairs = [(i, j) for i in idx for j in idx]
    signs = [(1, 1), (1, -1), (-1, 1), (-1, -1)]
    k = len(pairs) * 4
    dx = np.zeros((runs * k, n))
    for r in range(runs):
        for q, (i, j) in enumerate(pairs):
            for s, (a, b) in enumerate(signs):
                dx[r * k + q * 4 + s, i] += a * h
                dx[r * k + q * 4 + s, j] += b * h
    z = make(runs * k).predict(apply_feedback(_stack_runs(nav, k), dx, layout)).z_hat.reshape(runs, len(pairs), 4, m.dim)
    fd = (z[:, :, 0] - z[:, :, 1] - z[:, :, 2] + z[:, :, 3]) / (4 * h * h)  # (runs, pairs, m)
    want = np.stack([A[:, :, i, j] for i, j in pairs], axis=1)
    roundoff = 16 * np.finfo(float).eps * np.max(np.abs(z)) / h**2  # of the second difference itself
    np.testing.assert_allclose(fd, want, rtol=0, atol=2e-3 * np.max(np.abs(want)) + roundoff)


def test_simulate_has_the_stated_noise_and_reads_the_truth_bias(case):
    name, make, layout, nav, _ = case
    runs = 4000
    truth = _stack_runs(NavState(*(getattr(nav, f)[:1] for f in ("p", "v", "q", "ba", "bg", "bm"))), runs)
    m = make(runs)
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(9).spawn(runs)]
    z = m.simulate(truth, rngs)
    e = z - m.predict(truth).z_hat  # the prediction at the truth: model + truth bias
    sigma = np.sqrt(np.diag(m.predict(truth).R[0]))
    assert z.shape == (runs, m.dim)
    assert np.all(np.abs(e.mean(axis=0)) < 4 * sigma / np.sqrt(runs))
    assert np.all(np.abs(e.std(axis=0) - sigma) < 4 * sigma / np.sqrt(2 * runs))
    # the same unit normals given explicitly give the same measurement (kinds with a fixed draw order)
    noise = np.random.default_rng(3).standard_normal((runs, m.dim))
    np.testing.assert_allclose(m.simulate(truth, noise=noise), m.predict(truth).z_hat + sigma * noise, rtol=0,
                               atol=1e-9 * np.max(np.abs(z)))


# --- the contract generalised to the orbital state (issue 11): the spacecraft centre-pixel measurement -------------

from sarnav.filters.mekf import reset  # noqa: E402
from sarnav.ins.orbital import OrbitalNavState  # noqa: E402
from sarnav.measurements.spacecraft import (CenterPixelMeasurement, SarMeasurementNoise,  # noqa: E402
                                            boresight_intersection, simulate_image)
from sarnav.trajectory.orbit import antenna_dcm, initial_ecef_state, lvlh_dcm, table2_elements  # noqa: E402

LOOK = antenna_dcm(np.radians(34.3))
NOISE = SarMeasurementNoise(D=np.diag([25.0, 16.0, 36.0]))


def _orbital_truth(runs):
    r, v = initial_ecef_state(table2_elements())
    return OrbitalNavState(np.tile(r, (runs, 1)), np.tile(v, (runs, 1)), np.tile([1.0, 0, 0, 0], (runs, 1)))


def _orbital_estimate(rng, runs):
    t = _orbital_truth(runs)
    dx = np.concatenate([rng.normal(0, 500, (runs, 3)), rng.normal(0, 5, (runs, 3)), rng.normal(0, 1e-3, (runs, 3))], 1)
    return reset(t, dx)


def _centre_pixel(runs, model):
    t = _orbital_truth(runs)
    T_eb = lvlh_dcm(t.r, t.v)
    r_f = boresight_intersection(t.r, LOOK @ T_eb)
    return CenterPixelMeasurement(T_eb, LOOK, r_f, NOISE, velocity_model=model)


ORBITAL = {"centre-pixel-speed": "speed", "centre-pixel-effective": "effective"}


@pytest.mark.parametrize("name", sorted(ORBITAL))
def test_orbital_measurement_follows_the_contract(name):
    runs = 3
    m = _centre_pixel(runs, ORBITAL[name])
    assert isinstance(m, Measurement) and not m.has_hessians and m.dim == len(m.names) == len(m.units) == 4
    est = _orbital_estimate(np.random.default_rng(4), runs)
    pred = m.predict(est)
    assert pred.z_hat.shape == (runs, 4) and pred.H.shape == (runs, 4, m.n_states) and pred.hessians is None
    assert pred.names == m.names and np.all(np.linalg.eigvalsh(pred.R) > 0)  # R + B: B gives the angles their noise
    # H against central differences: the truth is the estimate corrected by dx (mekf.reset: the MEKF's convention)
    steps = np.array([1.0] * 3 + [1e-3] * 3 + [1e-7] * 3)
    J = np.zeros_like(pred.H)
    for j in range(9):
        dx = np.zeros((runs, 9))
        dx[:, j] = steps[j]
        J[:, :, j] = (m.predict(reset(est, dx)).z_hat - m.predict(reset(est, -dx)).z_hat) / (2 * steps[j])
    scale = np.max(np.abs(pred.H), axis=-1, keepdims=True)
    np.testing.assert_allclose(J / scale, pred.H / scale, atol=2e-6)


@pytest.mark.parametrize("name", sorted(ORBITAL))
def test_orbital_simulation_has_the_stated_noise(name):
    """simulate_image: y - z_hat (predicted from the geolocated r_f at the truth) has the covariance R + B."""
    runs = 4000
    truth = _orbital_truth(runs)
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(9).spawn(runs)]
    meas, y, r_f_true = simulate_image(truth, lvlh_dcm(truth.r, truth.v), LOOK, NOISE, rngs, ORBITAL[name])
    pred = meas.predict(truth)
    e = y - pred.z_hat
    sigma = np.sqrt(np.diag(pred.R.mean(axis=0)))
    assert np.all(np.abs(e.mean(axis=0)) < 4 * sigma / np.sqrt(runs))
    assert np.all(np.abs(e.std(axis=0) - sigma) < 4 * sigma / np.sqrt(2 * runs))
    # the same unit normals give the same measurement (a fixed draw order)
    again = meas.simulate(truth, noise=np.zeros((runs, 2)))
    np.testing.assert_allclose(again[:, 2], np.linalg.norm(r_f_true - truth.r, axis=1))
