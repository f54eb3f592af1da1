"""The scene and receiver of the image-quality experiments (``quality-sweep``, ``gpsd-search``; docs/quality.md §2):
the USU-like binary picture or points over clutter on the square of a
:class:`~sarnav.radar.quality_scenes.QualityGeometry`, and the receiver noise, drawn from one seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sarnav.radar.quality_scenes import QualityGeometry, binary_scene, point_clutter_scene, usu_picture

__all__ = ["SCENE_TYPES", "QualitySceneSpec", "make_scene"]

SCENE_TYPES = ("usu", "point-clutter")


@dataclass(frozen=True)
class QualitySceneSpec:
    """A scene of the quality experiments: ``type`` (:data:`SCENE_TYPES`), ``seed`` of the point/clutter draw and the
    noise, ``points``, ``point_to_clutter_db`` [dB], ``clutter_density`` [1/m^2], ``usu_cells`` (the picture's side
    in cells); the receiver: ``receiver_noise`` and ``snr_db`` (per-sample SNR of the strongest scatterer [dB],
    ``radar.echoes``; used when ``receiver_noise``)."""

    type: str
    seed: int
    points: int
    point_to_clutter_db: float
    clutter_density: float
    usu_cells: int
    receiver_noise: bool
    snr_db: float

    def scatterers(self, geo: QualityGeometry) -> float:
        """How many scatterers the scene holds on the square of ``geo``: ``points`` plus the expected clutter count
        (density x extent^2) of a point-clutter scene, the lit cells of the USU picture."""
        if self.type == "point-clutter":
            return self.points + self.clutter_density * geo.scene_extent**2
        return float(np.count_nonzero(usu_picture((self.usu_cells,) * 2)))


def make_scene(scene: QualitySceneSpec, geo: QualityGeometry, seed_offset: int = 0):
    """(Scene, receiver-noise Generator or None, snr_db or None) of ``scene`` on the square of ``geo``; the
    point/clutter draw and the noise come from ``SeedSequence([scene.seed, seed_offset])``."""
    ss = np.random.SeedSequence([scene.seed, seed_offset])
    scene_ss, noise_ss = ss.spawn(2)
    if scene.type == "usu":
        pic = usu_picture((scene.usu_cells,) * 2)
        sc = binary_scene(pic, geo.scene_center, geo.scene_extent)
    else:
        sc = point_clutter_scene(np.random.default_rng(scene_ss), geo.scene_center, geo.scene_extent,
                                 n_points=scene.points, point_to_clutter_db=scene.point_to_clutter_db,
                                 clutter_density=scene.clutter_density)
    if not scene.receiver_noise:
        return sc, None, None
    return sc, np.random.default_rng(noise_ss), scene.snr_db
