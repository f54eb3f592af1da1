"""``sarnav image FILE.cphd``: an image formed from a CPHD file (wiring only).

The collect is read with :func:`sarnav.io.cphd.read_collect` (monostatic, FX domain, ECEF; an optional filter of the
frequency samples), back-projected (``imaging.backprojection.backproject``, "bpa") or by fast factorised
back-projection (``imaging.ffbp.ffbp``, "ffbp") onto a plane grid: the file's image grid by default, or the same
plane resampled with ``spacing`` / ``extent`` (``io.cphd.image_grid``); an optional azimuth window weights the pulses.
Written into ``out``: ``image.npz``, ``image.png``, ``metrics.json`` (as for a scenario) and, with ``sicd``, the image
as SICD ``image.nitf`` (``io.sicd.write_image``). Bad input is one line naming the flag or the file's field.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from sarnav.errors import ConfigError, InputDataError

__all__ = ["ALGORITHMS", "MAX_PIXELS", "is_cphd", "run_cphd_image"]

ALGORITHMS = ("bpa", "ffbp")
#: the largest image formed from a CPHD [pixels] (complex128: 1 GiB)
MAX_PIXELS = 2**26
_C = 299792458.0


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
    from sarnav.io.cphd import image_grid

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
    return image_grid(default, sp, ext)


def _filter(path):
    """The frequency-sample weights of ``--filter FILE.npy``: a 1-D array of numbers."""
    if path is None:
        return None
    try:
        h = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as err:
        raise ConfigError("--filter", f"cannot read {str(path)!r} as a .npy array ({err})") from None
    if h.ndim != 1 or h.dtype.kind not in "biufc":
        raise ConfigError("--filter", f"must hold a 1-D array of weights, got shape {h.shape} dtype {h.dtype}")
    return h


def _read(path: Path, filter_path):
    from sarnav.io.cphd import read_collect

    try:
        return read_collect(path, filter=_filter(filter_path))
    except InputDataError as err:   # the filter's length against the collect's frequency samples
        if err.field in ("phase_history.data", "filter") and filter_path is not None:
            raise InputDataError("--filter", f"{err.message} ({str(filter_path)!r})") from None
        raise


def _identity(path: Path, options: dict) -> dict:
    st = path.stat()
    text = f"{path.resolve()}|{st.st_size}|{st.st_mtime_ns}|{sorted(options.items())}"
    return {"kind": "image-cphd", "scenario": path.stem, "fingerprint": hashlib.sha256(text.encode()).hexdigest(),
            "seed": None}


def _form(rc, grid, algorithm: str, window: str | None):
    from sarnav.imaging.backprojection import backproject
    from sarnav.imaging.ffbp import ffbp
    from sarnav.signal.windows import as_window

    w = as_window(window or "none", "--window")
    if w.name != "none":
        rc = rc.__class__(**{**rc.__dict__, "data": rc.data * w.samples(rc.n_pulses)[:, None]})
    img = backproject(rc, grid) if algorithm == "bpa" else ffbp(rc, grid)
    img.metadata["window"] = w.label
    return img


def _report(path: Path, rc, img, algorithm: str, bandwidth: float, sicd: bool) -> dict:
    from sarnav.imaging import quality

    md = img.metadata
    report = {"source": str(path), "algorithm": algorithm, "n_pulses": int(rc.n_pulses),
              "n_range_samples": int(rc.data.shape[1]), "image_shape": list(img.shape),
              "pixel_spacing_m": {img.y_name: img.dy, img.x_name: img.dx},
              "carrier_frequency_hz": _C / rc.wavelength, "bandwidth_hz": bandwidth,
              "interpolation": md.get("interpolation"),
              "quality": {"normalised_kurtosis": quality.normalised_complex_kurtosis(img.data),
                          "entropy_magnitude_100": quality.entropy_magnitude(img.data, 100),
                          "normalised_variance": quality.normalised_variance(img.data)}}
    if algorithm == "ffbp":
        report["ffbp"] = {k[5:]: md[k] for k in md if k.startswith("ffbp_")}
    if sicd:
        report["files"] = ["image.nitf"]
    return report


def run_cphd_image(path, out, *, algorithm: str = "bpa", spacing=None, extent=None, window: str | None = None,
                   filter_path=None, sicd: bool = False, overwrite: bool = False) -> dict:
    """Read the CPHD ``path``, form the image, write the files into ``out`` (module doc); return the metrics."""
    from sarnav.imaging.backprojection import data_oversampling
    from sarnav.io.sicd import SicdGeometry, write_image
    from sarnav.montecarlo.outdir import OutputFolder
    from sarnav.report.image_files import write_image_npz, write_image_png, write_json

    path = Path(path)
    if not path.is_file():
        raise ConfigError("FILE", f"{str(path)!r} is not a readable file")
    if algorithm not in ALGORITHMS:
        raise ConfigError("--algorithm", f"a CPHD is back-projected: must be one of {ALGORITHMS}, got {algorithm!r}")
    rc, default = _read(path, filter_path)
    grid = _grid(default, spacing, extent)
    options = {"algorithm": algorithm, "spacing": spacing, "extent": extent, "window": window,
               "filter": str(filter_path), "sicd": sicd}
    with OutputFolder(out, _identity(path, options), overwrite=overwrite):
        out = Path(out)
        img = _form(rc, grid, algorithm, window)
        fs = _C / (2.0 * float(rc.slant_range[1] - rc.slant_range[0]))
        bandwidth = fs / data_oversampling(rc)                  # the signal's band, from its spectrum
        figures = SimpleNamespace(carrier_frequency=_C / rc.wavelength, bandwidth=bandwidth, wavelength=rc.wavelength,
                                  prf=(rc.n_pulses - 1) / float(np.ptp(rc.pulse_times)))
        speed = float(np.mean(np.sqrt(np.sum(np.diff(rc.positions, axis=0) ** 2, axis=1))) * figures.prf)
        write_image_npz(img, figures, out / "image.npz", speed=speed)
        if sicd:
            write_image(out / "image.nitf", img, SicdGeometry(grid, rc.positions, rc.pulse_times, rc.wavelength,
                                                              bandwidth))
        report = _report(path, rc, img, algorithm, bandwidth, sicd)
        write_json(report, out / "metrics.json")
        write_image_png(img, out / "image.png", f"{path.name}: {algorithm.upper()}")
        return report
