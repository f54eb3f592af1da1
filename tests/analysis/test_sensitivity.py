import numpy as np
import pytest

from sarnav.analysis import sensitivity as sens
from sarnav.errors import ConfigError, InputDataError
from sarnav.units import C

G = 9.81
LAM = C / 9.75e9
# extraction seed-000 §11.5 geometry: x along-track (north), y cross-track toward the target, z down;
# V = 10 m/s, altitude 1000 m, target 1800 m cross-track at mid-aperture
P0 = np.array([0.0, 0.0, -1000.0])
V0 = np.array([10.0, 0.0, 0.0])


def _dx(dp=(0, 0, 0), dv=(0, 0, 0), dth=(0, 0, 0)):
    return np.r_[dp, dv, dth].astype(float)


def test_linear_error_propagation_matches_straight_level_closed_form():
    # thesis (4.20): dp(t) = dp0 + dv0 t + 1/2 (f x dth0) t^2, f x dth = [g dth_y, -g dth_x, 0] (4.37)
    dx0 = _dx((1, 2, 3), (0.1, 0.2, 0.3), (0.01, 0.02, 0.03))
    t = np.array([0.0, 1.0, 10.0])
    out = sens.propagate_nav_error(dx0, t)
    acc = np.array([G * 0.02, -G * 0.01, 0.0])
    want = dx0[:3] + np.outer(t, dx0[3:6]) + 0.5 * np.outer(t**2, acc)
    np.testing.assert_allclose(out[:, :3], want, rtol=1e-12, atol=1e-12)
    # extraction T6: pitch 0.02 rad -> 0.0981 m along-track after 1 s, 9.81 m after 10 s
    pitch = sens.propagate_nav_error(_dx(dth=(0, 0.02, 0)), t)
    assert pitch[1:, 0] == pytest.approx([0.0981, 9.81], rel=1e-12)


# (injected error, aperture length, thesis O - X along = V(eta0_hat - eta0), O - X range = R0_hat - R0)
# values: extraction seed-000 §11.5 table (an independent BPA/4.41 computation by the note's author)
CASES = [
    ("along 3 m", _dx(dp=(3, 0, 0)), 20.0, 3.00, 0.0),
    ("cross 3 m", _dx(dp=(0, 3, 0)), 20.0, 0.0, 2.62),
    ("elev 3 m", _dx(dp=(0, 0, 3)), 20.0, 0.0, 1.46),
    ("dv along 20 s", _dx(dv=(0.1, 0, 0)), 20.0, 1.01, None),
    ("dv along 4 s", _dx(dv=(0.1, 0, 0)), 4.0, 0.20, None),
    ("dv cross", _dx(dv=(0, 0.05, 0)), 20.0, -9.00, None),
    ("dv elev", _dx(dv=(0, 0, 0.05)), 20.0, -5.00, None),
    ("roll 20 s", _dx(dth=(0.001, 0, 0)), 20.0, 21.4, None),
    ("roll 4 s", _dx(dth=(0.001, 0, 0)), 4.0, 4.29, None),
    ("pitch 20 s", _dx(dth=(0, 0.02, 0)), 20.0, 12.4, None),
    ("pitch 4 s", _dx(dth=(0, 0.02, 0)), 4.0, 0.41, None),
    ("yaw", _dx(dth=(0, 0, 0.1)), 20.0, 0.0, 0.0),
]


@pytest.mark.parametrize("name,dx0,aperture,along,rng", CASES, ids=[c[0] for c in CASES])
def test_eq_4_41_reproduces_the_extraction_table(name, dx0, aperture, along, rng):
    targ = np.array([V0[0] * aperture / 2, 1800.0, 0.0])
    pred = sens.predict_shift(targ, P0, V0, dx0, (-aperture, 2 * aperture))
    assert pred.eta0 == pytest.approx(aperture / 2, abs=1e-7)
    assert pred.r0 == pytest.approx(np.hypot(1800.0, 1000.0), rel=1e-12)
    # the table gives 3 significant figures: compare to half a unit in the last place
    tol = 0.005 if abs(along) < 10 else 0.05
    assert -pred.offset_along == pytest.approx(along, abs=tol)
    if rng is not None:
        assert -pred.offset_range == pytest.approx(rng, abs=0.005)


@pytest.mark.parametrize("dx0", [_dx(dp=(3, 0, 0)), _dx(dp=(0, 3, 0)), _dx(dp=(0, 0, 3)), _dx(dp=(1, -2, 1.5)),
                                 _dx(dv=(0, 0.05, 0)), _dx(dv=(0, 0, 0.05)), _dx(dv=(0, 0.02, -0.03))])
def test_closed_forms_match_numerical_minimisation_for_shift_errors(dx0):
    targ = np.array([50.0, 1800.0, 0.0])
    pred = sens.predict_shift(targ, P0, V0, dx0, (-20.0, 40.0))
    r_lin, a_lin = sens.linear_shift(targ, P0, V0, dx0)
    # first order; second-order bound: |e|^2/R0 + shift * |d_hat.e'|/V + shift^2/(2 R0)
    e = sens.propagate_nav_error(dx0, [5.0])[0]
    shift = abs(pred.offset_along)
    tol = e[:3] @ e[:3] / pred.r0 + shift * np.linalg.norm(e[3:6]) / 10.0 + shift**2 / (2 * pred.r0)
    assert r_lin == pytest.approx(pred.offset_range, abs=tol)
    assert a_lin == pytest.approx(pred.offset_along, abs=1e-2 + 2e-3 * abs(pred.offset_along))


@pytest.mark.parametrize("dx0", [_dx(dv=(0.01, 0, 0)), _dx(dth=(1e-4, 0, 0)), _dx(dth=(0, 2e-3, 0)),
                                 _dx(dth=(0, 0, 0.1)), _dx(dp=(3, 3, 3))])
def test_fm_rate_error_matches_finite_difference_curvature_of_the_estimated_range(dx0):
    """Independent check: K = (2/lambda) d2R/deta2 at the closest approach, by central differences."""
    targ = np.array([50.0, 1800.0, 0.0])
    pred = sens.predict_shift(targ, P0, V0, dx0, (-20.0, 40.0))

    def r_hat(t):
        e = sens.propagate_nav_error(dx0, [t])[0, :3]
        return np.linalg.norm(targ - (P0 + V0 * t - e))

    h = 0.05
    t = pred.eta0_hat
    rdd = (r_hat(t + h) - 2 * r_hat(t) + r_hat(t - h)) / h**2
    dk_num = 2.0 / LAM * (rdd - V0 @ V0 / pred.r0)
    dk = sens.fm_rate_error(targ, P0, V0, dx0, LAM)
    k_a = 2 * 100.0 / (LAM * pred.r0)
    assert dk == pytest.approx(dk_num, abs=2e-2 * abs(dk_num) + 1e-6 * k_a)


def test_fm_rate_error_of_along_track_velocity_is_2_dv_over_v():
    # thesis §4.3.2: the 2 v0^T dv0 term; relative FM-rate error -2 dv/V (dv = truth - estimate)
    targ = np.array([50.0, 1800.0, 0.0])
    r0 = np.hypot(1800.0, 1000.0)
    k_a = 2 * 100.0 / (LAM * r0)
    dk = sens.fm_rate_error(targ, P0, V0, _dx(dv=(0.1, 0, 0)), LAM)
    assert dk / k_a == pytest.approx(-2 * 0.1 / 10.0, rel=1e-12)


@pytest.mark.parametrize("dk,T", [(0.01, 4.0), (0.063, 10.0), (0.5, 10.0), (-0.2, 3.0)])
def test_fresnel_peak_loss_matches_direct_sum(dk, T):
    eta = np.linspace(-T / 2, T / 2, 200001)
    direct = 1 - abs(np.trapezoid(np.exp(1j * np.pi * dk * eta**2), eta)) / T
    assert sens.peak_loss_from_fm_rate_error(dk, T) == pytest.approx(direct, abs=1e-8)


def test_bad_inputs_name_the_field():
    with pytest.raises(InputDataError, match="dx0"):
        sens.propagate_nav_error(np.zeros(8), [1.0])
    with pytest.raises(ConfigError, match="span"):
        sens.predict_shift([0, 1800.0, 0], P0, V0, np.zeros(9), (5.0, 1.0))
    with pytest.raises(InputDataError, match="p_targ"):
        sens.predict_shift([500.0, 1800.0, 0], P0, V0, np.zeros(9), (0.0, 10.0))
    with pytest.raises(ConfigError, match="aperture_time"):
        sens.peak_loss_from_fm_rate_error(0.1, 0.0)
    with pytest.raises(ConfigError, match="wavelength"):
        sens.fm_rate_error([0, 1800.0, 0], P0, V0, np.zeros(9), -1.0)
