"""Shared fixtures. The tests folder mirrors the package (tests/filters/ for sarnav.filters, ...); this folder is on
``sys.path`` (pytest's rootdir conftest), so helper modules here (``toy_kind``; ``helpers``: per-run generators and
seeds, NavStates from a truth or level, child process ids) import from any test.

Fixtures
--------
small_radar : an X-band radar with a short receive window (fast echo simulation), 60 m/s-capable PRF.
point_target_block : one range-compressed block of one point target flown past at 60 m/s, with its geometry.
short_flight : the rda-nav paper flight cut to 3 s (parsed parameters), for spine and measurement tests.
small_campaigns : finished telemetry campaigns (4 runs, 2 s, serial) written by ``sarnav run``: ``tactical`` (with
    figures) and ``consumer`` (``imu.grade=consumer``, ``--no-figures``); read them, copy them before changing them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest


@pytest.fixture(scope="session")
def small_radar():
    from sarnav.radar.presets import nav_paper_sim

    # 9.75 GHz, 500 MHz, fs = 1 GHz, 1-us chirp; window around 1995-2005 m; PRF 250 Hz for a 0.5-m antenna at 60 m/s
    return nav_paper_sim(prf=250.0, antenna_length=0.5, near_range=1995.0 - 150.0 - 5.0, n_range_samples=2134)


@dataclass(frozen=True)
class PointTargetBlock:
    """A range-compressed block (``rc``) of one unit point target at ``target`` (NED) seen from a straight north
    track at ``speed`` and ``altitude`` with pulse times centred on 0; ``r0`` the range of closest approach."""

    rc: object
    target: np.ndarray
    speed: float
    altitude: float
    r0: float


@pytest.fixture(scope="session")
def point_target_block(small_radar):
    from sarnav.imaging.range_compression import range_compress
    from sarnav.radar.echoes import simulate_echoes
    from sarnav.radar.scene import point_targets

    speed, altitude, r0 = 60.0, 1000.0, 2000.0
    n = 250
    t = (np.arange(n) - n // 2) / small_radar.prf
    pos = np.c_[speed * t, np.zeros(n), np.full(n, -altitude)]
    target = np.array([0.0, np.sqrt(r0**2 - altitude**2), 0.0])
    rc = range_compress(simulate_echoes(small_radar, pos, t, point_targets(target)))
    return PointTargetBlock(rc, target, speed, altitude, r0)


@pytest.fixture(scope="session")
def short_flight():
    from sarnav.scenarios import rda_nav as rn

    cfg = rn.default_config()
    cfg["trajectory"]["duration"] = 3.0
    return rn.parse(cfg)


@pytest.fixture(scope="session")
def small_campaigns(tmp_path_factory):
    """{"tactical": Path, "consumer": Path}: two small finished telemetry campaigns (see the module docstring)."""
    from sarnav.cli.main import main

    root = tmp_path_factory.mktemp("campaigns")
    small = ["--runs", "4", "--set", "trajectory.duration=2.0", "--executor", "serial", "--quiet"]
    dirs = {"tactical": root / "tactical", "consumer": root / "consumer"}
    assert main(["run", "telemetry", *small, "--out", str(dirs["tactical"])]) == 0
    assert main(["run", "telemetry", *small, "--set", "imu.grade=consumer", "--no-figures",
                 "--out", str(dirs["consumer"])]) == 0
    return dirs


@pytest.fixture(scope="session")
def compared_campaigns(small_campaigns, tmp_path_factory):
    """(out, printed lines) of ``sarnav compare tactical consumer --out out`` (run once: drawing is the cost)."""
    import contextlib
    import io

    from sarnav.cli.main import main

    out = tmp_path_factory.mktemp("compare") / "cmp"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["compare", str(small_campaigns["tactical"]), str(small_campaigns["consumer"]),
                     "--out", str(out)]) == 0
    return out, buf.getvalue().split()
