"""The netCDF results files follow the CF conventions (issue 30, docs/results.md): every kind's file is written by the
command and read back; ``Conventions = "CF-1.10"``, a ``long_name`` on every variable, and every ``units`` string (the
attributes and the per-component units of the ``*_units`` coordinate variables) parsed by UDUNITS-2 through cf-units
(an independent parser: the unit strings are sarnav's own, the grammar is not)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from sarnav.cli.main import main
from sarnav.scenarios import registry

cf_units = pytest.importorskip("cf_units")  # in the test extra

#: one scenario per kind, small (one run, a short flight: the files' attributes do not depend on the length)
SMALL = {
    "telemetry": ("telemetry", {"trajectory.duration": 1.0}),
    "rda-nav": ("rda-nav", {"trajectory.duration": 1.0}),
    "study": ("telemetry-imu-grade", {"base.trajectory.duration": 1.0}),
    "spacecraft": ("spacecraft-tc2", {"simulation.duration": 20.0}),
    "spacecraft-closed-loop": ("spacecraft-closed-loop", {"simulation.duration": 5.0}),
    "multi-imu-path1": ("multi-imu-path1", {"path.duration": 2.0, "filter.n_particles": 50, "filter.settle_s": 0.5}),
    "multi-imu": ("multi-imu-adis", {"flight.duration": 10.0, "filter.n_particles": 50, "filter.settle_s": 1.0}),
    "upf-flight": ("upf-flight", {"flight.duration": 120.0, "filter.n_particles": 50, "filter.settle_s": 1.0,
                                  "output.rate_hz": 200.0}),
    "nav-source-focus": ("nav-source-focus", {"cart.run_in_s": 1.0, "aperture.n_pulses": 150,
                                              "navigation.n_particles": 50, "navigation.adis_particles": 50,
                                              "image.chip_half_m": 0.4}),
    "multi-imu-sar": ("multi-imu-sar-fix", {"flight.duration": 2.0, "filter.n_particles": 50, "filter.settle_s": 0.5}),
    "quality-nav": ("quality-nav", {"trajectory.duration": 1.0, "focus.calibration_apertures": 4, "focus.pixels": 32}),
    "quality-sweep": ("quality-sweep", {"aperture.n_pulses": 200, "sweep.sizes": [6], "sweep.steps": 1,
                                        "sweep.figure_size": 6, "reliability.scenes": 0, "sweep.bins": [10]}),
}
#: kinds whose files are tables and images, no netCDF (checked: a netCDF file they start writing must join SMALL)
NO_NETCDF = {"image": ("point-target", {"trajectory.duration": 0.25}),
             "bpa-sensitivity": ("bpa-sensitivity", {"trajectory.duration": 3.0, "image.spacing": 0.2,
                                                     "image.margin": 2.0}),
             "gpsd-search": ("gpsd-search", {"aperture.n_pulses": 400, "search.initial_pulses": 200,
                                             "search.block_pulses": [100], "image.size": 8, "search.sigmas": 1,
                                             "search.spacings": 1, "scene.extent": 4.0})}
NO_RUNS = ("image", "bpa-sensitivity", "quality-sweep")


def _run(kind: str, scenario: str, sets: dict, out) -> list:
    args = ["run", scenario, "--executor", "serial", "--quiet", "--no-figures", "--out", str(out)]
    args += [] if kind in NO_RUNS else ["--runs", "1"]
    for key, value in sets.items():
        args += ["--set", f"{key}={json.dumps(value)}"]
    assert main(args) == 0
    return sorted(out.rglob("*.nc"))


def _parses(units: str) -> bool:
    try:
        unit = cf_units.Unit(units)
    except ValueError:
        return False
    return not unit.is_unknown() and not unit.is_no_unit()


def cf_problems(ds: xr.Dataset) -> list[str]:
    """What keeps ``ds`` from the CF attribute rules of docs/results.md (empty when it follows them)."""
    bad = [] if ds.attrs.get("Conventions") == "CF-1.10" else [f"Conventions = {ds.attrs.get('Conventions')!r}"]
    bad += [f"global {k} missing" for k in ("title", "source", "sarnav_version", "sarnav_commit") if not ds.attrs.get(k)]
    for name in ds.variables:
        attrs, text = ds[name].attrs, ds[name].dtype.kind in "USO"
        if not attrs.get("long_name"):
            bad.append(f"{name}: no long_name")
        if "description" in attrs:
            bad.append(f"{name}: description instead of long_name")
        if text:  # labels: no units; a coordinate of units: each one parses
            if "units" in attrs:
                bad.append(f"{name}: units on a string variable")
            if name.endswith("_units"):
                bad += [f"{name}[{i}] = {u!r}" for i, u in enumerate(ds[name].values) if not _parses(str(u))]
        elif "units_coordinate" in attrs:  # mixed units: one per component, along a dimension of the variable
            ref = attrs["units_coordinate"]
            if ref not in ds.variables or ds[ref].dims[0] not in ds[name].dims or "units" in attrs:
                bad.append(f"{name}: units_coordinate {ref!r} is not a units coordinate along its dimensions")
        elif not isinstance(attrs.get("units"), str) or not _parses(attrs["units"]):
            bad.append(f"{name}: units {attrs.get('units')!r}")
    return bad


@pytest.mark.parametrize("kind", sorted(SMALL))
def test_every_results_file_of_every_kind_follows_cf(kind, tmp_path):
    scenario, sets = SMALL[kind]
    files = _run(kind, scenario, sets, tmp_path / "o")
    assert files, f"{kind} wrote no netCDF file"
    for f in files:
        with xr.open_dataset(f) as ds:
            assert cf_problems(ds) == [], f.name


def test_every_campaign_kind_is_checked():
    """A new kind is added to SMALL (or NO_NETCDF) here, so that its files are checked too."""
    kinds = {registry.get_scenario(name)["scenario"]["kind"] for name, _ in registry.list_scenarios()}
    assert kinds == set(SMALL) | set(NO_NETCDF)


@pytest.mark.parametrize("kind", sorted(NO_NETCDF))
def test_kinds_without_netcdf_write_none(kind, tmp_path):
    scenario, sets = NO_NETCDF[kind]
    assert _run(kind, scenario, sets, tmp_path / "o") == []


def test_the_check_finds_what_breaks_cf():
    """The checker is not vacuous: the old forms of results.nc fail it."""
    ds = xr.Dataset({"error": (("state",), [1.0, 2.0], {"units": "per state: see state_units",
                                                         "description": "truth minus estimate"})},
                    coords={"state": ("state", ["pN", "vN"], {"units": ["m", "m/s"]})})
    bad = cf_problems(ds)
    assert any(b.startswith("Conventions") for b in bad)
    assert "error: units 'per state: see state_units'" in bad and "error: description instead of long_name" in bad
    assert "state: units on a string variable" in bad


def test_apply_cf_turns_the_old_forms_into_cf():
    from sarnav.cf import apply_cf

    ds = xr.Dataset({"error": (("run", "ric"), np.zeros((2, 2)), {"units_coordinate": "ric_units",
                                                                  "description": "position / velocity error"}),
                     "count": (("run",), [1, 2], {"units": ""})},
                    coords={"ric": ("ric", ["pR", "vR"], {"units": ["m", "m/s"], "description": "axes"})})
    apply_cf(ds, "a test")
    assert cf_problems(ds) == []
    assert list(ds["ric_units"].values) == ["m", "m/s"] and ds["ric_units"].dims == ("ric",)
    assert ds["error"].attrs["long_name"] == "position / velocity error" and ds["count"].attrs["units"] == "1"
    assert ds.attrs["title"] == "a test" and ds.attrs["Conventions"] == "CF-1.10"


def test_sweep_nc_keeps_the_sense_of_each_measure_and_the_pivot(tmp_path):
    """sweep.nc had lost ``maximise_*`` and ``pivot`` and described every measure as "(maximise: None)"."""
    from sarnav.imaging.quality import QUALITY_MEASURES

    scenario, sets = SMALL["quality-sweep"]
    (path,) = _run("quality-sweep", scenario, {**sets, "sweep.pivot": "centre"}, tmp_path / "o")
    with xr.open_dataset(path) as ds:
        assert ds.attrs["pivot"] == "centre"
        measures = [m for m in ds.data_vars if m != "error"]
        assert measures
        for m in measures:
            sense = QUALITY_MEASURES[m].maximise
            assert ds.attrs[f"maximise_{m}"] == int(sense)
            assert ds[m].attrs["long_name"].endswith(f"{'larger' if sense else 'smaller'} is better focus")
            assert "None" not in ds[m].attrs["long_name"]
