"""sarnav.radar: radar description, scenes and raw echo simulation (docs/radar.md)."""

from sarnav.radar.echoes import simulate_echoes
from sarnav.radar.params import RadarParams
from sarnav.radar.presets import flexsar, nav_paper_sim
from sarnav.radar.scene import Scene, point_targets, random_scatterers, speckle_scene

__all__ = ["RadarParams", "Scene", "flexsar", "nav_paper_sim", "point_targets", "random_scatterers",
           "simulate_echoes", "speckle_scene"]
