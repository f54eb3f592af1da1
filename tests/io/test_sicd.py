"""SICD written by sarnav: passes sarkit's checker, and SICD Volume 3 projection of each simulated
scatterer's true position lands within 0.1 pixel of its peak in the written pixels.

Chain: echo simulator (raw, NED) -> CPHD (range compressed on write) -> read back (ECEF) ->
back-projection on the tangent plane -> SICD (image.nitf) -> sarkit projection.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("sarkit")
import sarkit.sicd as sksicd  # noqa: E402
import sarkit.sicd.projection as skproj  # noqa: E402
import sarkit.verification as skver  # noqa: E402

from sarnav.errors import InputDataError  # noqa: E402
from sarnav.imaging.backprojection import backproject  # noqa: E402
from sarnav.imaging.grid import GroundGrid  # noqa: E402
from sarnav.io.cphd import read_collect, write_collect  # noqa: E402
from sarnav.io.frames import ground_grid_to_ecef, ned_to_ecef  # noqa: E402
from sarnav.io.sicd import SicdGeometry, write_image  # noqa: E402
from sarnav.radar.echoes import simulate_echoes  # noqa: E402
from sarnav.radar.params import RadarParams  # noqa: E402
from sarnav.radar.scene import point_targets  # noqa: E402
from sarnav.signal.metrics import peak_location  # noqa: E402

REF = (58.4, 15.6, 100.0)
TARGETS = np.array([[0.0, 0.0, 0.0], [10.3, -9.7, 0.0], [-12.2, 11.9, 0.0]])   # NED at REF [m]


@pytest.fixture(scope="module")
def sicd_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("sicd")
    p, prf, speed = 256, 400.0, 50.0
    t = (np.arange(p) - 0.5 * (p - 1)) / prf
    pos = np.column_stack([speed * t, np.full(p, -1800.0), np.full(p, -1000.0)])
    params = RadarParams(carrier_frequency=9.75e9, bandwidth=150e6, pulse_length=0.5e-6, sample_rate=187.5e6,
                         prf=prf, near_range=1990.0, n_range_samples=320, antenna_length=1.0)
    raw = simulate_echoes(params, pos, t, point_targets(TARGETS), pattern=False)
    write_collect(out / "collect.cphd", raw, REF, window="none", image_half_extent=(30.0, 30.0))
    rc, _ = read_collect(out / "collect.cphd")
    grid = ground_grid_to_ecef(GroundGrid.centered(0.0, 0.0, 0.6, (72, 64)), REF)
    img = backproject(rc, grid)
    write_image(out / "image.nitf", img, SicdGeometry(grid, rc.positions, rc.pulse_times, rc.wavelength, 150e6))
    return out / "image.nitf", rc, grid, img


def test_written_sicd_passes_sarkit_consistency_check(sicd_file):
    path = sicd_file[0]
    with open(path, "rb") as f:
        con = skver.SicdConsistency.from_file(f)
        con.check()
    assert con.passes() and not con.failures(), con.failures()


def test_projection_of_true_positions_lands_on_the_peaks(sicd_file):
    path = sicd_file[0]
    with open(path, "rb") as f, sksicd.NitfReader(f) as reader:
        pixels = reader.read_image()
        xml = reader.metadata.xmltree
    locs, _, ok = skproj.scene_to_image(skproj.MetadataParams.from_xml(xml), ned_to_ecef(TARGETS, REF))
    assert ok
    rowcol = sksicd.xrowycol_to_rowcol(xml, locs)
    for rc_ in rowcol:
        near = tuple(int(round(v)) for v in rc_)
        peak = peak_location(pixels, near=near, search_radius=3)      # complex: the band-limited peak
        assert np.all(np.abs(np.subtract(peak, rc_)) < 0.1), (peak, rc_)


def test_bad_geometry_is_named(sicd_file, tmp_path):
    _, rc, grid, img = sicd_file
    bad = rc.positions.copy()
    bad[3, 0] = np.nan
    with pytest.raises(InputDataError, match="^geometry.positions"):
        write_image(tmp_path / "x.nitf", img, SicdGeometry(grid, bad, rc.pulse_times, rc.wavelength, 150e6))
    with pytest.raises(InputDataError, match="^geometry.grid"):
        write_image(tmp_path / "x.nitf", img, SicdGeometry(grid.points(), rc.positions, rc.pulse_times,
                                                           rc.wavelength, 150e6))


def test_file_title_names_the_algorithm_that_formed_the_pixels(sicd_file, tmp_path):
    """FTITLE says BPA for a back-projected image and FFBP for a factorised one (not "BPA" for every image)."""
    from dataclasses import replace

    path, rc, grid, img = sicd_file
    with open(path, "rb") as f, sksicd.NitfReader(f) as reader:
        assert reader.metadata.file_header_part.ftitle == "sarnav BPA image"
    fast = replace(img, metadata=dict(img.metadata, algorithm="ffbp"))
    write_image(tmp_path / "ffbp.nitf", fast, SicdGeometry(grid, rc.positions, rc.pulse_times, rc.wavelength, 150e6))
    with open(tmp_path / "ffbp.nitf", "rb") as f, sksicd.NitfReader(f) as reader:
        assert reader.metadata.file_header_part.ftitle == "sarnav FFBP image"
