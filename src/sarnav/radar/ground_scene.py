"""Scenes that look like the ground, in the local NED frame of the aircraft scenarios: a terrain height map,
distributed clutter with speckle, a few bright features, and the same ground seen by another pass.

* :class:`HillTerrain`: heights h(N, E) [m] above the reference plane (D = 0) as a sum of Gaussian hills and hollows
  (tens of metres of relief over hundreds of metres); its height moves every scatterer, so slant ranges see the
  terrain (foreshortening and layover come from the geometry of the echoes, not from a model of them).
* :func:`distributed_clutter`: a homogeneous Poisson field of point scatterers with circular complex Gaussian
  amplitudes, several per resolution cell, so that the image of it is fully developed speckle (complex Gaussian
  pixels, exponential intensity). The power per unit area ``power_per_m2`` (a sigma^0 in the units of
  ``radar.scene``: |a|^2 of one raw sample on boresight) is fixed whatever the density, and scaled by the local
  incidence on the terrain: ``max(n . l, 0.05) / l_D`` (n the terrain normal, l the unit vector to the radar;
  flat ground gives 1), so slopes facing the radar are brighter and the image has texture tied to the DEM (a
  choice, not from a source; the spacecraft terrain of ``radar.terrain`` uses the same law).
* another pass (the reference product's): the stable scatterers (reflectors, bright features) unchanged, the clutter
  decorrelated with temporal coherence gamma: ``a' = gamma a + sqrt(1 - gamma^2) a_new``. Geometric (baseline)
  decorrelation is not modelled here: it comes from imaging the same 3-D scatterers from the other pass's track.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError
from sarnav.radar.scene import Scene

__all__ = ["HillTerrain", "distributed_clutter"]


@dataclass(frozen=True)
class HillTerrain:
    """h(N, E) = sum_k a_k exp(-((N - n_k)^2 + (E - e_k)^2) / (2 w_k^2)) [m] above D = 0 (up positive)."""

    centres: np.ndarray  # (K, 2) north, east [m]
    widths: np.ndarray  # (K,) [m]
    heights: np.ndarray  # (K,) [m], positive hills and negative hollows

    @classmethod
    def random(cls, rng: np.random.Generator, extent, relief: float, scale=(40.0, 200.0),
               hills_per_km2: float = 60.0) -> "HillTerrain":
        """Hills over ``extent`` = ((n_min, n_max), (e_min, e_max)) [m] (extended by 2 widths so the edges are not
        flat): Poisson(hills_per_km2 x area) centres uniform, widths uniform in ``scale`` [m], heights N(0, relief^2)
        (``relief`` [m] >= 0; 0 gives flat ground)."""
        if not (math.isfinite(relief) and 0.0 <= relief <= 1000.0):
            raise ConfigError("scene.terrain_relief_m", f"must be in [0, 1000] m, got {relief!r}")
        lo, hi = float(scale[0]), float(scale[1])
        if not (0.0 < lo <= hi <= 1.0e4):
            raise ConfigError("scene.terrain_scale_m", f"must be [min, max] widths with 0 < min <= max <= 1e4 m, "
                              f"got {list(scale)!r}")
        ext = np.asarray(extent, dtype=np.float64) + np.array([[-2 * hi, 2 * hi], [-2 * hi, 2 * hi]])
        area = (ext[0, 1] - ext[0, 0]) * (ext[1, 1] - ext[1, 0]) / 1.0e6
        k = int(rng.poisson(hills_per_km2 * area))
        c = np.stack([rng.uniform(*ext[0], k), rng.uniform(*ext[1], k)], axis=1)
        return cls(c, rng.uniform(lo, hi, k), rng.normal(0.0, relief, k))

    def height(self, north, east) -> np.ndarray:
        n, e = np.asarray(north, dtype=np.float64), np.asarray(east, dtype=np.float64)
        h = np.zeros(np.broadcast(n, e).shape)
        for (cn, ce), w, a in zip(self.centres, self.widths, self.heights):
            h += a * np.exp(-((n - cn) ** 2 + (e - ce) ** 2) / (2.0 * w * w))
        return h

    def surface_down(self, points) -> np.ndarray:
        """The surface's down coordinate [m] (NED: -height) under ``points`` (..., 3): the DEM as a reference
        product gives it (``measurements.sar_product.ground_points``)."""
        q = np.asarray(points, dtype=np.float64)
        return -self.height(q[..., 0], q[..., 1])

    def gradient(self, north, east) -> tuple[np.ndarray, np.ndarray]:
        """(dh/dN, dh/dE) at the points."""
        n, e = np.asarray(north, dtype=np.float64), np.asarray(east, dtype=np.float64)
        gn, ge = np.zeros(np.broadcast(n, e).shape), np.zeros(np.broadcast(n, e).shape)
        for (cn, ce), w, a in zip(self.centres, self.widths, self.heights):
            g = a * np.exp(-((n - cn) ** 2 + (e - ce) ** 2) / (2.0 * w * w)) / (w * w)
            gn -= g * (n - cn)
            ge -= g * (e - ce)
        return gn, ge


def _incidence_factor(terrain: HillTerrain | None, points: np.ndarray, radar: np.ndarray) -> np.ndarray:
    """max(n . l, 0.05) / l_up: the local-incidence scaling of the backscatter (module docstring)."""
    los = radar - points
    los /= np.linalg.norm(los, axis=1, keepdims=True)
    up = -los[:, 2]
    if terrain is None:
        return np.ones(points.shape[0])
    gn, ge = terrain.gradient(points[:, 0], points[:, 1])
    normal = np.stack([-gn, -ge, -np.ones_like(gn)], axis=1)  # NED: up is -D; n = (-dh/dN, -dh/dE, 1 up)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    return np.maximum(np.sum(normal * los, axis=1), 0.05) / np.maximum(up, 1e-3)


def distributed_clutter(rng: np.random.Generator, trajectory, toc_window, ground_range, density: float,
                        power_per_m2: float, look_side: str = "right", terrain: HillTerrain | None = None,
                        coherence: float = 1.0) -> tuple[Scene, Scene]:
    """Speckle clutter beside any trajectory over the patch whose TOC lies in ``toc_window`` (absolute times [s])
    and whose ground range lies in ``ground_range`` [m] (module docstring), as (this pass, another pass):
    Poisson(density x area) scatterers [per m^2], uniform in TOC and ground range (the patch's along-track length is
    the track length flown in the window), heights on ``terrain`` (flat ground if None), amplitudes circular complex
    Gaussian with E|a|^2 = power_per_m2 / density x the incidence factor; the other pass's amplitudes
    ``gamma a + sqrt(1 - gamma^2) a_new`` (``coherence`` gamma in [0, 1]). Draws: count, TOCs, ground ranges, real
    and imaginary parts of a, then of a_new."""
    from sarnav.radar.scene import beside_trajectory

    if not (math.isfinite(density) and 0.0 < density <= 1.0e3):
        raise ConfigError("scene.clutter_density_m2", f"must be in (0, 1000] scatterers per m^2, got {density!r}")
    if not (math.isfinite(power_per_m2) and power_per_m2 >= 0.0):
        raise ConfigError("scene.clutter_power_m2", f"must be finite and >= 0, got {power_per_m2!r}")
    if not (math.isfinite(coherence) and 0.0 <= coherence <= 1.0):
        raise ConfigError("scene.reference_coherence", f"must be in [0, 1], got {coherence!r}")
    t0, t1 = float(toc_window[0]), float(toc_window[1])
    g0, g1 = float(ground_range[0]), float(ground_range[1])
    st = trajectory.state(np.array([t0, t1]))
    length = float(np.mean(np.hypot(st.velocity[:, 0], st.velocity[:, 1]))) * (t1 - t0)
    n = int(rng.poisson(density * length * (g1 - g0)))
    toc = rng.uniform(t0, t1, n)
    gr = rng.uniform(g0, g1, n)
    height = None if terrain is None else terrain.height
    pos = beside_trajectory(trajectory, toc, gr, look_side, height) if n else np.zeros((0, 3))
    radar = trajectory.state(toc).position if n else np.zeros((0, 3))
    scale = np.sqrt(power_per_m2 / density * _incidence_factor(terrain, pos, radar)) if n else np.zeros(0)
    z = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / math.sqrt(2.0)
    z_new = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / math.sqrt(2.0)
    return Scene(pos, scale * z), Scene(pos, scale * (coherence * z + math.sqrt(1.0 - coherence**2) * z_new))
