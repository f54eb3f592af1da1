"""``imaging.hill_climb``: Algorithm 1 of Pogorelsky et al. (2022) on sharpness curves of known peak."""

import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.imaging.hill_climb import hill_climb

PEAK = 7.3


def _counting(f):
    calls = []

    def g(v):
        calls.append(v)
        return f(v)
    return g, calls


def test_walk_alone_stops_on_the_step_grid_nearest_the_peak():
    """No refinement: the walk visits v0 + k step and keeps the best, within step / 2 of the peak."""
    f, calls = _counting(lambda v: -(v - PEAK) ** 2)
    res = hill_climb(f, 0.0, step=1.0, refine=(), parabolic=False)
    assert res.best == 7.0 and res.value == pytest.approx(-(0.3**2))
    assert not res.hit_limit
    assert len(calls) == len(set(calls)) == res.evaluations  # every distinct v evaluated once


def test_refinement_and_parabola_recover_the_peak_of_a_parabola_exactly():
    """The vertex through three samples of a parabola is its peak (to rounding)."""
    res = hill_climb(lambda v: 5.0 - 2.0 * (v - PEAK) ** 2, 20.0, step=1.0, refine=(0.5, 0.25))
    assert res.best == pytest.approx(PEAK, abs=1e-9)
    res = hill_climb(lambda v: 5.0 - 2.0 * (v - PEAK) ** 2, -3.0, step=2.0, refine=(0.5,), parabolic=False)
    assert abs(res.best - PEAK) <= 0.25  # half the last step


def test_smooth_non_parabolic_peak_within_a_fraction_of_the_last_step():
    """A Gaussian-shaped curve (e.g. image sharpness vs speed): the parabolic vertex lands within a tenth of the
    last step of the true peak."""
    res = hill_climb(lambda v: math.exp(-0.5 * ((v - PEAK) / 3.0) ** 2), 0.0, step=1.0, refine=(0.5, 0.25))
    assert abs(res.best - PEAK) < 0.025


def test_a_start_at_the_peak_costs_three_evaluations_and_a_far_peak_hits_the_limit():
    res = hill_climb(lambda v: -abs(v - PEAK), PEAK, step=1.0, refine=(), parabolic=False)
    assert res.best == PEAK and res.evaluations == 3
    far = hill_climb(lambda v: -abs(v - 100.0), 0.0, step=1.0, max_iter=5, refine=(), parabolic=False)
    assert far.hit_limit and far.best == 6.0  # the first step, then five more


@pytest.mark.parametrize("kw, field", [(dict(step=0.0), "autofocus.step"), (dict(step=np.nan), "autofocus.step"),
                                       (dict(max_iter=0), "autofocus.max_iter"),
                                       (dict(refine=(2.0,)), "autofocus.refine")])
def test_bad_settings_name_the_field(kw, field):
    with pytest.raises(ConfigError, match=field):
        hill_climb(lambda v: 0.0, 0.0, **kw)
