"""Fixtures of the report tests (the small telemetry campaigns are in tests/conftest.py).

small_study : the IMU-grade study cut to two cases (2 runs, 1 s each), as `sarnav run` writes it; copy it before
    changing it.
"""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def small_study(tmp_path_factory):
    """The IMU-grade study cut to two cases of 2 runs over 1 s, run by `sarnav run`."""
    from sarnav.cli.main import main
    from sarnav.scenarios.registry import get_scenario
    from sarnav.tomlio import dump_toml

    cfg = get_scenario("telemetry-imu-grade")
    cfg["cases"] = cfg["cases"][:2]
    cfg["campaign"]["runs"] = 2
    cfg["base"]["trajectory"]["duration"] = 1.0
    root = tmp_path_factory.mktemp("study")
    (root / "study.toml").write_text(dump_toml(cfg))
    out = root / "out"
    assert main(["run", str(root / "study.toml"), "--out", str(out), "--executor", "serial", "--quiet"]) == 0
    return out
