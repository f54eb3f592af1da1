"""``sarnav image FILE.cphd``: an image formed from a CPHD file (the command's options and wiring only).

The collect is read with :func:`sarnav.io.cphd.read_collect` (monostatic, FX domain, ECEF; an optional filter of the
frequency samples, ``io.cphd.read_filter``) and formed by ``imaging.collect_image.run_collect_image``
(back-projection "bpa" or fast factorised back-projection "ffbp", an optional azimuth window; the collect's figures
and the image's metrics) onto a plane grid: the file's image grid by default, or the same plane resampled with
``spacing`` / ``extent`` (``imaging.grid.PlaneGrid.resampled``).
Written into ``out`` by ``report.image_files.write_image_files``: ``image.npz``, ``image.png``, ``metrics.json`` (as
for a scenario), with ``sicd`` the image as SICD ``image.nitf`` (without ``spacing``: on the same extent at the
spacing of its impulse-response bandwidth, ``io.sicd.SicdGeometry.at_resolution``), with ``geotiff`` the image
geocoded as ``image.tif`` (``io.geotiff.write_plane_geotiff``). Bad input is one line naming the flag or the
file's field.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.collect_image import ALGORITHMS

__all__ = ["ALGORITHMS", "MAX_PIXELS", "is_cphd", "run_cphd_image"]

#: the largest image formed from a CPHD [pixels] (complex128: 1 GiB)
MAX_PIXELS = 2**26


def is_cphd(target: str) -> bool:
    """Whether the ``sarnav image`` target names a CPHD file (by its suffix)."""
    return str(target).lower().endswith(".cphd")


def _flag_number(name: str, value) -> float | None:
    if value is None:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ConfigError(name, f"must be a number [m], got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ConfigError(name, f"must be finite and > 0 m, got {value!r}")
    return v


def _extent(value):
    if value is None:
        return None
    parts = [p for p in str(value).replace("x", ",").split(",") if p.strip()]
    if len(parts) not in (1, 2):
        raise ConfigError("--extent", f"must be X or X,Y [m], got {value!r}")
    return tuple(_flag_number("--extent", p) for p in parts) if len(parts) == 2 else _flag_number("--extent", parts[0])


def _grid(default, spacing, extent):
    sp, ext = _flag_number("--spacing", spacing), _extent(extent)
    rows, cols = default.rows, default.cols
    dy, dx = (sp, sp) if sp is not None else (rows[1] - rows[0], cols[1] - cols[0])
    ey, ex = (ext if isinstance(ext, tuple) else (ext, ext)) if ext is not None else (np.ptp(rows), np.ptp(cols))
    n = (math.floor(ey / dy + 1e-9) + 1) * (math.floor(ex / dx + 1e-9) + 1)
    if n > MAX_PIXELS:
        raise ConfigError("--extent" if ext is not None else "--spacing",
                          f"{ey:g} x {ex:g} m at {dy:g} x {dx:g} m spacing is {n:.3g} pixels (at most {MAX_PIXELS:.3g}): "
                          "raise --spacing or lower --extent")
    if min(math.floor(ey / dy + 1e-9), math.floor(ex / dx + 1e-9)) < 1:
        raise ConfigError("--extent", f"must span at least two pixels of the spacing, got {ey:g} x {ex:g} m")
    return default.resampled(sp, ext)


def _read(path: Path, filter_path):
    from sarnav.io.cphd import read_collect, read_filter

    try:
        return read_collect(path, filter=None if filter_path is None else read_filter(filter_path, "--filter"))
    except InputDataError as err:   # the filter's length against the collect's frequency samples
        if err.field in ("phase_history.data", "filter") and filter_path is not None:
            raise InputDataError("--filter", f"{err.message} ({str(filter_path)!r})") from None
        raise


def _identity(path: Path, options: dict) -> dict:
    st = path.stat()
    text = f"{path.resolve()}|{st.st_size}|{st.st_mtime_ns}|{sorted(options.items())}"
    return {"kind": "image-cphd", "scenario": path.stem, "fingerprint": hashlib.sha256(text.encode()).hexdigest(),
            "seed": None}


def run_cphd_image(path, out, *, algorithm: str = "bpa", spacing=None, extent=None, window: str | None = None,
                   filter_path=None, sicd: bool = False, overwrite: bool = False, geotiff: bool = False) -> dict:
    """Read the CPHD ``path``, form the image, write the files into ``out`` (module doc); return the metrics."""
    from sarnav.imaging.collect_image import run_collect_image
    from sarnav.io.sicd import SicdGeometry
    from sarnav.montecarlo.outdir import OutputFolder
    from sarnav.report.image_files import write_image_files

    path = Path(path)
    if not path.is_file():
        raise ConfigError("FILE", f"{str(path)!r} is not a readable file")
    if algorithm not in ALGORITHMS:
        raise ConfigError("--algorithm", f"a CPHD is back-projected: must be one of {ALGORITHMS}, got {algorithm!r}")
    if geotiff:
        from sarnav.io.geotiff import check_geo_extra

        check_geo_extra("--geotiff")
    rc, default = _read(path, filter_path)
    grid = _grid(default, spacing, extent)
    if sicd and spacing is None:      # the SICD's pixels spaced from its impulse-response bandwidth (sicdcheck: OSR)
        grid = SicdGeometry.of_collect(grid, rc).at_resolution().grid
        if grid.shape[0] * grid.shape[1] > MAX_PIXELS:
            raise ConfigError("--sicd", f"the resolution's spacing gives {grid.shape} pixels (at most {MAX_PIXELS:.3g}): "
                              "give --spacing or a smaller --extent")
    options = {"algorithm": algorithm, "spacing": spacing, "extent": extent, "window": window,
               "filter": str(filter_path), "sicd": sicd, **({"geotiff": True} if geotiff else {})}
    with OutputFolder(out, _identity(path, options), overwrite=overwrite):
        img, figures, metrics = run_collect_image(rc, grid, algorithm, window, window_field="--window")
        report = {"source": str(path), **metrics}
        if sicd or geotiff:
            report["files"] = [name for name, on in (("image.nitf", sicd), ("image.tif", geotiff)) if on]
        geometry = SicdGeometry(grid, rc.positions, rc.pulse_times, rc.wavelength, figures.bandwidth) if sicd else None
        write_image_files(out, img, figures, report, f"{path.name}: {algorithm.upper()}", speed=figures.speed,
                          sicd=geometry, geotiff=grid if geotiff else None)
        return report
