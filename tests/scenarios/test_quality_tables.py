"""``scenarios.quality_tables``: the tables the image-quality kinds share: the geometry and scene read from a
configuration (values in SI), every refusal with its key and range, and the size bounds (echo samples, echo work)
checked at their boundaries, computed here from their definitions."""

from __future__ import annotations

import copy

import pytest

from sarnav.errors import ConfigError
from sarnav.scenarios import quality_sweep
from sarnav.scenarios.quality_tables import MAX_ECHO_SAMPLES, MAX_ECHO_WORK, RADAR_KEYS, read_geometry, read_scene


@pytest.fixture
def cfg():
    return copy.deepcopy(quality_sweep.default_config())


def _error(fn, *args):
    with pytest.raises(ConfigError) as err:
        fn(*args)
    assert "\n" not in str(err.value)
    return err.value


def test_geometry_reads_the_shared_vocabulary(cfg):
    """speed, altitude (= -start_ned[2]), pulses, extent, ground range, pulse length [us -> s] and range margin."""
    cfg["trajectory"].update(speed=45.0, start_ned=[0.0, 0.0, -1500.0])
    cfg["aperture"]["n_pulses"] = 1200
    cfg["scene"].update(extent=30.0, ground_range=2000.0)
    cfg["radar"].update(pulse_length_us=0.5, range_margin_m=20.0)
    g = read_geometry(cfg)
    assert (g.speed, g.altitude, g.n_pulses, g.scene_extent, g.ground_range) == (45.0, 1500.0, 1200, 30.0, 2000.0)
    assert g.pulse_length == pytest.approx(0.5e-6, rel=1e-15) and g.range_margin == 20.0


def test_scene_reads_its_table_and_the_receiver(cfg):
    """[scene] and the receiver of [radar] land in the QualitySceneSpec unchanged."""
    cfg["scene"].update(type="point-clutter", seed=17, points=3, point_to_clutter_db=12.5, clutter_density=0.75,
                        usu_cells=30)
    cfg["radar"].update(receiver_noise=True, snr_db=-6.0)
    s = read_scene(cfg, read_geometry(cfg))
    assert (s.type, s.seed, s.points, s.point_to_clutter_db, s.clutter_density, s.usu_cells) == \
        ("point-clutter", 17, 3, 12.5, 0.75, 30)
    assert s.receiver_noise is True and s.snr_db == -6.0


@pytest.mark.parametrize("key, value, field, words", [
    ("radar.prf_hz", 1000.0, "radar.prf_hz", "known: " + ", ".join(RADAR_KEYS)),
    ("radar.preset", "nav-paper-sim", "radar.preset", "must be one of ['flexsar']"),
    ("trajectory.speed", 0.5, "trajectory.speed", "[1"),
    ("trajectory.speed", 400.0, "trajectory.speed", "the PRF is the source's"),
    ("scene.extent", 0.5, "scene.extent", "[1"),
    ("scene.ground_range", 40.0, "scene.ground_range", "twice scene.extent"),
    ("aperture.n_pulses", 15, "aperture.n_pulses", "[16, 100000]"),
    ("radar.pulse_length_us", 20.0, "radar.pulse_length_us", "10"),
    ("radar.range_margin_m", -1.0, "radar.range_margin_m", "0"),
])
def test_bad_geometry_is_one_line_naming_the_key(cfg, key, value, field, words):
    """Each bad value: a one-line ConfigError with its key and the valid range or reason."""
    sec, k = key.split(".")
    cfg[sec][k] = value
    err = _error(read_geometry, cfg)
    assert err.field == field and words in err.message, err


def test_echo_samples_bound_is_pulses_times_range_samples(cfg):
    """aperture.n_pulses is refused exactly when pulses x range samples exceeds MAX_ECHO_SAMPLES (the message gives
    both factors); a geometry just under the bound passes."""
    from sarnav.radar.quality_scenes import QualityGeometry

    def samples(n):
        return n * QualityGeometry(n_pulses=n, scene_extent=25.0).radar().n_range_samples

    hi = 60000
    assert samples(hi) > MAX_ECHO_SAMPLES
    cfg["aperture"]["n_pulses"] = hi
    err = _error(read_geometry, cfg)
    assert err.field == "aperture.n_pulses" and f"{hi} pulses x" in err.message
    lo = 20000
    assert samples(lo) <= MAX_ECHO_SAMPLES
    cfg["aperture"]["n_pulses"] = lo
    assert read_geometry(cfg).n_pulses == lo


def test_echo_work_bound_at_its_boundary(cfg):
    """Point clutter on 25 m x 25 m with 12 points and 4000 pulses: work = (12 + d 625) x 4000, over 1e8 from
    d = (25000 - 12) / 625 = 39.98 per m^2; the error names scene.clutter_density."""
    cfg["scene"].update(type="point-clutter", points=12, extent=25.0)
    cfg["aperture"]["n_pulses"] = 4000
    cfg["scene"]["clutter_density"] = 39.9
    assert read_scene(cfg, read_geometry(cfg)).clutter_density == 39.9
    cfg["scene"]["clutter_density"] = 40.0
    err = _error(read_scene, cfg, read_geometry(cfg))
    assert err.field == "scene.clutter_density" and f"{MAX_ECHO_WORK:.0e}" in err.message


def test_usu_work_bound_names_usu_cells(cfg):
    """A 240-cell USU picture (100 x the lit cells of the 24-cell one) over 20000 pulses exceeds the work bound."""
    from sarnav.radar.quality_scenes import usu_picture
    import numpy as np

    lit = np.count_nonzero(usu_picture((240, 240)))
    assert lit * 20000 > MAX_ECHO_WORK
    cfg["scene"].update(type="usu", usu_cells=240)
    cfg["aperture"]["n_pulses"] = 20000
    err = _error(read_scene, cfg, read_geometry(cfg))
    assert err.field == "scene.usu_cells"


@pytest.mark.parametrize("key, value, field", [
    ("scene.type", "city", "scene.type"),
    ("scene.seed", -1, "scene.seed"),
    ("scene.points", 1001, "scene.points"),
    ("scene.point_to_clutter_db", 81.0, "scene.point_to_clutter_db"),
    ("scene.clutter_density", -0.1, "scene.clutter_density"),
    ("scene.usu_cells", 23, "scene.usu_cells"),
    ("radar.receiver_noise", "yes", "radar.receiver_noise"),
    ("radar.snr_db", 101.0, "radar.snr_db"),
])
def test_bad_scene_is_one_line_naming_the_key(cfg, key, value, field):
    sec, k = key.split(".")
    cfg[sec][k] = value
    assert _error(read_scene, cfg, read_geometry(cfg)).field == field


def test_an_empty_scene_is_refused(cfg):
    """Point clutter with no points and no clutter: 'no scatterer', naming scene.points."""
    cfg["scene"].update(type="point-clutter", points=0, clutter_density=0.0)
    err = _error(read_scene, cfg, read_geometry(cfg))
    assert err.field == "scene.points" and "no scatterer" in err.message


def test_bounds_are_the_documented_sizes():
    """2^24 complex128 samples = 256 MiB; 1e8 echo evaluations."""
    assert MAX_ECHO_SAMPLES * 16 == 256 * 2**20 and MAX_ECHO_WORK == 1e8
