"""Fixtures of the report tests (the small telemetry campaigns are in tests/conftest.py).

small_study : the IMU-grade study cut to two cases (2 runs, 1 s each), run by `sarnav run --no-figures`, with small
    stand-in PNG files where `sarnav run` draws its figures (drawing them is slow and tested elsewhere); copy it
    before changing it.
"""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def small_study(tmp_path_factory):
    """The IMU-grade study cut to two cases of 2 runs over 1 s (see the module docstring)."""
    import numpy as np
    from matplotlib.image import imsave

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
    assert main(["run", str(root / "study.toml"), "--out", str(out), "--executor", "serial", "--quiet",
                 "--no-figures"]) == 0
    stand_ins = [out / "study_3sigma.png"] + [out / c["label"] / "figures" / f"{name}.png" for c in cfg["cases"]
                                               for name in ("position", "velocity", "attitude", "residuals")]
    for k, path in enumerate(stand_ins):
        path.parent.mkdir(parents=True, exist_ok=True)
        imsave(path, np.full((2, 2, 3), k / len(stand_ins)))  # distinct bytes per file
    return out
