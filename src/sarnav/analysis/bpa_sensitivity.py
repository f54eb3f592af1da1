"""BPA image shift and blur from navigation errors: thesis ch. 4 (§4.3-4.4, Figs 4.11-4.13; extraction
seed-000 §11, §12.10, E5). Scenario ``bpa-sensitivity`` (docs/scenarios/bpa-sensitivity.md).

For each injected error:

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

The study of the scenario is :func:`run` (:class:`BpaSensitivityParams`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sarnav import rotations
from sarnav.analysis import sensitivity as sens
from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.backprojection import backproject
from sarnav.imaging.grid import GroundGrid
from sarnav.imaging.range_compression import range_compress
from sarnav.radar.echoes import simulate_echoes
from sarnav.radar.params import RadarParams, pulse_clock
from sarnav.radar.scene import point_targets
from sarnav.signal.metrics import impulse_response, interpolate_value, peak_location
from sarnav.trajectory.sampled import closest_approach
from sarnav.units import G0

__all__ = ["THESIS_SIM_ERRORS", "ImageSettings", "Geometry", "make_geometry", "injected_error",
           "estimated_trajectory", "CaseResult", "CasePlan", "plan_case", "image_pixels", "run_case", "run_study",
           "CSV_FIELDS", "MAX_PIXEL_PULSES", "BpaSensitivityParams", "run"]


@dataclass(frozen=True)
class ImageSettings:
    """Ground-plane image of the study: pixel ``spacing`` [m], ``margin`` [m] around the reference and predicted
    positions, BPA ``interpolation``."""

    spacing: float
    margin: float
    interpolation: str


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


@dataclass
class Geometry:
    speed: float
    p0: np.ndarray
    v0: np.ndarray
    target: np.ndarray
    times: np.ndarray
    aperture: float

    @property
    def mid_aperture_range(self) -> float:
        """Range from the mid-aperture position to the target [m]."""
        return float(np.linalg.norm(self.target - (self.p0 + self.v0 * self.aperture / 2)))

    @property
    def truth_positions(self) -> np.ndarray:
        return self.p0 + self.times[:, None] * self.v0


def make_geometry(speed: float, altitude: float, target_ground_range: float, aperture: float, prf: float,
                  start=None) -> Geometry:
    """Straight and level north at ``speed`` [m/s] from ``start`` (NED [m]; default (0, 0, -``altitude``)); the
    target on the ground ``target_ground_range`` [m] east of the track at mid-aperture; pulses at ``prf`` [Hz]
    centred on the aperture [0, ``aperture``] s."""
    speed, alt, yt, T = float(speed), float(altitude), float(target_ground_range), float(aperture)
    n = int(round(T * prf))
    times = pulse_clock(n, prf, 0.5 * T, 0.5 * (n - 1))  # pulses centred on the aperture, eta in [0, T]
    p0 = np.array([0.0, 0.0, -alt]) if start is None else np.asarray(start, dtype=np.float64)
    return Geometry(speed, p0, np.array([speed, 0.0, 0.0]),
                    np.array([p0[0] + speed * T / 2.0, p0[1] + yt, 0.0]), times, T)


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


#: the largest BPA image of one case, in pixel-pulses (pixels x pulses back-projected; the default study's images are
#: 1e7): about 10 s of back-projection on one core
MAX_PIXEL_PULSES = 2e9


@dataclass(frozen=True)
class CasePlan:
    """What one injected error needs before any echo is simulated: the estimated track, the predicted shift and
    image point, the patch to image (``centre`` (3,), ``half`` (2,) [m] north/east)."""

    dx0: np.ndarray
    p_hat: np.ndarray
    v_hat: np.ndarray
    pred: object
    q_pred: np.ndarray
    centre: np.ndarray
    half: np.ndarray


def _too_far(name: str, value: float, geo: Geometry) -> ConfigError:
    return ConfigError(f"errors.{name}", f"{value:g} {THESIS_SIM_ERRORS[name][3]} moves the target's closest approach "
                       f"to the estimated track outside the {geo.aperture:g}-s aperture: the shift is not measurable "
                       "(smaller error or longer trajectory.duration)")


def image_pixels(half_n: float, half_e: float, spacing: float) -> int:
    """Pixels of the ground image of half-extents ``half_n``, ``half_e`` [m] at ``spacing`` [m] (``_image_around``)."""
    return (2 * int(math.ceil(half_n / spacing)) + 1) * (2 * int(math.ceil(half_e / spacing)) + 1)


def plan_case(name: str, value: float, geo: Geometry, image: ImageSettings, pred=None) -> CasePlan:
    """The :class:`CasePlan` of one injected error; ConfigError naming ``errors.<name>`` when the target or its
    predicted image falls outside the aperture (no shift to measure) or the image would exceed
    :data:`MAX_PIXEL_PULSES` (checked by the scenario's validation, before anything is simulated).

    ``pred``: the eq. 4.41 prediction (``analysis.sensitivity.predict_shift``) when known; without it (validation) the
    true track's closest approach is the closed form of the straight line, and ``CasePlan.pred`` is None.
    """
    dx0 = injected_error(name, value)
    p_hat, v_hat = estimated_trajectory(geo, dx0)
    slowest = float(np.min(np.linalg.norm(v_hat, axis=1)))
    if not slowest > 0.5 * geo.speed:  # the zero-Doppler plane of a track at rest is undefined
        raise ConfigError(f"errors.{name}", f"{value:g} {THESIS_SIM_ERRORS[name][3]} slows the estimated track to "
                          f"{slowest:.3g} m/s: it must stay above half the true speed {geo.speed:g} m/s")
    if pred is None:
        eta0 = float(np.dot(geo.target - geo.p0, geo.v0) / np.dot(geo.v0, geo.v0))
        r0 = float(np.linalg.norm(geo.target - geo.p0 - geo.v0 * eta0))
    else:
        eta0, r0 = pred.eta0, pred.r0
    try:
        # predicted image location: the ground point whose closest approach to the estimate is (R0, eta0)
        q_pred = _ground_point_at(r0, eta0, geo.times, p_hat, v_hat)
        for point in (geo.target, q_pred):
            closest_approach(point, geo.times, p_hat)
    except InputDataError:
        raise _too_far(name, value, geo) from None
    centre = 0.5 * (geo.target + q_pred)
    half = np.abs(geo.target - q_pred)[:2] / 2 + image.margin
    n = image_pixels(half[0], half[1], image.spacing) * len(geo.times)
    if n > MAX_PIXEL_PULSES:
        raise ConfigError(f"errors.{name}", f"{value:g} {THESIS_SIM_ERRORS[name][3]} needs a {2 * half[0]:.3g} m x "
                          f"{2 * half[1]:.3g} m image: {n:.3g} pixel-pulses at image.spacing = {image.spacing:g} m "
                          f"(at most {MAX_PIXEL_PULSES:.3g}): a smaller error, a larger image.spacing or a smaller "
                          "image.margin")
    return CasePlan(dx0, p_hat, v_hat, pred, q_pred, centre, half)


def run_case(name: str, value: float, geo: Geometry, rc, ref_peak_amp: float, irw_ref: float,
             image: ImageSettings) -> CaseResult:
    """One injected error: image, measure, predict."""
    dx0 = injected_error(name, value)
    pred = sens.predict_shift(geo.target, geo.p0, geo.v0, dx0, (-geo.aperture, 2 * geo.aperture))
    plan = plan_case(name, value, geo, image, pred)
    p_hat, v_hat, q_pred = plan.p_hat, plan.v_hat, plan.q_pred
    dk = sens.fm_rate_error(geo.target, geo.p0, geo.v0, dx0, rc.wavelength)
    pred_loss = sens.peak_loss_from_fm_rate_error(dk, geo.aperture)
    img = _image_around(rc, p_hat, plan.centre, plan.half[0], plan.half[1], image.spacing, image.interpolation)
    pk, p_img, amp = _peak(img)
    try:
        eta_img, r_img, _ = closest_approach(p_img, geo.times, p_hat)
        eta_ref, r_ref, _ = closest_approach(geo.target, geo.times, p_hat)
    except InputDataError:
        raise _too_far(name, value, geo) from None
    speed_hat = float(np.linalg.norm(_interp3(eta_ref, geo.times, v_hat)))
    return CaseResult(
        name=name, value=value, unit=THESIS_SIM_ERRORS[name][3],
        pred_offset_range=pred.offset_range, pred_offset_along=pred.offset_along,
        meas_offset_range=r_img - r_ref, meas_offset_along=speed_hat * (eta_img - eta_ref),
        pred_peak_loss=pred_loss, meas_peak_loss=1.0 - amp / ref_peak_amp,
        irw_along_ref=irw_ref, irw_along=_irw_along(img, pk), image=img,
        reference_xy=(geo.target[0], geo.target[1]), predicted_xy=(q_pred[0], q_pred[1]),
    )


def run_study(geo: Geometry, params, errors: dict, image: ImageSettings) -> tuple[list[CaseResult], object]:
    """Every error of ``errors`` (name -> value, names of :data:`THESIS_SIM_ERRORS`) imaged with ``params``
    (a ``RadarParams`` whose receive window covers the target); returns the results and the reference image."""
    raw = simulate_echoes(params, geo.truth_positions, geo.times, point_targets(geo.target, 1.0))
    rc = range_compress(raw)
    m = image.margin
    ref = _image_around(rc, geo.truth_positions, geo.target, m, m, image.spacing, image.interpolation)
    pk_ref, _, amp_ref = _peak(ref)
    irw_ref = _irw_along(ref, pk_ref)
    results = [run_case(n, float(v), geo, rc, amp_ref, irw_ref, image) for n, v in errors.items()]
    return results, ref


@dataclass(frozen=True)
class BpaSensitivityParams:
    """The study: the flight and target ``geometry``, the ``radar`` (receive window around the target), the injected
    ``errors`` (name of :data:`THESIS_SIM_ERRORS` -> value, in its unit) and the ``image`` settings."""

    geometry: Geometry
    radar: RadarParams
    errors: dict
    image: ImageSettings


def run(prm: BpaSensitivityParams, names=None) -> tuple[list[CaseResult], object]:
    """:func:`run_study` of every error of ``prm`` (or the named ones, in that order): results and reference image."""
    errors = {n: prm.errors[n] for n in (list(prm.errors) if names is None else names)}
    return run_study(prm.geometry, prm.radar, errors, prm.image)


CSV_FIELDS = ("name", "value", "unit", "pred_offset_range", "pred_offset_along", "meas_offset_range",
              "meas_offset_along", "pred_peak_loss", "meas_peak_loss", "irw_along_ref", "irw_along")
