"""The SICD reader (``io.sicd.read_sicd``) on a SICD written by sarnav: each simulated scatterer's true position
projects (ground-to-image) onto its peak in the pixels read, and the peak projects back (image-to-ground, onto the
scatterer's height) onto the true position, both within 0.1 pixel; a DEM given as the surface gives the same point;
the pixel types sarkit writes read back to the same complex values; bad fields are one error naming the field.

Chain: echo simulator (raw, NED) -> CPHD -> read back (ECEF) -> BPA on the ground plane -> SICD -> ``read_sicd``.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("sarkit")
import sarkit.sicd as sksicd  # noqa: E402
import sarkit.wgs84 as wgs84  # noqa: E402

from sarnav.errors import InputDataError  # noqa: E402
from sarnav.io.sicd import SicdGeometry, SicdProduct, read_sicd, write_image  # noqa: E402
from sarnav.signal.metrics import peak_location  # noqa: E402

REF = (-33.9, 151.2, 40.0)          # == tests/io/conftest.py (the ground_scene fixture)


@pytest.fixture(scope="module")
def written(ground_scene):
    g = ground_scene
    assert tuple(g.ref) == REF
    geo = SicdGeometry(g.grid, g.rc.positions, g.rc.pulse_times, g.rc.wavelength, 150e6)
    return g.out / "image.nitf", write_image(g.out / "image.nitf", g.image, geo)


def test_read_back_pixels_and_metadata(written):
    path, xml = written
    prod = read_sicd(path)
    with open(path, "rb") as f, sksicd.NitfReader(f) as r:
        direct = r.read_image()
    assert isinstance(prod, SicdProduct) and prod.pixels.dtype == np.complex64
    assert prod.shape == prod.pixels.shape == direct.shape and np.array_equal(prod.pixels, direct)
    assert prod.spacing == (float(xml.findtext("{*}Grid/{*}Row/{*}SS")), float(xml.findtext("{*}Grid/{*}Col/{*}SS")))
    assert read_sicd(path, pixels=False).pixels is None


def test_scatterers_project_within_a_tenth_of_a_pixel_both_ways(written, ground_scene):
    prod = read_sicd(written[0])
    truth, targets = ground_scene.truth, ground_scene.targets
    rows, cols = prod.ground_to_image(truth)
    hae = wgs84.cartesian_to_geodetic(truth)[:, 2]
    for k in range(len(targets)):
        peak = np.array(peak_location(prod.pixels, near=(int(round(rows[k])), int(round(cols[k]))), search_radius=3))
        assert np.all(np.abs(peak - (rows[k], cols[k])) < 0.1), (k, peak, rows[k], cols[k])
        back = prod.image_to_ground(peak[0], peak[1], hae[k])
        # the error in pixels along the image axes (the grid is on the ground: the plane of the scatterers)
        urow = np.array([float(written[1].findtext(f"{{*}}Grid/{{*}}Row/{{*}}UVectECF/{{*}}{c}")) for c in "XYZ"])
        ucol = np.array([float(written[1].findtext(f"{{*}}Grid/{{*}}Col/{{*}}UVectECF/{{*}}{c}")) for c in "XYZ"])
        err_px = np.array([(back - truth[k]) @ urow / prod.spacing[0], (back - truth[k]) @ ucol / prod.spacing[1]])
        assert np.all(np.abs(err_px) < 0.1) and abs(wgs84.cartesian_to_geodetic(back)[2] - hae[k]) < 1e-3, err_px
        print(f"scatterer {k}: ground-to-image vs peak {np.abs(peak - (rows[k], cols[k])).max():.4f} px, "
              f"image-to-ground {np.abs(err_px).max():.4f} px")


def test_image_to_ground_round_trips_and_follows_a_terrain(written):
    prod = read_sicd(written[0])
    rows, cols = np.meshgrid([3.0, 30.5, 61.25], [2.0, 40.0, 64.5], indexing="ij")
    for hae in (40.0, 140.0):
        pts = prod.image_to_ground(rows, cols, hae)
        assert pts.shape == rows.shape + (3,)
        assert np.allclose(wgs84.cartesian_to_geodetic(pts)[..., 2], hae, atol=1e-3)
        r2, c2 = prod.ground_to_image(pts)
        assert np.allclose(r2, rows, atol=1e-3) and np.allclose(c2, cols, atol=1e-3)
    # a terrain tilted 2 % to the north: the projected points lie on it
    lat0 = REF[0]

    def terrain(lat, lon):
        return 40.0 + 0.02 * (np.asarray(lat) - lat0) * 111_000.0

    pts = prod.image_to_ground(rows, cols, terrain)
    llh = wgs84.cartesian_to_geodetic(pts)
    assert np.allclose(llh[..., 2], terrain(llh[..., 0], llh[..., 1]), atol=2e-3)
    r2, c2 = prod.ground_to_image(pts)
    assert np.allclose(r2, rows, atol=1e-3) and np.allclose(c2, cols, atol=1e-3)


@pytest.mark.parametrize("pixel_type", ["RE16I_IM16I", "AMP8I_PHS8I"])
def test_integer_pixel_types_read_as_complex(written, tmp_path, pixel_type):
    path, xml = written
    with open(path, "rb") as f, sksicd.NitfReader(f) as r:
        meta, px = r.metadata, r.read_image()
    tree = meta.xmltree
    tree.find("{*}ImageData/{*}PixelType").text = pixel_type
    if pixel_type == "RE16I_IM16I":
        scale = 30000.0 / np.abs(px).max()
        raw = np.zeros(px.shape, sksicd.PIXEL_TYPES[pixel_type]["dtype"])
        raw["real"], raw["imag"] = np.round(px.real * scale), np.round(px.imag * scale)
        expect = (raw["real"] + 1j * raw["imag"]).astype(np.complex64)
    else:
        raw = np.zeros(px.shape, sksicd.PIXEL_TYPES[pixel_type]["dtype"])
        amp = np.abs(px) / np.abs(px).max() * 255
        raw["amp"] = np.round(amp).astype(np.uint8)
        raw["phase"] = np.round(np.angle(px) / (2 * np.pi) * 256).astype(np.int64) % 256
        expect = raw["amp"] * np.exp(2j * np.pi * raw["phase"] / 256.0)     # no AmpTable: amplitude as stored
    out = tmp_path / f"{pixel_type}.nitf"
    meta2 = sksicd.NitfMetadata(xmltree=tree, file_header_part=meta.file_header_part,
                                im_subheader_part=meta.im_subheader_part, de_subheader_part=meta.de_subheader_part)
    with open(out, "wb") as f, sksicd.NitfWriter(f, meta2) as w:
        w.write_image(raw)
    prod = read_sicd(out)
    assert prod.pixels.dtype == np.complex64 and np.allclose(prod.pixels, expect, atol=1e-4 * np.abs(expect).max())


def _edited(src, dst, path, text):
    with open(src, "rb") as f, sksicd.NitfReader(f) as r:
        meta, px = r.metadata, r.read_image()
    meta.xmltree.find("./{*}" + path.replace(".", "/{*}")).text = text
    with open(dst, "wb") as f, sksicd.NitfWriter(f, meta) as w:
        w.write_image(px)
    return dst


@pytest.mark.filterwarnings("ignore::UserWarning")        # sarkit's schema check on writing the bad value
@pytest.mark.parametrize("fld, text, words", [
    ("Grid.Row.SS", "0", "in [1e-06, 10000]"),
    ("Grid.Col.SS", "nan", "finite"),
    ("Grid.Row.UVectECF.X", "3.0", "unit vector"),
    ("GeoData.SCP.ECF.Z", "1e7", "ellipsoid"),
    ("SCPCOA.SideOfTrack", "X", "L or R"),
    ("Position.ARPPoly.X.Coef", "inf", "finite"),
])
def test_bad_fields_are_named(written, tmp_path, fld, text, words):
    bad = _edited(written[0], tmp_path / "bad.nitf", fld, text)
    name = fld.removesuffix(".X").removesuffix(".Z").removesuffix(".Coef")
    if name == "Position.ARPPoly.X":
        name = "Position.ARPPoly"
    with pytest.raises(InputDataError, match=f"^sicd.{name}") as err:
        read_sicd(bad)
    assert words in str(err.value) and "bad.nitf" in str(err.value) and "\n" not in str(err.value)


def test_unknown_pixel_type_is_named(written, tmp_path):
    data = written[0].read_bytes()
    bad = tmp_path / "pixel_type.nitf"
    bad.write_bytes(data.replace(b"PixelType>RE32F_IM32F<", b"PixelType>RE64F_IM64F<"))
    with pytest.raises(InputDataError, match="^sicd.ImageData.PixelType: must be one of"):
        read_sicd(bad)


def test_inconsistent_antenna_track_is_refused(written, tmp_path):
    path = written[0]
    with open(path, "rb") as f, sksicd.NitfReader(f) as r:
        x0 = float(r.metadata.xmltree.findtext("{*}Position/{*}ARPPoly/{*}X/{*}Coef"))
    bad = _edited(path, tmp_path / "moved.nitf", "Position.ARPPoly.X.Coef", repr(x0 + 2000.0))
    with pytest.raises(InputDataError, match="^sicd.Position.ARPPoly: .* SCPCOA.ARPPos"):
        read_sicd(bad)


def test_projection_onto_a_dem_geotiff(written, tmp_path):
    """The reference (b) chain: a SICD and a DEM GeoTIFF (EPSG:4326, a 3 % slope to the east with a void) -> each pixel
    projected onto the terrain lies on the DEM's bilinear surface and projects back onto the same pixel."""
    pytest.importorskip("rasterio")
    from sarnav.io.geotiff import read_dem, write_geotiff

    prod = read_sicd(written[0])
    lat_top, lon_left, d = REF[0] + 0.002, REF[1] - 0.002, 2e-5
    lat_c = lat_top - (np.arange(200) + 0.5) * d
    lon_c = lon_left + (np.arange(200) + 0.5) * d
    z = 40.0 + 0.03 * (lon_c[None, :] - REF[1]) * 92_500.0 + 0.0 * lat_c[:, None]
    z[150:160, 150:160] = -9999.0
    write_geotiff(tmp_path / "dem.tif", z.astype(np.float32), "EPSG:4326", (d, 0, lon_left, 0, -d, lat_top),
                  nodata=-9999.0)
    dem = read_dem(tmp_path / "dem.tif")
    rows, cols = np.meshgrid([5.0, 35.0, 64.5], [3.0, 33.0, 60.0], indexing="ij")
    pts = prod.image_to_ground(rows, cols, dem.height)
    llh = wgs84.cartesian_to_geodetic(pts)
    assert np.all(np.isfinite(pts)) and np.allclose(llh[..., 2], dem.height(llh[..., 0], llh[..., 1]), atol=2e-3)
    assert np.ptp(llh[..., 2]) > 1.0                     # the terrain is not flat over the pixels
    r2, c2 = prod.ground_to_image(pts)
    assert np.allclose(r2, rows, atol=1e-3) and np.allclose(c2, cols, atol=1e-3)
    outside = prod.image_to_ground(5.0, 3.0, lambda lat, lon: np.full(np.shape(lat), np.nan))
    assert np.all(np.isnan(outside))
