"""Sampled trajectories: closest approach to a point and interpolation of a history (float64).

Used wherever a sampled track (an INS history, the true antenna positions of an aperture) is related to a point
on the ground: the time and range of closest approach (TOC, ROC; thesis eq. 4.41) and the state at that time.
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import InputDataError

__all__ = ["closest_approach", "interpolate_state", "closest_sample_is_inside", "min_distance", "along_offset", "along_rate"]


def _vec3(name: str, value) -> np.ndarray:
    a = np.asarray(value, dtype=np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise InputDataError(name, f"must be a finite 3-vector (NED, m), got shape {a.shape}")
    return a


def closest_approach(p_targ, times, positions):
    """Time and range of closest approach of a sampled trajectory to a target (thesis eq. 4.41).

    The squared range of the three samples around the discrete minimum is fitted by a parabola, which is
    exact for constant-velocity motion; the position at the TOC is interpolated linearly.

    Returns
    -------
    eta0 : time of closest approach [s]; r0 : range of closest approach [m]; p0 : (3,) position at eta0.
    """
    p_targ = _vec3("p_targ", p_targ)
    times = np.asarray(times, dtype=np.float64)
    positions = np.asarray(positions, dtype=np.float64)
    if times.ndim != 1 or len(times) < 3 or positions.shape != (len(times), 3):
        raise InputDataError("positions", f"need (T, 3) positions with T >= 3 matching times, got {positions.shape}")
    if np.any(np.diff(times) <= 0):
        raise InputDataError("times", "must be strictly increasing")
    r2 = np.sum((positions - p_targ) ** 2, axis=1)
    k = int(np.argmin(r2))
    if k == 0 or k == len(times) - 1:
        raise InputDataError("positions", "closest approach lies at the end of the trajectory samples")
    t3, y3 = times[k - 1:k + 2], r2[k - 1:k + 2]
    a, b, _ = np.polyfit(t3 - t3[1], y3, 2)
    eta0 = t3[1] - b / (2 * a) if a > 0 else t3[1]
    eta0 = float(np.clip(eta0, t3[0], t3[2]))
    p0 = np.array([np.interp(eta0, times, positions[:, i]) for i in range(3)])
    return eta0, float(np.linalg.norm(p0 - p_targ)), p0


def interpolate_state(times, values, eta):
    """Linear interpolation of an (T, 3) history (positions or velocities) at time eta."""
    times = np.asarray(times, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    if not (times[0] <= eta <= times[-1]):
        raise InputDataError("eta", f"must be in [{times[0]}, {times[-1]}] s, got {eta}")
    return np.array([np.interp(eta, times, values[:, i]) for i in range(values.shape[1])])


def closest_sample_is_inside(p_targ, times, positions) -> bool:
    """True when the sample closest to ``p_targ`` is not the first or last one (the TOC lies inside the track)."""
    d = np.sum((np.asarray(positions) - p_targ) ** 2, axis=1)
    k = int(np.argmin(d))
    return 0 < k < len(times) - 1


def min_distance(positions, point) -> float:
    """Smallest distance [m] from sampled positions (..., 3) to a point (3,)."""
    return float(np.min(np.linalg.norm(np.asarray(positions, dtype=np.float64) - point, axis=-1)))


def along_offset(point, position, velocity):
    """Along-track offset [m] of ``point`` (3,) from track positions ``position`` (..., 3) moving with ``velocity``
    (..., 3): ``(point - p) . v / |v|``; zero at the closest approach (where the line of sight is perpendicular to
    the velocity). The cross-range measurement of rda-nav is this offset at the measured TOC."""
    v = np.asarray(velocity, dtype=np.float64)
    return np.sum((np.asarray(point, dtype=np.float64) - position) * v, axis=-1) / np.linalg.norm(v, axis=-1)


def along_rate(trajectory, target, eta: float, h: float = 1e-3) -> float:
    """How fast [m/s] the target's :func:`along_offset` falls through zero at its closest approach ``eta`` (a
    central difference over +-h): the speed V on a straight track, V (1 - R / rho) on a turn of radius rho towards a
    target at range R (a target near the turn's centre has a flat range history, and a small along-track error of the
    image moves its TOC a long way). A TOC error dt is an error of ``along_rate * dt`` metres in the offset."""
    st = trajectory.state(np.array([eta - h, eta + h]))
    a = along_offset(target, st.position, st.velocity)
    return float(-(a[1] - a[0]) / (2.0 * h))
