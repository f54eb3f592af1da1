"""``sarnav compare`` (sarnav.report.compare): compare.csv columns and numbers against an independent computation
from each results.nc, the shared states, the page, and the one-line errors for inputs that cannot be compared."""

from __future__ import annotations

import csv
import re

import numpy as np
import pytest
import xarray as xr
from scipy.stats import chi2

from page_checks import assert_self_contained

from sarnav.errors import ConfigError
from sarnav.montecarlo.campaign import run_campaign
from sarnav.report.compare import CSV_COLUMNS, compare_campaigns
from toy_kind import TOY, toy_cfg


@pytest.fixture(scope="module")
def toy_campaign(tmp_path_factory):
    """A finished toy campaign (one state ``x`` [m], exact scalar Kalman filter), in no way like telemetry."""
    out = tmp_path_factory.mktemp("toy") / "toy"
    run_campaign(toy_cfg(runs=6, steps=20), out, TOY, executor="serial", quiet=True)
    return out


def _rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_csv_has_a_row_per_campaign_and_state_with_independent_numbers(small_campaigns, compared_campaigns):
    a, b = small_campaigns["tactical"], small_campaigns["consumer"]
    page, table = compared_campaigns[0] / "compare.html", compared_campaigns[0] / "compare.csv"
    with open(table, newline="") as fh:
        assert tuple(next(csv.reader(fh))) == CSV_COLUMNS
    rows = _rows(table)
    with xr.open_dataset(a / "results.nc") as ds:
        states = [str(s) for s in ds["state"].values]
        err, sig, nees = ds["error"].values, ds["sigma"].values, ds["nees"].values
        nis, nis_dof = ds["nis"].values, ds["nis_dof"].values
    assert [(r["campaign"], r["state"]) for r in rows] == [(d.name, s) for d in (a, b) for s in states]
    n_runs, n_state = err.shape[0], err.shape[2]
    lo, hi = chi2.ppf([0.025, 0.975], n_runs * n_state) / n_runs  # Bar-Shalom §5.4.2
    present = nis_dof > 0
    for j, s in enumerate(states):
        r = rows[j]
        rms_t = np.sqrt(np.mean(err[:, :, j] ** 2, axis=0))
        expect = {"final_3sigma": 3 * sig[:, -1, j].mean(), "rms_error_final": rms_t[-1],
                  "rms_error_time_average": rms_t.mean(),
                  "fraction_inside_3sigma": np.mean(np.abs(err[:, :, j]) <= 3 * sig[:, :, j]),
                  "nees_time_average": nees.mean(axis=0).mean(), "nees_dof": n_state,
                  "nees_band_lo": lo, "nees_band_hi": hi,
                  "nis_per_dof": nis[present].sum() / nis_dof[present].sum()}
        for key, value in expect.items():
            assert float(r[key]) == pytest.approx(value, rel=1e-5), (s, key)
        assert r["units"] == {"p": "m", "v": "m/s", "t": "rad"}.get(s[0], r["units"])
    text = page.read_text(encoding="utf-8")
    assert len(assert_self_contained(text)) == 4  # consistency + position, velocity, attitude overlays
    for s in states:
        assert f"<td class=\"t\">{s}</td>" in text


def test_different_state_sets_compare_over_the_shared_ones(small_campaigns, toy_campaign, tmp_path):
    """Telemetry (18 states) against a toy campaign (state x): nothing shared, so an error naming the toy folder."""
    with pytest.raises(ConfigError) as err:
        compare_campaigns([small_campaigns["tactical"], toy_campaign], tmp_path / "cmp")
    assert err.value.field == str(toy_campaign) and "no state in common" in err.value.message
    assert not (tmp_path / "cmp").exists()


def test_same_folder_names_are_labelled_by_their_paths(toy_campaign, tmp_path):
    """Two copies of one campaign in folders of the same name: labelled by the paths given, identical numbers."""
    import shutil

    other = tmp_path / "elsewhere" / toy_campaign.name
    shutil.copytree(toy_campaign, other)
    _, table = compare_campaigns([toy_campaign, other], tmp_path / "cmp")
    rows = _rows(table)
    assert [(r["campaign"], r["state"]) for r in rows] == [(str(toy_campaign), "x"), (str(other), "x")]
    assert {k: v for k, v in rows[0].items() if k not in ("campaign", "directory")} == \
        {k: v for k, v in rows[1].items() if k not in ("campaign", "directory")}
    assert float(rows[0]["nis_per_dof"]) > 0 and rows[0]["units"] == "m"


@pytest.mark.parametrize("case", ["one", "twice", "missing", "not_campaign", "unfinished", "study"])
def test_inputs_that_cannot_be_compared_name_the_directory(case, small_campaigns, tmp_path):
    a = small_campaigns["tactical"]
    bad = tmp_path / "bad"
    if case == "one":
        dirs, field = [a], "DIR"
    elif case == "twice":
        dirs, field = [a, str(a) + "/"], str(a) + "/"
    elif case == "missing":
        dirs, field = [a, bad], str(bad)
    elif case == "not_campaign":
        bad.mkdir()
        (bad / "notes.txt").write_text("x")
        dirs, field = [a, bad], str(bad)
    elif case == "unfinished":
        bad.mkdir()
        (bad / "campaign.json").write_text('{"complete": false, "runs": 4}')
        (bad / "INCOMPLETE").write_text("")
        dirs, field = [a, bad], str(bad)
    else:
        bad.mkdir()
        (bad / "study.json").write_text("{}")
        dirs, field = [bad, a], str(bad)
    with pytest.raises(ConfigError) as err:
        compare_campaigns(dirs, tmp_path / "cmp")
    assert err.value.field == field
    assert "\n" not in str(err.value)
    if case == "unfinished":
        assert re.search(r"unfinished campaign \(0 of 4 runs stored", err.value.message)
