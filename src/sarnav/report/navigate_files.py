"""The files ``sarnav navigate`` writes (docs/navigate.md), and the run that writes them.

:func:`run_navigate` navigates a recording (``recording.navigate``) into a folder: ``navigate.json`` first
(``complete: false``), then, at the end, every output written as ``NAME.partial`` and renamed, and ``navigate.json``
rewritten with ``complete: true`` and the summary. An interrupted run (an exception, Ctrl-C) writes what it had
done as ``NAME.partial`` and leaves ``navigate.json`` at ``complete: false`` with the reason.

Outputs: ``trajectory.nc`` (estimate, 1-sigma and covariance at every output epoch, every update and pair with its
status; CF-style ``units`` and ``long_name``), ``trajectory.csv`` (``time, north, east, down, v_north, v_east,
v_down, roll, pitch, yaw``, each with its ``sigma_`` column, and ``latitude, longitude, height``), ``trajectory.geojson``
and ``trajectory.kml`` (the track as a LineString in longitude, latitude, height, and the update points),
``updates.csv`` (one row per aperture and reference point) and, where the recording has truth, ``errors.csv``
(truth minus estimate per error state, 1-sigma, NEES) and its consistency summary (NEES and NIS against their 95 %
chi-square bands, ``analysis.consistency``) in ``navigate.json``; ``report.html`` (``report.navigate_html``, drawn
from the other outputs) unless ``report=False``; ``images/`` (``report.navigate_images``: a PNG of every in-flight
image formed, with ``sicd=True`` its SICD too, and images.csv), written as the run goes into ``images.partial/``,
renamed with the rest at the end (an interrupted run leaves ``images.partial/``).
"""

from __future__ import annotations

import csv
import json
import math
import os
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pymap3d

import sarnav
from sarnav.cf import apply_cf
from sarnav.analysis.consistency import nees_statistics, nis_statistics, sigma_containment
from sarnav.filters import error_state
from sarnav.ins import NavState
from sarnav.recording.navigate import REJECTIONS, SKIPPED, NavigateSettings, Navigation, navigate
from sarnav.recording.tables import write_columns
from sarnav.report.navigate_images import IMAGE_DIR, NavigateImages, remove_images
from sarnav.rotations import dcm_to_euler, euler_to_quat, quat_to_dcm

__all__ = ["run_navigate", "write_navigation", "prepare_output", "consistency", "TRAJECTORY_COLUMNS", "UPDATE_COLUMNS", "OUTPUT_FILES", "STATUS_FILE",
           "euler_sigma", "truth_errors"]

STATUS_FILE = "navigate.json"
#: every file navigate writes (``--overwrite`` removes them, and their ``.partial`` forms, before a run)
OUTPUT_FILES = ("trajectory.nc", "trajectory.csv", "trajectory.geojson", "trajectory.kml", "updates.csv", "errors.csv",
                "report.html")
_NAV = ("north", "east", "down", "v_north", "v_east", "v_down", "roll", "pitch", "yaw")
#: trajectory.csv's columns, in order
TRAJECTORY_COLUMNS = (("time",) + _NAV + tuple(f"sigma_{c}" for c in _NAV) + ("latitude", "longitude", "height"))
#: updates.csv's columns, in order
UPDATE_COLUMNS = ("time", "aperture", "point", "toc", "measured_range", "measured_cross_range", "sigma_range",
                  "sigma_along", "innovation_sigma_range", "innovation_sigma_cross", "residual_range",
                  "residual_cross", "correlation", "ambiguity", "status", "status_code", "fused")
_UNITS = {"north": "m", "east": "m", "down": "m", "v_north": "m/s", "v_east": "m/s", "v_down": "m/s",
          "roll": "rad", "pitch": "rad", "yaw": "rad"}
_LONG = {"north": "position north of the origin", "east": "position east of the origin",
         "down": "position below the origin's tangent plane", "v_north": "velocity north", "v_east": "velocity east",
         "v_down": "velocity down", "roll": "roll (3-2-1 Euler, body FRD to NED)", "pitch": "pitch (3-2-1 Euler)",
         "yaw": "yaw (3-2-1 Euler, from north)"}
_ERROR_NAMES = ("north", "east", "down", "v_north", "v_east", "v_down", "th_north", "th_east", "th_down",
                "accel_bias_x", "accel_bias_y", "accel_bias_z", "gyro_bias_x", "gyro_bias_y", "gyro_bias_z",
                "b_alt", "b_range", "b_cross")


def euler_sigma(q, P_th) -> np.ndarray:
    """(K, 3) 1-sigma of roll, pitch, yaw [rad] from the covariance ``P_th`` (K, 3, 3) of the NED attitude error
    at attitudes ``q`` (K, 4): d(euler) = E^-1 d(theta^n), E's columns the NED axes of the roll, pitch and yaw
    rotations of C = Rz(yaw) Ry(pitch) Rx(roll) (x_n, Rz y, Rz Ry x: Titterton & Weston 2004 eq. 3.52 in NED)."""
    _, pitch, yaw = dcm_to_euler(quat_to_dcm(q))
    cp, sp, cy, sy = np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    z, o = np.zeros_like(cp), np.ones_like(cp)
    E = np.stack([np.stack([cy * cp, -sy, z], -1), np.stack([sy * cp, cy, z], -1), np.stack([-sp, z, o], -1)], -2)
    Ei = np.linalg.inv(E)
    cov = Ei @ P_th @ np.swapaxes(Ei, -1, -2)
    return np.sqrt(np.maximum(np.einsum("kii->ki", cov), 0.0))


def _trajectory(rec, est: dict) -> dict:
    """trajectory.csv's columns (TRAJECTORY_COLUMNS) of the estimate ``est`` (``Navigation.estimate()``)."""
    roll, pitch, yaw = dcm_to_euler(quat_to_dcm(est["q"]))
    sig = est["sigma"]
    s_rpy = euler_sigma(est["q"], est["P"][:, 6:9, 6:9])
    lat0, lon0, h0 = (float(x) for x in rec.manifest.frame.origin)
    lat, lon, h = pymap3d.ned2geodetic(est["p"][:, 0], est["p"][:, 1], est["p"][:, 2], lat0, lon0, h0)
    values = [est["time"], *est["p"].T, *est["v"].T, roll, pitch, yaw, *sig[:, 0:6].T, *s_rpy.T,
              np.asarray(lat), np.asarray(lon), np.asarray(h)]
    return dict(zip(TRAJECTORY_COLUMNS, values))


def _truth_state(truth, t) -> tuple[NavState, np.ndarray]:
    """The truth at the epochs ``t`` (linear in time between the log's rows; NaN outside it) and which of the
    error states it gives (the biases only with the optional columns)."""
    def at(values):
        v = np.asarray(values, dtype=np.float64)
        out = np.stack([np.interp(t, truth.time, c, left=np.nan, right=np.nan) for c in np.atleast_2d(v.T)], -1)
        return out
    rpy = truth.rpy.copy()
    rpy[:, 2] = np.unwrap(rpy[:, 2])
    a = at(rpy)
    q = np.asarray(euler_to_quat(a[:, 0], a[:, 1], a[:, 2]))
    x = truth.extra
    names = (("accel_bias_x", "accel_bias_y", "accel_bias_z"), ("gyro_bias_x", "gyro_bias_y", "gyro_bias_z"),
             ("b_alt", "b_range", "b_cross"))
    parts = [at(np.stack([x[n] for n in group], -1)) if all(n in x for n in group) else np.full((t.size, 3), np.nan)
             for group in names]
    has = np.array([True] * 9 + [all(n in x for n in g) for g in names for _ in range(3)])
    return NavState(p=at(truth.position), v=at(truth.velocity), q=q, ba=parts[0], bg=parts[1], bm=parts[2]), has


def truth_errors(rec, est: dict, layout) -> dict | None:
    """Truth minus estimate at every epoch with truth: ``error`` (K, n) (NaN for states the truth log lacks),
    ``nees`` (K,) over the states it has whose 1-sigma is not zero (``nees_dof`` of them); None without a truth
    log."""
    if rec.truth is None:
        return None
    truth, has = _truth_state(rec.truth, est["time"])
    nav = NavState(p=est["p"], v=est["v"], q=est["q"], ba=est["ba"], bg=est["bg"], bm=est["bm"])
    e = error_state(truth, nav, layout)
    e[:, ~has] = np.nan
    idx = np.flatnonzero(has & np.all(est["sigma"] > 0, axis=0))  # a state never uncertain (no altimeter) is left out
    P = est["P"][:, idx[:, None], idx[None, :]]
    ee = e[:, idx]
    nees = np.full(ee.shape[0], np.nan)
    ok = np.all(np.isfinite(ee), axis=1)
    if ok.any():
        nees[ok] = np.einsum("ki,ki->k", ee[ok], np.linalg.solve(P[ok], ee[ok][..., None])[..., 0])
    return {"error": e, "nees": nees, "nees_dof": int(idx.size)}


def _updates_rows(nav: Navigation) -> list:
    rows = []
    for p in nav.pairs:
        rows.append([p["time"], p["aperture"], p["point"], p["toc"], p["range"], p["z"][1], p["sigma"][0],
                     p["sigma"][1], p["residual_sigma"][0], p["residual_sigma"][1], p["residual"][0], p["residual"][1],
                     p["correlation"], p["ambiguity"], p["reason"], p["code"], int(p["code"] == 0)])
    return rows


def _write_csv_rows(path: Path, header, rows) -> None:
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(header)
        w.writerows(rows)


def _geojson(traj: dict, nav: Navigation) -> dict:
    line = [[float(lo), float(la), float(h)] for lo, la, h in zip(traj["longitude"], traj["latitude"], traj["height"])]
    feats = [{"type": "Feature", "geometry": {"type": "LineString", "coordinates": line},
              "properties": {"name": "estimated track", "start_s": float(traj["time"][0]),
                             "end_s": float(traj["time"][-1])}}]
    for u in _update_points(traj, nav):
        feats.append({"type": "Feature", "geometry": {"type": "Point", "coordinates": u["coordinates"]},
                      "properties": {k: v for k, v in u.items() if k != "coordinates"}})
    return {"type": "FeatureCollection", "features": feats}


def _update_points(traj: dict, nav: Navigation) -> list:
    """Each update's estimated position (lon, lat, height) after it, with its time, aperture and pairs fused."""
    out = []
    for up in nav.updates:
        k = int(np.argmin(np.abs(traj["time"] - up["time"])))
        out.append({"coordinates": [float(traj["longitude"][k]), float(traj["latitude"][k]), float(traj["height"][k])],
                    "time_s": up["time"], "aperture": int(up["aperture"]), "altimeter": bool(up["altimeter"]),
                    "pairs_fused": up["pairs_fused"], "nis": up["nis"]})
    return out


def _kml(traj: dict, nav: Navigation) -> ET.ElementTree:
    ns = "http://www.opengis.net/kml/2.2"
    ET.register_namespace("", ns)
    root = ET.Element(f"{{{ns}}}kml")
    doc = ET.SubElement(root, f"{{{ns}}}Document")
    ET.SubElement(doc, f"{{{ns}}}name").text = "sarnav navigate"
    pm = ET.SubElement(doc, f"{{{ns}}}Placemark")
    ET.SubElement(pm, f"{{{ns}}}name").text = "estimated track"
    ls = ET.SubElement(pm, f"{{{ns}}}LineString")
    ET.SubElement(ls, f"{{{ns}}}altitudeMode").text = "absolute"
    ET.SubElement(ls, f"{{{ns}}}coordinates").text = " ".join(
        f"{lo!r},{la!r},{h!r}" for lo, la, h in zip(traj["longitude"].tolist(), traj["latitude"].tolist(),
                                                    traj["height"].tolist()))
    for u in _update_points(traj, nav):
        p = ET.SubElement(doc, f"{{{ns}}}Placemark")
        ET.SubElement(p, f"{{{ns}}}name").text = f"update t={u['time_s']:.3f} s"
        ET.SubElement(p, f"{{{ns}}}description").text = (f"aperture {u['aperture']}, pairs fused {u['pairs_fused']}, "
                                                         f"NIS {u['nis']:.4g}")
        pt = ET.SubElement(p, f"{{{ns}}}Point")
        ET.SubElement(pt, f"{{{ns}}}altitudeMode").text = "absolute"
        ET.SubElement(pt, f"{{{ns}}}coordinates").text = ",".join(repr(c) for c in u["coordinates"])
    return ET.ElementTree(root)


def _dataset(rec, nav: Navigation, traj: dict, est: dict, errors: dict | None, complete: bool):
    """trajectory.nc as an xarray Dataset (CF-style units and long_name on every variable)."""
    import xarray as xr

    L = nav.layout
    names, units = L.state_names(), L.state_units()
    data = {c: ("time", traj[c], {"units": _UNITS[c], "long_name": _LONG[c]}) for c in _NAV}
    data.update({f"sigma_{c}": ("time", traj[f"sigma_{c}"], {"units": _UNITS[c], "long_name": f"1-sigma of {c}"})
                 for c in _NAV})
    data["latitude"] = ("time", traj["latitude"], {"units": "degrees_north", "long_name": "WGS-84 latitude"})
    data["longitude"] = ("time", traj["longitude"], {"units": "degrees_east", "long_name": "WGS-84 longitude"})
    data["height"] = ("time", traj["height"], {"units": "m", "long_name": "height above the WGS-84 ellipsoid"})
    data["quaternion"] = (("time", "quaternion_component"), est["q"],
                          {"units": "1", "long_name": "attitude quaternion body FRD to NED, scalar first"})
    data["accel_bias"] = (("time", "axis"), est["ba"], {"units": "m s-2", "long_name": "accelerometer bias estimate"})
    data["gyro_bias"] = (("time", "axis"), est["bg"], {"units": "rad s-1", "long_name": "gyro bias estimate"})
    data["measurement_bias"] = (("time", "measurement_bias"), est["bm"],
                                {"units": "m", "long_name": "altimeter, SAR range and SAR cross-range bias estimates"})
    data["sigma"] = (("time", "state"), est["sigma"], {"units_coordinate": "state_units",
                                                      "long_name": "1-sigma per error state"})
    data["covariance"] = (("time", "state", "state2"), est["P"],
                          {"units_coordinate": "state_units", "long_name": "error-state covariance P (element i, j in "
                                                                         "state_units[i] times state_units[j])"})
    data.update(_update_vars(nav, REJECTIONS))
    data.update(_gnss_vars(nav))
    if errors is not None:
        data["error"] = (("time", "state"), errors["error"], {"units_coordinate": "state_units",
                                                              "long_name": "truth minus estimate (error state)"})
        data["nees"] = ("time", errors["nees"], {"units": "1", "long_name": "normalised estimation error squared",
                                                 "dof": errors["nees_dof"]})
    coords = {"time": ("time", est["time"], {"units": "s", "long_name": "recording time (from the manifest's epoch)"}),
              "state": ("state", np.array(names), {"long_name": "error states"}),
              "state_units": ("state", np.array(units), {"long_name": "units of each error state"})}
    attrs = {"recording": str(rec.folder), "complete": int(complete),
             "epoch": rec.manifest.time.epoch.isoformat(),
             "origin_lat_lon_height": [float(x) for x in rec.manifest.frame.origin]}
    return apply_cf(xr.Dataset(data, coords=coords, attrs=attrs),
                    "sarnav navigate: SAR-aided navigation of a recorded flight")


def _update_vars(nav: Navigation, rejections) -> dict:
    U, M = len(nav.updates), 1 + 2 * max(nav.targets, 1)
    res, rsig = np.full((U, M), np.nan), np.full((U, M), np.nan)
    for i, up in enumerate(nav.updates):
        off = 0 if up["altimeter"] else 1  # an update without the altimeter leaves its column NaN
        res[i, off:off + up["residual"].size] = up["residual"]
        rsig[i, off:off + up["residual"].size] = up["residual_sigma"]
    col = lambda key, dtype: np.array([u[key] for u in nav.updates], dtype=dtype)  # noqa: E731
    pc = lambda key, dtype: np.array([p[key] for p in nav.pairs], dtype=dtype)  # noqa: E731
    codes = list(range(-1, len(rejections)))
    meanings = " ".join(["skipped"] + [(r or "fused").replace(" ", "_").replace("(", "").replace(")", "")
                                       for r in rejections])
    return {
        "update_time": ("update", col("time", float), {"units": "s", "long_name": "time of each update"}),
        "update_aperture": ("update", col("aperture", np.int64), {"units": "1", "long_name": "aperture fused (-1: none)"}),
        "residual": (("update", "meas"), res, {"units": "m", "long_name": "residual z - z_hat: altimeter, then range "
                                                                          "and cross-range of each point"}),
        "residual_sigma": (("update", "meas"), rsig, {"units": "m", "long_name": "predicted 1-sigma of the residual"}),
        "nis": ("update", col("nis", float), {"units": "1", "long_name": "normalised innovation squared"}),
        "nis_dof": ("update", col("nis_dof", np.int64), {"units": "1", "long_name": "measurements in nis"}),
        "pair_time": ("pair", pc("time", float), {"units": "s", "long_name": "update time of each SAR pair"}),
        "pair_aperture": ("pair", pc("aperture", np.int64), {"units": "1", "long_name": "aperture"}),
        "pair_point": ("pair", pc("point", np.int64), {"units": "1", "long_name": "reference point"}),
        "pair_toc": ("pair", pc("toc", float), {"units": "s", "long_name": "measured time of closest approach"}),
        "pair_range": ("pair", pc("range", float), {"units": "m", "long_name": "image-derived range of closest approach"}),
        "pair_status": ("pair", pc("code", np.int64), {"units": "1", "long_name": "status of the SAR pair",
                                                       "flag_values": codes, "flag_meanings": meanings}),
        "pair_status_reason": ("pair", np.array([p["reason"] for p in nav.pairs], dtype=str),
                               {"long_name": "status of the SAR pair in words"}),
    }


def _gnss_vars(nav: Navigation) -> dict:
    """The GNSS updates (up to ``initial.gnss_until_s``): time, fix, residuals (position, then velocity; NaN where
    the log has none), their predicted 1-sigma, NIS."""
    G = len(nav.gnss)
    res, rsig = np.full((G, 6), np.nan), np.full((G, 6), np.nan)
    for i, g in enumerate(nav.gnss):
        res[i, :g["residual"].size], rsig[i, :g["residual"].size] = g["residual"], g["residual_sigma"]
    col = lambda key, dtype: np.array([g[key] for g in nav.gnss], dtype=dtype)  # noqa: E731
    return {
        "gnss_time": ("gnss_update", col("time", float), {"units": "s", "long_name": "time of each GNSS update"}),
        "gnss_fix": ("gnss_update", col("fix", np.int64), {"units": "1", "long_name": "row of gnss.csv fused (0: the "
                                                                                       "first fix)"}),
        "gnss_residual": (("gnss_update", "gnss_meas"), res, {"units_coordinate": "gnss_meas_units", "long_name":
                                                              "GNSS residual z - z_hat: north, east, down, then "
                                                              "v_north, v_east, v_down"}),
        "gnss_residual_sigma": (("gnss_update", "gnss_meas"), rsig, {"units_coordinate": "gnss_meas_units",
                                                                     "long_name": "predicted 1-sigma of the GNSS "
                                                                                  "residual"}),
        "gnss_meas_units": ("gnss_meas", np.array(["m"] * 3 + ["m s-1"] * 3), {"long_name": "units of each GNSS "
                                                                                        "component (UDUNITS)"}),
        "gnss_nis": ("gnss_update", col("nis", float), {"units": "1", "long_name": "NIS of the GNSS update"}),
        "gnss_nis_dof": ("gnss_update", col("nis_dof", np.int64), {"units": "1", "long_name": "components in gnss_nis"}),
    }


def _errors_columns(est: dict, errors: dict) -> dict:
    cols = {"time": est["time"]}
    cols.update({f"error_{n}": errors["error"][:, i] for i, n in enumerate(_ERROR_NAMES)})
    cols.update({f"sigma_{n}": est["sigma"][:, i] for i, n in enumerate(_ERROR_NAMES)})
    cols["nees"] = errors["nees"]
    cols["nees_dof"] = np.full(est["time"].size, errors["nees_dof"], dtype=np.int64)
    return cols


def consistency(nav: Navigation, est: dict, errors: dict | None) -> dict:
    """The run's consistency against its 95 % chi-square bands (``analysis.consistency``): NIS of the updates and,
    with truth, NEES of the epochs, the final position error and the share of errors inside 3 sigma."""
    out = {}
    if nav.updates:
        nis = np.array([[u["nis"] for u in nav.updates]])
        dof = np.array([[u["nis_dof"] for u in nav.updates]])
        st = nis_statistics(nis, dof)
        out["nis"] = {"per_dof": st["per_dof"], "per_dof_band_95": list(st["per_dof_band"]),
                      "fraction_in_band": st["fraction_in_band"], "updates": int(nis.size)}
    if nav.gnss:
        st = nis_statistics(np.array([[g["nis"] for g in nav.gnss]]), np.array([[g["nis_dof"] for g in nav.gnss]]))
        out["gnss_nis"] = {"per_dof": st["per_dof"], "per_dof_band_95": list(st["per_dof_band"]),
                           "fraction_in_band": st["fraction_in_band"], "updates": len(nav.gnss)}
    if errors is not None and np.any(np.isfinite(errors["nees"])):
        ok = np.isfinite(errors["nees"])
        st = nees_statistics(errors["nees"][ok][None], errors["nees_dof"])
        e, s = errors["error"][ok], est["sigma"][ok]
        out["nees"] = {"dof": st["dof"], "time_average": st["time_average"], "band_95": list(st["band"]),
                       "fraction_in_band": st["fraction_in_band"], "epochs": int(ok.sum())}
        out["final_position_error_m"] = e[-1, 0:3].tolist()
        out["final_position_sigma_m"] = s[-1, 0:3].tolist()
        out["within_3sigma"] = float(np.nanmean(sigma_containment(e[:, 0:9], s[:, 0:9])))
    return out


def write_navigation(out, rec, nav: Navigation, complete: bool, suffix: str = "") -> list[str]:
    """Write every output of ``nav`` into the folder ``out`` (names + ``suffix``); the names written."""
    out = Path(out)
    written = []
    est = nav.estimate()
    traj = _trajectory(rec, est)
    errors = truth_errors(rec, est, nav.layout)

    def path(name):
        written.append(name + suffix)
        return out / (name + suffix)

    write_columns(path("trajectory.csv"), traj)
    _write_csv_rows(path("updates.csv"), UPDATE_COLUMNS, _updates_rows(nav))
    path("trajectory.geojson").write_text(json.dumps(_geojson(traj, nav), indent=1) + "\n", encoding="utf-8")
    tree = _kml(traj, nav)
    tree.write(path("trajectory.kml"), encoding="utf-8", xml_declaration=True)
    if errors is not None:
        write_columns(path("errors.csv"), _errors_columns(est, errors))
    ds = _dataset(rec, nav, traj, est, errors, complete)
    ds.to_netcdf(path("trajectory.nc"), engine="netcdf4")
    return written


def _status(out: Path, doc: dict) -> None:
    tmp = out / f".{STATUS_FILE}.tmp"
    tmp.write_text(json.dumps(doc, indent=1, default=float) + "\n", encoding="utf-8")
    os.replace(tmp, out / STATUS_FILE)


def prepare_output(out, overwrite: bool = False) -> Path:
    """The output folder, created; one holding other files is refused (ConfigError ``--out``) unless
    ``overwrite``, which removes navigate's own files (OUTPUT_FILES, their .partial forms, navigate.json;
    ``simulation.export.prepare_folder``; the images it writes, ``report.navigate_images.remove_images``)."""
    from sarnav.simulation.export import prepare_folder

    own = [f for name in OUTPUT_FILES + (STATUS_FILE,) for f in (name, f"{name}.partial")]
    if overwrite and Path(out).is_dir():
        remove_images(out)
    return prepare_folder(out, overwrite, own, "navigate's outputs")


def run_navigate(rec, out, settings: NavigateSettings | None = None, progress=None, overwrite: bool = False,
                 describe: dict | None = None, report: bool = True, sicd: bool = False) -> dict:
    """Navigate ``rec`` into the folder ``out`` (module docstring); returns navigate.json's content.
    ``describe``: extra entries for navigate.json (the command line's settings); ``report``: write report.html
    (``report.navigate_html``, from the other outputs); ``sicd``: each in-flight image as SICD too."""
    out = prepare_output(out, overwrite)
    doc = {"complete": False, "recording": str(rec.folder), "sarnav_version": sarnav.__version__,
           "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), **(describe or {})}
    _status(out, doc)
    nav, t0, images = Navigation(), time.perf_counter(), NavigateImages(out, rec, sicd)
    try:
        navigate(rec, settings, progress, into=nav, images=images)
        files = write_navigation(out, rec, nav, complete=True, suffix=".partial")
    except BaseException as exc:  # an interruption (Ctrl-C) or a failure: what was done, marked incomplete
        doc.update(interrupted=f"{type(exc).__name__}: {exc}".strip(), **_counts(nav, time.perf_counter() - t0))
        try:
            folder = images.write_index()
            doc.update(images=images.summary())
            if nav.time:
                doc["files"] = write_navigation(out, rec, nav, complete=False, suffix=".partial")
                doc["files"] += ([f"{folder}/"] if folder else []) + (_report(out, doc, rec) if report else [])
        finally:
            _status(out, doc)
        raise
    est = nav.estimate()
    summary = consistency(nav, est, truth_errors(rec, est, nav.layout))
    doc.update(complete=True, files=[f.removesuffix(".partial") for f in files], consistency=summary,
               notices=nav.notices, images=images.summary(), **_counts(nav, time.perf_counter() - t0))
    images.write_index()
    files += _report(out, doc, rec) if report else []
    for name in files:
        os.replace(out / name, out / name.removesuffix(".partial"))
    doc["files"] = [f.removesuffix(".partial") for f in files]
    if images.publish():
        doc["files"].append(f"{IMAGE_DIR}/")
    _status(out, doc)
    return doc


def _report(out: Path, doc: dict, rec) -> list[str]:
    """report.html.partial from the .partial outputs and ``doc`` (``report.navigate_html``); a failure to draw it
    is a notice in ``doc``, not a failed run."""
    from sarnav.report.navigate_html import write_navigate_report

    try:
        return [write_navigate_report(out, doc, rec, suffix=".partial")]
    except Exception as err:  # noqa: BLE001 - the navigation's own outputs stand without the page
        doc.setdefault("notices", []).append(f"report.html not written: {type(err).__name__}: {err}")
        return []


def _counts(nav: Navigation, seconds: float) -> dict:
    span = nav.time[-1] - nav.time[0] if len(nav.time) > 1 else 0.0
    pairs = [p["code"] for p in nav.pairs]
    return {"updates": len(nav.updates), "updates_planned": nav.plan.n_updates if nav.plan else 0,
            "epochs": len(nav.time), "flight_seconds": float(span), "wall_seconds": float(seconds),
            "real_time_factor": float(span / seconds) if seconds > 0 else math.nan,
            "pairs_fused": int(sum(c == 0 for c in pairs)), "pairs_rejected": int(sum(c > 0 for c in pairs)),
            "pairs_skipped": int(sum(c == SKIPPED for c in pairs))}
