"""The in-flight images ``sarnav navigate`` writes (docs/navigate.md): ``images/aperture_NNN.png`` for every image
the navigator formed and registered against the reference, with ``--sicd`` also ``images/aperture_NNN.sicd``, and
``images/images.csv`` (one row per image: its aperture, point, update time, files and pixel axes).

PNG (:func:`write_png`): the magnitude in dB, ``20 log10 |pixel|``, from the image's peak (white) down to
``DYNAMIC_RANGE_DB`` below it (black), 8-bit grey, the pixels as the image has them (not north-up): an RDA image
has one row per pulse (row i: zero-Doppler time of pulse i, the first at the top) and one column per slant-range
bin (range increasing to the right); a BPA image is on its ground grid, rows along the estimated track (increasing
downward), columns ground range away from it toward the look side (increasing to the right). The axes are in
images.csv (``rows``/``cols``: name, first value, spacing, unit) and in the PNG's text chunks.

SICD (:func:`write_sicd`, ``io.sicd.write_image``, sarkit): the aperture's range-compressed pulses back-projected
along the estimated focusing track the in-flight image was formed with (RDA: the navigator's estimate interpolated
to the pulse times; BPA: ``measurements.sar_image.focusing_track``; never truth, never the file's antenna
positions) onto the plane of the in-flight image over its extent (RDA: the slant plane through the straight track
the RDA assumed and the map's reference point, rows along track over the aperture, columns the image's slant-range
window; BPA: its ground grid), at the spacing of the impulse-response bandwidth (``SicdGeometry.at_resolution``:
a back-projected image on a plane is what a SICD holds, and its oversampling is one sarkit's checker accepts).
ARPPoly is that track in ECEF, the SCP the centre pixel; CollectStart the manifest's epoch plus the first pulse's
time.

The files go into ``images.partial/`` as the run goes; :meth:`NavigateImages.write_index` writes images.csv there
and, once the run is complete, :meth:`NavigateImages.publish` renames the folder ``images/``: an interrupted run
leaves ``images.partial/``.
"""

from __future__ import annotations

import csv
import datetime
import os
import time
from pathlib import Path

import numpy as np

__all__ = ["IMAGE_DIR", "INDEX_FILE", "INDEX_COLUMNS", "DYNAMIC_RANGE_DB", "NavigateImages", "image_name",
           "db_pixels", "write_png", "write_sicd", "remove_images"]

IMAGE_DIR = "images"
INDEX_FILE = "images.csv"
#: the PNG's grey scale spans the image's peak down to this far below it [dB]
DYNAMIC_RANGE_DB = 40.0
#: images.csv's columns, in order
INDEX_COLUMNS = ("time", "aperture", "point", "png", "sicd", "rows", "row_first", "row_spacing", "row_unit", "cols",
                 "col_first", "col_spacing", "col_unit", "peak_db", "algorithm")


def image_name(aperture: int, point: int, points: int) -> str:
    """``aperture_NNN`` (one reference point per aperture), else ``aperture_NNN_point_K``."""
    return f"aperture_{aperture:03d}" + ("" if points == 1 else f"_point_{point}")


def db_pixels(data, dynamic_range: float = DYNAMIC_RANGE_DB) -> tuple[np.ndarray, float]:
    """(uint8 grey levels, peak [dB]) of the magnitude of ``data``: 255 at the peak, 0 at ``dynamic_range`` dB below
    it and under; an image without a finite non-zero pixel is black (peak -inf)."""
    power = np.abs(np.asarray(data)) ** 2
    power = np.where(np.isfinite(power), power, 0.0)
    peak = float(power.max()) if power.size else 0.0
    if not peak > 0:
        return np.zeros(power.shape, dtype=np.uint8), -np.inf
    level = 10.0 * np.log10(np.maximum(power, peak * 1e-30) / peak)      # dB below the peak, <= 0
    grey = np.clip((level + dynamic_range) * (255.0 / dynamic_range), 0.0, 255.0)
    return np.rint(grey).astype(np.uint8), 10.0 * float(np.log10(peak))


def write_png(path, data, title: str = "", axes: str = "", dynamic_range: float = DYNAMIC_RANGE_DB) -> float:
    """``data``'s magnitude in dB as an 8-bit grey PNG (:func:`db_pixels`; row 0 at the top) with ``title`` and a
    description (the scale, its peak and ``axes``) as tEXt chunks; returns the peak [dB]. Written with Pillow at
    zlib level 1, no figure (docs/navigate.md gives its measured cost)."""
    from PIL import Image, PngImagePlugin

    grey, peak = db_pixels(data, dynamic_range)
    info = PngImagePlugin.PngInfo()
    info.add_text("Title", title)
    info.add_text("Description", f"20 log10|pixel| from the peak ({peak:.6g} dB, white) down {dynamic_range:g} dB "
                                 f"(black); {axes}")
    Image.fromarray(grey, mode="L").save(path, format="PNG", compress_level=1, pnginfo=info)
    return peak


def _axes(entry: dict) -> tuple[np.ndarray, tuple, tuple, str]:
    """(pixels, (rows name, first, spacing, unit), (cols ...), algorithm) of a kept image
    (``ApertureMeasurements.images``)."""
    img, grid = entry["image"], entry["grid"]
    if grid is None:                                                  # RDA: pulses x slant-range bins
        t = np.asarray(entry["pulses"].pulse_times, dtype=np.float64)
        dt = float(t[-1] - t[0]) / max(t.size - 1, 1)
        return (img.data, ("zero_doppler_time", float(t[0]), dt, "s"),
                ("slant_range", float(img.x[0]), float(img.dx), "m"), "rda")
    n, m = grid.shape
    return (img, ("along_track", -0.5 * (n - 1) * grid.da, float(grid.da), "m"),
            ("ground_range", -0.5 * (m - 1) * grid.dg, float(grid.dg), "m"), "bpa")


def _plane(entry: dict, target: np.ndarray):
    """The in-flight image's plane as an NED ``PlaneGrid`` over its extent (module docstring)."""
    from sarnav.imaging.grid import PlaneGrid, regular_axis

    img, grid = entry["image"], entry["grid"]
    if grid is not None:
        n, m = grid.shape
        return PlaneGrid(grid.centre, grid.along, grid.across, regular_axis(0.0, grid.da, n, "rows"),
                         regular_axis(0.0, grid.dg, m, "cols"), "along_track", "ground_range")
    o = np.asarray(img.metadata["along_track_origin"], dtype=np.float64)
    u = np.asarray(img.metadata["along_track_direction"], dtype=np.float64)
    w = np.asarray(target, dtype=np.float64) - o
    look = w - np.dot(w, u) * u                                     # toward the map's point, across the track
    y = np.asarray(img.y, dtype=np.float64)
    rows = regular_axis(0.5 * float(y[0] + y[-1]), float(y[-1] - y[0]) / (y.size - 1), y.size, "rows")
    return PlaneGrid(o, u, look, rows, np.asarray(img.x, dtype=np.float64), "along_track", "slant_range")


def write_sicd(path, entry: dict, target, origin, epoch: datetime.datetime):
    """The SICD of a kept image (module docstring) at ``path``; ``target`` the map's point the image was centred on
    (NED), ``origin`` the NED frame's (lat, lon, height), ``epoch`` the recording's time 0 (UTC). Returns the
    ``SicdGeometry`` written."""
    from sarnav.imaging.backprojection import backproject
    from sarnav.imaging.grid import PlaneGrid
    from sarnav.io.frames import grid_to_ecef, ned_basis, ned_to_ecef
    from sarnav.io.sicd import SicdGeometry, write_image

    pulses, track = entry["pulses"], np.asarray(entry["positions"], dtype=np.float64)
    times = np.asarray(pulses.pulse_times, dtype=np.float64)
    start = epoch + datetime.timedelta(seconds=float(times[0]))
    geo = SicdGeometry(grid_to_ecef(_plane(entry, target), origin), ned_to_ecef(track, origin), times,
                       float(pulses.wavelength), float(pulses.bandwidth), start).at_resolution()
    o, rot = ned_basis(origin)                                  # the SICD's grid in NED, where the pulses are
    g = geo.grid
    ned = PlaneGrid((g.origin - o) @ rot, g.row_direction @ rot, g.col_direction @ rot, g.rows, g.cols, g.row_name,
                    g.col_name)
    write_image(path, backproject(pulses, ned, positions=track), geo)
    return geo


class NavigateImages:
    """The ``images`` hook of ``recording.navigate.navigate`` for the folder ``out`` (module docstring): each call
    ``(aperture, time, images)`` writes the PNG (and with ``sicd`` the SICD) of every image kept; ``seconds`` the
    time spent on each kind of file, ``rows`` images.csv's rows."""

    def __init__(self, out, rec, sicd: bool = False):
        self.out, self.rec, self.sicd = Path(out), rec, bool(sicd)
        self.folder = self.out / f"{IMAGE_DIR}.partial"
        self.points = rec.points.anchors.shape[1] if rec.points is not None else 1
        self.rows: list = []
        self.seconds = {"png": 0.0, "sicd": 0.0}

    def __call__(self, aperture: int, t: float, images: dict) -> None:
        self.folder.mkdir(exist_ok=True)
        m = self.rec.manifest
        for k in sorted(images):
            entry, name = images[k], image_name(aperture, k, self.points)
            data, rows, cols, algorithm = _axes(entry)
            t0 = time.perf_counter()
            peak = write_png(self.folder / f"{name}.png", data,
                             f"sarnav navigate: {algorithm.upper()} in-flight image of aperture {aperture}, point {k}, "
                             f"update t = {t!r} s", f"rows {_axis_text(rows)}, columns {_axis_text(cols)}")
            t1 = time.perf_counter()
            self.seconds["png"] += t1 - t0
            self.rows.append([t, aperture, k, f"{name}.png", "", *rows, *cols, peak, algorithm])
            if self.sicd:   # a SICD that fails leaves the PNG listed, its sicd column empty (and a notice)
                write_sicd(self.folder / f"{name}.sicd", entry, self.rec.points.map[aperture, k], m.frame.origin,
                           m.time.epoch)
                self.rows[-1][4] = f"{name}.sicd"
                self.seconds["sicd"] += time.perf_counter() - t1

    def write_index(self) -> str | None:
        """images.csv into ``images.partial/``; the folder's name (None: no image was written)."""
        if not self.rows and not self.folder.is_dir():
            return None
        self.folder.mkdir(exist_ok=True)
        tmp = self.folder / f".{INDEX_FILE}.tmp"
        with open(tmp, "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(INDEX_COLUMNS)
            w.writerows(self.rows)
        os.replace(tmp, self.folder / INDEX_FILE)
        return self.folder.name

    def publish(self) -> str | None:
        """``images.partial/`` renamed ``images/`` (the run is complete); its name (None: no image folder)."""
        if not self.folder.is_dir():
            return None
        os.replace(self.folder, self.out / IMAGE_DIR)
        return IMAGE_DIR

    def summary(self) -> dict:
        """navigate.json's ``images``: counts, and seconds per file of each kind."""
        n_png = len(self.rows)
        n_sicd = sum(1 for r in self.rows if r[4])
        return {"png": n_png, "sicd": n_sicd, "dynamic_range_db": DYNAMIC_RANGE_DB,
                "seconds_per_png": self.seconds["png"] / n_png if n_png else None,
                "seconds_per_sicd": self.seconds["sicd"] / n_sicd if n_sicd else None}


def _axis_text(axis: tuple) -> str:
    name, first, spacing, unit = axis
    return f"{name} {first!r} {unit} + index x {spacing!r} {unit}"


def remove_images(out) -> None:
    """``--overwrite``: navigate's own files in ``out/images`` and ``out/images.partial`` (the PNG, SICD and
    images.csv it writes) and the folders; a folder that holds anything else is left alone and refused (ConfigError
    ``--out``: the run would publish its images into it)."""
    from sarnav.errors import ConfigError

    found = {}
    for name in (IMAGE_DIR, f"{IMAGE_DIR}.partial"):
        folder = Path(out) / name
        if folder.is_dir():
            own = [f for pattern in ("aperture_*.png", "aperture_*.sicd", INDEX_FILE, f".{INDEX_FILE}.tmp")
                   for f in folder.glob(pattern) if f.is_file()]
            other = sorted(f.name for f in folder.iterdir() if f not in own)
            if other:
                raise ConfigError("--out", f"{str(folder)!r} holds files navigate did not write ({', '.join(other[:3])}"
                                  f"{' ...' if len(other) > 3 else ''}): move them away (--overwrite replaces only "
                                  "navigate's own)")
            found[folder] = own
    for folder, own in found.items():      # checked first: a refused run removes nothing
        for f in own:
            f.unlink()
        folder.rmdir()
