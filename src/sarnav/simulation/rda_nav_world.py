"""The world of an ``rda-nav`` scenario: reference targets, the scene of each sub-aperture as each pass sees it, the
reference pass, the map's geolocation errors and the receive window that follows the geometry.

Wiring of library pieces (``radar.scene``, ``radar.ground_scene``, ``trajectory.offset``, ``radar.presets``); the
scene keys are documented in docs/scenarios/rda-nav.md §1 (G4, G5) and §4 (scenes that look like the ground).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from sarnav.errors import ConfigError
from sarnav.measurements.sar_image import AperturePasses
from sarnav.radar.ground_scene import HillTerrain, distributed_clutter
from sarnav.radar.params import window_over
from sarnav.radar.scene import Scene, beside_trajectory, clutter_beside_trajectory, point_targets, slant_ranges
from sarnav.simulation.sar_echoes import simulated_imager
from sarnav.trajectory.offset import OffsetTrack

__all__ = ["WorldFlight", "SCENE_TYPES", "terrain_of", "swath_extent", "reference_targets", "scene_factory", "world_imager", "reference_track", "map_errors",
           "slant_range_span", "CLUTTER_MARGIN_M"]

SCENE_TYPES = ("points", "terrain")
#: ground-range margin of the distributed clutter around each reference target [m] (covers the search window)
CLUTTER_MARGIN_M = 15.0


@dataclass(frozen=True)
class WorldFlight:
    """What the world reads of a flight (``RdaNavParams`` is one; every kind that flies rda-nav's world builds one,
    e.g. ``multi-imu-sar``): the true ``trajectory``, the ``scene`` dict of rda-nav's ``[scene]`` table (the keys
    ``scenarios.rda_nav`` parses; the functions below read those they need), a ``radar`` with a ``look_side`` and the
    number of 1-s sub-apertures ``n_updates``."""

    trajectory: Any
    scene: dict
    radar: Any
    n_updates: int


def terrain_of(prm) -> HillTerrain | None:
    """The terrain (``scene.type = "terrain"``) from ``[scene.seed, 8]``, over the swath of the flight; else None."""
    sc = prm.scene
    if sc["type"] != "terrain":
        return None
    rng = np.random.default_rng(np.random.SeedSequence([sc["seed"], 8]))
    return HillTerrain.random(rng, swath_extent(prm), sc["terrain_relief"], sc["terrain_scale"])


def swath_extent(prm) -> tuple:
    """((n_min, n_max), (e_min, e_max)) [m]: the box of the ground the sub-apertures image (the targets' band plus
    the clutter margin, to the look side of the whole flight)."""
    t = np.linspace(0.0, prm.trajectory.duration, 64)
    g0, g1 = prm.scene["ground_range"]
    q = np.concatenate([beside_trajectory(prm.trajectory, t, np.full(t.size, g), prm.radar.look_side)
                        for g in (max(g0 - CLUTTER_MARGIN_M, 0.0), g1 + CLUTTER_MARGIN_M)])
    return (float(q[:, 0].min()), float(q[:, 0].max())), (float(q[:, 1].min()), float(q[:, 1].max()))


def _height(terrain):
    return None if terrain is None else terrain.height


def reference_targets(prm) -> np.ndarray:
    """(U, T, 3) ``scene.targets_per_image`` geolocated reference targets per sub-aperture, on the ground (the
    terrain's height) to the look side of the true track: TOC at the aperture centre +- ``scene.toc_jitter_s``,
    ground range uniform in the configured band; drawn from ``scene.seed`` (the same world for every run)."""
    sc = prm.scene
    rng = np.random.default_rng(np.random.SeedSequence(sc["seed"]))
    U, T = prm.n_updates, sc["targets_per_image"]
    k = np.arange(U)
    shape = (U,) if T == 1 else (U, T)  # one target: the draws of sarnav 0.2 (same world)
    toc = (k if T == 1 else k[:, None]) + 0.5 + rng.uniform(-sc["toc_jitter"], sc["toc_jitter"], shape)
    gr = rng.uniform(*sc["ground_range"], shape)
    q = beside_trajectory(prm.trajectory, np.ravel(toc), np.ravel(gr), prm.radar.look_side, _height(terrain_of(prm)))
    return q.reshape(U, T, 3)


def reference_track(prm):
    """The reference pass's true track: the in-flight truth shifted by ``scene.reference_offset_m`` = [across (to
    the right of the velocity), up] [m] (``trajectory.offset.OffsetTrack``), or the truth itself for [0, 0]."""
    across, up = prm.scene["reference_offset"]
    if across == 0.0 and up == 0.0:
        return prm.trajectory
    return OffsetTrack(prm.trajectory, across, up)


def map_errors(prm, clutter_seeds) -> np.ndarray:
    """(R, U, T, 3) the map's geolocation error of each reference target, per run: N(0, diag(sigma^2)) with
    ``scene.geolocation_sigma_m`` = [N, E, D] 1-sigma [m], from ``[clutter seed, 6]`` (each run is another map
    realisation, so that the Monte Carlo statistics hold; docs §4). Zero when the sigmas are zero."""
    sig = np.asarray(prm.scene["geolocation_sigma"], dtype=np.float64)
    U, T = prm.n_updates, prm.scene["targets_per_image"]
    out = np.zeros((len(clutter_seeds), U, T, 3))
    if np.any(sig > 0):
        for r, s in enumerate(clutter_seeds):
            out[r] = np.random.default_rng(np.random.SeedSequence([int(s), 6])).standard_normal((U, T, 3)) * sig
    return out


def _point_clutter(prm, rng, u) -> Scene:
    sc = prm.scene
    return clutter_beside_trajectory(rng, prm.trajectory, (u + 0.1, u + 0.9), sc["ground_range"], sc["clutter"],
                                     prm.radar.look_side)


def _terrain_passes(prm, rng, u, targets, terrain) -> tuple[Scene, Scene]:
    """Bright features and speckle clutter of sub-aperture u around each reference target: (flight, reference)."""
    sc, traj, side = prm.scene, prm.trajectory, prm.radar.look_side
    st = traj.state(np.array([u + 0.5]))
    g_t = np.hypot(*(targets[:, :2] - st.position[0, :2]).T)
    nb = sc["bright_features"]
    bright = beside_trajectory(traj, rng.uniform(u, u + 1, nb * len(g_t)),
                               np.repeat(g_t, nb) + rng.uniform(-CLUTTER_MARGIN_M, CLUTTER_MARGIN_M, nb * len(g_t)),
                               side, terrain.height) if nb else np.zeros((0, 3))
    b_amp = sc["bright_amplitude"] * np.exp(2j * np.pi * rng.uniform(size=bright.shape[0]))
    stable = point_targets(bright, b_amp) if bright.shape[0] else None
    flight, reference = [], []
    for g in g_t:
        f, r = distributed_clutter(rng, traj, (u, u + 1), (g - CLUTTER_MARGIN_M, g + CLUTTER_MARGIN_M),
                                   sc["clutter_density"], sc["clutter_power"], side, terrain, sc["reference_coherence"])
        flight.append(f)
        reference.append(r)
    fl, rf = flight[0], reference[0]
    for f, r in zip(flight[1:], reference[1:]):
        fl, rf = fl + f, rf + r
    if stable is not None:
        fl, rf = fl + stable, rf + stable
    return fl, rf


def scene_factory(prm, targets: np.ndarray):
    """``(u, clutter_seed) -> AperturePasses`` of sub-aperture u: its reference reflectors (amplitude
    ``scene.reflector_amplitude``, the same in both passes) plus, for ``scene.type = "points"``,
    ``scene.clutter_per_image`` Rayleigh scatterers whose TOC lies in the aperture (u + 0.1 .. u + 0.9 s), the same in
    both passes; for ``"terrain"``, bright features and speckle clutter on the terrain, decorrelated between the passes
    (``radar.ground_scene``). Drawn from ``[scene.seed, 1, u]`` (one world) or ``[clutter_seed, 2, u]`` (per run)."""
    terrain = terrain_of(prm)

    def scene_for(u: int, clutter_seed: int | None) -> AperturePasses:
        key = [prm.scene["seed"], 1, u] if clutter_seed is None else [clutter_seed, 2, u]
        rng = np.random.default_rng(np.random.SeedSequence(key))
        refl = point_targets(targets[u], prm.scene["reflector_amplitude"])
        if terrain is None:
            s = refl + _point_clutter(prm, rng, u)
            return AperturePasses(s, s)
        f, r = _terrain_passes(prm, rng, u, targets[u], terrain)
        return AperturePasses(refl + f, refl + r)

    return scene_for


def slant_range_span(prm, margin: float) -> tuple[float, float]:
    """(min, max) slant range [m] of every scatterer the sub-apertures may image, both passes: the ranges of closest
    approach of the reference targets, widened by the ground-range band of their clutter (terrain scenes), the
    terrain's height spread, the reference pass's offset and ``margin`` [m] (``radar.range_margin_m``: navigation
    errors and the search window)."""
    sc = prm.scene
    targets = reference_targets(prm)
    U = targets.shape[0]
    tocs = np.repeat(np.arange(U) + 0.5, targets.shape[1])
    r = slant_ranges(prm.trajectory, targets, tocs)
    t = np.arange(U) + 0.5  # the edges of the ground-range band, where point clutter may lie
    for g in sc["ground_range"]:
        edge = beside_trajectory(prm.trajectory, t, np.full(U, g), prm.radar.look_side)
        r = np.concatenate([r, slant_ranges(prm.trajectory, edge, t)])
    pad = margin + abs(sc["reference_offset"][0]) + abs(sc["reference_offset"][1])
    if sc["type"] == "terrain":
        terrain = terrain_of(prm)
        (n0, n1), (e0, e1) = swath_extent(prm)
        h = terrain.height(np.arange(n0, n1 + 2.0, 2.0)[:, None], np.arange(e0, e1 + 2.0, 2.0)[None, :])
        pad += CLUTTER_MARGIN_M + float(h.max() - h.min())
    lo, hi = float(r.min()) - pad, float(r.max()) + pad
    if not lo > 0:
        raise ConfigError("scene.ground_range_min", f"the nearest slant range {r.min():.1f} m must exceed the "
                          f"receive-window margin {pad:.1f} m (radar.range_margin_m and the scene's extent)")
    return lo, hi


def receive_window(prm_radar_fields: dict, span: tuple[float, float]) -> dict:
    """``near_range`` and ``n_range_samples`` of a receive window over ``span`` (slant range [m]) plus the pulse's
    half-extent cT/4 (every scatterer's whole chirp inside the window, as the presets do)."""
    return window_over(span, prm_radar_fields["pulse_length"], prm_radar_fields["sample_rate"])


def world_imager(prm, seeds, settings=None, capture_aperture=None):
    """(reference targets (U, T, 3), the simulated world's ``SubApertureImager``) of a flight ``prm`` for runs whose
    clutter and in-flight receiver noise are keyed by ``seeds`` (one per run), imaging with ``settings`` (default: the
    scenario's ``prm.imaging``): the one wiring of the world's scene, reference pass and noise to the extractor that
    the campaign, its tests and ``benchmarks/bench_bpa_chip.py`` share. Over terrain the reference comes with the
    scene's DEM (``ReferencePulses.surface``; the world's own heights: the DEM has no error here)."""
    targets = reference_targets(prm)
    imager = simulated_imager(
        radar=prm.radar, truth=prm.trajectory, targets=targets, scene_for=scene_factory(prm, targets),
        reflector_amplitude=prm.scene["reflector_amplitude"], snr_db=prm.snr_db, reference_seed=prm.scene["seed"],
        noise_seeds=seeds, clutter_seeds=seeds if prm.scene["clutter_per_run"] else None,
        reference_truth=reference_track(prm), settings=prm.imaging if settings is None else settings,
        capture_aperture=capture_aperture, surface=terrain_of(prm))
    return targets, imager
