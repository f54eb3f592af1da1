"""Azimuth antenna pattern and the look geometry.

Uniformly illuminated aperture of length L (Cumming & Wong 2005 eq. 4.27): one-way amplitude
pattern ``sinc(L sin(theta) / lambda)`` (normalised sinc), one-way -3 dB beamwidth 0.886 lambda/L;
the two-way amplitude is its square, ``sinc^2(L sin(theta) / lambda)``.

Look geometry (zero squint): the along-track unit vector u is the platform velocity direction; the
boresight lies in the plane perpendicular to u, on the look side. With NED axes (z down) the right
side is ``z_down x u``. theta is the azimuth angle of the line of sight off that plane:
``sin(theta) = u . d / |d|``, d = target - antenna. Targets on the other side get zero gain.
"""

from __future__ import annotations

import numpy as np

DOWN = np.array([0.0, 0.0, 1.0])


def two_way_gain(sin_theta, antenna_length: float, wavelength: float) -> np.ndarray:
    """Two-way amplitude gain ``sinc^2(L sin(theta) / lambda)`` (1 on boresight)."""
    return np.sinc(antenna_length * np.asarray(sin_theta, dtype=np.float64) / wavelength) ** 2


def right_vectors(along_track: np.ndarray) -> np.ndarray:
    """(P,3) unit vectors to the right of the along-track directions: normalised ``z_down x u``."""
    r = np.cross(DOWN, np.asarray(along_track, dtype=np.float64))
    return r / np.linalg.norm(r, axis=-1, keepdims=True)


def look_vectors(along_track: np.ndarray, look_side: str) -> np.ndarray:
    """(P,3) horizontal unit vectors towards the look side (+right for "right", -right for "left")."""
    r = right_vectors(along_track)
    return r if look_side == "right" else -r


def along_track_directions(positions: np.ndarray, times: np.ndarray) -> np.ndarray:
    """(P,3) unit velocity directions from positions by second-order finite differences (``np.gradient``)."""
    v = np.gradient(np.asarray(positions, dtype=np.float64), np.asarray(times, dtype=np.float64), axis=0)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def gain(positions: np.ndarray, along_track: np.ndarray, targets: np.ndarray, antenna_length: float,
         wavelength: float, look_side: str) -> np.ndarray:
    """(P,K) two-way amplitude gain of K targets seen from P antenna positions (numpy reference)."""
    d = np.asarray(targets, dtype=np.float64)[None, :, :] - np.asarray(positions, dtype=np.float64)[:, None, :]
    rng = np.linalg.norm(d, axis=-1)
    sin_theta = np.einsum("pkc,pc->pk", d, along_track) / rng
    side = np.einsum("pkc,pc->pk", d, look_vectors(along_track, look_side))
    return np.where(side > 0, two_way_gain(sin_theta, antenna_length, wavelength), 0.0)
