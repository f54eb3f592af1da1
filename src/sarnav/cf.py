"""The CF conventions (CF-1.10, https://cfconventions.org) for the netCDF files sarnav writes (docs/results.md).

:func:`apply_cf` makes a Dataset follow them before it is written:

* global attributes ``Conventions = "CF-1.10"``, ``title``, ``source`` (sarnav and its version), ``sarnav_version``
  and ``sarnav_commit`` (:mod:`sarnav.version`);
* every variable has a ``long_name`` (sarnav's older ``description`` attribute is renamed);
* ``units`` are UDUNITS-2 strings (``m``, ``m/s``, ``rad``, ``1`` for dimensionless: the empty string sarnav's kinds
  give an index or a count becomes ``1``). String variables (labels) carry none. A variable whose components have different units along one labelled dimension (``error`` along ``state``:
  m, m/s, rad) carries none either: its ``units_coordinate`` attribute names the coordinate variable holding one
  UDUNITS string per component (``state_units``); a label coordinate given a list of units (sarnav's older form)
  gets that coordinate variable (``<dim>_units``) made from the list.
"""

from __future__ import annotations

import numpy as np

from sarnav.version import provenance

__all__ = ["CONVENTIONS", "apply_cf", "UNITS_COORDINATE"]

#: the value of the global ``Conventions`` attribute
CONVENTIONS = "CF-1.10"
#: attribute naming the coordinate variable that holds a mixed-unit variable's units, one per component
UNITS_COORDINATE = "units_coordinate"


def _is_text(values) -> bool:
    return np.asarray(values).dtype.kind in "USO"


def apply_cf(ds, title: str):
    """Make ``ds`` (an :class:`xarray.Dataset`) follow CF-1.10 in place (module docstring); returns it."""
    ds.attrs["Conventions"] = CONVENTIONS
    ds.attrs.setdefault("title", title)
    for key, value in provenance().items():
        ds.attrs.setdefault(key, value)
    ds.attrs.setdefault("source", f"sarnav {ds.attrs['sarnav_version']}")
    for name in list(ds.coords):  # a list of units on a label coordinate -> a coordinate variable of them
        units = ds[name].attrs.get("units")
        if name in ds.dims and units is not None and not isinstance(units, str):
            units = [str(u) for u in units]
            ds[name].attrs.pop("units")
            if f"{name}_units" not in ds.variables:
                ds.coords[f"{name}_units"] = (name, np.array(units, dtype=str),
                                              {"long_name": f"units of each {name} (UDUNITS)"})
    for name in ds.variables:
        attrs = ds[name].attrs
        if "description" in attrs:
            attrs.setdefault("long_name", attrs["description"])
            del attrs["description"]
        attrs.setdefault("long_name", name)
        if _is_text(ds[name].values) or UNITS_COORDINATE in attrs:
            attrs.pop("units", None)
        elif attrs.get("units") == "":
            attrs["units"] = "1"
    return ds
