"""Focus one block of range-compressed pulses flown along a straight track, with the algorithm and autofocus asked.

The processor's trajectory is the straight line through ``centre`` along ``direction`` flown at the speed estimate
``speed`` (a navigation speed error exercises autofocus); the pulse times are those of the data. ``"rda"`` forms a
Range-Doppler image (optionally after ``"mapdrift"`` or ``"contrast"`` autofocus, ``imaging.autofocus``);
``"bpa"`` back-projects onto the slant plane of the track with the same zero-Doppler axes as the RDA image, the
azimuth window applied in slow time (as the RDA applies it in Doppler).
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import ConfigError
from sarnav.imaging.autofocus import contrast_autofocus, mapdrift
from sarnav.imaging.backprojection import backproject
from sarnav.imaging.grid import SlantGrid
from sarnav.imaging.rda import radar_constants, range_doppler, uniform_prf
from sarnav.signal.data import PulseData, SarImage
from sarnav.signal.windows import as_window

__all__ = ["ALGORITHMS", "AUTOFOCUS", "focus_straight_block"]

ALGORITHMS = ("rda", "bpa")
AUTOFOCUS = ("none", "mapdrift", "contrast")


def focus_straight_block(rc: PulseData, speed: float, centre, *, look_side: str = "right", algorithm: str = "rda",
                         window="none", rcmc_kernel: str = "sinc8", azimuth_model: str = "parabolic",
                         autofocus: str = "none", bpa_interpolation: str = "upsample") -> tuple[SarImage, dict | None]:
    """(image, autofocus report or None) of ``rc`` along the straight north track through ``centre`` at ``speed``.

    Parameters
    ----------
    rc : range-compressed pulses (their own positions are replaced by the processor's straight track).
    speed : the processor's speed estimate [m/s]; centre : (3,) track position at pulse time 0 (NED, m).
    look_side : "left" or "right"; algorithm : one of :data:`ALGORITHMS`; autofocus : one of :data:`AUTOFOCUS`
        (RDA only); window, rcmc_kernel, azimuth_model : RDA settings (``imaging.rda``); bpa_interpolation : BPA.
    """
    if algorithm not in ALGORITHMS:
        raise ConfigError("image.algorithm", f"must be one of {ALGORITHMS}, got {algorithm!r}")
    if autofocus not in AUTOFOCUS:
        raise ConfigError("image.autofocus", f"must be one of {AUTOFOCUS}, got {autofocus!r}")
    centre = np.asarray(centre, dtype=np.float64)
    est = rc.with_positions(centre + np.outer(rc.pulse_times, [speed, 0.0, 0.0]))
    if algorithm == "bpa":
        if autofocus != "none":
            raise ConfigError("image.autofocus", "autofocus works on RDA images; set image.algorithm = \"rda\"")
        w = as_window(window, "image.window")
        if w.name != "none":  # same slow-time weighting as the RDA (rda module docstring)
            est = est.__class__(**{**est.__dict__, "data": est.data * w.samples(est.n_pulses)[:, None]})
        side = 1.0 if look_side == "right" else -1.0
        grid = SlantGrid(origin=centre, direction=[1.0, 0.0, 0.0], look_point=[0.0, side * 1e3, 0.0],
                         along_track=speed * rc.pulse_times, slant_range=rc.slant_range)
        img = backproject(est, grid, interpolation=bpa_interpolation)
        radar, prf = radar_constants(rc), uniform_prf(rc.pulse_times)  # as the RDA's metadata: from the pulses' fields
        img.metadata.update({"window": w.label, "speed": speed, "prf": prf,
                             "carrier_frequency": radar["carrier_frequency"], "bandwidth": radar["bandwidth"],
                             "aperture_length": speed * rc.n_pulses / prf,
                             "closest_approach_range": float(0.5 * (rc.slant_range[0] + rc.slant_range[-1]))})
        return img, None
    kw = dict(window=window, rcmc_kernel=rcmc_kernel, azimuth_model=azimuth_model, along_track_origin=centre)
    if autofocus == "mapdrift":
        res = mapdrift(est, speed, **kw)
        return res.image, {"method": "mapdrift", "speed_in": speed, "speed_estimate": res.speed,
                           "fm_rate_error_hz_per_s": res.fm_rate_error, "iterations": res.iterations,
                           "misregistration_s": res.misregistration}
    if autofocus == "contrast":
        res = contrast_autofocus(est, speed, **kw)
        return res.image, {"method": "contrast(normalised_variance)", "speed_in": speed, "speed_estimate": res.speed,
                           "fm_rate_error_hz_per_s": res.fm_rate_error, "evaluations": len(res.evaluations[0])}
    return range_doppler(est, speed, **kw), None
