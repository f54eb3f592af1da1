"""The ground lattices of back-projected sub-aperture images and the track they are focused along.

A BPA image of the image-aided flight (docs/scenarios/rda-nav.md §6) is formed on a horizontal ground grid spanned by
the along-track and the look-side across-track unit vectors (:func:`ground_frame`, :class:`BpaGrid`), along the
*focusing track* (:func:`focusing_track`): the estimate at the aperture centre turned by the gyros' heading change.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sarnav.rotations import dcm_to_euler, quat_to_dcm

__all__ = ["focusing_track", "ground_frame", "BpaGrid"]


def focusing_track(times, ap_t, p, v, q=None) -> np.ndarray:
    """(P, 3) antenna positions at the pulse ``times`` that a back-projection along the estimated track focuses with:
    the estimate's position and velocity at the aperture centre, the velocity turned by the change of the heading of
    its attitude ``q`` (K, 4) (else of its velocity) at each epoch ``ap_t`` (K,): constant speed and climb rate, the
    turn the gyros measured.

    Why not the INS positions themselves: at 10 m/s and 2 km the azimuth FM rate is 3 Hz/s, and the INS's own
    acceleration error (a 2 mrad tilt x g = 0.02 m/s^2 along the line of sight) changes it by half: focused along
    the INS positions, a target's zero-Doppler time moves by up to a tenth of a second (1 m along track, measured;
    thesis ch. 4: tilt errors blur BPA images). The heading change from the gyros is good to their drift
    (1 deg/hr), so a real turn is kept and the spurious accelerations are not; what remains are the errors of
    position and velocity at the aperture centre, which the measurement models (the lever and, by refocusing, the
    speed: docs §2)."""
    ap_t = np.asarray(ap_t, dtype=np.float64)
    i_c = len(ap_t) // 2
    t_c = ap_t[i_c]
    if q is None:
        psi = np.unwrap(np.arctan2(v[:, 1], v[:, 0]))
    else:
        psi = np.unwrap(dcm_to_euler(quat_to_dcm(np.asarray(q, dtype=np.float64)))[2])
    fine = np.union1d(ap_t, times)
    turn = np.interp(fine, ap_t, psi - psi[i_c])
    c, s = np.cos(turn), np.sin(turn)
    v0 = np.asarray(v[i_c], dtype=np.float64)
    vel = np.stack([c * v0[0] - s * v0[1], s * v0[0] + c * v0[1], np.full(fine.size, v0[2])], axis=1)
    steps = np.diff(fine)[:, None] * 0.5 * (vel[1:] + vel[:-1])
    path = np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])
    path -= path[int(np.searchsorted(fine, t_c))]
    track = p[i_c] + path
    return np.stack([np.interp(times, fine, track[:, i]) for i in range(3)], axis=1)


def ground_frame(velocity, look_side: str):
    """(along (3,), across (3,)): horizontal unit vectors along the velocity and toward the look side."""
    vh = np.array([velocity[0], velocity[1], 0.0])
    along = vh / np.linalg.norm(vh)
    across = np.array([-along[1], along[0], 0.0]) * (1.0 if look_side == "right" else -1.0)
    return along, across


@dataclass(frozen=True)
class BpaGrid:
    """A BPA ground grid: ``centre`` + rows x ``along`` + columns x ``across`` (spacings ``da``, ``dg`` [m]), in the
    flight's along / across-track frame at any centre and fractional node (``point``); the image formers' own grids
    are ``imaging.grid`` (``GroundGrid``: a north x east lattice)."""

    centre: np.ndarray
    along: np.ndarray
    across: np.ndarray
    da: float
    dg: float
    shape: tuple

    def points(self) -> np.ndarray:
        i = (np.arange(self.shape[0]) - (self.shape[0] - 1) / 2) * self.da
        j = (np.arange(self.shape[1]) - (self.shape[1] - 1) / 2) * self.dg
        return self.centre + i[:, None, None] * self.along + j[None, :, None] * self.across

    def point(self, row: float, col: float) -> np.ndarray:
        return (self.centre + (row - (self.shape[0] - 1) / 2) * self.da * self.along
                + (col - (self.shape[1] - 1) / 2) * self.dg * self.across)
