"""CPHD written by sarnav: passes sarkit's consistency checker, reads back to the same image (< -120 dB)."""

from __future__ import annotations

import numpy as np
import pytest

sarkit = pytest.importorskip("sarkit")
import sarkit.cphd as skcphd  # noqa: E402
import sarkit.verification as skver  # noqa: E402

from sarnav.errors import ConfigError, InputDataError  # noqa: E402
from sarnav.imaging.backprojection import backproject  # noqa: E402
from sarnav.imaging.grid import GroundGrid, PointGrid  # noqa: E402
from sarnav.io.cphd import read_collect, write_collect  # noqa: E402
from sarnav.io.frames import ecef_to_ned, ned_to_ecef  # noqa: E402
from sarnav.signal.data import PulseData  # noqa: E402

C = 299792458.0
FC, BW = 9.75e9, 150e6
LAM = C / FC
REF = (34.0, -118.0, 10.0)          # scene reference point: lat, lon [deg], hae [m]
TARGETS = np.array([[0.0, 0.0, 0.0], [3.0, 5.0, 0.0], [-4.0, -6.0, 0.0]])


def collect(p=128):
    """Ideal range-compressed pulses (sinc, docs/conventions.md) of three targets, NED, north track."""
    pos = np.zeros((p, 3))
    pos[:, 0] = (np.arange(p) - p / 2) * 0.1
    pos[:, 1] = -1732.0
    pos[:, 2] = -1000.0
    rt = np.linalg.norm(TARGETS[None] - pos[:, None], axis=2)
    dr = C / (4 * BW)
    r = rt.min() - 40 * dr + np.arange(int((rt.max() - rt.min()) / dr) + 80) * dr
    data = sum(a * np.sinc(2 * BW / C * (r[None] - rt[:, t:t + 1])) * np.exp(-4j * np.pi * rt[:, t:t + 1] / LAM)
               for t, a in enumerate((1.0, 0.5, 0.7)))
    return PulseData(data, r, np.arange(p) / 400.0, pos, None, compressed=True, wavelength=LAM)


def error_db(a, b):
    return float(10 * np.log10(np.sum(np.abs(a - b) ** 2) / np.sum(np.abs(b) ** 2)))


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    path = tmp_path_factory.mktemp("cphd") / "collect.cphd"
    rc = collect()
    write_collect(path, rc, REF, image_half_extent=(20.0, 20.0), image_spacing=0.5)
    return path, rc


def test_written_cphd_passes_sarkit_consistency_check(written):
    path, _ = written
    with open(path, "rb") as f:
        con = skver.CphdConsistency.from_file(f, thorough=True)
        con.check()
    assert con.passes() and not con.failures(), con.failures()


def test_read_back_image_equals_the_image_formed_from_memory(written):
    path, rc = written
    back, grid = read_collect(path, oversample=1.0)   # the DFT lattice: the pulses written
    assert back.data.shape == rc.data.shape and back.params is None
    np.testing.assert_allclose(back.slant_range, rc.slant_range, rtol=0, atol=1e-6)
    np.testing.assert_allclose(ecef_to_ned(back.positions, REF), rc.positions, rtol=0, atol=1e-6)
    g = GroundGrid.centered(0.0, 0.0, 0.25, (64, 64))
    a = backproject(rc, g).data
    b = backproject(back, PointGrid(ned_to_ecef(g.points(), REF))).data
    assert error_db(b, a) < -120.0
    # default grid: the file's image grid, 81 x 81 at 0.5 m on the tangent plane (ECEF) around the SRP
    assert grid.shape == (81, 81)
    np.testing.assert_allclose(ecef_to_ned(grid.points()[40, 40], REF), [0, 0, 0], atol=1e-6)


def _rewrite_without(path, out, pvp_name):
    with open(path, "rb") as f, skcphd.Reader(f) as r:
        tree = r.metadata.xmltree
        sig, pvp = r.read_channel("1")
    el = tree.find(f"./{{*}}PVP/{{*}}{pvp_name}")
    el.getparent().remove(el)
    new = np.zeros(pvp.shape, dtype=skcphd.get_pvp_dtype(tree))
    for name in new.dtype.names:
        new[name] = pvp[name]
    with open(out, "wb") as f, skcphd.Writer(f, skcphd.Metadata(xmltree=tree)) as w:
        w.write_signal("1", sig)
        w.write_pvp("1", new)


def test_bad_input_one_line_named_errors(written, tmp_path):
    path, rc = written
    _rewrite_without(path, tmp_path / "no_srp.cphd", "SRPPos")
    with pytest.raises(InputDataError, match=r"^cphd.PVP.SRPPos: missing required"):
        read_collect(tmp_path / "no_srp.cphd")
    bad = rc.positions.copy()
    bad[5, 0] = np.nan
    with pytest.raises(InputDataError, match="^pulses.positions"):
        write_collect(tmp_path / "x.cphd", PulseData(rc.data, rc.slant_range, rc.pulse_times, bad, None, True,
                                                     wavelength=LAM), REF)
    with pytest.raises(ConfigError, match="^image_spacing"):
        write_collect(tmp_path / "x.cphd", rc, REF, image_spacing=0.0)
    with pytest.raises(ConfigError, match="^grid.north.spacing"):
        GroundGrid.centered(0.0, 0.0, -0.5, (4, 4))
    with pytest.raises(ConfigError, match="^params"):
        write_collect(tmp_path / "x.cphd", PulseData(rc.data, rc.slant_range, rc.pulse_times, rc.positions, None),
                      REF)
