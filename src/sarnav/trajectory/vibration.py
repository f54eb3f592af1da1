"""A trajectory with a translational vibration: the cart's sway and bounce on rough ground (issue 29, Sun 2022 §6.2).

The source's ground test ran the radar, the NovAtel and the ADIS on a cart across a field and says nothing of its
vibration (gap); :class:`Vibrating` adds to any :class:`~sarnav.trajectory.base.Trajectory` a sum of sinusoids in the
navigation frame, ``d(t) = sum_k A_k sin(2 pi f_k t + phi_k)`` (``A_k`` (3,) NED [m], ``f_k`` [Hz], ``phi_k`` [rad]),
with its exact derivatives: position + d, velocity + d', acceleration and specific force + d'' (rotated to the body
frame); the attitude and body rate are the base's (no angular vibration). What an ideal IMU on the cart senses is
therefore the vibration's acceleration, ``A (2 pi f)^2`` (1 mm at 5 Hz is 1 m/s^2), which every IMU-driven
navigation source integrates, while a spline of 20 Hz fixes cannot follow it.
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import ConfigError
from sarnav.rotations import quat_to_dcm
from sarnav.trajectory.base import Trajectory, TrajectoryState

__all__ = ["Vibrating", "MAX_VIBRATION_HZ", "check_tones"]

#: highest tone [Hz]: a GeodeticFlight integrates latitude and longitude by RK4 every 20 ms with a cubic Hermite
#: interpolant between nodes, whose error on a tone of amplitude A is at most A (2 pi f 0.02)^4 / 384 (6.5e-3 A at
#: 10 Hz, tested against the flat track); the filters' IMUs sample at 100-200 Hz, 10 to 20 samples per period
MAX_VIBRATION_HZ = 10.0


def check_tones(frequencies, amplitudes, phases=None) -> tuple:
    """Validated tones as ((f [Hz], (aN, aE, aD) [m], phase [rad]), ...): ``frequencies`` (K,) in (0,
    :data:`MAX_VIBRATION_HZ`], ``amplitudes`` K lists of three in [-0.1, 0.1] m, ``phases`` (K,) finite (default 0);
    a ConfigError names ``cart.vibration_hz`` / ``cart.vibration_m`` (their keys in nav-source-focus)."""
    try:
        f = np.atleast_1d(np.asarray(frequencies, dtype=float))
    except (TypeError, ValueError):
        raise ConfigError("cart.vibration_hz", f"must be a list of numbers [Hz], got {frequencies!r}") from None
    try:
        a = np.asarray(amplitudes, dtype=float)
    except (TypeError, ValueError):
        a = None
    if f.size == 0 and a is not None and a.size == 0:
        return ()
    if f.ndim != 1 or a is None or a.shape != (f.size, 3):
        raise ConfigError("cart.vibration_m", f"must be one [north, east, down] amplitude [m] per cart.vibration_hz "
                          f"({f.size}), got {amplitudes!r}")
    p = np.zeros_like(f) if phases is None else np.atleast_1d(np.asarray(phases, dtype=float))
    if np.any(~np.isfinite(f)) or np.any(f <= 0.0) or np.any(f > MAX_VIBRATION_HZ):
        raise ConfigError("cart.vibration_hz", f"must be in (0, {MAX_VIBRATION_HZ}] Hz, got {f.tolist()}")
    if np.any(~np.isfinite(a)) or np.any(np.abs(a) > 0.1):
        raise ConfigError("cart.vibration_m", f"must be in [-0.1, 0.1] m, got {a.tolist()}")
    if p.shape != f.shape or np.any(~np.isfinite(p)):
        raise ConfigError("cart.vibration_phase_rad", f"must be {f.size} finite numbers [rad], got {p.tolist()}")
    return tuple((float(fk), tuple(float(x) for x in ak), float(pk)) for fk, ak, pk in zip(f, a, p))


class Vibrating(Trajectory):
    """``base`` plus the tones ``frequencies`` (K,) [Hz] with NED amplitudes ``amplitudes`` (K, 3) [m] and
    ``phases`` (K,) [rad] (module docstring; checked by :func:`check_tones`)."""

    def __init__(self, base: Trajectory, frequencies, amplitudes, phases=None):
        tones = check_tones(frequencies, amplitudes, phases)
        self.frequencies = np.array([t[0] for t in tones])
        self.amplitudes = np.array([t[1] for t in tones]).reshape(-1, 3)
        self.phases = np.array([t[2] for t in tones])
        self.base, self.duration = base, base.duration

    def _tones(self, t, order):
        """The ``order``-th time derivative of d at ``t`` (...,) -> (..., 3)."""
        w = 2.0 * np.pi * self.frequencies
        arg = np.asarray(t, dtype=float)[..., None] * w + self.phases + 0.5 * np.pi * order
        return (np.sin(arg) * w**order) @ self.amplitudes

    def state(self, t) -> TrajectoryState:
        t = self._times(t)
        s = self.base.state(t)
        return TrajectoryState(s.position + self._tones(t, 0), s.velocity + self._tones(t, 1), s.quaternion)

    def _kin(self, t) -> tuple:
        s = self.base.state(t)
        dd = self._tones(t, 2)
        dd_body = np.einsum("...ji,...j->...i", quat_to_dcm(s.quaternion), dd)  # C^T d''
        return (s.velocity + self._tones(t, 1), s.quaternion, self.base.acceleration(t) + dd,
                self.base.specific_force(t) + dd_body, self.base.angular_rate(t))
