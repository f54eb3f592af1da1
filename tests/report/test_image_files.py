"""``sarnav.report.image_files``: the files of one image (``image.npz``, ``image.png``, ``metrics.json``, with a
simulated scene ``collect.cphd`` and ``image.nitf``), read back with numpy, json, matplotlib and sarkit."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from matplotlib.image import imread

from sarnav.radar.params import RadarParams
from sarnav.report.image_files import (PNG_DYNAMIC_RANGE_DB, json_safe, write_image_files, write_image_npz,
                                       write_image_png, write_json, write_scene_image)
from sarnav.signal.data import SarImage

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def strict_load(path):
    """JSON that refuses NaN / Infinity (what a strict reader does)."""
    def bad(name):
        raise ValueError(f"non-strict JSON constant {name}")
    return json.loads(path.read_text(), parse_constant=bad)


def radar() -> RadarParams:
    return RadarParams(carrier_frequency=9.75e9, bandwidth=150e6, pulse_length=0.5e-6, sample_rate=187.5e6,
                       prf=250.0, near_range=1960.0, n_range_samples=320, antenna_length=0.5)


def image(ny=24, nx=32, metadata=None, seed=0) -> SarImage:
    rng = np.random.default_rng(seed)
    data = rng.standard_normal((ny, nx)) + 1j * rng.standard_normal((ny, nx))
    data[ny // 3, nx // 4] = 50.0  # a bright point
    return SarImage(data, np.linspace(-5.0, 5.0, ny), 1990.0 + 0.75 * np.arange(nx), "along_track", "slant_range",
                    dict(metadata or {}))


# ---- json --------------------------------------------------------------------------------------------------------


def test_json_safe_turns_numpy_scalars_into_numbers_and_non_finite_into_none():
    obj = {"a": np.float32(1.5), "b": np.int64(7), 3: [np.float64(np.nan), math.inf, (1, -math.inf)],
           "c": {"d": np.float64(2.25), "e": "text", "f": None, "g": True}}
    got = json_safe(obj)
    assert got == {"a": 1.5, "b": 7, "3": [None, None, [1, None]], "c": {"d": 2.25, "e": "text", "f": None, "g": True}}
    assert type(got["a"]) is float and type(got["b"]) is int and type(got["c"]["d"]) is float


def test_write_json_writes_strict_json_that_reads_back(tmp_path):
    obj = {"snr_db": np.float64(12.5), "shape": (3, 4), "bad": np.nan, "nested": {"n": np.int32(2)}}
    path = write_json(obj, tmp_path / "metrics.json")
    assert path == tmp_path / "metrics.json"
    assert path.read_text().endswith("}\n")
    assert strict_load(path) == {"snr_db": 12.5, "shape": [3, 4], "bad": None, "nested": {"n": 2}}


# ---- image.npz ---------------------------------------------------------------------------------------------------


def test_image_npz_holds_data_axes_radar_figures_and_metadata(tmp_path):
    img = image(metadata={"algorithm": "rda", "closest_approach_range": np.float64(2001.5), "aperture_length": 60.0,
                          "quality": np.nan})
    params = radar()
    path = write_image_npz(img, params, tmp_path / "image.npz", speed=60.0, scenario_toml="[radar]\nprf = 250.0\n")
    assert path == tmp_path / "image.npz"
    with np.load(path, allow_pickle=False) as z:
        np.testing.assert_array_equal(z["data"], img.data)
        np.testing.assert_array_equal(z["y"], img.y)
        np.testing.assert_array_equal(z["x"], img.x)
        assert (str(z["y_name"]), str(z["x_name"])) == ("along_track", "slant_range")
        assert float(z["carrier_frequency"]) == 9.75e9
        assert float(z["bandwidth"]) == 150e6 and float(z["prf"]) == 250.0
        assert float(z["speed"]) == 60.0
        assert float(z["closest_approach_range"]) == 2001.5 and float(z["aperture_length"]) == 60.0
        assert str(z["scenario_toml"]) == "[radar]\nprf = 250.0\n"
        meta = json.loads(str(z["metadata_json"]), parse_constant=lambda c: pytest.fail(c))
    assert meta["algorithm"] == "rda" and meta["quality"] is None
    assert meta["wavelength"] == pytest.approx(299792458.0 / 9.75e9, rel=1e-15)


def test_image_npz_speed_from_metadata_and_missing_figures_as_nan(tmp_path):
    """The image's own speed (metadata) wins over the argument; absent geometry figures are NaN; a wavelength in the
    metadata is kept."""
    img = image(metadata={"speed": 55.5, "wavelength": 0.03})
    write_image_npz(img, radar(), tmp_path / "image.npz", speed=60.0)
    with np.load(tmp_path / "image.npz", allow_pickle=False) as z:
        assert float(z["speed"]) == 55.5
        assert math.isnan(float(z["closest_approach_range"])) and math.isnan(float(z["aperture_length"]))
        assert json.loads(str(z["metadata_json"]))["wavelength"] == 0.03
        assert str(z["scenario_toml"]) == ""


# ---- image.png ---------------------------------------------------------------------------------------------------


def test_image_png_is_a_png_showing_the_image(tmp_path):
    img = image()
    path = write_image_png(img, tmp_path / "sub" / "image.png", "a title")
    assert path == tmp_path / "sub" / "image.png"
    assert path.read_bytes()[:8] == PNG_MAGIC
    pixels = imread(path)
    assert pixels.ndim == 3 and pixels.shape[0] > 100 and pixels.shape[1] > 100
    assert np.ptp(pixels[..., :3]) > 0.5  # black-to-white grey scale drawn, not a blank canvas


def test_png_dynamic_range_is_50_db():
    assert PNG_DYNAMIC_RANGE_DB == 50.0


# ---- write_image_files -------------------------------------------------------------------------------------------


def test_image_files_writes_npz_metrics_and_png_only_unless_asked(tmp_path):
    img = image()
    metrics = {"image_shape": [24, 32], "peak_db": np.float64(-0.0), "contrast": math.nan}
    write_image_files(tmp_path, img, radar(), metrics, "title", speed=60.0, scenario_toml="x = 1\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["image.npz", "image.png", "metrics.json"]
    assert strict_load(tmp_path / "metrics.json") == {"image_shape": [24, 32], "peak_db": -0.0, "contrast": None}
    with np.load(tmp_path / "image.npz", allow_pickle=False) as z:
        np.testing.assert_array_equal(z["data"], img.data)
        assert str(z["scenario_toml"]) == "x = 1\n"
    assert (tmp_path / "image.png").read_bytes()[:8] == PNG_MAGIC


# ---- write_scene_image -------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def scenes():
    """Two small simulated point-target scenes (half a second at 250 Hz): RDA and BPA."""
    from sarnav.simulation.image_scene import ImageSceneParams, run

    out = {}
    for alg in ("rda", "bpa"):
        p = ImageSceneParams(radar=radar(), start_ned=(10.0, -5.0, -1000.0), speed=60.0, duration=0.5,
                             target_along_track=1.0, target_slant_range=2003.0, algorithm=alg, name="tiny")
        out[alg] = (p, run(p))
    return out


def test_scene_image_without_extras_writes_the_image_files_and_its_metrics(scenes, tmp_path):
    p, res = scenes["rda"]
    metrics = write_scene_image(p, res, tmp_path, scenario_toml="[scene]\n")
    assert metrics == res.metrics and "files" not in metrics
    assert sorted(f.name for f in tmp_path.iterdir()) == ["image.npz", "image.png", "metrics.json"]
    assert strict_load(tmp_path / "metrics.json") == json.loads(json.dumps(json_safe(res.metrics)))
    with np.load(tmp_path / "image.npz", allow_pickle=False) as z:
        np.testing.assert_array_equal(z["data"], res.image.data)
        assert float(z["speed"]) == 60.0 and str(z["scenario_toml"]) == "[scene]\n"


def test_scene_image_collect_is_a_cphd_of_the_pulses(scenes, tmp_path):
    """collect.cphd: one vector per pulse, listed in the metrics' files; the result's own metrics untouched."""
    skcphd = pytest.importorskip("sarkit.cphd")
    p, res = scenes["rda"]
    before = dict(res.metrics)
    metrics = write_scene_image(p, res, tmp_path, cphd=True)
    assert metrics["files"] == ["collect.cphd"] and res.metrics == before
    assert strict_load(tmp_path / "metrics.json")["files"] == ["collect.cphd"]
    with open(tmp_path / "collect.cphd", "rb") as f, skcphd.Reader(f) as r:
        xml = r.metadata.xmltree
        n_vec = int(xml.find("./{*}Data/{*}Channel/{*}NumVectors").text)
        fxc = float(xml.find("./{*}Channel/{*}Parameters/{*}FxC").text)
    assert n_vec == res.pulses.data.shape[0] == round(p.duration * p.radar.prf)
    assert fxc == pytest.approx(p.radar.carrier_frequency, rel=1e-9)


def test_scene_image_sicd_of_a_bpa_image(scenes, tmp_path):
    """image.nitf holds the BPA image's pixels as SICD: the same magnitudes (complex64), the array oriented as SICD
    wants it (range rows: transposed and/or flipped; the phase deramped)."""
    sksicd = pytest.importorskip("sarkit.sicd")
    p, res = scenes["bpa"]
    metrics = write_scene_image(p, res, tmp_path, cphd=True, sicd=True)
    assert metrics["files"] == ["collect.cphd", "image.nitf"]
    with open(tmp_path / "image.nitf", "rb") as f, sksicd.NitfReader(f) as reader:
        pixels = reader.read_image()
    assert sorted(pixels.shape) == sorted(res.image.data.shape)
    want = np.sort(np.abs(res.image.data.astype(np.complex64)).ravel())
    np.testing.assert_allclose(np.sort(np.abs(pixels).ravel()), want, rtol=1e-5, atol=1e-6 * want[-1])
