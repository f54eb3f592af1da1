"""Study ``bpa-sensitivity``: image shift and blur of a BPA image formed with an erroneous trajectory.

Thesis ch. 4 (§4.3-4.4, Figs 4.11-4.13; extraction seed-000 §11, §12.10, E5). For each injected error of
the thesis's simulated-data column (3 m position on each axis; velocity 0.1 along, 0.05 cross, 0.05
elevation m/s; roll 0.001, pitch 0.02, yaw 0.1 rad):

1. echoes of one point target are simulated along the **true** straight-and-level track and range
   compressed (``radar.echoes``, ``imaging.range_compression``);
2. the processor's trajectory is the exact kinematics of an INS started with the injected error and fed
   perfect IMU data (constant q_hat = m(q, dth0), specific force T_hat nu^b; thesis eq. 4.20 without
   linearisation);
3. a ground-plane BPA image is formed with that trajectory (``imaging.backprojection``) and a reference
   image with the truth;
4. measured offset: the image peak (sub-pixel) expressed as range and time of closest approach to the
   *estimated* trajectory, minus the closest approach of the geolocated target to the same trajectory; peak
   loss against the reference image; azimuth IRW;
5. predicted offset: thesis eq. 4.41 through the linear model (``analysis.sensitivity``); predicted peak
   loss from the first-order FM-rate error and the Fresnel integral.

Geometry (the thesis gives none for ch. 4; docs/scenarios/bpa-sensitivity.md): 10 m/s north at 1000 m,
target on the ground 1800 m east of the track at mid-aperture, 6-s aperture, nav-paper radar (9.75 GHz,
500 MHz, 1 GHz sampling, PRF 100 Hz) with a 0.2 us chirp and a receive window around the target.
"""

from __future__ import annotations

import copy
import csv
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sarnav import rotations
from sarnav.analysis import sensitivity as sens
from sarnav.errors import ConfigError, InputDataError, require_finite, require_positive
from sarnav.imaging.backprojection import backproject
from sarnav.imaging.grid import GroundGrid
from sarnav.signal.metrics import impulse_response, interpolate_value, peak_location
from sarnav.imaging.range_compression import range_compress
from sarnav.measurements.image_shift import closest_approach
from sarnav.montecarlo.record import RunRecord
from sarnav.radar.echoes import simulate_echoes
from sarnav.radar.presets import nav_paper_sim
from sarnav.radar.scene import point_targets
from sarnav.montecarlo.kind import ScenarioKind
from sarnav.units import C, G0, us_to_s

#: thesis §12.10, simulated-data column: name -> (block, axis, value, unit)
THESIS_SIM_ERRORS = {
    "position_along": ("dp", 0, 3.0, "m"),
    "position_cross": ("dp", 1, 3.0, "m"),
    "position_elevation": ("dp", 2, 3.0, "m"),
    "velocity_along": ("dv", 0, 0.1, "m/s"),
    "velocity_cross": ("dv", 1, 0.05, "m/s"),
    "velocity_elevation": ("dv", 2, 0.05, "m/s"),
    "roll": ("dth", 0, 0.001, "rad"),
    "pitch": ("dth", 1, 0.02, "rad"),
    "yaw": ("dth", 2, 0.1, "rad"),
}
_BLOCK = {"dp": 0, "dv": 3, "dth": 6}


def default_config() -> dict:
    """The ``bpa-sensitivity`` study as a TOML-able dict."""
    return {
        "scenario": {"name": "bpa-sensitivity", "kind": "bpa-sensitivity",
                     "description": "Thesis ch. 4 / Figs 4.11-4.13: BPA image shift and blur from injected navigation errors"},
        "campaign": {"runs": 1, "seed": 0},
        "geometry": {"speed": 10.0, "altitude": 1000.0, "target_ground_range": 1800.0, "aperture": 6.0},
        "radar": {"prf": 100.0, "pulse_length_us": 0.2, "range_margin": 30.0},
        "image": {"spacing": 0.1, "margin": 4.0, "interpolation": "cubic"},
        "errors": {name: v[2] for name, v in THESIS_SIM_ERRORS.items()},
    }


def validate(cfg: dict) -> None:
    """Raise ConfigError naming the first bad field."""
    for table in ("geometry", "radar", "image", "errors"):
        if not isinstance(cfg.get(table), dict):
            raise ConfigError(table, "missing table")
    g, r, im, e = cfg["geometry"], cfg["radar"], cfg["image"], cfg["errors"]
    require_positive("geometry.speed", g.get("speed"), "m/s")
    require_positive("geometry.altitude", g.get("altitude"), "m")
    require_positive("geometry.target_ground_range", g.get("target_ground_range"), "m")
    require_finite("geometry.aperture", g.get("aperture"), 0.5, 60.0, "s")
    require_positive("radar.prf", r.get("prf"), "Hz")
    require_finite("radar.pulse_length_us", r.get("pulse_length_us"), 0.01, 10.0, "us")
    require_finite("radar.range_margin", r.get("range_margin"), 5.0, 500.0, "m")
    require_finite("image.spacing", im.get("spacing"), 0.01, 1.0, "m")
    require_finite("image.margin", im.get("margin"), 0.5, 50.0, "m")
    if im.get("interpolation") not in ("nearest", "linear", "cubic", "upsample"):
        raise ConfigError("image.interpolation", f"must be nearest, linear, cubic or upsample, got {im.get('interpolation')!r}")
    for name in e:
        if name not in THESIS_SIM_ERRORS:
            raise ConfigError(f"errors.{name}", f"unknown error; known: {', '.join(THESIS_SIM_ERRORS)}")
        require_finite(f"errors.{name}", e[name], -10.0, 10.0, THESIS_SIM_ERRORS[name][3])
    if not e:
        raise ConfigError("errors", "needs at least one injected error")


@dataclass
class Geometry:
    speed: float
    p0: np.ndarray
    v0: np.ndarray
    target: np.ndarray
    times: np.ndarray
    aperture: float

    @property
    def truth_positions(self) -> np.ndarray:
        return self.p0 + self.times[:, None] * self.v0


def make_geometry(cfg: dict) -> Geometry:
    g = cfg["geometry"]
    speed, alt, yt, T = (float(g[k]) for k in ("speed", "altitude", "target_ground_range", "aperture"))
    prf = float(cfg["radar"]["prf"])
    n = int(round(T * prf))
    times = (np.arange(n) - 0.5 * (n - 1)) / prf + 0.5 * T  # pulses centred on the aperture, eta in [0, T]
    return Geometry(speed, np.array([0.0, 0.0, -alt]), np.array([speed, 0.0, 0.0]),
                    np.array([speed * T / 2.0, yt, 0.0]), times, T)


def injected_error(name: str, value: float) -> np.ndarray:
    """dx0 (9,) = [dp, dv, dth] (truth minus estimate) for one named error."""
    block, axis, _, _ = THESIS_SIM_ERRORS[name]
    dx = np.zeros(9)
    dx[_BLOCK[block] + axis] = value
    return dx


def estimated_trajectory(geo: Geometry, dx0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact kinematics of an INS started with error dx0 and fed perfect IMU data (level truth, q = 1).

    q_hat = m(q, dth0) (thesis eq. A.5) stays constant (omega = 0); f_hat^n = T_hat nu^b with
    nu^b = (0, 0, -g); v_hat = v0 - dv0 + (f_hat^n + g^n) t; p_hat = p0 - dp0 + (v0 - dv0) t + 1/2 (...) t^2.
    """
    q_hat = rotations.corrupt_attitude(rotations.quat_identity(), dx0[6:9])
    acc = rotations.quat_rotate(q_hat, [0.0, 0.0, -G0]) + np.array([0.0, 0.0, G0])
    t = geo.times[:, None]
    v_hat = (geo.v0 - dx0[3:6]) + acc * t
    p_hat = (geo.p0 - dx0[0:3]) + (geo.v0 - dx0[3:6]) * t + 0.5 * acc * t**2
    return p_hat, v_hat


def _radar(cfg: dict, r0: float):
    r = cfg["radar"]
    T = us_to_s(float(r["pulse_length_us"]))
    margin = float(r["range_margin"])
    fs = 1.0e9
    pad = C * T / 4.0
    near = r0 - margin - pad
    n = int(math.ceil((2 * (margin + pad)) / (C / (2 * fs)))) + 1
    return nav_paper_sim(pulse_length=T, prf=float(r["prf"]), near_range=near, n_range_samples=n)


def _image_around(rc, positions, centre, half_n, half_e, spacing, interpolation):
    ny = 2 * int(math.ceil(half_n / spacing)) + 1
    nx = 2 * int(math.ceil(half_e / spacing)) + 1
    grid = GroundGrid.centered(centre[0], centre[1], spacing, (ny, nx), down=0.0)
    return backproject(rc, grid, positions=positions, interpolation=interpolation)


def _interp3(t, times, values) -> np.ndarray:
    return np.array([np.interp(t, times, values[:, i]) for i in range(3)])


def _ground_point_at(r0: float, eta0: float, times, positions, velocities) -> np.ndarray:
    """Ground point (down = 0) at range r0 in the zero-Doppler plane of the trajectory at eta0, right side."""
    p = _interp3(eta0, times, positions)
    u = _interp3(eta0, times, velocities)
    u /= np.linalg.norm(u)
    w = np.cross([0.0, 0.0, 1.0], u)  # horizontal, to the right of the velocity
    w /= np.linalg.norm(w)
    z = np.cross(u, w)  # completes the zero-Doppler plane basis (points down for level flight)
    b = -p[2] / z[2]
    a2 = r0**2 - b**2
    if not a2 > 0:
        raise InputDataError("geometry.altitude", f"range {r0:.1f} m does not reach the ground")
    return p + math.sqrt(a2) * w + b * z


@dataclass
class CaseResult:
    name: str
    value: float
    unit: str
    pred_offset_range: float
    pred_offset_along: float
    meas_offset_range: float
    meas_offset_along: float
    pred_peak_loss: float
    meas_peak_loss: float
    irw_along_ref: float
    irw_along: float
    image: object = None
    reference_xy: tuple = ()
    predicted_xy: tuple = ()


def _peak(img):
    pk = peak_location(img.data)
    y = img.y[0] + pk[0] * img.dy
    x = img.x[0] + pk[1] * img.dx
    return pk, np.array([y, x, 0.0]), abs(interpolate_value(img.data, pk))


def _irw_along(img, pk) -> float:
    try:
        hw = min(64, img.shape[0] // 2 - 1)
        return float(impulse_response(img.data, 0, peak=pk, half_width=hw, n_sidelobes=None).irw * abs(img.dy))
    except InputDataError:  # a badly blurred response may have no nulls inside the image: IRW undefined
        return float("nan")


def run_case(cfg: dict, name: str, value: float, geo: Geometry, rc, ref_peak_amp: float,
             irw_ref: float) -> CaseResult:
    """One injected error: image, measure, predict."""
    dx0 = injected_error(name, value)
    p_hat, v_hat = estimated_trajectory(geo, dx0)
    pred = sens.predict_shift(geo.target, geo.p0, geo.v0, dx0, (-geo.aperture, 2 * geo.aperture))
    dk = sens.fm_rate_error(geo.target, geo.p0, geo.v0, dx0, rc.params.wavelength)
    pred_loss = sens.peak_loss_from_fm_rate_error(dk, geo.aperture)
    # predicted image location: the ground point whose closest approach to the estimate is (R0, eta0)
    q_pred = _ground_point_at(pred.r0, pred.eta0, geo.times, p_hat, v_hat)
    im = cfg["image"]
    margin = float(im["margin"])
    centre = 0.5 * (geo.target + q_pred)
    half = np.abs(geo.target - q_pred)[:2] / 2 + margin
    img = _image_around(rc, p_hat, centre, half[0], half[1], float(im["spacing"]), im["interpolation"])
    pk, p_img, amp = _peak(img)
    eta_img, r_img, _ = closest_approach(p_img, geo.times, p_hat)
    eta_ref, r_ref, _ = closest_approach(geo.target, geo.times, p_hat)
    speed_hat = float(np.linalg.norm(_interp3(eta_ref, geo.times, v_hat)))
    return CaseResult(
        name=name, value=value, unit=THESIS_SIM_ERRORS[name][3],
        pred_offset_range=pred.offset_range, pred_offset_along=pred.offset_along,
        meas_offset_range=r_img - r_ref, meas_offset_along=speed_hat * (eta_img - eta_ref),
        pred_peak_loss=pred_loss, meas_peak_loss=1.0 - amp / ref_peak_amp,
        irw_along_ref=irw_ref, irw_along=_irw_along(img, pk), image=img,
        reference_xy=(geo.target[0], geo.target[1]), predicted_xy=(q_pred[0], q_pred[1]),
    )


def run_study(cfg: dict, names=None) -> tuple[list[CaseResult], object]:
    """All (or the named) cases of the study; returns the results and the reference image."""
    validate(cfg)
    geo = make_geometry(cfg)
    r0 = float(np.linalg.norm(geo.target - (geo.p0 + geo.v0 * geo.aperture / 2)))
    params = _radar(cfg, r0)
    raw = simulate_echoes(params, geo.truth_positions, geo.times, point_targets(geo.target, 1.0))
    rc = range_compress(raw)
    im = cfg["image"]
    m = float(im["margin"])
    ref = _image_around(rc, geo.truth_positions, geo.target, m, m, float(im["spacing"]), im["interpolation"])
    pk_ref, _, amp_ref = _peak(ref)
    irw_ref = _irw_along(ref, pk_ref)
    names = list(cfg["errors"]) if names is None else list(names)
    results = [run_case(cfg, n, float(cfg["errors"][n]), geo, rc, amp_ref, irw_ref) for n in names]
    return results, ref


CSV_FIELDS = ("name", "value", "unit", "pred_offset_range", "pred_offset_along", "meas_offset_range",
              "meas_offset_along", "pred_peak_loss", "meas_peak_loss", "irw_along_ref", "irw_along")


def write_csv(results: list[CaseResult], path) -> Path:
    path = Path(path)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(CSV_FIELDS)
        for r in results:
            w.writerow([getattr(r, f) if isinstance(getattr(r, f), str) else f"{getattr(r, f):.6g}" for f in CSV_FIELDS])
    return path


def plot_grid(results: list[CaseResult], ref, path) -> Path:
    """Figure like thesis Figs 4.11-4.13: |image| in dB, X = reference target, O = predicted location."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(results)
    ncol = 3
    nrow = int(math.ceil(n / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.0 * ncol, 3.2 * nrow), squeeze=False)
    peak = np.max(np.abs(ref.data))
    for ax, r in zip(axes.flat, results):
        img = r.image
        db = 20 * np.log10(np.maximum(np.abs(img.data) / peak, 1e-6))
        ax.imshow(db, origin="lower", cmap="gray", vmin=-40, vmax=0, aspect="equal",
                  extent=[img.x[0], img.x[-1], img.y[0], img.y[-1]])
        ax.plot(r.reference_xy[1], r.reference_xy[0], "rx", ms=9, mew=2, label="X reference")
        ax.plot(r.predicted_xy[1], r.predicted_xy[0], "o", mfc="none", mec="c", ms=10, mew=2, label="O predicted")
        ax.set_title(f"{r.name} {r.value:g} {r.unit}", fontsize=9)
        ax.set_xlabel("east [m]", fontsize=8)
        ax.set_ylabel("north [m]", fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def run_sensitivity(cfg: dict, out_dir) -> Path:
    """Run the study, write ``sensitivity.csv`` and ``sensitivity.png`` into ``out_dir``; return the CSV path."""
    out = Path(out_dir)
    os.makedirs(out, exist_ok=True)
    results, ref = run_study(cfg)
    path = write_csv(results, out / "sensitivity.csv")
    plot_grid(results, ref, out / "sensitivity.png")
    return path


class BpaSensitivityKind(ScenarioKind):
    """Registry entry for the study; it is run by :func:`run_sensitivity`, not by the Monte Carlo engine."""

    kind = "bpa-sensitivity"

    def default_config(self) -> dict:
        return default_config()

    def validate(self, cfg: dict) -> None:
        validate(cfg)

    def state_names(self, cfg: dict) -> list[str]:
        return []

    def meas_names(self, cfg: dict) -> list[str]:
        return []

    def run_scenario(self, cfg: dict, out, figures: bool = True, **campaign_opts) -> Path:
        """``sarnav run bpa-sensitivity``: the deterministic study (executor options do not apply);
        writes ``sensitivity.csv`` and, unless ``figures`` is False, ``sensitivity.png``."""
        if figures:
            return run_sensitivity(cfg, out)
        out = Path(out)
        os.makedirs(out, exist_ok=True)
        results, _ = run_study(cfg)
        return write_csv(results, out / "sensitivity.csv")

    def simulate(self, cfg, run_ids, seeds) -> list[RunRecord]:
        raise ConfigError("scenario.kind", "bpa-sensitivity is a deterministic study: run it with "
                                           "sarnav.scenarios.bpa_sensitivity.run_sensitivity(cfg, out_dir)")
