"""The ``spacecraft-closed-loop`` scenario kind: the spacecraft SAR navigation closed on images formed from simulated
ALOS-like L-band raw echoes (issue 11 Build 5; Pogorelsky et al. 2022 §VI.A with a simulated pass; docs/spacecraft.md).

Configuration and wiring only: the world and the image chain are ``measurements.spacecraft_image``, the filter loop
``simulation.spacecraft_closed_loop`` (``run_closed_loop_records``). ``[measurement] mode = "oracle"`` runs the
paper's open loop on the same updates and world (claim T19). R and B use ``[measurement] sigma_vic`` and ``D``, set
from the Monte Carlo of the first measurement (docs/spacecraft.md gives the command and the numbers).
"""

from __future__ import annotations

from sarnav import units
from sarnav.errors import ConfigError, require_extra, require_finite
from sarnav.measurements.spacecraft_image import REGISTRATIONS, STAGES, ImagingConfig
from sarnav.montecarlo.kind import validate_campaign
from sarnav.scenarios import spacecraft as sc
from sarnav.scenarios.fields import choice, get, integer, number
from sarnav.scenarios.fields import positive as _pos
from sarnav.simulation.spacecraft import OpenLoopParams, check_geometry
from sarnav.simulation.spacecraft_closed_loop import CLOSED_LOOP_ATTRS as EXTRA_ATTRS
from sarnav.simulation.spacecraft_closed_loop import MODES, ClosedLoopParams, run_closed_loop_records


def read_imaging(cfg: dict) -> ImagingConfig:
    """``[radar]``, ``[aperture]``, ``[terrain]``, ``[autofocus]``, ``[registration]`` -> ImagingConfig (SI)."""
    refine = get(cfg, "autofocus", "refine")
    if not isinstance(refine, list) or len(refine) > 6:
        raise ConfigError("autofocus.refine", f"must be a list of at most 6 smaller steps [m/s], got {refine!r}")
    step = _pos(cfg, "autofocus", "step", "m/s", 1e-3, 100.0)
    refine = tuple(require_finite(f"autofocus.refine[{i}]", r, 1e-4, step * (1 - 1e-9), "m/s")
                   for i, r in enumerate(refine))
    return ImagingConfig(
        carrier_frequency=float(units.ghz_to_hz(_pos(cfg, "radar", "carrier_ghz", "GHz", 0.3, 20.0))),
        bandwidth=float(units.mhz_to_hz(_pos(cfg, "radar", "bandwidth_mhz", "MHz", 1.0, 200.0))),
        pulse_length=float(units.us_to_s(_pos(cfg, "radar", "pulse_length_us", "us", 0.1, 50.0))),
        sample_rate=float(units.mhz_to_hz(_pos(cfg, "radar", "sample_rate_mhz", "MHz", 1.0, 400.0))),
        prf=_pos(cfg, "radar", "prf_hz", "Hz", 500.0, 10000.0),
        range_samples=integer(cfg, "radar", "n_range_samples", 128, 2048),
        antenna_length=_pos(cfg, "radar", "antenna_length_m", "m", 1.0, 30.0),
        block=_pos(cfg, "aperture", "duration", "s", 0.2, 6.0),
        snr_db=number(cfg, "radar", "snr_db", -60.0, 100.0, "dB"),
        seed=integer(cfg, "terrain", "seed", 0, 2**63 - 1),
        relief=number(cfg, "terrain", "relief_m", 0.0, 1000.0, "m"),
        clutter_spacing=_pos(cfg, "terrain", "clutter_spacing_m", "m", 10.0, 1000.0),
        n_bright=integer(cfg, "terrain", "bright_scatterers", 0, 1000),
        bright_amplitude=_pos(cfg, "terrain", "bright_amplitude", "", 0.1, 1e3),
        coherence=number(cfg, "terrain", "coherence", 0.0, 1.0),
        half_along=_pos(cfg, "terrain", "half_along_m", "m", 200.0, 5000.0),
        half_range=_pos(cfg, "terrain", "half_range_m", "m", 200.0, 5000.0),
        map_spacing=_pos(cfg, "terrain", "map_spacing_m", "m", 2.0, 50.0), step=step,
        max_iter=integer(cfg, "autofocus", "max_iter", 1, 1000), refine=refine,
        registration=choice(cfg, "registration", "method", REGISTRATIONS),
        min_inliers=integer(cfg, "registration", "min_inliers", 3, 10000),
        smoothing=number(cfg, "registration", "smoothing_px", 0.0, 10.0),
        residual_px=_pos(cfg, "registration", "residual_px", "px", 0.1, 50.0),
        reference_look_offset=float(units.deg_to_rad(number(cfg, "terrain", "reference_look_offset_deg", -10.0, 10.0))))


def _check_radar(img: ImagingConfig) -> None:
    """Consistency of the radar with the window and the scene (one-line errors naming the key)."""
    if img.sample_rate < img.bandwidth:
        raise ConfigError("radar.sample_rate_mhz", "must be >= radar.bandwidth_mhz (complex Nyquist)")
    if img.pulse_length >= 1.0 / img.prf:
        raise ConfigError("radar.pulse_length_us", "must be shorter than the pulse repetition interval 1 / prf")
    window = img.range_samples * img.dr
    need = 2 * img.half_range + units.C * img.pulse_length / 2 + 200.0
    if window < need:
        raise ConfigError("terrain.half_range_m", f"the scene (2 x {img.half_range:g} m of slant range, + the chirp "
                          f"and migration) must fit the receive window radar.n_range_samples x c/(2 fs) = {window:.0f} m")
    if img.pulses * img.range_samples > 2e7:
        raise ConfigError("aperture.duration", f"block of {img.pulses} pulses x {img.range_samples} samples exceeds "
                          "2e7")


def parse(cfg: dict) -> ClosedLoopParams:
    """Validate ``cfg`` and convert to SI; ConfigError names the first bad field and its range."""
    validate_campaign(cfg)
    mode = choice(cfg, "measurement", "mode", MODES)
    ini = sc.read_initial(cfg, 1e5, 100.0, 1.0)
    model, uw = sc.read_mekf(cfg)
    sim = sc.read_simulation(cfg)
    if sim["duration"] > 600.0:
        raise ConfigError("simulation.duration", f"must be <= 600 s for the closed loop (an image per update), got "
                          f"{sim['duration']!r}")
    base = OpenLoopParams(elements=sc.read_elements(cfg), noise=sc.read_noise(cfg), mekf=model, underweighting=uw,
                          **sc.read_antenna(cfg), **sim, **ini)
    check_geometry(base)
    img = read_imaging(cfg)
    _check_radar(img)
    return ClosedLoopParams(base=base, imaging=img, mode=mode)


class ClosedLoopKind(sc.SpacecraftKind):
    """Simulated closed loop of the spacecraft SAR navigation (module docstring)."""

    kind = scenario = "spacecraft-closed-loop"
    parse, run_records, attrs = staticmethod(parse), staticmethod(run_closed_loop_records), EXTRA_ATTRS

    def validate(self, cfg: dict) -> None:
        if parse(cfg).mode == "image":  # registration by scikit-image, an optional dependency
            require_extra("measurement.mode", "registration", "skimage", "scikit-image")

    def extra_coords(self, cfg):
        out = super().extra_coords(cfg)
        out["stage"] = (list(STAGES), {"units": "", "description": "stages of the image chain"})
        out["xyz"] = (["x", "y", "z"], {"units": "", "description": "ECEF axes"})
        return out
