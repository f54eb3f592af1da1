"""Per-pulse antenna positions from every navigation source of Sun (2022) §6 (L1332-1403), for the back-projection
focus comparison (Figs. 6.5-6.9, 6.12-6.13; ``simulation.nav_focus``): the UPF and the interpolated KF on the pulse
grid, cubic splines of the fixes and of the 200 Hz filter outputs, the SIR fusion of three ADIS16465 PFs and one
NovAtel PF, flown over the rig and world of ``simulation.imu_rig``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sarnav.filters.fusion import cloud_mean, draw_sensors, sensor_log_weights
from sarnav.filters.grid_kalman import GridKalmanFilter
from sarnav.filters.grid_particle import GridParticleFilter
from sarnav.filters.pulse_grid import TIME_TOLERANCE, FixStream, NavFrame, uniform_times
from sarnav.frames.wgs84 import geodetic_difference_ned
from sarnav.simulation.imu_rig import (ADIS_LEVER_ARMS, FIX_SIGMA, ORIGIN, aided_pf, cart_track, correlated_fix_errors,
                                       gnss_ins_sim_imu, rig_imu, rngs_for, seed_sequences, simulate_fixes,
                                       spec_accel_psd, truth_native)
from sarnav.trajectory import Maneuvering
from sarnav.trajectory.geodetic import GeodeticFlight

NAV_SOURCES = ("truth", "upf", "kf-interp", "spline-gps", "spline-kf", "spline-pf", "sir-3adis", "novatel")


@dataclass
class NavSources:
    """What :func:`navigation_sources` returns: ``positions`` source -> (R, P, 3) antenna positions at the pulses,
    NED metres relative to the true first-pulse position (``truth`` (1, P, 3)); for the filters with a covariance
    (``upf``, ``kf-interp``) at their fix epochs ``fix_times`` (K,): ``fix_errors`` name -> (R, K, 3) estimate -
    truth [m] after the update and ``fix_covs`` name -> (R, K, 3, 3) [m^2] (cloud sample covariance / KF P)."""

    positions: dict
    fix_times: np.ndarray | None = None
    fix_errors: dict = field(default_factory=dict)
    fix_covs: dict = field(default_factory=dict)


def navigation_sources_at_pulses(pulse_times, runs: int = 1, seed=0, track: Maneuvering | None = None,
                                 n_particles: int = 2000, adis_particles: int = 1000, fix_sigma=FIX_SIGMA,
                                 accel_psd="spec", n_draws: int = 50, sources=NAV_SOURCES):
    """The positions of :func:`navigation_sources` (dict source -> (R, P, 3))."""
    return navigation_sources(pulse_times, runs, seed, track, n_particles, adis_particles, fix_sigma, accel_psd,
                              n_draws, sources).positions


def navigation_sources(pulse_times, runs: int = 1, seed=0, track: Maneuvering | None = None,
                       n_particles: int = 2000, adis_particles: int = 1000, fix_sigma=FIX_SIGMA,
                       accel_psd="spec", n_draws: int = 50, sources=NAV_SOURCES,
                       fix_correlated=(0.0, 0.0, 0.0), fix_tau: float = 300.0) -> NavSources:
    """Antenna (reference point) positions at every pulse from each navigation source, NED metres relative to
    the true position at the first pulse: ``positions`` source -> (R, P, 3) (``truth`` is (1, P, 3)), and the
    fix-epoch errors and covariances of the UPF and the interpolated KF (:class:`NavSources`).

    ``pulse_times`` (P,) [s] must start after a run-in (the filters start at t = 0 from the first fix and
    converge, e.g. 30 s, then the aperture). Sources (L1332-1403): ``upf`` (NovAtel + 20 Hz fix, 2000-particle
    UPF on the pulse grid), ``kf-interp`` (the KF on the pulse grid), ``spline-gps`` (cubic spline of the 20 Hz
    fixes), ``spline-kf`` / ``spline-pf`` (cubic splines of the KF / PF output at the 200 Hz IMU epochs),
    ``sir-3adis`` (three ADIS16465 PFs on the pulse grid, SIR-fused at each fix, indices held in between),
    ``novatel`` (the NovAtel PF on the pulse grid: the UPF with ``adis_particles`` particles, the multi-IMU
    comparison's single-IMU solution). The lever arm IMU -> antenna is zero (gap G12).

    Fix errors: white N(0, ``fix_sigma``^2) per NED axis at every fix (gnss-ins-sim's model, the default) plus,
    when ``fix_correlated`` (3,) [m] is non-zero, a first-order Gauss-Markov error of that stationary 1-sigma and
    correlation time ``fix_tau`` (:func:`correlated_fix_errors`); the filters assume the total 1-sigma
    ``sqrt(fix_sigma^2 + fix_correlated^2)`` as white (what a receiver's specification gives them).
    """
    from sarnav.filters.pulse_grid import spline_positions

    pulse_times = np.asarray(pulse_times, dtype=float)
    t_end = float(pulse_times[-1]) + 0.1
    flat = track if track is not None else cart_track(np.ceil(t_end) + 1.0)
    geo = GeodeticFlight(flat, *ORIGIN)
    frame = NavFrame(geodetic=True, origin=ORIGIN)
    seqs = seed_sequences(seed, runs)
    sig = np.asarray(fix_sigma, dtype=float)
    t_fix = uniform_times(0.0, t_end, 20.0)
    corr = np.asarray(fix_correlated, dtype=float)
    bias = correlated_fix_errors(t_fix, corr, fix_tau, rngs_for(seqs, 5)) if np.any(corr > 0) else np.zeros(3)
    fixes = simulate_fixes(geo, t_fix, sig, rngs_for(seqs, 1), bias)
    sig = np.hypot(sig, corr)  # what the filters assume
    fixes = FixStream(fixes.times, fixes.position, sig)
    truth0 = truth_native(geo, pulse_times[:1])[0][0]
    to_ned = lambda p: geodetic_difference_ned(p[..., 0], p[..., 1], p[..., 2], *truth0)  # noqa: E731
    out = {"truth": to_ned(truth_native(geo, pulse_times)[0])[None]}
    s0 = geo.state(0.0)
    p0 = np.diag(np.r_[sig**2, [0.05**2] * 3])
    v0 = np.broadcast_to(s0.velocity, (runs, 3))
    t_nov = uniform_times(0.0, t_end, 200.0)
    nov = rig_imu(geo, t_nov, np.zeros(3), gnss_ins_sim_imu("novatel-isa-100c", 200.0), rngs_for(seqs, 2))
    q_nov = spec_accel_psd("novatel-isa-100c", 200.0) if accel_psd == "spec" else float(accel_psd)
    t_win = t_nov[(t_nov >= pulse_times[0] - 0.05) & (t_nov <= pulse_times[-1] + 0.05)]
    # the filters' grid merges epochs closer than TIME_TOLERANCE (filters.pulse_grid): an IMU sample that close to a
    # pulse is the pulse's epoch, or the outputs would not line up with these times
    j = np.clip(np.searchsorted(pulse_times, t_win), 1, pulse_times.size - 1) if pulse_times.size > 1 else None
    if j is not None:
        gap = np.minimum(np.abs(t_win - pulse_times[j - 1]), np.abs(t_win - pulse_times[j]))
        t_win = t_win[gap > TIME_TOLERANCE]
    both = np.union1d(pulse_times, t_win)
    at_pulse = np.searchsorted(both, pulse_times)
    want = set(sources)
    res = NavSources(out, fixes.times[1:])

    def keep_fix(name, o):
        res.fix_errors[name] = frame.error_ned(o.fix_position, truth_native(geo, o.fix_times)[0])
        res.fix_covs[name] = o.position_cov

    if want & {"upf", "spline-pf"}:
        pf = GridParticleFilter(frame, n_particles, q_nov, model="geodetic", ess_threshold=0.5, kernel_h=0.3)
        pf.initialize(0.0, fixes.position[:, 0], v0, s0.quaternion, p0, rngs_for(seqs, 3))
        o = pf.run(nov, t_end, fixes, both)
        out["upf"] = to_ned(o.position[:, at_pulse])
        k = np.isin(both, t_nov)
        out["spline-pf"] = to_ned(spline_positions(both[k], o.position[:, k], pulse_times))
        keep_fix("upf", o)
    if want & {"kf-interp", "spline-kf"}:
        kf = GridKalmanFilter(frame, q_nov).initialize(0.0, fixes.position[:, 0], v0, s0.quaternion, p0)
        o = kf.run(nov, t_end, fixes, both)
        out["kf-interp"] = to_ned(o.position[:, at_pulse])
        k = np.isin(both, t_nov)
        out["spline-kf"] = to_ned(spline_positions(both[k], o.position[:, k], pulse_times))
        keep_fix("kf-interp", o)
    if "spline-gps" in want:
        out["spline-gps"] = to_ned(spline_positions(t_fix, fixes.position, pulse_times))
    if "novatel" in want:
        pf = GridParticleFilter(frame, adis_particles, q_nov, model="geodetic", ess_threshold=0.5, kernel_h=0.3)
        pf.initialize(0.0, fixes.position[:, 0], v0, s0.quaternion, p0, rngs_for(seqs, 4))
        out["novatel"] = to_ned(pf.run(nov, t_end, fixes, pulse_times).position)
    if "sir-3adis" in want:
        out["sir-3adis"] = _sir_at_pulses(geo, fixes, pulse_times, t_end, adis_particles, accel_psd, n_draws,
                                          seqs, to_ned)
    res.positions = {k: out[k] for k in sources if k in out}
    return res


def _sir_at_pulses(geo, fixes, pulse_times, t_end, n_particles, accel_psd, n_draws, seqs, to_ned):
    """Three ADIS PFs on the pulse grid (outputs at pulses and fixes), SIR indices drawn at each fix and held."""
    t_adis = uniform_times(0.0, t_end, 100.0)
    model = gnss_ins_sim_imu("adis16465", 100.0)
    q = spec_accel_psd("adis16465", 100.0) if accel_psd == "spec" else float(accel_psd)
    grid = np.union1d(pulse_times, fixes.times)
    est = []
    for s in range(3):
        imu = rig_imu(geo, t_adis, ADIS_LEVER_ARMS[s], model, rngs_for(seqs, 60 + s))
        pos, _ = aided_pf(geo, imu, fixes, ADIS_LEVER_ARMS[s], n_particles, q, rngs_for(seqs, 70 + s), grid, t_end)
        est.append(to_ned(pos))
    est = np.stack(est, 1)  # (R, 3, T, 3)
    fix_ned = to_ned(fixes.position)
    is_fix = np.isin(grid, fixes.times)
    rngs = rngs_for(seqs, 80)
    fused = np.empty((est.shape[0], grid.size, 3))
    idx = np.zeros((est.shape[0], n_draws, 3), dtype=np.int64)  # equal draws before the first fix
    idx[:, :, :] = np.arange(n_draws)[None, :, None] % 3
    for k in range(grid.size):
        if is_fix[k] and grid[k] > 0:
            j = int(np.searchsorted(fixes.times, grid[k] - 1e-9))
            idx = draw_sensors(sensor_log_weights(est[:, :, k], fix_ned[:, j], fixes.sigma), n_draws, rngs)
        fused[:, k] = cloud_mean(est[:, :, k], idx)
    return fused[:, np.searchsorted(grid, pulse_times)]
