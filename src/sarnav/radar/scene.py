"""Scenes of point scatterers (NED positions, complex amplitudes).

The complex amplitude of a scatterer multiplies its echo directly (no range spreading loss, no
elevation pattern): ``|a|^2`` is the scatterer's power as seen in one raw sample on boresight.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError, InputDataError

AMPLITUDE_LAWS = ("constant", "rayleigh")


@dataclass(frozen=True, eq=False)
class Scene:
    """K point scatterers.

    Attributes
    ----------
    positions : (K,3) float64 NED positions [m].
    amplitudes : (K,) complex128 amplitudes.

    Both arrays are copied and made read-only; equality is identity (compare arrays explicitly).
    """

    positions: np.ndarray
    amplitudes: np.ndarray

    def __post_init__(self):
        pos = np.array(self.positions, dtype=np.float64)  # copy: the caller's array stays writable
        if pos.ndim == 1 and pos.size == 3:
            pos = pos[None, :]
        if pos.ndim != 2 or pos.shape[1] != 3:
            raise InputDataError("scene.positions", f"must have shape (K, 3), got {np.shape(self.positions)}")
        amp = np.array(self.amplitudes, dtype=np.complex128)
        if amp.ndim == 0:
            amp = np.full(pos.shape[0], complex(amp))
        if amp.shape != (pos.shape[0],):
            raise InputDataError("scene.amplitudes", f"must have shape ({pos.shape[0]},), got {amp.shape}")
        if not np.all(np.isfinite(pos)):
            raise InputDataError("scene.positions", "contains NaN or inf")
        if not np.all(np.isfinite(amp)):
            raise InputDataError("scene.amplitudes", "contains NaN or inf")
        pos.setflags(write=False)
        amp.setflags(write=False)
        object.__setattr__(self, "positions", pos)
        object.__setattr__(self, "amplitudes", amp)

    def __len__(self) -> int:
        return self.positions.shape[0]

    @property
    def n_targets(self) -> int:
        return self.positions.shape[0]

    def slant_ranges(self, antenna_positions: np.ndarray) -> np.ndarray:
        """(P,K) distances from P antenna positions to the scatterers [m] (float64)."""
        a = np.asarray(antenna_positions, dtype=np.float64).reshape(-1, 3)
        return np.linalg.norm(self.positions[None, :, :] - a[:, None, :], axis=-1)

    def __add__(self, other: "Scene") -> "Scene":
        return Scene(np.vstack([self.positions, other.positions]),
                     np.concatenate([self.amplitudes, other.amplitudes]))


def point_targets(positions, amplitudes=1.0) -> Scene:
    """Scene of explicit point targets: ``positions`` (K,3) or (3,), ``amplitudes`` scalar or (K,)."""
    return Scene(positions, amplitudes)


def _draw_amplitudes(rng: np.random.Generator, n: int, law: str, mean_power) -> np.ndarray:
    mean_power = np.asarray(mean_power, dtype=np.float64)
    if law == "constant":
        # |a|^2 = mean power, phase uniform on [0, 2 pi)
        return np.sqrt(mean_power) * np.exp(2j * np.pi * rng.random(n))
    # circular complex Gaussian: E|a|^2 = mean power, |a| Rayleigh
    z = rng.standard_normal((n, 2))
    return np.sqrt(mean_power / 2.0) * (z[:, 0] + 1j * z[:, 1])


def random_scatterers(rng: np.random.Generator, extent, density: float, amplitude_law: str = "rayleigh",
                      mean_power: float = 1.0, down: float = 0.0) -> Scene:
    """Scatterers scattered uniformly over a horizontal rectangle (homogeneous Poisson process).

    Parameters
    ----------
    rng : numpy Generator (from a SeedSequence).
    extent : ((north_min, north_max), (east_min, east_max)) [m].
    density : mean number of scatterers per m^2 (>= 0); the count is Poisson(density * area).
    amplitude_law : "rayleigh" (circular complex Gaussian, E|a|^2 = mean_power) or "constant"
        (|a|^2 = mean_power, uniform phase).
    mean_power : mean |a|^2 (> 0).
    down : D coordinate of all scatterers [m] (flat ground).
    """
    if not isinstance(rng, np.random.Generator):
        raise ConfigError("rng", f"must be a numpy.random.Generator, got {type(rng).__name__}")
    ext = np.asarray(extent, dtype=np.float64)
    if ext.shape != (2, 2) or not np.all(np.isfinite(ext)) or np.any(ext[:, 1] <= ext[:, 0]):
        raise ConfigError("extent", f"must be ((n_min, n_max), (e_min, e_max)) with max > min, got {extent!r}")
    if not np.isfinite(density) or density < 0:
        raise ConfigError("density", f"must be finite and >= 0 per m^2, got {density!r}")
    if amplitude_law not in AMPLITUDE_LAWS:
        raise ConfigError("amplitude_law", f"must be one of {AMPLITUDE_LAWS}, got {amplitude_law!r}")
    if not np.isfinite(mean_power) or mean_power <= 0:
        raise ConfigError("mean_power", f"must be finite and > 0, got {mean_power!r}")
    area = float(np.prod(ext[:, 1] - ext[:, 0]))
    n = int(rng.poisson(density * area))
    u = rng.random((n, 2))
    north = ext[0, 0] + u[:, 0] * (ext[0, 1] - ext[0, 0])
    east = ext[1, 0] + u[:, 1] * (ext[1, 1] - ext[1, 0])
    pos = np.column_stack([north, east, np.full(n, float(down))])
    return Scene(pos, _draw_amplitudes(rng, n, amplitude_law, mean_power))


def speckle_scene(reflectivity, north_axis, east_axis, rng: np.random.Generator, down: float = 0.0) -> Scene:
    """Distributed scene: one circular-Gaussian scatterer at every cell centre of a grid.

    Parameters
    ----------
    reflectivity : (Ny, Nx) mean power per cell, E|a|^2 (>= 0); cells with 0 are omitted.
    north_axis : (Ny,) north coordinates of the cell centres [m].
    east_axis : (Nx,) east coordinates of the cell centres [m].
    rng : numpy Generator.
    down : D coordinate of the grid [m].
    """
    if not isinstance(rng, np.random.Generator):
        raise ConfigError("rng", f"must be a numpy.random.Generator, got {type(rng).__name__}")
    refl = np.asarray(reflectivity, dtype=np.float64)
    n_ax = np.asarray(north_axis, dtype=np.float64)
    e_ax = np.asarray(east_axis, dtype=np.float64)
    if refl.ndim != 2:
        raise InputDataError("reflectivity", f"must be 2-D (Ny, Nx), got shape {refl.shape}")
    if n_ax.shape != (refl.shape[0],) or e_ax.shape != (refl.shape[1],):
        raise InputDataError("north_axis/east_axis",
                             f"must have shapes ({refl.shape[0]},) and ({refl.shape[1]},), got {n_ax.shape}, {e_ax.shape}")
    if not (np.all(np.isfinite(refl)) and np.all(refl >= 0)):
        raise InputDataError("reflectivity", "must be finite and >= 0")
    if not (np.all(np.isfinite(n_ax)) and np.all(np.isfinite(e_ax))):
        raise InputDataError("north_axis/east_axis", "contain NaN or inf")
    nn, ee = np.meshgrid(n_ax, e_ax, indexing="ij")
    keep = refl.ravel() > 0
    pos = np.column_stack([nn.ravel(), ee.ravel(), np.full(nn.size, float(down))])[keep]
    z = rng.standard_normal((refl.size, 2))[keep]
    amp = np.sqrt(refl.ravel()[keep] / 2.0) * (z[:, 0] + 1j * z[:, 1])
    return Scene(pos, amp)


def beside_track(origin, heading: float, speed: float, tocs, ground_ranges) -> np.ndarray:
    """(K, 3) ground points (down = 0) to the right of a straight, level track.

    The track starts at ``origin`` (3,) NED [m] at t = 0 and flies at ``speed`` [m/s] along ``heading`` [rad];
    point k has its time of closest approach ``tocs[k]`` [s] and lies ``ground_ranges[k]`` [m] to the right of
    the track (horizontal distance).
    """
    origin = np.asarray(origin, dtype=np.float64)
    u = np.array([math.cos(heading), math.sin(heading), 0.0])
    w = np.array([-math.sin(heading), math.cos(heading), 0.0])  # right of the heading
    ground = np.array([origin[0], origin[1], 0.0])
    return ground + (speed * np.asarray(tocs, dtype=np.float64))[:, None] * u \
        + np.asarray(ground_ranges, dtype=np.float64)[:, None] * w


def clutter_beside_track(rng: np.random.Generator, origin, heading: float, speed: float, toc_start: float,
                         toc_window, ground_range, n: int) -> Scene:
    """``n`` unit-mean-power Rayleigh scatterers (circular complex Gaussian amplitudes) beside a straight track.

    TOC = ``toc_start`` + uniform in ``toc_window`` [s], ground range uniform in ``ground_range`` [m] (right of the
    track); draws in this order: TOCs, ground ranges, real parts, imaginary parts.
    """
    toc = toc_start + rng.uniform(toc_window[0], toc_window[1], n)
    gr = rng.uniform(ground_range[0], ground_range[1], n)
    pos = beside_track(origin, heading, speed, toc, gr)
    amp = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / math.sqrt(2.0)
    return Scene(pos, amp)


LOOK_SIGN = {"right": 1.0, "left": -1.0}


def beside_trajectory(trajectory, tocs, ground_ranges, look_side: str = "right", height=None) -> np.ndarray:
    """(K, 3) points beside any trajectory (a ``trajectory.base.Trajectory``, NED) whose zero-Doppler time is
    ``tocs[k]`` [s]: ``ground_ranges[k]`` [m] (horizontal distance) to the ``look_side`` of the ground track, on the
    horizontal normal of the velocity v at ``tocs[k]``, moved along the horizontal track direction by
    ``v_D (p_D - q_D) / |v_h|`` so that ``v . (p - q) = 0`` (a zero-squint radar that climbs or descends sees the
    ground ahead or behind its normal: 300 m at 3 m/s climb, 10 m/s and 1000 m). ``height``: ``None`` (ground,
    D = 0) or a function (N, E) -> height above the reference [m] (a terrain model; D = -height; the along-track
    move uses the height at the normal's foot). For a straight, level track this is :func:`beside_track`."""
    if look_side not in LOOK_SIGN:
        raise ConfigError("radar.look_side", f"must be one of {tuple(LOOK_SIGN)}, got {look_side!r}")
    tocs = np.asarray(tocs, dtype=np.float64)
    st = trajectory.state(tocs)
    p, v = np.atleast_2d(st.position), np.atleast_2d(st.velocity)
    vh = np.hypot(v[:, 0], v[:, 1])
    if np.any(vh <= 0):
        raise InputDataError("trajectory", "has no horizontal velocity at a target's time of closest approach")
    uh = np.stack([v[:, 0] / vh, v[:, 1] / vh, np.zeros_like(vh)], axis=1)
    w = np.stack([-uh[:, 1], uh[:, 0], np.zeros_like(vh)], axis=1) * LOOK_SIGN[look_side]  # right of v
    q = np.stack([p[:, 0], p[:, 1], np.zeros_like(vh)], axis=1) + np.asarray(ground_ranges, dtype=np.float64)[:, None] * w
    if height is not None:
        q[:, 2] = -np.asarray(height(q[:, 0], q[:, 1]), dtype=np.float64)
    q += (v[:, 2] * (p[:, 2] - q[:, 2]) / vh)[:, None] * uh  # zero Doppler at the TOC
    if height is not None:
        q[:, 2] = -np.asarray(height(q[:, 0], q[:, 1]), dtype=np.float64)
    return q


def clutter_beside_trajectory(rng: np.random.Generator, trajectory, toc_window, ground_range, n: int,
                              look_side: str = "right", height=None) -> Scene:
    """``n`` unit-mean-power Rayleigh scatterers beside any trajectory (:func:`beside_trajectory`): TOC uniform in
    ``toc_window`` (absolute times [s]), ground range uniform in ``ground_range`` [m]; draws in this order: TOCs,
    ground ranges, real parts, imaginary parts (as :func:`clutter_beside_track`)."""
    toc = rng.uniform(toc_window[0], toc_window[1], n)
    gr = rng.uniform(ground_range[0], ground_range[1], n)
    pos = beside_trajectory(trajectory, toc, gr, look_side, height)
    amp = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / math.sqrt(2.0)
    return Scene(pos, amp)


def slant_ranges(trajectory, points, times) -> np.ndarray:
    """(K,) distance [m] from the trajectory's position at ``times[k]`` to ``points[k]`` (K, 3)."""
    p = np.atleast_2d(trajectory.state(np.asarray(times, dtype=np.float64)).position)
    return np.linalg.norm(np.asarray(points, dtype=np.float64).reshape(-1, 3) - p, axis=1)
