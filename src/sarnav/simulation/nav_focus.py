"""Which navigation source focuses a back-projected image: the Ku-band cart test of Sun (2022) §6.2-6.3 (Figs. 6.5-6.9,
6.12-6.13; extraction seed-003 §3.7, E9, claims T27-T32), simulated.

Per run: the cart (1 m/s, straight, level, optionally vibrating: ``FocusGeometry.vibration``) carries the NovAtel-model IMU (200 Hz), three ADIS16465 (100 Hz) and a
20 Hz fix; after a run-in the radar (``radar.presets.sun_ku_cart``: 16.6 GHz, 300 MHz, PRF 3 kHz, no window)
records ``n_pulses`` pulses. Echoes are simulated along the **true** track (the same for every run: noise-free
echoes of three reflectors about 20 m to the right); each navigation source of
``simulation.nav_sources.navigation_sources`` gives the antenna positions at every pulse, and the pulses are
back-projected (``imaging.backprojection.backproject``) with those positions onto a ground chip around each
reflector. Per source and reflector (``focus_metrics``):

* ``irw_along_m``, ``pslr_along_db``: the along-track cut through the peak (``signal.metrics.impulse_response``,
  whole cut, 32x upsampled); where the response does not fall to -3 dB (or to a first null) inside the chip the
  IRW is the chip length and the PSLR 0 dB, and the value is marked *censored* (the reflector is smeared
  beyond the chip);
* ``peak_offset_m``: horizontal distance of the sub-pixel peak (``signal.metrics.peak_location``) from the true
  reflector;
* ``entropy``: intensity entropy of the chip (``imaging.quality.intensity_entropy``, nats; lower = sharper);
* ``kurtosis``: normalised complex kurtosis of the chip (``imaging.quality.normalised_complex_kurtosis``, eq. 3.5
  / m2^2; higher = sharper).

The phase error a position error makes is ``(4 pi / lambda) u . delta`` (eq. 4.12, u the line of sight):
``los_error_rms`` reports, per source and reflector, the RMS over the aperture of ``u . delta`` after removing
its mean and linear trend (a constant offset only translates the image, a linear drift shifts it along track;
the rest defocuses when above lambda/16, eq. 4.13, T31).

The ``nav-source-focus`` campaign: :class:`FocusParams` -> :func:`run_focus_records` (the records of
``simulation.fusion_records``: states = the UPF / KF position errors at their fix epochs, and the focus variables).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.backprojection import backproject
from sarnav.imaging.grid import GroundGrid
from sarnav.imaging.quality import intensity_entropy, normalised_complex_kurtosis
from sarnav.imaging.range_compression import range_compress
from sarnav.radar.echoes import simulate_echoes
from sarnav.radar.params import RadarParams
from sarnav.radar.presets import sun_ku_cart
from sarnav.radar.scene import point_targets
from sarnav.signal.data import PulseData
from sarnav.signal.metrics import impulse_response, index_to_coordinate, peak_location
from sarnav.record import RunRecord
from sarnav.simulation.fusion_records import run_records, source_records
from sarnav.simulation.imu_rig import cart_track
from sarnav.simulation.nav_sources import NAV_SOURCES, navigation_sources
from sarnav.trajectory.vibration import Vibrating

__all__ = ["FOCUS_METRICS", "FOCUS_FILTERS", "FOCUS_ATTRS", "FocusGeometry", "FocusParams", "FocusRun",
           "reflector_positions", "focus_metrics", "form_chips", "run_focus", "run_focus_records", "los_error_rms",
           "scene_images", "run_scene_images"]

#: the per-reflector metrics, in the order of ``focus (source, reflector, metric)`` and focus.csv
FOCUS_METRICS = ("irw_along_m", "pslr_along_db", "peak_offset_m", "entropy", "kurtosis")
#: the sources whose filter has a covariance (recorded as the states), and the source that carries each
FOCUS_FILTERS = {"upf": ("upf", "spline-pf"), "kf-interp": ("kf-interp", "spline-kf")}
#: attributes of the record variables of :func:`run_focus_records` (results.nc)
FOCUS_ATTRS = {
    "focus": {"units_coordinate": "metric_units", "description": "per source and reflector: irw_along_m, "
              "pslr_along_db, peak_offset_m, entropy, kurtosis of the BPA chip (simulation.nav_focus)"},
    "focus_censored": {"units": "1", "description": "1 where the along-track response does not reach -3 dB or a null "
                       "inside the chip (IRW = chip length, PSLR = 0 dB)"},
    "los_error_rms": {"units": "m", "description": "RMS over the aperture of the line-of-sight antenna position error "
                      "after removing its mean and linear trend (defocus above lambda/16)"},
    "nav_error": {"units": "m", "description": "antenna position estimate minus truth at every pulse, NED"},
    "source_ms": {"units": "m2", "description": "mean over the aperture of the squared 3-D antenna error"},
    "filter_nees": {"units": "1", "description": "NEES of the UPF / KF position at their fix epochs (3 dof)"},
}


@dataclass(frozen=True)
class FocusGeometry:
    """The cart test: ``speed`` [m/s] northbound, ``run_in`` [s] of navigation before the first pulse,
    ``n_pulses`` at the radar's PRF, reflectors at (along-track offset from the aperture centre [m], ground range
    to the right [m]) ``reflectors``, ``antenna_height`` [m] above them; chips of ``chip_half`` [m] half-size at
    ``spacing`` [m] around each reflector; the cart's ``vibration``: tones (frequency [Hz], (north, east, down)
    amplitude [m]) added to the true track (``trajectory.vibration.Vibrating``; none by default)."""

    radar: RadarParams = field(default_factory=sun_ku_cart)
    speed: float = 1.0
    run_in: float = 30.0
    n_pulses: int = 2000
    reflectors: tuple = ((-2.5, 19.5), (0.0, 20.0), (2.5, 20.5))
    antenna_height: float = 1.5
    chip_half: float = 1.2
    spacing: float = 0.04
    vibration: tuple = ()

    def track(self, duration: float):
        """The true cart track over ``duration`` [s]: straight and level northbound, plus the tones of
        ``vibration``."""
        track = cart_track(duration, self.speed, heading=0.0)
        if not self.vibration:
            return track
        return Vibrating(track, [f for f, _ in self.vibration], [a for _, a in self.vibration])

    def pulse_times(self) -> np.ndarray:
        return self.radar.pulse_times(self.n_pulses, self.run_in)


def reflector_positions(geo: FocusGeometry, truth) -> np.ndarray:
    """(K, 3) NED reflector positions in the frame of the pulse positions ``truth`` (P, 3) (first pulse at 0):
    along-track offsets from the aperture centre, to the right of the northbound track, ``antenna_height``
    below it."""
    centre = truth[len(truth) // 2]
    return np.array([[centre[0] + a, centre[1] + g, centre[2] + geo.antenna_height] for a, g in geo.reflectors])


def chip_grid(geo: FocusGeometry, target) -> GroundGrid:
    n = 2 * int(round(geo.chip_half / geo.spacing)) + 1
    return GroundGrid.centered(float(target[0]), float(target[1]), geo.spacing, (n, n), down=float(target[2]))


def form_chips(rc: PulseData, positions, targets, geo: FocusGeometry) -> list:
    """BPA chips (``SarImage``) around each reflector with the antenna ``positions`` (P, 3)."""
    return [backproject(rc, chip_grid(geo, t), positions=positions) for t in targets]


def focus_metrics(chip, target) -> tuple[np.ndarray, bool]:
    """(:data:`FOCUS_METRICS` values (5,), censored) of one chip around the reflector at ``target`` (module doc)."""
    data = chip.data
    n = data.shape[0]
    pk = peak_location(data, half_width=min(16, n // 2))
    north = index_to_coordinate(chip.y, pk[0])
    east = index_to_coordinate(chip.x, pk[1])
    censored = False
    try:
        ir = impulse_response(data, 0, peak=pk, upsample=32, half_width=n // 2, n_sidelobes=None)
        irw, pslr = ir.irw * abs(chip.dy), ir.pslr_db
    except InputDataError:  # smeared beyond the chip: no -3 dB point or no first null inside it
        irw, pslr, censored = n * abs(chip.dy), 0.0, True
    offset = float(np.hypot(north - target[0], east - target[1]))
    return np.array([irw, pslr, offset, intensity_entropy(data), normalised_complex_kurtosis(data)]), censored


def los_error_rms(positions, truth, targets) -> np.ndarray:
    """RMS over the pulses of the line-of-sight component of (positions - truth) after removing its best-fit
    line in time (a constant LOS error shifts the image in range, a linear one in azimuth: neither defocuses),
    per run and reflector: positions (R, P, 3), truth (P, 3), targets (K, 3) -> (R, K) [m]."""
    u = truth[None] - targets[:, None]  # (K, P, 3) from reflector to antenna
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    los = np.einsum("kpi,rpi->rkp", u, np.asarray(positions) - truth[None])
    x = np.linspace(-1.0, 1.0, los.shape[-1])
    slope = (los @ x) / (x @ x)
    res = los - los.mean(axis=-1, keepdims=True) - slope[..., None] * x
    return np.sqrt(np.mean(res**2, axis=-1))


@dataclass
class FocusRun:
    """Results of :func:`run_focus` for R runs: ``sources`` (S names); ``focus`` (R, S, K, 5) (:data:`FOCUS_METRICS`),
    ``censored`` (R, S, K) bool; ``los_rms`` (R, S, K) [m]; ``nav_error`` (R, P, S, 3) antenna position error at
    the pulses [m]; ``pulse_times`` (P,); ``targets`` (K, 3); the UPF / KF fix-epoch records ``fix_times``,
    ``fix_errors``, ``fix_covs`` (``simulation.nav_sources.NavSources``); ``chips`` (first run, if asked)."""

    sources: list
    focus: np.ndarray
    censored: np.ndarray
    los_rms: np.ndarray
    nav_error: np.ndarray
    pulse_times: np.ndarray
    targets: np.ndarray
    fix_times: np.ndarray
    fix_errors: dict
    fix_covs: dict
    truth: np.ndarray
    positions: dict


def echoes(geo: FocusGeometry, truth, targets, pulse_times) -> PulseData:
    """Range-compressed, noise-free echoes of the reflectors along the true antenna track ``truth`` (P, 3)."""
    raw = simulate_echoes(geo.radar, truth, pulse_times, point_targets(targets, 1.0))
    return range_compress(raw)


def run_focus(seeds, geo: FocusGeometry | None = None, sources=NAV_SOURCES, n_particles: int = 2000,
              adis_particles: int = 1000, fix_sigma=(0.3, 0.3, 0.5), fix_correlated=(0.0, 0.0, 0.0),
              fix_tau: float = 300.0) -> FocusRun:
    """The experiment of the module docstring for the runs of ``seeds`` (one SeedSequence per run); the fix
    errors: white ``fix_sigma`` plus a Gauss-Markov part ``fix_correlated``, ``fix_tau``
    (``nav_sources.navigation_sources``)."""
    geo = geo or FocusGeometry()
    if "truth" not in sources:
        raise ConfigError("sources", "must include 'truth' (the reference image)")
    pt = geo.pulse_times()
    track = geo.track(float(np.ceil(pt[-1] + 0.1)) + 1.0)
    nav = navigation_sources(pt, runs=len(seeds), seed=list(seeds), track=track, n_particles=n_particles,
                             adis_particles=adis_particles, fix_sigma=np.asarray(fix_sigma, dtype=float),
                             sources=tuple(sources), fix_correlated=fix_correlated, fix_tau=fix_tau)
    truth = nav.positions["truth"][0]
    targets = reflector_positions(geo, truth)
    rc = echoes(geo, truth, targets, pt)
    R, S, K = len(seeds), len(sources), len(targets)
    focus, censored = np.empty((R, S, K, len(FOCUS_METRICS))), np.zeros((R, S, K), dtype=bool)
    los = np.empty((R, S, K))
    err = np.empty((R, pt.size, S, 3))
    for j, name in enumerate(sources):
        pos = np.broadcast_to(nav.positions[name], (R, pt.size, 3))
        err[:, :, j] = pos - truth[None]
        los[:, j] = los_error_rms(pos, truth, targets)
        for r in range(R):
            for k, chip in enumerate(form_chips(rc, pos[r], targets, geo)):
                focus[r, j, k], censored[r, j, k] = focus_metrics(chip, targets[k])
    return FocusRun(list(sources), focus, censored, los, err, pt, targets, nav.fix_times, nav.fix_errors,
                    nav.fix_covs, truth, nav.positions)


@dataclass(frozen=True)
class FocusParams:
    """The ``nav-source-focus`` campaign (arguments of :func:`run_focus`, SI): the cart test ``geometry``, the
    navigation ``sources``, ``n_particles`` (UPF) and ``adis_particles`` (each ADIS PF, the NovAtel PF), the white
    fix 1-sigma ``fix_sigma`` (3,) [m] and its Gauss-Markov part ``fix_correlated`` (3,) [m], ``fix_tau`` [s]."""

    runs: int
    geometry: FocusGeometry
    sources: tuple
    n_particles: int
    adis_particles: int
    fix_sigma: tuple
    fix_correlated: tuple
    fix_tau: float

    def filters(self) -> list[str]:
        """The filters with a covariance carried by one of the sources (:data:`FOCUS_FILTERS`; the states)."""
        return [f for f, carriers in FOCUS_FILTERS.items() if any(s in self.sources for s in carriers)]


def run_focus_records(prm: FocusParams, seeds, run_ids=None) -> list[RunRecord]:
    """One record per run of ``seeds`` (numbered ``run_ids``, default 0, 1, ...): the states are the position errors
    of the UPF / KF at their fix epochs (``fusion_records.run_records``), the kind's variables ``focus (source,
    reflector, metric)``, ``focus_censored``, ``los_error_rms (source, reflector)``, ``nav_error (pulse, source,
    axis)`` and ``source_ms (source)`` (mean over the aperture of the squared 3-D antenna error)."""
    seeds = list(seeds)
    res = run_focus(seeds, prm.geometry, prm.sources, prm.n_particles, prm.adis_particles, prm.fix_sigma,
                    prm.fix_correlated, prm.fix_tau)
    filters = prm.filters()
    rec = source_records(res.fix_times, res.fix_errors, res.fix_covs, filters, filters, 0.0)
    extras = {"focus": (("source", "reflector", "metric"), res.focus),
              "focus_censored": (("source", "reflector"), res.censored.astype("int8")),
              "los_error_rms": (("source", "reflector"), res.los_rms),
              "nav_error": (("pulse", "source", "axis"), res.nav_error),
              "source_ms": (("source",), (res.nav_error**2).sum(-1).mean(1))}
    return run_records(rec, list(range(len(seeds))) if run_ids is None else list(run_ids), extras, sources=False)


def scene_images(run: FocusRun, geo: FocusGeometry, run_index: int = 0, margin: float = 1.5,
                 spacing: float = 0.05) -> tuple[dict, tuple]:
    """One image covering every reflector per source, of run ``run_index`` (for the side-by-side figure):
    (source -> magnitude (rows, cols), extent (east0, east1, north0, north1))."""
    t = run.targets
    n0, n1 = t[:, 0].min() - margin, t[:, 0].max() + margin
    e0, e1 = t[:, 1].min() - margin, t[:, 1].max() + margin
    north = np.arange(n0, n1 + 1e-9, spacing)
    east = np.arange(e0, e1 + 1e-9, spacing)
    grid = GroundGrid(north, east, down=float(t[:, 2].mean()))
    rc = echoes(geo, run.truth, t, run.pulse_times)
    out = {}
    for name in run.sources:
        pos = np.broadcast_to(run.positions[name], (run.focus.shape[0], run.pulse_times.size, 3))[run_index]
        out[name] = np.abs(backproject(rc, grid, positions=pos).data)
    return out, (east[0], east[-1], north[0], north[-1])


def run_scene_images(prm: FocusParams, seed) -> tuple[FocusRun, dict, tuple]:
    """The run of ``seed`` again (the same numbers as the campaign's run of that seed) and its whole scene imaged per
    source (:func:`scene_images`): (the run, source -> magnitude, extent), for the side-by-side figure."""
    res = run_focus([seed], prm.geometry, prm.sources, prm.n_particles, prm.adis_particles, prm.fix_sigma,
                    prm.fix_correlated, prm.fix_tau)
    images, extent = scene_images(res, prm.geometry)
    return res, images, extent
