"""Outputs a strict parser and a colleague can read (issue 9): summary.json is strict JSON (null with a reason where a
statistic is undefined), every results.nc variable and coordinate has units and a description, and a diverged filter
is reported (warning line, ``"consistent": false``) while the command still succeeds."""

import json

import pytest

from sarnav.cli.main import main
from sarnav.montecarlo.assemble import open_results


def _strict_load(path):
    def bad(token):
        raise ValueError(f"non-strict JSON constant {token}")

    return json.loads(path.read_text(), parse_constant=bad)


def test_an_undefined_statistic_is_null_with_a_reason(tmp_path):
    out = tmp_path / "o"
    assert main(["run", "rda-nav", "--runs", "2", "--set", "sar.enabled=false", "--set", "trajectory.duration=2",
                 "--executor", "serial", "--quiet", "--no-figures", "--out", str(out)]) == 0
    summary = _strict_load(out / "summary.json")
    cross = summary["residuals"]["cross"]
    assert cross["count"] == 0 and cross["mean"] is None
    assert "absent" in cross["undefined"]["mean"]
    assert summary["residuals"]["alt"]["mean"] is not None


@pytest.mark.parametrize("scenario,extra", [
    ("telemetry", ["--set", "trajectory.duration=1"]),
    ("rda-nav", ["--set", "trajectory.duration=2"]),
])
def test_every_variable_and_coordinate_has_units_and_a_long_name(tmp_path, scenario, extra):
    out = tmp_path / "o"
    assert main(["run", scenario, "--runs", "2", "--executor", "serial", "--quiet", "--no-figures", "--out", str(out),
                 *extra]) == 0
    ds = open_results(out / "results.nc")
    for name in ds.variables:
        text = ds[name].dtype.kind in "USO"  # labels carry no units; mixed units name their coordinate (CF)
        assert text or "units" in ds[name].attrs or ds[ds[name].attrs["units_coordinate"]].dtype.kind == "U", name
        assert ds[name].attrs.get("long_name") and not ds[name].attrs["long_name"].startswith("kind-specific"), name
    if scenario == "rda-nav":
        assert list(ds["stage"].values) == ["echoes", "rda", "autofocus", "registration", "update"]
        assert ds["registration_error"].attrs["units"] == "m" and ds["toc"].attrs["units"] == "s"
    assert list(ds["state_units"].values)[:3] == ["m", "m", "m"]  # the per-state units, as documented


def test_a_diverged_filter_is_reported_and_the_command_succeeds(tmp_path, capsys):
    """``initial.p_3sigma = [1000, 1000, 1000]``: 0.1 exited 0 with 1.5 % of errors inside 3 sigma and no word."""
    out = tmp_path / "o"
    code = main(["run", "telemetry", "--runs", "10", "--set", "initial.p_3sigma=[1000.0, 1000.0, 1000.0]",
                 "--executor", "serial", "--quiet", "--no-figures", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 0
    summary = _strict_load(out / "summary.json")
    assert summary["consistent"] is False and summary["inconsistency"]
    assert err.startswith("sarnav: warning: the filter is inconsistent (")
    assert "inside 3 sigma" in err or "NEES" in err
    ok = tmp_path / "ok"
    assert main(["run", "telemetry", "--runs", "10", "--executor", "serial", "--quiet", "--no-figures",
                 "--out", str(ok)]) == 0
    assert _strict_load(ok / "summary.json")["consistent"] is True
