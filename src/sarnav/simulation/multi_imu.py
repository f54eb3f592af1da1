"""The experiments of Sun (2022) as batched Monte Carlo library functions (extraction seed-003 §4, §8).

* :func:`single_step_sir` — one time step, N i.i.d. sensors, SIR weights from a fix (Figs. 5.2-5.3, T14-T16, T25);
* :func:`run_path1` — simulated path 1 (eq. 5.21) with the three position sensors of Table 5.1, one PF per
  sensor, fused by the mean and by SIR (Figs. 5.5, 5.11, T17-T19);
* :func:`run_multi_imu` — 3 x ADIS16465 (Table 5.4) against one NovAtel IMU-ISA-100C (Table 5.2) on a
  climb-and-turn flight over the rotating Earth, one 1000-particle aided PF per IMU, SIR / mean / virtual IMU
  (Figs. 5.10, 5.12, 5.13, T20-T23);
* :func:`run_upf_flight` — the one-hour flight (climb, figure-eights, racetracks) with the NovAtel model,
  200 Hz IMU + 20 Hz fix, the 2000-particle UPF and the interpolated KF at 3 kHz (Figs. 5.8, 5.26, T10-T13);
* :func:`navigation_sources_at_pulses` — per-pulse antenna positions from every navigation source for the
  back-projection focus comparison (Figs. 6.5-6.9, 6.12-6.13).

Every function takes a ``numpy.random.SeedSequence`` (or int) and spawns one child per run; runs are
independent of how they are batched. Errors are point-estimate position errors in NED metres against the
noise-free truth; "rmse" is the 3-D RMS over runs and epochs after ``settle`` seconds (the source's
"3-dimensional positional accuracy", Fig. 5.24; its eq. 5.22 cloud RMS is reported as ``cloud_rmse`` where a
cloud exists, gap G18). Parameter choices where the source is silent are the module constants below and are
discussed in docs/particles.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sarnav.errors import ConfigError
from sarnav.filters.fusion import cloud_mean, draw_sensors, mean_fuse, sensor_log_weights, virtual_imu
from sarnav.filters.grid_kalman import GridKalmanFilter
from sarnav.filters.grid_particle import GridParticleFilter
from sarnav.filters.pulse_grid import FixStream, GridOutput, ImuStream, NavFrame, uniform_times
from sarnav.frames.wgs84 import geodetic_difference_ned, ned_offset_to_geodetic
from sarnav.rotations import quat_to_dcm
from sarnav.sensors import ImuModel, imu_grade
from sarnav.sensors.lever_arm import lever_arm_specific_force, rate_derivative
from sarnav.trajectory import Maneuvering, RateProfile
from sarnav.trajectory.geodetic import GeodeticFlight

#: origin of the simulated flights: Norman, Oklahoma (the source's test area), 1000 m
ORIGIN = (np.radians(35.2), np.radians(-97.44), 1000.0)
#: fix (GPS) standard deviation per NED axis [m] (extraction §8 default; the source gives none, G8/G20)
FIX_SIGMA = np.array([0.3, 0.3, 0.5])
#: gnss-ins-sim draws a bias stability with infinite correlation time as white noise at every sample; an
#: FOGM with a correlation time far below the sample interval is that process (sarnav.sensors.imu docstring)
WHITE_BIAS_TAU = 1e-9
#: Table 5.1 noise standard deviations of the three path-1 sensors [m]
PATH1_SIGMAS = (0.5, 1.0, 0.1)
#: lever arms of the three ADIS16465 on the rig (body frame, metres from the reference point / GPS antenna)
ADIS_LEVER_ARMS = np.array([[0.10, 0.08, 0.0], [0.10, -0.08, 0.0], [-0.12, 0.0, 0.02]])
#: horizon [s] over which :func:`spec_accel_psd` lets the gyro-driven tilt error grow
SPEC_HORIZON = 100.0


def _seeds(seed, runs):
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    return ss.spawn(runs)


def _rngs(seqs, stream):
    """One Generator per run for a named stream (sensor noise, fixes, filter s, fusion) of that run."""
    return [np.random.default_rng(np.random.SeedSequence(s.entropy, spawn_key=s.spawn_key + (stream,)))
            for s in seqs]


def _rms(err, t, settle):
    k = t >= settle
    return float(np.sqrt(np.mean(np.sum(err[:, k] ** 2, axis=-1))))


@dataclass
class FusionResult:
    """Per-source results: ``rmse`` [m] (3-D RMS after ``settle``), ``errors`` (R, K, 3) NED error time series
    at ``times`` (K,), ``cloud_rmse`` [m] (eq. 5.22, filters with a cloud), ``info`` (settings used)."""

    rmse: dict
    errors: dict
    times: np.ndarray
    cloud_rmse: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)


# --------------------------------------------------------------------------------------------------------
# single time step (Figs. 5.2, 5.3)

def single_step_sir(n_sensors: int, sigma: float = 1.0, fix_sigma: float = 1.0, trials: int = 2000,
                    n_draws: int = 50, seed=0, fix_bias: float = 0.0):
    """One time step, 1-D: sensors x_s = x + N(0, sigma^2), fix g = x + fix_bias + N(0, fix_sigma^2), SIR with
    ``n_draws`` draws. Returns dict of the SIR and mean estimates' errors (trials,) and their variances / MSEs."""
    seqs = _seeds(seed, trials)
    rng = _rngs(seqs, 0)
    draws = np.stack([g.standard_normal(n_sensors + 1) for g in rng])
    x_s = sigma * draws[:, :n_sensors]
    g = fix_bias + fix_sigma * draws[:, n_sensors]
    est = np.zeros((trials, n_sensors, 3))
    est[..., 0] = x_s
    fix = np.zeros((trials, 3))
    fix[:, 0] = g
    lw = sensor_log_weights(est, fix, np.array([fix_sigma, 1.0, 1.0]), per_axis=True)
    sir = cloud_mean(est, draw_sensors(lw, n_draws, _rngs(seqs, 1)))[:, 0]
    mean = x_s.mean(axis=1)
    return {"sir": sir, "mean": mean, "var_sir": float(sir.var()), "var_mean": float(mean.var()),
            "mse_sir": float(np.mean(sir**2)), "mse_mean": float(np.mean(mean**2)),
            "crlb": sigma**2 / n_sensors, "fix_mse": fix_sigma**2 + fix_bias**2}


# --------------------------------------------------------------------------------------------------------
# simulated path 1 (eq. 5.21)

def path1(t):
    """Path 1 (eq. 5.21) and its analytic derivatives: (p, v, a), each (..., 3) [m, m/s, m/s^2]."""
    t = np.asarray(t, dtype=float)
    c4, s4, c5, s5 = np.cos(t / 4), np.sin(t / 4), np.cos(t / 5), np.sin(t / 5)
    p = np.stack([0.1 * t * c4, 10 * t * s5, 10 * t], -1)
    v = np.stack([0.1 * c4 - 0.025 * t * s4, 10 * s5 + 2 * t * c5, np.full_like(t, 10.0)], -1)
    a = np.stack([-0.05 * s4 - 0.00625 * t * c4, 4 * c5 - 0.4 * t * s5, np.zeros_like(t)], -1)
    return p, v, a


def _fuse_at_fixes(estimates, fix_local, fix_sigma, n_draws, rngs, per_axis):
    """SIR at every fix epoch: estimates (R, S, K, 3), fixes (R, K, 3) -> (R, K, 3)."""
    out = np.empty(fix_local.shape)
    for k in range(fix_local.shape[1]):
        lw = sensor_log_weights(estimates[:, :, k], fix_local[:, k], fix_sigma, per_axis)
        out[:, k] = cloud_mean(estimates[:, :, k], draw_sensors(lw, n_draws, rngs))
    return out


def run_path1(runs: int = 4, seed=0, duration: float = 100.0, sensor_sigmas=PATH1_SIGMAS, fix_sigma: float = 0.1,
              n_particles: int = 1000, accel_psd: float = 1.0, rate: float = 20.0, n_draws: int = 50,
              per_axis: bool = True, settle: float = 5.0) -> FusionResult:
    """Path 1 with position sensors of Table 5.1 (module doc). Each sensor's PF propagates with the path's
    acceleration (the source differentiates the path, Fig. 5.4) plus white-acceleration process noise
    ``accel_psd`` and is updated with that sensor's noisy positions at ``rate``; SIR weights use a separate
    fix of ``fix_sigma`` per axis (gap G19: the source states none). Returns rmse for ``sensor1..S``,
    ``mean``, ``sir`` and ``fix``."""
    seqs = _seeds(seed, runs)
    frame = NavFrame()
    t_imu, t_fix = uniform_times(0.0, duration, 10 * rate), uniform_times(0.0, duration, rate)
    _, _, a = path1(t_imu)
    f_b = np.broadcast_to(a - [0.0, 0.0, frame.gravity], (runs, t_imu.size, 3))
    imu = ImuStream(t_imu, f_b, np.zeros((runs, t_imu.size, 3)))
    p_fix, v0 = path1(t_fix)[0], path1(0.0)[1]
    est, clouds, errors, rmse, cloud_rmse = [], [], {}, {}, {}
    for s, sig in enumerate(sensor_sigmas):
        noise = np.stack([g.standard_normal((t_fix.size, 3)) for g in _rngs(seqs, 10 + s)])
        meas = FixStream(t_fix, p_fix[None] + sig * noise, np.full(3, sig))
        pf = GridParticleFilter(frame, n_particles, accel_psd, noise_at="fix", ess_threshold=0.5, kernel_h=0.3)
        pf.initialize(0.0, meas.position[:, 0], np.broadcast_to(v0, (runs, 3)), [1.0, 0, 0, 0],
                      np.diag([sig**2] * 3 + [1.0] * 3), _rngs(seqs, 20 + s))
        out = pf.run(imu, duration, meas, t_fix)
        est.append(out.position)
        errors[f"sensor{s + 1}"] = out.position - p_fix
        rmse[f"sensor{s + 1}"] = _rms(errors[f"sensor{s + 1}"], t_fix, settle)
        cloud_rmse[f"sensor{s + 1}"] = _cloud_rms(out, errors[f"sensor{s + 1}"], t_fix, settle)
    est = np.stack(est, 1)
    fix = p_fix[None] + fix_sigma * np.stack([g.standard_normal((t_fix.size, 3)) for g in _rngs(seqs, 30)])
    errors["mean"] = mean_fuse(est) - p_fix
    errors["sir"] = _fuse_at_fixes(est, fix, np.full(3, fix_sigma), n_draws, _rngs(seqs, 31), per_axis) - p_fix
    errors["fix"] = fix - p_fix
    for k in ("mean", "sir", "fix"):
        rmse[k] = _rms(errors[k], t_fix, settle)
    return FusionResult(rmse, errors, t_fix, cloud_rmse,
                        {"fix_sigma": fix_sigma, "accel_psd": accel_psd, "n_particles": n_particles, "runs": runs})


def _cloud_rms(out: GridOutput, err, t, settle):
    """Eq. 5.22 at the fix epochs: sqrt(|mean error|^2 + trace(cloud covariance)), RMS over runs and time."""
    idx = np.searchsorted(t, out.fix_times - 1e-9)
    k = out.fix_times >= settle
    e2 = np.sum(err[:, idx[k]] ** 2, -1)
    return float(np.sqrt(np.mean(e2 + np.trace(out.position_cov[:, k], axis1=-2, axis2=-1))))


# --------------------------------------------------------------------------------------------------------
# IMU rigs over the rotating Earth

def gnss_ins_sim_imu(name: str, rate: float) -> ImuModel:
    """An ImuModel of the named preset with gnss-ins-sim's semantics for the bias stability (white, G23)."""
    return ImuModel(imu_grade(name), rate, WHITE_BIAS_TAU, WHITE_BIAS_TAU)


def rig_imu(flight: GeodeticFlight, times, lever_arm, model: ImuModel, rngs) -> ImuStream:
    """Measured samples of an IMU at body offset ``lever_arm`` from the flight's reference point."""
    f, w = flight.imu(times)
    f = lever_arm_specific_force(f, w, rate_derivative(w, float(times[1] - times[0])), lever_arm)
    ba, bg = model.initial_biases(rngs)
    nu, om, *_ = model.measure(f, w, ba, bg, rngs)
    return ImuStream(times, nu, om)


def simulate_fixes(flight: GeodeticFlight, times, sigma, rngs, bias=(0.0, 0.0, 0.0)) -> FixStream:
    """Absolute fixes of the reference point: truth + bias + N(0, diag sigma^2) in NED metres, as geodetic."""
    s = flight.state(times)
    d = np.asarray(bias, dtype=float) + np.asarray(sigma) * np.stack([g.standard_normal((times.size, 3)) for g in rngs])
    lat, lon, h = ned_offset_to_geodetic(s.lat, s.lon, s.h, d)
    return FixStream(times, np.stack([lat, lon, h], -1), np.asarray(sigma, dtype=float))


def _truth_native(flight, t):
    s = flight.state(t)
    return np.stack([s.lat, s.lon, s.h], -1), s


def _aided_pf(flight, imu, fixes, lever_arm, n_particles, accel_psd, rngs, out_times, t_end, model="geodetic"):
    """One aided PF per IMU; returns its output translated to the reference point (R, T, 3) native."""
    frame = NavFrame(geodetic=True, origin=ORIGIN)
    s0 = flight.state(0.0)
    C0 = quat_to_dcm(s0.quaternion)
    lat, lon, h = ned_offset_to_geodetic(s0.lat, s0.lon, s0.h, C0 @ lever_arm)
    runs = imu.specific_force.shape[0]
    sig = fixes.sigma
    pf = GridParticleFilter(frame, n_particles, accel_psd, model=model, noise_at="fix", ess_threshold=0.5,
                            kernel_h=0.3, fix_lever_arm=-np.asarray(lever_arm, dtype=float))
    pf.initialize(0.0, np.broadcast_to([lat, lon, h], (runs, 3)), np.broadcast_to(s0.velocity, (runs, 3)),
                  s0.quaternion, np.diag(np.r_[sig**2, [0.05**2] * 3]), rngs)
    out = pf.run(imu, t_end, fixes, out_times)
    back = -np.einsum("rkij,j->rki", quat_to_dcm(out.quaternion), lever_arm)
    la, lo, hh = ned_offset_to_geodetic(out.position[..., 0], out.position[..., 1], out.position[..., 2], back)
    return np.stack([la, lo, hh], -1), out


def climb_and_turn(duration: float = 300.0, speed: float = 50.0) -> Maneuvering:
    """The multi-IMU flight (Fig. 5.9 "changes in latitude, longitude and altitude"): the built-in S-turn with
    climb and descent (``Maneuvering.s_turn_climb``)."""
    return Maneuvering.s_turn_climb([0.0, 0.0, -ORIGIN[2]], speed, np.radians(30.0), duration)


def spec_accel_psd(name: str, rate: float, horizon: float = SPEC_HORIZON) -> float:
    """White-acceleration PSD [m^2/s^3] for an aided PF from an IMU's specs (gap G16: "derived from the IMU
    specifications", L1145): the accelerometer white noise (VRW^2 plus gnss-ins-sim's white bias-stability
    term sigma_b^2 dt) plus the gyro-driven tilt error, g ARW sqrt(horizon) after ``horizon`` s, treated as
    white over ``horizon``: ``q = VRW^2 + sigma_b^2/rate + (g ARW horizon)^2``."""
    g = imu_grade(name)
    return float(g.vrw**2 + g.accel_bias**2 / rate + (9.81 * g.arw * horizon) ** 2)


def run_multi_imu(runs: int = 2, seed=0, duration: float = 300.0, n_particles: int = 1000, n_adis: int = 3,
                  accel_psd="spec", fix_sigma=FIX_SIGMA, n_draws: int = 50, per_axis: bool = True,
                  settle: float = 10.0, virtual: bool = True, fix_bias=(0.0, 0.0, 0.0),
                  shared_fix: bool = True) -> FusionResult:
    """S x ADIS16465 (100 Hz) against one NovAtel IMU-ISA-100C (200 Hz), 20 Hz fixes, on :func:`climb_and_turn`.

    Each IMU has its own geodetic aided PF (``n_particles``; process noise ``accel_psd`` [m^2/s^3] for all, or
    ``"spec"``: :func:`spec_accel_psd` of each IMU); the ADIS sit at :data:`ADIS_LEVER_ARMS`, the NovAtel and
    the fix antenna at the reference point. ``shared_fix`` True: every PF is aided by the same fix stream
    (one receiver on the rig); False: each IMU's PF by its own independent fix realisation (what separate
    gnss-ins-sim runs per IMU give), the NovAtel's stream weighting the SIR. Returns rmse for ``sensor1..S``
    (ADIS), ``mean``, ``sir``, ``novatel``, ``vimu`` (one PF on the virtual IMU of the ADIS) and ``fix``.
    """
    if not 1 <= n_adis <= len(ADIS_LEVER_ARMS):
        raise ConfigError("multi_imu.n_adis", f"must be in [1, {len(ADIS_LEVER_ARMS)}], got {n_adis}")
    seqs = _seeds(seed, runs)
    flight = GeodeticFlight(climb_and_turn(duration), *ORIGIN)
    t_fix = uniform_times(0.0, duration, 20.0)
    truth, _ = _truth_native(flight, t_fix)
    fixes = simulate_fixes(flight, t_fix, fix_sigma, _rngs(seqs, 1), fix_bias)
    fix_for = lambda s: fixes if shared_fix else simulate_fixes(flight, t_fix, fix_sigma, _rngs(seqs, 50 + s), fix_bias)  # noqa: E731
    psd = lambda name, rate: spec_accel_psd(name, rate) if accel_psd == "spec" else accel_psd  # noqa: E731
    t_adis, t_nov = uniform_times(0.0, duration, 100.0), uniform_times(0.0, duration, 200.0)
    adis = gnss_ins_sim_imu("adis16465", 100.0)
    est, errors, rmse, cloud = [], {}, {}, {}
    imus = []
    for s in range(n_adis):
        imu = rig_imu(flight, t_adis, ADIS_LEVER_ARMS[s], adis, _rngs(seqs, 10 + s))
        imus.append(imu)
        pos, out = _aided_pf(flight, imu, fix_for(s), ADIS_LEVER_ARMS[s], n_particles, psd("adis16465", 100.0),
                             _rngs(seqs, 20 + s), t_fix, duration)
        est.append(pos)
        errors[f"sensor{s + 1}"] = geodetic_difference_ned(*np.moveaxis(pos, -1, 0), *np.moveaxis(truth, -1, 0))
        cloud[f"sensor{s + 1}"] = _cloud_rms(out, errors[f"sensor{s + 1}"], t_fix, settle)
    nov = rig_imu(flight, t_nov, np.zeros(3), gnss_ins_sim_imu("novatel-isa-100c", 200.0), _rngs(seqs, 5))
    pos, out = _aided_pf(flight, nov, fixes, np.zeros(3), n_particles, psd("novatel-isa-100c", 200.0), _rngs(seqs, 6),
                         t_fix, duration)
    errors["novatel"] = geodetic_difference_ned(*np.moveaxis(pos, -1, 0), *np.moveaxis(truth, -1, 0))
    cloud["novatel"] = _cloud_rms(out, errors["novatel"], t_fix, settle)
    if virtual:
        f, w = virtual_imu(np.stack([i.specific_force for i in imus]), np.stack([i.angular_rate for i in imus]),
                           ADIS_LEVER_ARMS[:n_adis], 0.01)
        pos, _ = _aided_pf(flight, ImuStream(t_adis, f, w), fix_for(9), np.zeros(3), n_particles,
                           psd("adis16465", 100.0) / n_adis, _rngs(seqs, 7), t_fix, duration)
        errors["vimu"] = geodetic_difference_ned(*np.moveaxis(pos, -1, 0), *np.moveaxis(truth, -1, 0))
    # fusion in NED metres about the truth (any common origin gives the same weights)
    est_ned = np.stack([geodetic_difference_ned(*np.moveaxis(p, -1, 0), *np.moveaxis(truth, -1, 0)) for p in est], 1)
    fix_ned = geodetic_difference_ned(*np.moveaxis(fixes.position, -1, 0), *np.moveaxis(truth, -1, 0))
    errors["mean"] = mean_fuse(est_ned)
    errors["sir"] = _fuse_at_fixes(est_ned, fix_ned, np.asarray(fix_sigma), n_draws, _rngs(seqs, 40), per_axis)
    errors["fix"] = fix_ned
    for k, e in errors.items():
        rmse[k] = _rms(e, t_fix, settle)
    info = {"fix_sigma": np.asarray(fix_sigma).tolist(), "runs": runs, "n_particles": n_particles,
            "accel_psd": {"adis16465": psd("adis16465", 100.0), "novatel": psd("novatel-isa-100c", 200.0)},
            "shared_fix": shared_fix, "per_axis": per_axis, "duration": duration}
    return FusionResult(rmse, errors, t_fix, cloud, info)
