"""Table 2 orbit, RK4 + J2 propagator, LVLH and antenna frames (trajectory.orbit)."""

import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.frames.earth import GM_EARTH, J2_EARTH, WGS84_A, ecef_to_geodetic
from sarnav.trajectory.orbit import (KeplerElements, OrbitTruth, antenna_dcm, elements_to_eci, lvlh_dcm,
                                     propagate_rk4_eci, right_ascension_of_node, table2_elements)


def test_table2_elements_and_g1_geometry():
    el = table2_elements()
    assert el.a == pytest.approx(WGS84_A + 691.5e3) and el.e == 0.00118 and el.i == pytest.approx(math.radians(98.16))
    assert el.period / 60 == pytest.approx(98.60, abs=0.01)  # T21: 98.5 min in Table 2, 98.6 computed
    r, v = elements_to_eci(el)
    lat_gc = math.degrees(math.asin(r[2] / np.linalg.norm(r)))
    assert lat_gc == pytest.approx(30.15, abs=1e-9) and math.degrees(math.atan2(r[1], r[0])) == pytest.approx(-100.0)
    assert v[2] > 0  # ascending
    h = np.cross(r, v)
    assert math.degrees(math.acos(h[2] / np.linalg.norm(h))) == pytest.approx(98.16)
    # vis-viva checks the perifocal velocity
    assert np.dot(v, v) == pytest.approx(GM_EARTH * (2 / np.linalg.norm(r) - 1 / el.a), rel=1e-12)


@pytest.mark.parametrize("a,e,field", [(WGS84_A + 50e3, 0.0, "orbit.semi_major_axis"),
                                        (WGS84_A + 700e3, 1.2, "orbit.eccentricity"),
                                        (WGS84_A + 700e3, 0.2, "orbit.semi_major_axis")])
def test_bad_orbits_are_rejected(a, e, field):
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        KeplerElements(a, e, 1.0, 0.0, 0.0, 0.0)


def test_rk4_keplerian_energy_and_period():
    """Without J2 the RK4 orbit closes after one Keplerian period and conserves energy."""
    el = table2_elements()
    r0, v0 = elements_to_eci(el)
    n = 5000
    r, v = propagate_rk4_eci(r0, v0, el.period / n, n, j2=False)
    assert np.linalg.norm(r[-1] - r0) < 1e-3 and np.linalg.norm(v[-1] - v0) < 1e-6
    energy = 0.5 * np.sum(v * v, axis=1) - GM_EARTH / np.linalg.norm(r, axis=1)
    assert np.ptp(energy) / abs(energy[0]) < 1e-12


def test_rk4_batched_equals_single():
    r0, v0 = elements_to_eci(table2_elements())
    rb, vb = propagate_rk4_eci(np.stack([r0, r0 + 10.0]), np.stack([v0, v0]), 1.0, 100)
    rs, vs = propagate_rk4_eci(r0 + 10.0, v0, 1.0, 100)
    assert np.array_equal(rb[:, 1], rs) and np.array_equal(vb[:, 1], vs)


def test_j2_secular_node_rate_over_one_day():
    """Done-when: node rate from RK4 over one day within 1 % of -1.5 n J2 (R/p)^2 cos i."""
    el = table2_elements()
    dt = 10.0
    n_steps = int(86400 / dt)
    r, v = propagate_rk4_eci(*elements_to_eci(el), dt, n_steps)
    t = np.arange(n_steps + 1) * dt
    raan = right_ascension_of_node(r, v)
    keep = t <= math.floor(86400 / el.period) * el.period  # whole orbits: short-period terms average out
    rate = np.polyfit(t[keep], raan[keep], 1)[0]
    n = math.sqrt(GM_EARTH / el.a**3)
    p = el.a * (1 - el.e**2)
    theory = -1.5 * n * J2_EARTH * (WGS84_A / p) ** 2 * math.cos(el.i)
    assert math.degrees(theory) * 86400 == pytest.approx(0.986, abs=0.002)  # near sun-synchronous (0.9856 deg/day)
    assert rate == pytest.approx(theory, rel=0.01)


def test_orbit_truth_ecef_and_ground_track():
    truth = OrbitTruth(table2_elements(), duration=600.0, dt=0.5, every=20)
    assert truth.t[-1] == 600.0 and truth.r.shape == (61, 3)
    lat, lon, h = ecef_to_geodetic(truth.r)
    assert np.all(np.diff(lat) > 0)  # ascending, Houston -> northern Canada
    assert 680e3 < h.min() and h.max() < 720e3
    with pytest.raises(ConfigError):
        truth.index(0.3)
    assert truth.index(8.0 * 10) == 8


def test_lvlh_and_antenna_frames():
    r0, v0 = OrbitTruth(table2_elements(), duration=1.0, dt=1.0).r[0], OrbitTruth(table2_elements(), 1.0, 1.0).v[0]
    T = lvlh_dcm(r0, v0)
    assert np.allclose(T @ T.T, np.eye(3), atol=1e-15) and np.isclose(np.linalg.det(T), 1.0)
    assert np.allclose(T[2], -r0 / np.linalg.norm(r0))  # z_b nadir
    v_in = v0 + np.cross([0, 0, 7.292115e-5], r0)
    assert np.dot(T[0], v_in) / np.linalg.norm(v_in) > 0.9999  # x_b ~ along the inertial velocity
    assert abs(np.dot(T[1], np.cross(r0, v_in))) / np.linalg.norm(np.cross(r0, v_in)) == pytest.approx(1.0)
    th = math.radians(34.3)
    A = antenna_dcm(th)
    assert np.allclose(A, [[1, 0, 0], [0, math.cos(th), -math.sin(th)], [0, math.sin(th), math.cos(th)]])
    bore_body = A.T @ [0, 0, 1]
    assert math.degrees(math.acos(bore_body[2])) == pytest.approx(34.3) and bore_body[1] > 0  # right of track
    As = antenna_dcm(th, math.radians(2.0))
    assert np.allclose(As @ As.T, np.eye(3)) and (As.T @ [0, 0, 1])[0] > 0  # squint forward
    with pytest.raises(ConfigError, match="look_angle"):
        antenna_dcm(math.radians(95.0))
