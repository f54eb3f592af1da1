"""The Python entry point (issue 30, docs/api.md): ``sarnav.run`` returns the Dataset the CLI writes, ``figures``
returns matplotlib figures, ``python -m sarnav`` is the command, progress goes to stderr."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import xarray as xr
from matplotlib.figure import Figure

import sarnav
from sarnav.api import override_strings
from sarnav.cli.main import main
from sarnav.errors import ConfigError
from sarnav.montecarlo.assemble import open_results

ROOT = Path(__file__).resolve().parents[1]


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT / "src") + os.pathsep + env.get("PYTHONPATH", "")
    return env


def test_run_returns_the_dataset_the_cli_writes(tmp_path):
    """telemetry, 4 runs of a 2-s flight: the keyword overrides and the CLI's --set give one identical file."""
    assert main(["run", "telemetry", "--runs", "4", "--seed", "11", "--set", "trajectory.duration=2.0",
                 "--set", "imu.grade=consumer", "--executor", "serial", "--quiet", "--no-figures",
                 "--out", str(tmp_path / "cli")]) == 0
    cli = open_results(tmp_path / "cli" / "results.nc")
    ds = sarnav.run("telemetry", runs=4, seed=11, executor="serial", trajectory={"duration": 2.0},
                    imu__grade="consumer")
    assert isinstance(ds, xr.Dataset) and ds.sizes["run"] == 4
    xr.testing.assert_identical(ds, cli)
    assert 'grade = "consumer"' in ds.attrs["scenario"] and "duration = 2.0" in ds.attrs["scenario"]
    figs = sarnav.api.figures(ds)
    assert list(figs) == ["position", "velocity", "attitude", "residuals"]
    assert all(isinstance(f, Figure) for f in figs.values()) and len(figs["position"].axes) == 3


def test_run_keeps_the_folder_when_asked(tmp_path):
    res = sarnav.run_result("telemetry", runs=2, seed=1, out=tmp_path / "o", executor="serial",
                            trajectory__duration=1.0)
    assert (tmp_path / "o" / "results.nc").is_file() and (tmp_path / "o" / "summary.json").is_file()
    assert res.summary["runs"] == 2 and res.dataset.sizes["run"] == 2


def test_override_strings_are_the_cli_set_strings():
    assert override_strings({"imu": {"grade": "consumer"}, "filter__imu__grade": "navigation",
                             "trajectory": {"duration": 2, "start_ned": [0.0, 1.0, -500.0]}, "sar__enabled": False}) == [
        'imu.grade="consumer"', 'filter.imu.grade="navigation"', "trajectory.duration=2",
        "trajectory.start_ned=[0.0, 1.0, -500.0]", "sar.enabled=false"]


def test_a_bad_override_is_the_cli_one_line_error():
    with pytest.raises(ConfigError) as err:
        sarnav.run("telemetry", runs=1, executor="serial", imu={"grde": "consumer"})
    assert err.value.field == "imu.grde" and "unknown key" in err.value.message
    with pytest.raises(ConfigError) as err:
        sarnav.run("telemetry", runs=1, executor="serial", imu__grade=object())
    assert err.value.field == "imu.grade"


def test_kinds_that_write_their_own_files_are_named():
    with pytest.raises(ConfigError, match="sarnav run quality-sweep --out DIR"):
        sarnav.run("quality-sweep")


def test_import_sarnav_stays_light():
    """``sarnav.run``, ``sarnav.__version__`` are imported on first use: ``import sarnav`` loads no numpy."""
    out = subprocess.run([sys.executable, "-c", "import sys, sarnav; print('numpy' in sys.modules, "
                          "callable(sarnav.run), 'xarray' in sys.modules)"], capture_output=True, text=True,
                         env=_env(), timeout=120)
    assert out.stdout.split() == ["False", "True", "False"], out.stderr


def test_python_m_sarnav_is_the_command():
    out = subprocess.run([sys.executable, "-m", "sarnav", "scenarios"], capture_output=True, text=True, env=_env(),
                         timeout=120)
    assert out.returncode == 0 and out.stdout.split()[0] == "telemetry"
    bad = subprocess.run([sys.executable, "-m", "sarnav", "run", "no-such-scenario"], capture_output=True,
                         text=True, env=_env(), timeout=120)
    assert bad.returncode == 2 and bad.stderr.startswith("sarnav: error: ") and bad.stderr.count("\n") == 1


def test_gpsd_search_progress_goes_to_stderr(capsys):
    from sarnav.scenarios import gpsd_search

    gpsd_search._progress(50, 12.0)
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err == "gpsd-search: 50 runs, 12 s\n"


def test_quality_sweep_tells_its_stages_on_stderr(tmp_path, capsys):
    tiny = ["--set", "aperture.n_pulses=200", "--set", "sweep.sizes=[6]", "--set", "sweep.steps=1",
            "--set", "sweep.figure_size=6", "--set", "reliability.scenes=0", "--set", "sweep.bins=[10]"]
    assert main(["run", "quality-sweep", "--no-figures", "--out", str(tmp_path / "q"), *tiny]) == 0
    cap = capsys.readouterr()
    stages = [line for line in cap.err.splitlines() if line.startswith("quality-sweep: ")]
    assert any("along-track sweep" in s for s in stages) and any("T3 example" in s for s in stages)
    assert "quality-sweep: " not in cap.out
