"""Stored runs -> the ``results.nc`` Dataset (schema in docs/results.md)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Sequence

import numpy as np
import xarray as xr

from sarnav.errors import InputDataError
from sarnav.montecarlo.record import RunRecord
from sarnav.cf import UNITS_COORDINATE, apply_cf

__all__ = ["assemble_results", "write_results", "open_results"]


def _stack(records: Sequence[RunRecord], name: str) -> np.ndarray:
    return np.stack([np.asarray(getattr(r, name)) for r in records])


def assemble_results(
    records: Sequence[RunRecord],
    state_names: Sequence[str],
    meas_names: Sequence[str],
    state_units: Sequence[str],
    meas_units: Sequence[str],
    attrs: dict,
    extra_attrs: dict | None = None,
    extra_coords: dict | None = None,
) -> xr.Dataset:
    """Stack run records (sorted by run) into a Dataset with dims ``run, time, state, update, meas``.

    ``time`` and ``update_time`` must be identical in every run (RunRecord contract); a mismatch is
    an :class:`InputDataError`. Every variable and coordinate gets ``long_name`` and UDUNITS ``units`` attributes
    (``extra_attrs``: those of the kind's extras; ``extra_coords``: labels of the kind's own dimensions), and the
    Dataset the CF-1.10 attributes (:func:`sarnav.cf.apply_cf`).
    """
    records = sorted(records, key=lambda r: r.run)
    if not records:
        raise InputDataError("records", "no runs to assemble")
    t0, u0 = np.asarray(records[0].time), np.asarray(records[0].update_time)
    for r in records[1:]:
        if not np.array_equal(np.asarray(r.time), t0):
            raise InputDataError("time", f"run {r.run} has different output epochs than run {records[0].run}")
        if not np.array_equal(np.asarray(r.update_time), u0):
            raise InputDataError("update_time", f"run {r.run} has different update epochs than run {records[0].run}")
    data = {
        "error": (("run", "time", "state"), _stack(records, "error").astype(np.float64)),
        "sigma": (("run", "time", "state"), _stack(records, "sigma").astype(np.float64)),
        "nees": (("run", "time"), _stack(records, "nees").astype(np.float64)),
        "residual": (("run", "update", "meas"), _stack(records, "residual").astype(np.float64)),
        "residual_sigma": (("run", "update", "meas"), _stack(records, "residual_sigma").astype(np.float64)),
        "nis": (("run", "update"), _stack(records, "nis").astype(np.float64)),
        "nis_dof": (("run", "update"), _stack(records, "nis_dof").astype(np.int64)),
    }
    for name in records[0].extras:
        dims = tuple(records[0].extras[name][0])
        if name in data:
            raise InputDataError(f"extras.{name}", "clashes with a standard variable name")
        try:
            arr = np.stack([np.asarray(r.extras[name][1]) for r in records])
        except (KeyError, ValueError) as err:
            raise InputDataError(f"extras.{name}", f"missing or of different shape between runs ({err})") from None
        data[name] = (("run",) + dims, arr)
    coords = {
        "run": ("run", np.array([r.run for r in records], dtype=np.int64)),
        "time": ("time", t0.astype(np.float64), {"units": "s"}),
        "update_time": ("update", u0.astype(np.float64), {"units": "s"}),
        "state": ("state", np.array(list(state_names), dtype=str)),
        "meas": ("meas", np.array(list(meas_names), dtype=str)),
        "state_units": ("state", np.array(list(state_units), dtype=str)),
        "meas_units": ("meas", np.array(list(meas_units), dtype=str)),
    }
    for dim, (values, cattrs) in (extra_coords or {}).items():
        coords[dim] = (dim, np.asarray(values), dict(cattrs))
    ds = xr.Dataset(data, coords=coords, attrs=dict(attrs))
    for name, (units, long_name) in STANDARD_ATTRS.items():
        if name in ds.variables:
            ds[name].attrs.update(_units_attrs(units), long_name=long_name)
    for name, a in (extra_attrs or {}).items():
        if name in ds.variables:
            ds[name].attrs.update(a)
    for name in ds.variables:  # kinds outside sarnav may not describe their extras
        if UNITS_COORDINATE not in ds[name].attrs:
            ds[name].attrs.setdefault("units", "")
        if "description" not in ds[name].attrs:
            ds[name].attrs.setdefault("long_name", f"kind-specific variable {name!r}")
    return apply_cf(ds, f"sarnav {attrs.get('kind', '')} campaign {attrs.get('scenario_name', '')}".replace("  ", " "))


def _units_attrs(units: str) -> dict:
    """``units`` of a standard variable, or ``units_coordinate`` for a ``@coordinate`` reference (sarnav.cf)."""
    return {UNITS_COORDINATE: units[1:]} if units.startswith("@") else {"units": units}


#: units (UDUNITS; ``@name``: one per component, in the coordinate variable ``name``) and long name of every standard
#: variable and coordinate of results.nc (docs/results.md; sarnav.cf makes the file CF-1.10)
STANDARD_ATTRS = {
    "error": ("@state_units", "estimation error: truth minus estimate (error-state coordinates)"),
    "sigma": ("@state_units", "filter 1-sigma, sqrt(diag P)"),
    "nees": ("1", "normalised estimation error squared e^T P^-1 e, dof = number of states"),
    "residual": ("@meas_units", "measurement residual z - z_hat, NaN where absent"),
    "residual_sigma": ("@meas_units", "residual 1-sigma sqrt(diag(H P- H^T + R)), NaN where absent"),
    "nis": ("1", "normalised innovation squared over the measurements present"),
    "nis_dof": ("1", "number of measurements in nis"),
    "run": ("1", "Monte Carlo run index (seed: SeedSequence(campaign seed).spawn(runs)[run])"),
    "time": ("s", "time of the output epochs since the start of the run"),
    "update_time": ("s", "time of the measurement updates since the start of the run"),
    "state": ("", "names of the error states"),
    "meas": ("", "names of the measurement components"),
    "state_units": ("", "units of each error state (UDUNITS)"),
    "meas_units": ("", "units of each measurement component (UDUNITS)"),
}


def write_results(ds: xr.Dataset, path: str | os.PathLike) -> None:
    """Write ``ds`` as netCDF4 atomically (temporary file + ``os.replace``)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    ds.to_netcdf(tmp, engine="netcdf4")
    with open(tmp, "rb") as fh:
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def open_results(path: str | os.PathLike) -> xr.Dataset:
    """Load a ``results.nc`` fully into memory (the file is closed on return)."""
    with xr.open_dataset(path, engine="netcdf4") as ds:
        return ds.load()
