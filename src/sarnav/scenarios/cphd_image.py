"""``sarnav image FILE.cphd``: an image formed from a CPHD file (the command's options and wiring only).

The file's header and PVPs are read and checked by :func:`sarnav.io.cphd.read_collect_header` (one channel,
``--channel``; a range of vectors, ``--pulses START:STOP``; the reading of TDTropoSRP, ``--tropo``; every
uncompressed signal format, AmpSF, SGN) and the image is formed by ``io.cphd_stream.run_image_collect``:
back-projection "bpa" or fast factorised back-projection "ffbp" of the vectors read in blocks within the memory
``--budget`` (default 1G), an optional azimuth window and filter of the frequency samples (``io.cphd.read_filter``),
the collect's figures and the image's metrics, onto a plane grid: the file's image grid by default, or the same
plane resampled with ``spacing`` / ``extent`` (``imaging.grid.PlaneGrid.resampled``).
Written into ``out`` by ``report.image_files.write_image_files``: ``image.npz``, ``image.png``, ``metrics.json`` (as
for a scenario), with ``sicd`` the image as SICD ``image.nitf`` (without ``spacing``: on the same extent at the
spacing of its impulse-response bandwidth, ``io.sicd.SicdGeometry.at_resolution``), with ``geotiff`` the image
geocoded as ``image.tif`` (``io.geotiff.write_plane_geotiff``). Bad input is one line naming the flag or the
file's field.
"""

from __future__ import annotations

import hashlib
from pathlib import Path


from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.collect_image import ALGORITHMS
from sarnav.imaging.grid import check_resampled
from sarnav.io.cphd_stream import read_budget_flag as parse_budget
from sarnav.io.cphd_stream import read_error_db_flag as parse_error_db, read_pulses_flag as parse_pulses

__all__ = ["ALGORITHMS", "MAX_PIXELS", "is_cphd", "run_cphd_image"]

#: the largest image formed from a CPHD [pixels] (complex128: 1 GiB)
MAX_PIXELS = 2**26


def is_cphd(target: str) -> bool:
    """Whether the ``sarnav image`` target names a CPHD file (by its suffix)."""
    return str(target).lower().endswith(".cphd")


def _grid(default, spacing, extent):
    return check_resampled(default, spacing, extent, MAX_PIXELS, ("--spacing", "--extent"))


#: errors of the library's parameters that name a flag of ``sarnav image FILE.cphd``
_FLAGS = {"channel": "--channel", "pulses": "--pulses", "tropo": "--tropo", "budget": "--budget"}
def _open(path: Path, channel, pulses, tropo):
    from sarnav.io.cphd import read_collect_header

    try:
        return read_collect_header(path, channel=channel, pulses=pulses, tropo=tropo)
    except ConfigError as err:
        raise ConfigError(_FLAGS.get(err.field, err.field), err.message) from None


def _form(c, grid, algorithm, window, filter_path, budget, error_db=None):
    from sarnav.io.cphd import read_filter
    from sarnav.io.cphd_stream import run_image_collect

    h = None if filter_path is None else read_filter(filter_path, "--filter")
    try:
        return run_image_collect(c, grid, algorithm, window=window, window_field="--window", filter=h, budget=budget,
                                 budget_field="--budget", error_db=error_db, error_db_field="--error-db")
    except InputDataError as err:   # the filter's length against the collect's frequency samples
        if err.field in ("phase_history.data", "filter") and filter_path is not None:
            raise InputDataError("--filter", f"{err.message} ({str(filter_path)!r})") from None
        raise


def _identity(path: Path, options: dict) -> dict:
    st = path.stat()
    text = f"{path.resolve()}|{st.st_size}|{st.st_mtime_ns}|{sorted(options.items())}"
    return {"kind": "image-cphd", "scenario": path.stem, "fingerprint": hashlib.sha256(text.encode()).hexdigest(),
            "seed": None}


def run_cphd_image(path, out, *, algorithm: str = "auto", spacing=None, extent=None, window: str | None = None,
                   filter_path=None, sicd: bool = False, overwrite: bool = False, channel=None, pulses=None,
                   tropo: str = "in-data", budget=None, geotiff: bool = False, error_db=None) -> dict:
    """Read the CPHD ``path``, form the image, write the files into ``out`` (module doc); return the metrics.
    ``channel``: identifier (default the first); ``pulses``: ``START:STOP`` or (start, stop); ``tropo``: TDTropoSRP's
    reading (``io.cphd_read.TROPO``); ``budget``, ``error_db``: as the flags ``--budget``, ``--error-db``."""
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
    budget, error_db = parse_budget(budget, "--budget"), parse_error_db(error_db, algorithm, "--error-db")
    pulses = parse_pulses(pulses, "--pulses") if isinstance(pulses, str) else pulses
    c, default = _open(path, channel, pulses, tropo)
    grid = _grid(default, spacing, extent)
    if sicd and spacing is None:      # the SICD's pixels spaced from its impulse-response bandwidth (sicdcheck: OSR)
        from sarnav.io.cphd_stream import read_sicd_geometry

        grid = read_sicd_geometry(c, grid).at_resolution().grid
        if grid.shape[0] * grid.shape[1] > MAX_PIXELS:
            raise ConfigError("--sicd", f"the resolution's spacing gives {grid.shape} pixels (at most {MAX_PIXELS:.3g}): "
                              "give --spacing or a smaller --extent")
    options = {"algorithm": algorithm, "spacing": spacing, "extent": extent, "window": window,
               "filter": str(filter_path), "sicd": sicd, "channel": c.channel, "pulses": [c.start, c.stop],
               "tropo": tropo, **({"geotiff": True} if geotiff else {}),
               **({"error_db": error_db} if error_db is not None else {})}
    with OutputFolder(out, _identity(path, options), overwrite=overwrite):
        img, figures, metrics = _form(c, grid, algorithm, window, filter_path, budget, error_db)
        report = {"source": str(path), "channel": c.channel, "vectors": [c.start, c.stop], "tropo": tropo,
                  **metrics}
        if sicd or geotiff:
            report["files"] = [name for name, on in (("image.nitf", sicd), ("image.tif", geotiff)) if on]
        geometry = SicdGeometry(grid, c.positions, c.pulse_times, figures.wavelength, figures.bandwidth) \
            if sicd else None
        write_image_files(out, img, figures, report, f"{path.name}: {report.get('formed_by', algorithm).upper()}", speed=figures.speed,
                          sicd=geometry, geotiff=grid if geotiff else None)
        return report
