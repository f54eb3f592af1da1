"""``sarnav image FILE.cphd --sicd --geotiff`` with the file's image grid (no ``--spacing``): the SICD passes sarkit's
checker with no error and no warning (issue 28 item 5: the pixels spaced from the impulse-response bandwidth, an
oversampling ratio of :data:`sarnav.io.sicd.SICD_OVERSAMPLING` on both axes), reads back with ``io.sicd.read_sicd``
and projects the simulated target onto its peak within 0.1 pixel; the GeoTIFF opens in rasterio with a UTM CRS and
puts the target within one pixel of its map position; ``--geotiff`` refused in one line where it does not apply.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("sarkit")
rasterio = pytest.importorskip("rasterio")
import sarkit.verification as skver  # noqa: E402
import sarkit.wgs84 as wgs84  # noqa: E402

from sarnav.cli.main import main  # noqa: E402
from sarnav.io.frames import ned_to_ecef  # noqa: E402
from sarnav.io.geotiff import read_orthoimage  # noqa: E402
from sarnav.io.sicd import SICD_OVERSAMPLING, read_sicd  # noqa: E402
from sarnav.scenarios import imaging as scen  # noqa: E402
from sarnav.scenarios.config import load_scenario  # noqa: E402
from sarnav.signal.metrics import peak_location  # noqa: E402
from sarnav.simulation import image_scene  # noqa: E402

SETS = ["--set", "radar.range_margin_m=2.0", "--set", "scene.target_along_track_m=2.9",
        "--set", "scene.target_slant_range_m=1997.37"]


@pytest.fixture(scope="module")
def outs(tmp_path_factory):
    root = tmp_path_factory.mktemp("geo_cli")
    a, b = root / "a", root / "b"
    assert main(["image", "point-target", "--algorithm", "bpa", "--cphd", "--out", str(a), *SETS]) == 0
    assert main(["image", str(a / "collect.cphd"), "--sicd", "--geotiff", "--out", str(b)]) == 0
    cfg = load_scenario("point-target", [s for s in SETS if s != "--set"])
    centre, _ = image_scene.scene_centre(scen.parse(cfg))
    return a, b, ned_to_ecef(centre, scen.origin_llh(cfg))


def test_sicd_on_the_default_grid_passes_the_checker_without_a_warning(outs):
    path = outs[1] / "image.nitf"
    with open(path, "rb") as f:
        con = skver.SicdConsistency.from_file(f)
        con.check()
    failed = {k: [d["details"] for d in v["details"] if not d["passed"]] for k, v in con.failures().items()}
    assert not any(failed.values()), failed
    exe = shutil.which("sicdcheck") or shutil.which("sicdcheck", path=str(__import__("pathlib").Path(sys.executable).parent))
    if exe:                                    # the command itself: exit 0, nothing reported
        res = subprocess.run([exe, str(path)], capture_output=True, text=True, timeout=300)
        assert res.returncode == 0 and "Error" not in res.stdout and "Warning" not in res.stdout, res.stdout
    prod = read_sicd(path)
    for ax in ("Row", "Col"):
        ss = float(prod.xml.findtext(f"{{*}}Grid/{{*}}{ax}/{{*}}SS"))
        bw = float(prod.xml.findtext(f"{{*}}Grid/{{*}}{ax}/{{*}}ImpRespBW"))
        assert 1.1 <= 1 / (ss * bw) <= 2.2 and abs(1 / (ss * bw) - SICD_OVERSAMPLING) < 0.02 * SICD_OVERSAMPLING
    m = json.loads((outs[1] / "metrics.json").read_text())
    assert m["files"] == ["image.nitf", "image.tif"] and tuple(m["image_shape"]) in (prod.shape, prod.shape[::-1])


def test_sicd_read_back_projects_the_target_onto_its_peak(outs):
    prod = read_sicd(outs[1] / "image.nitf")
    rows, cols = (float(v) for v in prod.ground_to_image(outs[2]))
    peak = np.array(peak_location(prod.pixels, near=(int(round(rows)), int(round(cols))), search_radius=3))
    assert np.all(np.abs(peak - (rows, cols)) < 0.1), (peak, rows, cols)
    back = prod.image_to_ground(peak[0], peak[1], wgs84.cartesian_to_geodetic(outs[2])[2])
    assert np.linalg.norm(back - outs[2]) < 0.1 * min(prod.spacing)
    print(f"SICD {prod.shape}, spacing {prod.spacing}: peak - projection {peak - (rows, cols)} px, "
          f"image-to-ground {np.linalg.norm(back - outs[2]):.4f} m")


def test_geotiff_opens_with_its_crs_and_puts_the_target_within_one_pixel(outs):
    path = outs[1] / "image.tif"
    with rasterio.open(path) as src:
        assert src.crs.to_epsg() // 100 in (326, 327) and src.nodata != src.nodata   # UTM, nodata NaN
    ortho = read_orthoimage(path)
    lat, lon, _ = wgs84.cartesian_to_geodetic(outs[2])
    r, c = (float(v) for v in ortho.pixel_of(lat, lon))
    win = np.nan_to_num(ortho.values[int(r) - 3:int(r) + 4, int(c) - 3:int(c) + 4], nan=-1.0)
    i, j = np.unravel_index(np.argmax(win), win.shape)
    assert abs(int(r) - 3 + i - r) <= 1.0 and abs(int(c) - 3 + j - c) <= 1.0, (i, j, r, c)
    print(f"GeoTIFF {ortho.shape} {ortho.crs}: peak - map position {int(r) - 3 + i - r:+.3f}, {int(c) - 3 + j - c:+.3f} px")


def test_geotiff_refused_in_one_line_where_it_does_not_apply(outs, tmp_path, capsys, monkeypatch):
    code = main(["image", "point-target", "--geotiff", "--out", str(tmp_path / "x")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("sarnav: error: --geotiff: "), err
    monkeypatch.setitem(sys.modules, "rasterio", None)                 # the extra not installed
    code = main(["image", str(outs[0] / "collect.cphd"), "--geotiff", "--out", str(tmp_path / "y")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("sarnav: error: --geotiff: ") and \
        "pip install 'sarnav[geo]'" in err[0] and not (tmp_path / "y" / "image.npz").exists(), err
