"""``sarnav.report.outputs``: which kind of output a directory holds, and a finished campaign read back (docs/results.md).

A finished campaign is the conftest's ``small_campaigns`` (copied before it is changed); its files are read here
independently with json and netCDF4. Every problem is one ConfigError line whose field is the directory as given.
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.report.outputs import (CAMPAIGN, IMAGE, SENSITIVITY, STUDY, CampaignDir, describe, figure_files,
                                   output_kind, read_campaign, read_json)


def refused(fn, arg) -> ConfigError:
    with pytest.raises(ConfigError) as err:
        fn(arg)
    assert "\n" not in str(err.value)
    return err.value


# ---- output_kind, describe -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("marker, kind", [
    ("campaign.json", CAMPAIGN), ("results.nc", CAMPAIGN), ("study.json", STUDY),
    ("sensitivity.csv", SENSITIVITY), ("metrics.json", IMAGE), ("image.npz", IMAGE),
])
def test_output_kind_is_told_by_its_marker_file(tmp_path, marker, kind):
    (tmp_path / marker).write_text("{}")
    assert output_kind(tmp_path) == kind
    assert output_kind(str(tmp_path)) == kind


def test_campaign_markers_win_over_the_others(tmp_path):
    """A campaign folder may hold other files: its manifest or results decide."""
    for name in ("metrics.json", "sensitivity.csv", "study.json", "results.nc"):
        (tmp_path / name).write_text("{}")
    assert output_kind(tmp_path) == CAMPAIGN
    (tmp_path / "results.nc").unlink()
    assert output_kind(tmp_path) == STUDY


def test_a_marker_that_is_a_folder_does_not_count(tmp_path):
    (tmp_path / "campaign.json").mkdir()
    (tmp_path / "image.npz").write_bytes(b"")
    assert output_kind(tmp_path) == IMAGE


def test_output_kind_names_the_directory_as_given(tmp_path):
    given = str(tmp_path / "nope")
    err = refused(output_kind, given)
    assert (err.field, err.message) == (given, "no such directory")
    (tmp_path / "file.txt").write_text("x")
    err = refused(output_kind, tmp_path / "file.txt")
    assert err.field == str(tmp_path / "file.txt") and err.message.startswith("not a directory")
    (tmp_path / "empty").mkdir()
    err = refused(output_kind, tmp_path / "empty")
    assert err.field == str(tmp_path / "empty")
    assert err.message.startswith("not a sarnav output directory (none of campaign.json, results.nc, study.json, ")


def test_describe_puts_a_kind_in_words():
    assert [describe(k) for k in (CAMPAIGN, STUDY, SENSITIVITY, IMAGE)] == \
        ["a campaign", "a study", "a bpa-sensitivity output", "an image output"]
    assert describe("quality-sweep") == "a quality-sweep output"


# ---- read_json, figure_files ---------------------------------------------------------------------------------------


def test_read_json_reads_an_object_and_tolerates_nan(tmp_path):
    (tmp_path / "s.json").write_text('{"a": NaN, "b": [1, 2], "c": {"d": "x"}}')
    got = read_json(tmp_path / "s.json", "out/a")
    assert np.isnan(got["a"]) and got["b"] == [1, 2] and got["c"] == {"d": "x"}


@pytest.mark.parametrize("text, start", [
    ("[1, 2]", "s.json does not hold a JSON object"),
    ('{"a": ', "s.json cannot be read ("),
    (b"\xff\xfe{}", "s.json cannot be read ("),
])
def test_read_json_refuses_what_is_not_an_object_naming_the_folder(tmp_path, text, start):
    path = tmp_path / "s.json"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    with pytest.raises(ConfigError) as err:
        read_json(path, "out/a")
    assert err.value.field == "out/a" and err.value.message.startswith(start), str(err.value)


def test_read_json_of_a_missing_file_names_it(tmp_path):
    with pytest.raises(ConfigError, match=r"^out/a: s.json cannot be read"):
        read_json(tmp_path / "s.json", "out/a")


def test_figure_files_in_reading_order(tmp_path):
    """position, velocity, attitude, residuals first, then the other PNGs alphabetically; other files ignored."""
    for name in ("zeta.png", "residuals.png", "alpha.png", "velocity.png", "position.png", "attitude.png",
                 "notes.txt", "position.svg"):
        (tmp_path / name).write_bytes(b"")
    (tmp_path / "sub.png").mkdir()
    assert [p.name for p in figure_files(tmp_path)] == \
        ["position.png", "velocity.png", "attitude.png", "residuals.png", "alpha.png", "zeta.png"]
    assert figure_files(tmp_path / "missing") == []


# ---- read_campaign -------------------------------------------------------------------------------------------------


def test_read_campaign_reads_results_summary_manifest_and_figures(small_campaigns):
    """Everything matches the files read with json and netCDF4."""
    import netCDF4

    path = small_campaigns["tactical"]
    c = read_campaign(path)
    assert isinstance(c, CampaignDir) and c.path == path and c.given == str(path)
    assert c.summary == json.loads((path / "summary.json").read_text())
    assert c.manifest == json.loads((path / "campaign.json").read_text())
    assert [p.name for p in c.figures] == ["position.png", "velocity.png", "attitude.png", "residuals.png"]
    with netCDF4.Dataset(path / "results.nc") as nc:
        for var in ("error", "sigma", "nees"):
            v = nc.variables[var]
            v.set_auto_mask(False)
            np.testing.assert_array_equal(np.asarray(c.results[var].values), v[:])
        states = [str(s) for s in nc.variables["state"][:]]
        attrs = {k: nc.getncattr(k) for k in nc.ncattrs()}
    assert c.state_names == states
    assert len(c.state_units) == len(states)
    assert c.kind == attrs.get("kind", c.manifest["kind"]) == "telemetry"
    assert c.scenario_toml == (attrs.get("scenario") or c.manifest["scenario_toml"])
    assert "[trajectory]" in c.scenario_toml
    assert c.name == str(attrs.get("scenario_name") or c.summary.get("scenario") or path.name)


def test_a_campaign_without_figures_has_none(small_campaigns):
    assert read_campaign(small_campaigns["consumer"]).figures == []


def _copy(src, tmp_path, name="c"):
    dst = tmp_path / name
    shutil.copytree(src, dst)
    return dst


def test_unfinished_campaign_is_named_with_its_stored_runs(small_campaigns, tmp_path):
    c = _copy(small_campaigns["consumer"], tmp_path)
    manifest = json.loads((c / "campaign.json").read_text())
    stored = len(list((c / "runs").glob("run_*.npz")))
    manifest["complete"] = False
    (c / "campaign.json").write_text(json.dumps(manifest))
    err = refused(read_campaign, c)
    assert err.field == str(c)
    assert err.message.startswith(f"an unfinished campaign ({stored} of {manifest['runs']} runs stored, no results "
                                  "yet): finish it with the same `sarnav run` command and --resume")


@pytest.mark.parametrize("change", ["marker", "no results", "no summary"])
def test_incomplete_marker_or_missing_products_mean_unfinished(small_campaigns, tmp_path, change):
    c = _copy(small_campaigns["consumer"], tmp_path)
    if change == "marker":
        (c / "INCOMPLETE").write_text("")
    elif change == "no results":
        (c / "results.nc").unlink()
    else:
        (c / "summary.json").unlink()
    assert refused(read_campaign, c).message.startswith("an unfinished campaign (")


def test_a_changed_result_file_is_refused(small_campaigns, tmp_path):
    """The manifest's checksums catch a results.nc that is not the one written."""
    c = _copy(small_campaigns["consumer"], tmp_path)
    data = bytearray((c / "results.nc").read_bytes())
    data[-100] ^= 0xFF
    (c / "results.nc").write_bytes(bytes(data))
    with pytest.raises(Exception) as err:
        read_campaign(c)
    assert "results.nc" in str(err.value) and "\n" not in str(err.value)


def test_results_without_their_variables_are_not_a_campaign(small_campaigns, tmp_path):
    """results.nc copied without campaign.json (no checksums) that lacks 'nees': named, one line."""
    import netCDF4

    c = tmp_path / "bare"
    c.mkdir()
    shutil.copy(small_campaigns["consumer"] / "summary.json", c / "summary.json")
    with netCDF4.Dataset(c / "results.nc", "w") as nc:
        nc.createDimension("state", 2)
        nc.createVariable("error", "f8", ("state",))[:] = [1.0, 2.0]
        nc.createVariable("sigma", "f8", ("state",))[:] = [1.0, 2.0]
    err = refused(read_campaign, c)
    assert err.field == str(c)
    assert "results.nc" in err.message


def test_a_study_is_named_with_its_case_folders(tmp_path):
    (tmp_path / "study.json").write_text("{}")
    for case in ("b", "a"):
        (tmp_path / case).mkdir()
        (tmp_path / case / "campaign.json").write_text("{}")
    (tmp_path / "figures").mkdir()
    err = refused(read_campaign, tmp_path)
    assert err.message == f"a study, not one campaign: give its case folders, e.g. {tmp_path / 'a'} {tmp_path / 'b'}"


def test_an_image_output_is_not_a_campaign(tmp_path):
    (tmp_path / "metrics.json").write_text("{}")
    err = refused(read_campaign, tmp_path)
    assert (err.field, err.message) == (str(tmp_path), "an image output, not a Monte Carlo campaign (no results.nc)")
