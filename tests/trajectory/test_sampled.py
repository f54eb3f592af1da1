"""Closest approach of a sampled track to a point and interpolation of a history (sarnav.trajectory.sampled)."""

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.trajectory.sampled import closest_approach, closest_sample_is_inside, interpolate_state


def test_closest_approach_parabola_is_exact_for_constant_velocity_between_samples():
    times = np.arange(0.0, 1.0, 0.01)
    v = np.array([9.0, 1.5, -0.3])
    pos = np.array([0.0, 0.0, -1000.0]) + times[:, None] * v
    t_true = 0.4237
    perp = np.cross(v, [0, 0, 1.0])  # target orthogonal to v at t_true
    targ = pos[0] + v * t_true + 2000.0 * perp / np.linalg.norm(perp)
    eta0, r0, p0 = closest_approach(targ, times, pos)
    assert eta0 == pytest.approx(t_true, abs=1e-9)
    assert r0 == pytest.approx(2000.0, rel=1e-12)
    np.testing.assert_allclose(p0, pos[0] + v * t_true, atol=1e-9)
    assert closest_sample_is_inside(targ, times, pos)


def test_interpolation_and_bad_input():
    times = np.array([0.0, 1.0, 2.0])
    vals = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [3.0, 4.0, 5.0]])
    np.testing.assert_allclose(interpolate_state(times, vals, 1.5), [2.0, 3.0, 4.0])
    with pytest.raises(InputDataError, match="^eta"):
        interpolate_state(times, vals, 2.5)
    with pytest.raises(InputDataError, match="^positions"):
        closest_approach([0.0, 5.0, 0.0], times, vals[:, :2])
    with pytest.raises(InputDataError, match="^times"):
        closest_approach([0.0, 5.0, 0.0], times[::-1], vals)
    # a target abeam the first sample: closest approach at the end of the samples
    with pytest.raises(InputDataError, match="end of the trajectory"):
        closest_approach([-5.0, 100.0, 0.0], times, vals)
    assert not closest_sample_is_inside(np.array([-5.0, 100.0, 0.0]), times, vals)
