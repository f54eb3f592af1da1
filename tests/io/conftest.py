"""A small simulated point-target scene imaged by back-projection on the ground plane in ECEF (shared by the SICD
reader and GeoTIFF tests): echo simulator (raw, NED) -> CPHD -> read back (ECEF) -> BPA on the tangent plane."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

#: the scene's reference point: southern, eastern hemisphere (tests/io/test_sicd.py is at 58.4 N, 15.6 E)
REF = (-33.9, 151.2, 40.0)
#: scatterers, NED at REF [m], on the ground plane
TARGETS = np.array([[0.0, 0.0, 0.0], [9.3, -11.1, 0.0], [-12.6, 8.2, 0.0], [4.4, 13.7, 0.0]])


@pytest.fixture(scope="session")
def ground_scene(tmp_path_factory):
    pytest.importorskip("sarkit")
    from sarnav.imaging.backprojection import backproject
    from sarnav.imaging.grid import GroundGrid
    from sarnav.io.cphd import read_collect, write_collect
    from sarnav.io.frames import ground_grid_to_ecef, ned_to_ecef
    from sarnav.radar.echoes import simulate_echoes
    from sarnav.radar.params import RadarParams
    from sarnav.radar.scene import point_targets

    out = tmp_path_factory.mktemp("ground_scene")
    p, prf, speed = 256, 400.0, 50.0
    t = (np.arange(p) - 0.5 * (p - 1)) / prf
    pos = np.column_stack([np.full(p, 1700.0), speed * t, np.full(p, -1100.0)])        # flying east, looking south
    params = RadarParams(carrier_frequency=9.75e9, bandwidth=150e6, pulse_length=0.5e-6, sample_rate=187.5e6,
                         prf=prf, near_range=1960.0, n_range_samples=320, antenna_length=1.0)
    raw = simulate_echoes(params, pos, t, point_targets(TARGETS), pattern=False)
    write_collect(out / "collect.cphd", raw, REF, window="none", image_half_extent=(30.0, 30.0))
    rc, _ = read_collect(out / "collect.cphd")
    grid = ground_grid_to_ecef(GroundGrid.centered(0.0, 0.0, 0.6, (70, 66)), REF)
    return SimpleNamespace(ref=REF, targets=TARGETS, out=out, rc=rc, grid=grid, image=backproject(rc, grid), truth=ned_to_ecef(TARGETS, REF))
