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

import time
from dataclasses import dataclass, field

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters.fusion import cloud_mean, draw_sensors, mean_fuse, sensor_log_weights, virtual_imu
from sarnav.filters.grid_kalman import GridKalmanFilter
from sarnav.filters.grid_particle import GridParticleFilter
from sarnav.filters.pulse_grid import TIME_TOLERANCE, FixStream, GridOutput, ImuStream, NavFrame, uniform_times
from sarnav.frames.wgs84 import geodetic_difference_ned, ned_offset_to_geodetic
from sarnav.rotations import quat_to_dcm
from sarnav.sensors import ImuModel, imu_grade
from sarnav.sensors.gauss_markov import fogm_coefficients, fogm_path
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
    """One SeedSequence per run: ``seed`` (int or SeedSequence) spawns ``runs`` children; a list of SeedSequences
    (a campaign's run seeds, ``sarnav.montecarlo.seeding.run_seeds``) is used as given, one per run."""
    if isinstance(seed, (list, tuple)):
        if len(seed) != runs or not all(isinstance(s, np.random.SeedSequence) for s in seed):
            raise InputDataError("seeds", f"need {runs} SeedSequences (one per run), got {len(seed)}")
        return list(seed)
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    return ss.spawn(runs)


def rngs_for(seqs, stream):
    """One Generator per run for a named stream (sensor noise, fixes, filter s, fusion) of that run."""
    return [np.random.default_rng(np.random.SeedSequence(s.entropy, spawn_key=s.spawn_key + (stream,)))
            for s in seqs]


def _rms(err, t, settle):
    k = t >= settle
    return float(np.sqrt(np.mean(np.sum(err[:, k] ** 2, axis=-1))))


@dataclass
class FusionResult:
    """Per-source results: ``rmse`` [m] (3-D RMS after ``settle``), ``errors`` (R, K, 3) NED error time series
    at ``times`` (K,), ``cloud_rmse`` [m] (eq. 5.22, filters with a cloud), ``info`` (settings used),
    ``covariances`` (R, K - 1, 3, 3) [m^2] the cloud's position covariance after each update at ``times[1:]`` (the
    per-sensor filters: sensor1.., novatel)."""

    rmse: dict
    errors: dict
    times: np.ndarray
    cloud_rmse: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)
    covariances: dict = field(default_factory=dict)


# --------------------------------------------------------------------------------------------------------
# single time step (Figs. 5.2, 5.3)

def single_step_sir(n_sensors: int, sigma: float = 1.0, fix_sigma: float = 1.0, trials: int = 2000,
                    n_draws: int = 50, seed=0, fix_bias: float = 0.0):
    """One time step, 1-D (Figs. 5.2-5.3): sensors x_s = x + N(0, sigma^2), fix g = x + fix_bias +
    N(0, fix_sigma^2), SIR weights N(g; x_s, fix_sigma^2) (eq. 3.24), ``n_draws`` draws, fused = their mean.
    The trials are the samples of one Monte Carlo study, drawn from one Generator of ``seed`` (vectorised).
    Returns the SIR and mean errors (trials,) and their variances / MSEs, the CRLB sigma^2/N and the fix MSE."""
    rng = np.random.default_rng(seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed))
    x_s = sigma * rng.standard_normal((trials, n_sensors))
    g = fix_bias + fix_sigma * rng.standard_normal(trials)
    est = np.zeros((trials, n_sensors, 3))
    est[..., 0] = x_s
    fix = np.zeros((trials, 3))
    fix[:, 0] = g
    w = np.exp(sensor_log_weights(est, fix, np.array([fix_sigma, 1.0, 1.0]), per_axis=True)[..., 0])
    cdf = np.cumsum(w, axis=1)
    cdf /= cdf[:, -1:]
    u = rng.random((trials, n_draws))
    idx = np.minimum((u[..., None] >= cdf[:, None, :]).sum(-1), n_sensors - 1)  # inverse CDF (eq. 5.3 draws)
    sir = np.take_along_axis(x_s, idx, axis=1).mean(axis=1)
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
    est, covs, errors, rmse, cloud_rmse = [], {}, {}, {}, {}
    for s, sig in enumerate(sensor_sigmas):
        noise = np.stack([g.standard_normal((t_fix.size, 3)) for g in rngs_for(seqs, 10 + s)])
        meas = FixStream(t_fix, p_fix[None] + sig * noise, np.full(3, sig))
        pf = GridParticleFilter(frame, n_particles, accel_psd, noise_at="fix", ess_threshold=0.5, kernel_h=0.3)
        pf.initialize(0.0, meas.position[:, 0], np.broadcast_to(v0, (runs, 3)), [1.0, 0, 0, 0],
                      np.diag([sig**2] * 3 + [1.0] * 3), rngs_for(seqs, 20 + s))
        out = pf.run(imu, duration, meas, t_fix)
        est.append(out.position)
        covs[f"sensor{s + 1}"] = out.position_cov
        errors[f"sensor{s + 1}"] = out.position - p_fix
        rmse[f"sensor{s + 1}"] = _rms(errors[f"sensor{s + 1}"], t_fix, settle)
        cloud_rmse[f"sensor{s + 1}"] = _cloud_rms(out, errors[f"sensor{s + 1}"], t_fix, settle)
    est = np.stack(est, 1)
    fix = p_fix[None] + fix_sigma * np.stack([g.standard_normal((t_fix.size, 3)) for g in rngs_for(seqs, 30)])
    errors["mean"] = mean_fuse(est) - p_fix
    errors["sir"] = _fuse_at_fixes(est, fix, np.full(3, fix_sigma), n_draws, rngs_for(seqs, 31), per_axis) - p_fix
    errors["fix"] = fix - p_fix
    for k in ("mean", "sir", "fix"):
        rmse[k] = _rms(errors[k], t_fix, settle)
    return FusionResult(rmse, errors, t_fix, cloud_rmse,
                        {"fix_sigma": fix_sigma, "accel_psd": accel_psd, "n_particles": n_particles, "runs": runs},
                        covs)


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
                  shared_fix: bool = True, speed: float = 50.0) -> FusionResult:
    """S x ADIS16465 (100 Hz) against one NovAtel IMU-ISA-100C (200 Hz), 20 Hz fixes, on :func:`climb_and_turn`.

    Each IMU has its own geodetic aided PF (``n_particles``; process noise ``accel_psd`` [m^2/s^3] for all, or
    ``"spec"``: :func:`spec_accel_psd` of each IMU, or a dict preset name -> PSD); the ADIS sit at :data:`ADIS_LEVER_ARMS`, the NovAtel and
    the fix antenna at the reference point. ``shared_fix`` True: every PF is aided by the same fix stream
    (one receiver on the rig); False: each IMU's PF by its own independent fix realisation (what separate
    gnss-ins-sim runs per IMU give), the NovAtel's stream weighting the SIR. Returns rmse for ``sensor1..S``
    (ADIS), ``mean``, ``sir``, ``novatel``, ``vimu`` (one PF on the virtual IMU of the ADIS) and ``fix``.
    """
    if not 1 <= n_adis <= len(ADIS_LEVER_ARMS):
        raise ConfigError("multi_imu.n_adis", f"must be in [1, {len(ADIS_LEVER_ARMS)}], got {n_adis}")
    seqs = _seeds(seed, runs)
    flight = GeodeticFlight(climb_and_turn(duration, speed), *ORIGIN)
    t_fix = uniform_times(0.0, duration, 20.0)
    truth, _ = _truth_native(flight, t_fix)
    fixes = simulate_fixes(flight, t_fix, fix_sigma, rngs_for(seqs, 1), fix_bias)
    fix_for = lambda s: fixes if shared_fix else simulate_fixes(flight, t_fix, fix_sigma, rngs_for(seqs, 50 + s), fix_bias)  # noqa: E731
    psd = lambda name, rate: (spec_accel_psd(name, rate) if isinstance(accel_psd, str) and accel_psd == "spec"  # noqa: E731
                              else accel_psd[name] if isinstance(accel_psd, dict) else accel_psd)
    t_adis, t_nov = uniform_times(0.0, duration, 100.0), uniform_times(0.0, duration, 200.0)
    adis = gnss_ins_sim_imu("adis16465", 100.0)
    est, errors, rmse, cloud, covs = [], {}, {}, {}, {}
    imus = []
    for s in range(n_adis):
        imu = rig_imu(flight, t_adis, ADIS_LEVER_ARMS[s], adis, rngs_for(seqs, 10 + s))
        imus.append(imu)
        pos, out = _aided_pf(flight, imu, fix_for(s), ADIS_LEVER_ARMS[s], n_particles, psd("adis16465", 100.0),
                             rngs_for(seqs, 20 + s), t_fix, duration)
        est.append(pos)
        covs[f"sensor{s + 1}"] = out.position_cov
        errors[f"sensor{s + 1}"] = geodetic_difference_ned(*np.moveaxis(pos, -1, 0), *np.moveaxis(truth, -1, 0))
        cloud[f"sensor{s + 1}"] = _cloud_rms(out, errors[f"sensor{s + 1}"], t_fix, settle)
    nov = rig_imu(flight, t_nov, np.zeros(3), gnss_ins_sim_imu("novatel-isa-100c", 200.0), rngs_for(seqs, 5))
    pos, out = _aided_pf(flight, nov, fixes, np.zeros(3), n_particles, psd("novatel-isa-100c", 200.0), rngs_for(seqs, 6),
                         t_fix, duration)
    errors["novatel"] = geodetic_difference_ned(*np.moveaxis(pos, -1, 0), *np.moveaxis(truth, -1, 0))
    cloud["novatel"] = _cloud_rms(out, errors["novatel"], t_fix, settle)
    covs["novatel"] = out.position_cov
    if virtual:
        f, w = virtual_imu(np.stack([i.specific_force for i in imus]), np.stack([i.angular_rate for i in imus]),
                           ADIS_LEVER_ARMS[:n_adis], 0.01)
        pos, out = _aided_pf(flight, ImuStream(t_adis, f, w), fix_for(9), np.zeros(3), n_particles,
                             psd("adis16465", 100.0) / n_adis, rngs_for(seqs, 7), t_fix, duration)
        errors["vimu"] = geodetic_difference_ned(*np.moveaxis(pos, -1, 0), *np.moveaxis(truth, -1, 0))
        covs["vimu"] = out.position_cov
    # fusion in NED metres about the truth (any common origin gives the same weights)
    est_ned = np.stack([geodetic_difference_ned(*np.moveaxis(p, -1, 0), *np.moveaxis(truth, -1, 0)) for p in est], 1)
    fix_ned = geodetic_difference_ned(*np.moveaxis(fixes.position, -1, 0), *np.moveaxis(truth, -1, 0))
    errors["mean"] = mean_fuse(est_ned)
    errors["sir"] = _fuse_at_fixes(est_ned, fix_ned, np.asarray(fix_sigma), n_draws, rngs_for(seqs, 40), per_axis)
    errors["fix"] = fix_ned
    for k, e in errors.items():
        rmse[k] = _rms(e, t_fix, settle)
    info = {"fix_sigma": np.asarray(fix_sigma).tolist(), "runs": runs, "n_particles": n_particles,
            "accel_psd": {"adis16465": psd("adis16465", 100.0), "novatel": psd("novatel-isa-100c", 200.0)},
            "shared_fix": shared_fix, "per_axis": per_axis, "duration": duration}
    return FusionResult(rmse, errors, t_fix, cloud, info, covs)


# --------------------------------------------------------------------------------------------------------
# the one-hour UPF flight (Figs. 5.25-5.28) and the NovAtel-model comparison of KF and PF (Fig. 5.8)

def survey_flight(duration: float = 3600.0, speed: float = 50.0, climb: float = 3.0) -> Maneuvering:
    """A flight like the source's Piper Warrior sortie (L1273): climb (``climb`` m/s for the first 1/6), then
    figure-eights (a right and a left 360 deg turn at 3 deg/s) alternating with racetracks (straight 60 s,
    180 deg turn, straight 60 s, 180 deg turn), then a descent over the last 1/12. Transitions 4 s."""
    d = np.radians(3.0)
    starts, turn = [0.0], [0.0]
    t = duration / 12.0
    pattern = [(120.0, d), (120.0, -d), (30.0, 0.0), (60.0, 0.0), (60.0, d), (60.0, 0.0), (60.0, d), (30.0, 0.0)]
    i = 0
    while t + pattern[i % len(pattern)][0] < duration - 10.0:
        length, rate = pattern[i % len(pattern)]
        starts.append(t)
        turn.append(rate)
        t += length
        i += 1
    starts.append(t)
    turn.append(0.0)
    keep = np.concatenate([[True], np.diff(starts) >= 8.0])
    starts, turn = list(np.asarray(starts)[keep]), list(np.asarray(turn)[keep])
    c_starts = [0.0, duration / 6.0, 11.0 * duration / 12.0]
    return Maneuvering([0.0, 0.0, -ORIGIN[2]], speed, np.radians(200.0), RateProfile(tuple(starts), tuple(turn), 4.0),
                       RateProfile(tuple(c_starts), (climb, 0.0, -2.0 * climb), 4.0), duration)


@dataclass
class UpfFlightResult:
    """``rmse`` [m] per source at the output (pulse) epochs after ``settle`` (``upf``, ``kf-interp``) and at
    the fix epochs (``pf``, ``kf``, ``fix``); ``cloud_var_times`` (K,), ``cloud_var`` (R, K, 3) the UPF cloud's
    position variance per NED axis after each fix [m^2]; ``settle_time`` [s] (T13, worst run); ``info``.
    Per run: ``ms`` source -> (R,) mean squared 3-D error after ``settle`` [m^2], ``settle_times`` (R,) [s];
    at ``record_times`` (K1,) (fix epochs at the record rate): ``record_errors`` / ``record_covs`` filter ->
    (R, K1, 3) NED estimate - truth [m] / (R, K1, 3, 3) [m^2] after the update, ``record_cloud_var`` (R, K1, 3);
    ``seconds`` filter -> wall time of the whole batch [s] (T12)."""

    rmse: dict
    cloud_var_times: np.ndarray
    cloud_var: np.ndarray
    settle_time: float
    info: dict
    ms: dict = field(default_factory=dict)
    record_times: np.ndarray | None = None
    record_errors: dict = field(default_factory=dict)
    record_covs: dict = field(default_factory=dict)
    record_cloud_var: np.ndarray | None = None
    settle_times: np.ndarray | None = None
    seconds: dict = field(default_factory=dict)
    record_fix_errors: np.ndarray | None = None


def cloud_settle_time(times, variance, tolerance: float = 0.5, window: float = 5.0) -> float:
    """T13: the time after which the cloud variance (moving average over ``window`` s, per axis) no longer
    exceeds (1 + ``tolerance``) times its median over the second half of the record (the variance converges
    from its initial, larger value, Fig. 5.26); the largest over axes and runs."""
    times = np.asarray(times, dtype=float)
    var = np.asarray(variance, dtype=float)
    n = max(1, int(round(window / np.median(np.diff(times)))))
    kernel = np.ones(n) / n
    worst = 0.0
    for r in range(var.shape[0]):
        for a in range(var.shape[-1]):
            v = np.convolve(var[r, :, a], kernel, mode="same")
            ref = np.median(var[r, times >= times[0] + 0.5 * (times[-1] - times[0]), a])
            bad = np.flatnonzero(v[n:-n] / ref - 1.0 > tolerance)
            worst = max(worst, float(times[n:-n][bad[-1]]) if bad.size else float(times[n]))
    return worst


def run_upf_flight(runs: int = 1, seed=0, duration: float = 3600.0, n_particles: int = 2000,
                   out_rate: float = 3000.0, imu: str = "novatel-isa-100c", imu_rate: float = 200.0,
                   accel_psd="spec", fix_sigma=FIX_SIGMA, segment: float = 10.0, settle: float = 75.0,
                   noise_at: str = "fix", flight: Maneuvering | None = None, record_rate: float = 1.0,
                   fix_rate: float = 20.0, kf_coriolis: bool = False) -> UpfFlightResult:
    """The UPF (geodetic model, ``n_particles``) and the interpolated KF (eq. 3.10 model) on the pulse grid at
    ``out_rate`` over :func:`survey_flight`, 200 Hz IMU + 20 Hz fixes; processed in ``segment``-second pieces
    so that one hour at 3 kHz fits in memory. Errors accumulate as sums of squares per run; the filters' fix-epoch
    estimates and covariances are kept at ``record_rate`` (a divisor of ``fix_rate``). ``kf_coriolis`` gives the
    KF the Coriolis and transport-rate terms (``GridKalmanFilter(coriolis=True)``; False: the source's eq. 3.10)."""
    seqs = _seeds(seed, runs)
    flat = flight if flight is not None else survey_flight(duration)
    geo = GeodeticFlight(flat, *ORIGIN)
    frame = NavFrame(geodetic=True, origin=ORIGIN)
    model = gnss_ins_sim_imu(imu, imu_rate)
    q = spec_accel_psd(imu, imu_rate) if accel_psd == "spec" else float(accel_psd)
    sig = np.asarray(fix_sigma, dtype=float)
    s0 = geo.state(0.0)
    rng = {"imu": rngs_for(seqs, 1), "fix": rngs_for(seqs, 2)}
    ba, bg = model.initial_biases(rng["imu"])
    fix0 = simulate_fixes(geo, np.array([0.0]), sig, rngs_for(seqs, 4)).position[:, 0]
    p0 = np.diag(np.r_[sig**2, [0.05**2] * 3])
    v0 = np.broadcast_to(s0.velocity, (runs, 3))
    filters = {"upf": GridParticleFilter(frame, n_particles, q, model="geodetic", noise_at=noise_at,
                                         ess_threshold=0.5, kernel_h=0.3).initialize(0.0, fix0, v0, s0.quaternion,
                                                                                     p0, rngs_for(seqs, 3)),
               "kf-interp": GridKalmanFilter(frame, q, coriolis=kf_coriolis).initialize(0.0, fix0, v0, s0.quaternion,
                                                                                         p0)}
    acc = _UpfAccumulator(runs, settle, fix_rate, record_rate)
    t0 = 0.0
    while t0 < flat.duration - 1e-9:
        t1 = min(flat.duration, t0 + segment)
        t_imu = uniform_times(t0, t1, imu_rate)
        f, w = geo.imu(t_imu)
        nu, om, _, _, ba, bg = model.measure(f, w, ba, bg, rng["imu"])
        fixes = simulate_fixes(geo, uniform_times(t0, t1, fix_rate)[1:], sig, rng["fix"])
        t_out = uniform_times(t0, t1, out_rate)[1:]
        truth = (_truth_native(geo, t_out)[0], _truth_native(geo, fixes.times)[0])  # once for both filters
        for name, filt in filters.items():
            tic = time.perf_counter()
            out = filt.run(ImuStream(t_imu, nu, om), t1, fixes, t_out)
            acc.seconds[name] += time.perf_counter() - tic
            acc.add(name, frame, truth, out)
        acc.add_fixes(frame, truth[1], fixes)
        t0 = t1
    info = {"accel_psd": q, "n_particles": n_particles, "out_rate": out_rate, "duration": flat.duration,
            "noise_at": noise_at, "imu": imu, "collapsed_runs": int(np.count_nonzero(filters["upf"].collapsed))}
    return acc.result(info)


class _UpfAccumulator:
    """Per-run sums of squared 3-D errors after ``settle`` and the records of :func:`run_upf_flight`."""

    def __init__(self, runs, settle, fix_rate, record_rate):
        self.settle, self.runs = settle, runs
        self.every = int(round(fix_rate / record_rate))
        if self.every < 1 or abs(fix_rate / record_rate - self.every) > 1e-9:
            raise ConfigError("upf.record_rate_hz", f"must divide the fix rate {fix_rate} Hz, got {record_rate}")
        self.fix_rate = fix_rate
        self.sums = {k: np.zeros(runs) for k in ("upf", "kf-interp", "pf", "kf", "fix")}
        self.counts = {k: 0 for k in self.sums}
        self.seconds = {"upf": 0.0, "kf-interp": 0.0}
        self.var_t, self.var, self.rec_t, self.rec_fix = [], [], [], []
        self.rec_e = {"upf": [], "kf-interp": []}
        self.rec_c = {"upf": [], "kf-interp": []}

    def _sum(self, key, err, times):
        k = times >= self.settle
        self.sums[key] += np.sum(err[:, k] ** 2, axis=(1, 2))
        self.counts[key] += int(np.count_nonzero(k))

    def add(self, name, frame, truth, out: GridOutput):
        """``truth``: native truth at the output epochs and at the fix epochs of the segment."""
        self._sum(name, frame.error_ned(out.position, truth[0]), out.times)
        ef = frame.error_ned(out.fix_position, truth[1])
        self._sum("pf" if name == "upf" else "kf", ef, out.fix_times)
        keep = np.round(out.fix_times * self.fix_rate).astype(np.int64) % self.every == 0
        self.rec_e[name].append(ef[:, keep])
        self.rec_c[name].append(out.position_cov[:, keep])
        if name == "upf":
            self.var_t.append(out.fix_times)
            self.var.append(np.diagonal(out.position_cov, axis1=-2, axis2=-1))
            self.rec_t.append(out.fix_times[keep])

    def add_fixes(self, frame, truth_fix, fixes: FixStream):
        ef = frame.error_ned(fixes.position, truth_fix)
        self._sum("fix", ef, fixes.times)
        self.rec_fix.append(ef[:, np.round(fixes.times * self.fix_rate).astype(np.int64) % self.every == 0])

    def result(self, info) -> "UpfFlightResult":
        ms = {k: self.sums[k] / max(self.counts[k], 1) for k in self.sums}
        rmse = {k: float(np.sqrt(np.mean(v))) for k, v in ms.items()}
        var_t, var = np.concatenate(self.var_t), np.concatenate(self.var, axis=1)
        settle = np.array([cloud_settle_time(var_t, var[r:r + 1]) for r in range(self.runs)])
        rec_t = np.concatenate(self.rec_t)
        keep = np.round(var_t * self.fix_rate).astype(np.int64) % self.every == 0
        return UpfFlightResult(rmse, var_t, var, float(settle.max()), info, ms=ms, record_times=rec_t,
                               record_errors={k: np.concatenate(v, axis=1) for k, v in self.rec_e.items()},
                               record_covs={k: np.concatenate(v, axis=1) for k, v in self.rec_c.items()},
                               record_cloud_var=var[:, keep], settle_times=settle, seconds=dict(self.seconds),
                               record_fix_errors=np.concatenate(self.rec_fix, axis=1))


# --------------------------------------------------------------------------------------------------------
# per-pulse antenna positions of every navigation source (for the back-projection focus comparison)

NAV_SOURCES = ("truth", "upf", "kf-interp", "spline-gps", "spline-kf", "spline-pf", "sir-3adis", "novatel")


def cart_track(duration: float, speed: float = 1.0, heading: float = np.pi / 2) -> Maneuvering:
    """The ground-test cart (§3.7 of the extraction): straight at ``speed`` m/s, level, at the origin height."""
    return Maneuvering([0.0, 0.0, -ORIGIN[2]], speed, heading, RateProfile((0.0,), (0.0,), 1.0),
                       RateProfile((0.0,), (0.0,), 1.0), duration)


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


def correlated_fix_errors(times, sigma, tau, rngs) -> np.ndarray:
    """(R, K, 3) first-order Gauss-Markov fix errors (stationary 1-sigma ``sigma`` (3,) [m], correlation time
    ``tau`` [s]; ``sensors.gauss_markov``, exact discretisation) at uniformly spaced ``times`` (K,): the slowly
    varying part of a GNSS position error (multipath, atmosphere, orbits)."""
    sigma = np.asarray(sigma, dtype=float)
    phi, drive = fogm_coefficients(sigma, tau, float(times[1] - times[0]) if len(times) > 1 else 1.0)
    b0 = sigma * np.stack([g.standard_normal(3) for g in rngs])
    w = np.stack([g.standard_normal((len(times) - 1, 3)) for g in rngs])
    path, last = fogm_path(b0, w, phi, drive)
    return np.concatenate([path, last[:, None]], axis=1)


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
    seqs = _seeds(seed, runs)
    sig = np.asarray(fix_sigma, dtype=float)
    t_fix = uniform_times(0.0, t_end, 20.0)
    corr = np.asarray(fix_correlated, dtype=float)
    bias = correlated_fix_errors(t_fix, corr, fix_tau, rngs_for(seqs, 5)) if np.any(corr > 0) else np.zeros(3)
    fixes = simulate_fixes(geo, t_fix, sig, rngs_for(seqs, 1), bias)
    sig = np.hypot(sig, corr)  # what the filters assume
    fixes = FixStream(fixes.times, fixes.position, sig)
    truth0 = _truth_native(geo, pulse_times[:1])[0][0]
    to_ned = lambda p: geodetic_difference_ned(p[..., 0], p[..., 1], p[..., 2], *truth0)  # noqa: E731
    out = {"truth": to_ned(_truth_native(geo, pulse_times)[0])[None]}
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
        res.fix_errors[name] = frame.error_ned(o.fix_position, _truth_native(geo, o.fix_times)[0])
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
        pos, _ = _aided_pf(geo, imu, fixes, ADIS_LEVER_ARMS[s], n_particles, q, rngs_for(seqs, 70 + s), grid, t_end)
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
