"""``sarnav.measurements.spacecraft_image`` on its own (the image chain's heavy tests are in test_spacecraft_image.py):
``terrain_intersection`` against the closed-form ray/plane intersection on planar terrain (level and sloped planes
given to it as DEM heights along the ellipsoid normal) and against a bisection on a curved hill, with WGS-84
conversions written here; ``ImagingConfig`` validation and derived sizes; ``SpacecraftImager.rows_half``; a small
chip's window and boresight promises."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.measurements.spacecraft_image import (
    GROUND_SPEED,
    REGISTRATIONS,
    STAGES,
    ImagingConfig,
    SpacecraftImager,
    terrain_intersection,
)

A = 6378137.0
F = 1.0 / 298.257223563
E2 = F * (2.0 - F)
C_LIGHT = 299_792_458.0


def _normal(lat, lon):
    """Outward ellipsoid normal (up) at geodetic (lat, lon) [rad]."""
    return np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])


def _to_ecef(lat, lon, h):
    n = A / np.sqrt(1.0 - E2 * np.sin(lat) ** 2)
    return np.array([(n + h) * np.cos(lat) * np.cos(lon), (n + h) * np.cos(lat) * np.sin(lon),
                     (n * (1.0 - E2) + h) * np.sin(lat)])


def _to_geodetic(p):
    """(lat, lon, h) of ECEF p by the fixed-point iteration on latitude (converges to < 1e-12 rad in a few steps)."""
    x, y, z = p
    lon = math.atan2(y, x)
    rho = math.hypot(x, y)
    lat = math.atan2(z, rho * (1.0 - E2))
    for _ in range(20):
        n = A / math.sqrt(1.0 - E2 * math.sin(lat) ** 2)
        h = rho / math.cos(lat) - n
        lat = math.atan2(z, rho * (1.0 - E2 * n / (n + h)))
    n = A / math.sqrt(1.0 - E2 * math.sin(lat) ** 2)
    return lat, lon, rho / math.cos(lat) - n


class PlaneTerrain:
    """A DEM whose surface is the plane through ``p0`` with normal ``nrm``: the height above (lat, lon) is where the
    ellipsoid normal line e(lat, lon) + h up(lat, lon) meets the plane, h = (p0 - e) . nrm / (up . nrm)."""

    def __init__(self, p0, nrm):
        self.p0, self.nrm = np.asarray(p0, float), np.asarray(nrm, float) / np.linalg.norm(nrm)

    def height(self, lat, lon):
        lat, lon = np.asarray(lat, float), np.asarray(lon, float)
        e, up = _to_ecef(lat, lon, 0.0), _normal(lat, lon)
        return np.tensordot(self.nrm, self.p0[(...,) + (None,) * lat.ndim] - e, 1) / np.tensordot(self.nrm, up, 1)


class HillTerrain:
    """base + a Gaussian hill of ``peak`` m and ``width`` m (1-sigma) centred on (lat_c, lon_c)."""

    def __init__(self, lat_c, lon_c, base, peak, width):
        self.lat_c, self.lon_c, self.base, self.peak, self.width = lat_c, lon_c, base, peak, width

    def height(self, lat, lon):
        dn = (np.asarray(lat) - self.lat_c) * A
        de = (np.asarray(lon) - self.lon_c) * A * math.cos(self.lat_c)
        return self.base + self.peak * np.exp(-(dn**2 + de**2) / (2 * self.width**2))


LAT0, LON0, H0 = 0.62, 0.21, 300.0


def _geometry(d_lon=0.05, alt=691e3):
    """Spacecraft ``alt`` above (LAT0, LON0 + d_lon) looking at the ground point (LAT0, LON0, H0): (r, u, ground)."""
    r = _to_ecef(LAT0, LON0 + d_lon, alt)
    g = _to_ecef(LAT0, LON0, H0)
    u = (g - r) / np.linalg.norm(g - r)
    return r, u, g


def _tilted(axis_deg: float, slope_deg: float):
    """Unit normal of a plane at (LAT0, LON0) tilted ``slope_deg`` from level, its downhill side towards azimuth
    ``axis_deg`` (0 north, 90 east)."""
    up = _normal(LAT0, LON0)
    east = np.array([-math.sin(LON0), math.cos(LON0), 0.0])
    north = np.cross(up, east)
    az = math.radians(axis_deg)
    horiz = math.cos(az) * north + math.sin(az) * east
    s = math.radians(slope_deg)
    return math.cos(s) * up + math.sin(s) * horiz


def _ray_plane(r, u, p0, nrm):
    s = (p0 - r) @ nrm / (u @ nrm)
    return r + s * u


@pytest.mark.parametrize("d_lon", [0.0, 0.03, 0.06])
def test_level_plane_matches_the_closed_form_ray_plane_intersection(d_lon):
    """A level plane through a point at 300 m (nadir to ~30 deg off nadir): the intersection is the closed-form
    r + s u, s = (p0 - r) . n / (u . n), to 0.1 mm."""
    r, u, g = _geometry(d_lon if d_lon else 1e-9)
    nrm = _normal(LAT0, LON0)
    p = terrain_intersection(r, u, PlaneTerrain(g, nrm))
    np.testing.assert_allclose(p, _ray_plane(r, u, g, nrm), rtol=0, atol=1e-4)


@pytest.mark.parametrize("axis, slope", [(90.0, 10.0), (270.0, 10.0), (0.0, 15.0), (45.0, 5.0)])
def test_sloped_plane_matches_the_closed_form_ray_plane_intersection(axis, slope):
    """Planes sloping 5-15 deg, facing towards, away from and across the line of sight (the spacecraft is east):
    the intersection is the closed-form ray/plane point to 0.1 mm, on the ray."""
    r, u, g = _geometry()
    nrm = _tilted(axis, slope)
    p = terrain_intersection(r, u, PlaneTerrain(g, nrm))
    want = _ray_plane(r, u, g, nrm)
    np.testing.assert_allclose(p, want, rtol=0, atol=1e-4)
    assert np.linalg.norm(np.cross(p - r, u)) < 1e-4  # on the ray


def test_steep_plane_matches_the_closed_form_ray_plane_intersection():
    """A plane sloping 60 deg towards the spacecraft: still the closed-form ray/plane point to 0.1 mm."""
    r, u, g = _geometry()
    nrm = _tilted(90.0, 60.0)
    np.testing.assert_allclose(terrain_intersection(r, u, PlaneTerrain(g, nrm)), _ray_plane(r, u, g, nrm), rtol=0,
                               atol=1e-4)


def test_point_on_a_plane_is_on_the_terrain():
    """The returned point's geodetic height (converted here) equals the DEM height at its latitude and longitude."""
    r, u, g = _geometry()
    t = PlaneTerrain(g, _tilted(90.0, 10.0))
    p = terrain_intersection(r, u, t)
    lat, lon, h = _to_geodetic(p)
    assert h == pytest.approx(float(t.height(lat, lon)), abs=1e-5)


def _bisect(r, u, terrain, s_lo, s_hi, n=200):
    """s where h_geodetic(r + s u) - h_DEM = 0, by bisection (f > 0 above the terrain at s_lo)."""
    def f(s):
        lat, lon, h = _to_geodetic(r + s * u)
        return h - float(terrain.height(lat, lon))

    assert f(s_lo) > 0 > f(s_hi)
    for _ in range(n):
        mid = 0.5 * (s_lo + s_hi)
        if f(mid) > 0:
            s_lo = mid
        else:
            s_hi = mid
    return 0.5 * (s_lo + s_hi)


@pytest.mark.parametrize("peak, offset", [(80.0, 0.0), (-60.0, 500.0), (150.0, -1200.0)])
def test_curved_hill_matches_a_bisection(peak, offset):
    """On a Gaussian hill (or hollow) near the line of sight's ground point, the intersection equals the bisection
    root of h_geodetic(r + s u) - h_DEM(lat, lon) to 1 mm."""
    r, u, g = _geometry()
    hill = HillTerrain(LAT0 + offset / A, LON0, H0, peak, 1500.0)
    p = terrain_intersection(r, u, hill)
    s_ref = _bisect(r, u, hill, np.linalg.norm(g - r) - 3000.0, np.linalg.norm(g - r) + 3000.0)
    np.testing.assert_allclose(p, r + s_ref * u, rtol=0, atol=1e-3)


def test_ellipsoid_surface_is_the_ray_ellipsoid_root():
    """A DEM of height 0: the intersection is the near root of the ray/ellipsoid quadratic."""
    r, u, _ = _geometry()

    class Zero:
        def height(self, lat, lon):
            return np.zeros(np.shape(lat))

    b2 = (A * (1 - F)) ** 2
    w = np.array([1 / A**2, 1 / A**2, 1 / b2])
    qa, qb, qc = (w * u * u).sum(), 2 * (w * r * u).sum(), (w * r * r).sum() - 1
    s = (-qb - math.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa)
    np.testing.assert_allclose(terrain_intersection(r, u, Zero()), r + s * u, rtol=0, atol=1e-4)


# --- ImagingConfig ------------------------------------------------------------------------------------------

def test_defaults_are_valid_and_sizes_follow():
    """Default configuration: pulses = the even number nearest block x PRF; dr = c / (2 fs)."""
    c = ImagingConfig()
    assert c.registration in REGISTRATIONS
    assert c.pulses == 4400 and c.pulses % 2 == 0
    assert c.dr == pytest.approx(C_LIGHT / (2 * 32e6), rel=1e-15)


@pytest.mark.parametrize("block, prf, pulses", [(2.0, 2200.0, 4400), (1.0, 1001.0, 1000), (0.5, 1003.0, 502),
                                                (0.1, 2200.0, 220), (0.01, 250.0, 2)])
def test_pulses_is_even_and_nearest(block, prf, pulses):
    """pulses = 2 round(block prf / 2): even, within one pulse of block x prf."""
    c = ImagingConfig(block=block, prf=prf)
    assert c.pulses == pulses and c.pulses % 2 == 0 and abs(c.pulses - block * prf) <= 1.0


@pytest.mark.parametrize("method", REGISTRATIONS)
def test_every_registration_method_is_accepted(method):
    """orb, sift and correlation are accepted."""
    assert ImagingConfig(registration=method).registration == method


@pytest.mark.parametrize("method", ["ORB", "surf", "", None])
def test_unknown_registration_is_refused(method):
    """Any other registration method is one ConfigError naming registration.method and the choices."""
    with pytest.raises(ConfigError) as exc:
        ImagingConfig(registration=method)
    assert exc.value.field == "registration.method" and "orb" in exc.value.message and "\n" not in str(exc.value)


@pytest.mark.parametrize("n, ok", [(128, True), (4096, True), (384, True), (127, False), (4097, False),
                                   (256.0, False), ("256", False)])
def test_range_samples_integer_in_range(n, ok):
    """radar.range_samples: an integer in [128, 4096]; floats and strings refused, naming the key and range."""
    if ok:
        assert ImagingConfig(range_samples=n).range_samples == n
    else:
        with pytest.raises(ConfigError) as exc:
            ImagingConfig(range_samples=n)
        assert exc.value.field == "radar.range_samples" and "[128, 4096]" in exc.value.message


def test_stages_and_registrations():
    """The measurement's timed stages and the registration methods, as the records name them."""
    assert STAGES == ("echoes", "focusing", "autofocus", "registration")
    assert REGISTRATIONS == ("orb", "sift", "correlation")


@pytest.mark.parametrize("half_along, prf", [(900.0, 2200.0), (100.0, 2200.0), (900.0, 1500.0), (3000.0, 2000.0)])
def test_rows_half_covers_the_scene_in_look_pairs(half_along, prf):
    """rows_half: an even number of pulses covering the scene's half length + 150 m at the footprint speed, and no
    more than 2 beyond it."""
    im = SpacecraftImager(ImagingConfig(half_along=half_along, prf=prf), orbit=None, T_bs=np.eye(3))
    h = im.rows_half()
    need = (half_along + 150.0) / GROUND_SPEED * prf
    assert h % 2 == 0 and need <= h < need + 2


# --- a small chip (128 range bins, 0.4 s block: about a second) -------------------------------------------

def test_chip_window_is_centred_on_the_boresight_range():
    """The chip's centre pixel r_b lies on the terrain on the true boresight, the receive window is centred on its
    slant range rho_c, the block's pulse times are centred on t_m at the PRF, and chips are cached per update."""
    from sarnav.trajectory.orbit import (
        OrbitTruth,
        antenna_dcm,
        body_dcm,
        table2_elements,
    )

    cfg = ImagingConfig(range_samples=128, block=0.4, half_along=200.0, half_range=150.0, n_bright=4,
                        clutter_spacing=60.0, map_spacing=15.0)
    orbit = OrbitTruth(table2_elements(), 10.0, 0.1)
    T_bs = antenna_dcm(math.radians(34.3))
    im = SpacecraftImager(cfg, orbit, T_bs)
    t_m = 5.0
    chip = im.chip(0, t_m)
    assert im.chip(0, t_m) is chip
    k = int(orbit.index(t_m))
    np.testing.assert_array_equal(chip.r, orbit.r[k])
    # window: near range + N/2 bins = rho_c = |r_b - r|
    assert chip.rho_c == pytest.approx(np.linalg.norm(chip.r_b - chip.r), rel=1e-12)
    assert chip.params.near_range + (cfg.range_samples // 2) * cfg.dr == pytest.approx(chip.rho_c, abs=1e-6)
    # r_b on the true boresight, on the DEM
    u = (T_bs @ body_dcm(chip.r, chip.v, "zero-doppler"))[2]
    d = chip.r_b - chip.r
    assert np.linalg.norm(np.cross(d, u)) < 1e-3 and d @ u > 0
    lat, lon, h = _to_geodetic(chip.r_b)
    assert h == pytest.approx(float(chip.terrain.height(lat, lon)), abs=1e-3)
    # pulse clock
    assert chip.t.size == cfg.pulses
    np.testing.assert_allclose(np.diff(chip.t), 1.0 / cfg.prf, rtol=1e-9)
    assert chip.t[cfg.pulses // 2] == pytest.approx(t_m, abs=1e-9)
    np.testing.assert_allclose(chip.positions[cfg.pulses // 2], chip.r, rtol=0, atol=1e-3)


# --- the reference pass from another look (issue 29, Pogorelsky: a repeat pass with a different look angle) ----------

def _off_nadir(p, r_b):
    """Off-nadir angle at the antenna p of the scene point r_b by the law of cosines in the triangle (Earth centre,
    p, r_b): |r_b|^2 = |p|^2 + rho^2 - 2 |p| rho cos(theta) (no spherical-Earth step: the centre is the origin)."""
    a, rho, b = np.linalg.norm(p), np.linalg.norm(r_b - p), np.linalg.norm(r_b)
    return math.acos((a * a + rho * rho - b * b) / (2 * a * rho))


@pytest.mark.parametrize("offset_deg", [-8.0, -3.0, 2.0, 8.0])
def test_reference_shift_gives_the_asked_off_nadir_angle_across_the_track(offset_deg):
    from sarnav.measurements.spacecraft import boresight_intersection
    from sarnav.measurements.spacecraft_image import reference_shift
    from sarnav.trajectory.orbit import OrbitTruth, antenna_dcm, body_dcm, table2_elements

    orbit = OrbitTruth(table2_elements(), 10.0, 0.1)
    r, v = orbit.r[50], orbit.v[50]
    T_es = antenna_dcm(math.radians(34.3)) @ body_dcm(r, v, "zero-doppler")
    r_b = boresight_intersection(r[None], T_es[None])[0]
    assert math.degrees(_off_nadir(r, r_b)) == pytest.approx(34.3, abs=0.01)
    s = reference_shift(r, v, r_b, math.radians(offset_deg))
    assert _off_nadir(r + s, r_b) == pytest.approx(_off_nadir(r, r_b) + math.radians(offset_deg), abs=1e-7)
    unit = s / np.linalg.norm(s)
    assert abs(unit @ v) < 1e-9 * np.linalg.norm(v) and abs(unit @ r) < 1e-9 * np.linalg.norm(r)  # across, level
    assert (s @ (r_b - r) > 0) == (offset_deg < 0)  # towards the scene is a steeper look
    np.testing.assert_array_equal(reference_shift(r, v, r_b, 0.0), np.zeros(3))
    with pytest.raises(ConfigError, match=r"terrain\.reference_look_offset_deg"):
        reference_shift(r, v, r_b, math.radians(60.0))


def test_the_reference_clutter_is_lit_from_the_reference_pass_with_the_same_draws():
    """Flat terrain: the clutter power is cos(incidence) of each scatterer from each pass (``radar.terrain``); the
    reference's amplitudes from another place keep their phases and scale by sqrt(cos theta_ref / cos theta)."""
    from sarnav.radar.terrain import map_grid_around, synthetic_terrain, terrain_scene

    lat0, lon0 = math.radians(30.0), math.radians(-100.0)
    terrain = synthetic_terrain(map_grid_around(lat0, lon0, 600.0, 600.0, 20.0), np.random.default_rng(2), 0.0)
    centre = _to_ecef(lat0, lon0, 100.0)
    up, east = _normal(lat0, lon0), np.array([-math.sin(lon0), math.cos(lon0), 0.0])
    radar = centre + 690e3 * up - 470e3 * east  # about 34 deg off nadir, looking east
    other = centre + 690e3 * up - 340e3 * east  # a steeper look
    rest = (radar, 60.0, (2, 58, 2, 58), 4, 8.0, 0.7)  # spacing, extent, bright scatterers, their amplitude, coherence
    same = terrain_scene(terrain, np.random.default_rng(5), *rest)
    again = terrain_scene(terrain, np.random.default_rng(5), *rest, reference_ecef=radar)
    moved = terrain_scene(terrain, np.random.default_rng(5), *rest, reference_ecef=other)
    np.testing.assert_array_equal(again.reference, same.reference)
    np.testing.assert_array_equal(moved.amplitude, same.amplitude)
    clutter = ~same.bright
    np.testing.assert_array_equal(moved.reference[same.bright], same.reference[same.bright])
    np.testing.assert_allclose(np.angle(moved.reference[clutter] / same.reference[clutter]), 0.0, atol=1e-12)

    def cos_inc(p_radar):
        pos = same.positions[clutter]
        los = p_radar - pos
        los /= np.linalg.norm(los, axis=1, keepdims=True)
        lat = np.array([_to_geodetic(p)[0] for p in pos])
        lon = np.arctan2(pos[:, 1], pos[:, 0])
        return np.einsum("ij,ji->i", los, _normal(lat, lon))

    want = np.sqrt(cos_inc(other) / cos_inc(radar))
    assert np.all(want > 1.03)  # the steeper look sees more of the flat ground
    np.testing.assert_allclose(np.abs(moved.reference[clutter] / same.reference[clutter]), want, rtol=1e-6)


def test_a_reference_look_whose_window_cannot_hold_the_scene_names_the_key():
    """A shallower reference look spreads the scene over more slant range than the window holds: one line naming
    terrain.reference_look_offset_deg (not the echo simulator's near_range)."""
    from sarnav.trajectory.orbit import OrbitTruth, antenna_dcm, table2_elements

    cfg = ImagingConfig(range_samples=128, block=0.4, half_along=200.0, half_range=215.0, n_bright=4,
                        clutter_spacing=60.0, map_spacing=15.0, reference_look_offset=math.radians(10.0))
    im = SpacecraftImager(cfg, OrbitTruth(table2_elements(), 10.0, 0.1), antenna_dcm(math.radians(34.3)))
    with pytest.raises(ConfigError) as err:
        im.chip(0, 5.0)
    assert err.value.field == "terrain.reference_look_offset_deg" and "receive window" in err.value.message
