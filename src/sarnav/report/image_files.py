"""Files of a single image: ``image.npz`` (data, axes, radar figures, metadata), ``image.png`` (|image| in dB),
``metrics.json`` (strict JSON) and, through ``sarnav.io``, the image as SICD (``image.nitf``) and a simulated collect
as CPHD (``collect.cphd``): :func:`write_image_files` for any image, :func:`write_scene_image` for the image of a
simulated scene (``simulation.image_scene``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from sarnav.report.figures import save_png
from sarnav.simulation.image_scene import ImageSceneParams, ImageSceneResult, scene_centre, sicd_geometry
from sarnav.units import amplitude_to_db

__all__ = ["PNG_DYNAMIC_RANGE_DB", "json_safe", "write_image_npz", "write_image_png", "write_json",
           "write_image_files", "write_scene_image"]

#: dynamic range of the PNG [dB below the peak]
PNG_DYNAMIC_RANGE_DB = 50.0


def json_safe(obj):
    """``obj`` with numpy scalars as Python numbers and non-finite floats as None (strict JSON)."""
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, (np.floating, np.integer)):
        obj = obj.item()
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


def write_json(obj, path) -> Path:
    path = Path(path)
    path.write_text(json.dumps(json_safe(obj), indent=2, allow_nan=False) + "\n")
    return path


def write_image_npz(img, params, path, speed: float, scenario_toml: str = "") -> Path:
    """``img`` (a SarImage) with its axes, the radar's carrier / bandwidth / PRF and the image metadata."""
    meta = json_safe(dict(img.metadata))
    meta.setdefault("wavelength", params.wavelength)
    np.savez_compressed(
        path, data=img.data, y=img.y, x=img.x, y_name=img.y_name, x_name=img.x_name,
        carrier_frequency=params.carrier_frequency, bandwidth=params.bandwidth, prf=params.prf,
        speed=float(meta.get("speed", speed)),
        closest_approach_range=float(meta.get("closest_approach_range", np.nan)),
        aperture_length=float(meta.get("aperture_length", np.nan)),
        metadata_json=json.dumps(meta), scenario_toml=scenario_toml,
    )
    return Path(path)


def write_image_png(img, path, title: str) -> Path:
    """|image| in dB re its peak over :data:`PNG_DYNAMIC_RANGE_DB`, axes in metres, with a colour bar."""
    mag = np.abs(img.data)
    db = amplitude_to_db(np.maximum(mag, mag.max() * 10 ** (-PNG_DYNAMIC_RANGE_DB / 20) * 1e-3) / mag.max())
    fig = Figure(figsize=(7, 5), layout="constrained")
    ax = fig.subplots()
    extent = [img.x[0], img.x[-1], img.y[0], img.y[-1]]
    h = ax.imshow(db, origin="lower", aspect="auto", extent=extent, cmap="gray", vmin=-PNG_DYNAMIC_RANGE_DB, vmax=0)
    ax.set_xlabel(f"{img.x_name.replace('_', ' ')} [m]")
    ax.set_ylabel(f"{img.y_name.replace('_', ' ')} [m]")
    ax.set_title(title)
    fig.colorbar(h, ax=ax, label="amplitude [dB re peak]")
    return Path(save_png(fig, path))


def write_image_files(out, img, figures, metrics: dict, title: str, *, speed: float, scenario_toml: str = "",
                      sicd=None, geotiff=None) -> None:
    """``image.npz`` (radar ``figures``: carrier_frequency, bandwidth, prf, wavelength), with ``sicd`` (an
    ``io.sicd.SicdGeometry``) the image as SICD ``image.nitf``, ``metrics.json`` and ``image.png`` (``title``) in
    ``out``; with ``geotiff`` (the image's ``PlaneGrid`` in ECEF, a ground plane) the image geocoded as ``image.tif``."""
    from sarnav.io.sicd import write_image  # sarkit, imported when a file needs it

    out = Path(out)
    write_image_npz(img, figures, out / "image.npz", speed=speed, scenario_toml=scenario_toml)
    if sicd is not None:
        write_image(out / "image.nitf", img, sicd)
    if geotiff is not None:
        from sarnav.io.geotiff import write_plane_geotiff  # rasterio (sarnav[geo]), imported when a file needs it

        write_plane_geotiff(out / "image.tif", img.data, geotiff)
    write_json(metrics, out / "metrics.json")
    write_image_png(img, out / "image.png", title)


def write_scene_image(p: ImageSceneParams, result: ImageSceneResult, out, *, cphd: bool = False, sicd: bool = False,
                      scenario_toml: str = "") -> dict:
    """The files of a simulated scene's image (:func:`write_image_files`) in ``out``, with ``cphd`` the collect as
    ``collect.cphd`` (range-compressed pulses, NED at ``p.origin_llh``; the scene reference point at the scene centre,
    the image area its half sizes, uIAX east, uIAY north), with ``sicd`` the back-projected image as ``image.nitf``;
    return the metrics written (the result's, with the extra files listed)."""
    from sarnav.io.cphd import write_collect

    out = Path(out)
    if cphd:
        centre, (half_n, half_e) = scene_centre(p)
        write_collect(out / "collect.cphd", result.pulses, [float(x) for x in p.origin_llh], scene_point=centre,
                      image_half_extent=(half_e, half_n))
    metrics = dict(result.metrics)
    files = [name for name, on in (("collect.cphd", cphd), ("image.nitf", sicd)) if on]
    if files:
        metrics["files"] = files
    img = result.image
    write_image_files(out, img, p.radar, metrics, f"{p.name or 'image'}: {p.algorithm.upper()}, "
                                                  f"window {img.metadata.get('window', '')}",
                      speed=float(p.speed), scenario_toml=scenario_toml,
                      sicd=sicd_geometry(p, img, result.pulses) if sicd else None)
    return metrics
