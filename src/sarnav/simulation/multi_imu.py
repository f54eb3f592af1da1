"""The experiments of Sun (2022) as batched Monte Carlo library functions (extraction seed-003 §4, §8).

* :func:`single_step_sir` — one time step, N i.i.d. sensors, SIR weights from a fix (Figs. 5.2-5.3, T14-T16, T25);
* :func:`run_path1` — simulated path 1 (eq. 5.21) with the three position sensors of Table 5.1, one PF per
  sensor, fused by the mean and by SIR (Figs. 5.5, 5.11, T17-T19);
* :func:`run_multi_imu` — 3 x ADIS16465 (Table 5.4) against one NovAtel IMU-ISA-100C (Table 5.2) on a
  climb-and-turn flight over the rotating Earth, one 1000-particle aided PF per IMU, SIR / mean / virtual IMU
  (Figs. 5.10, 5.12, 5.13, T20-T23);
* :func:`run_upf_flight` — the one-hour flight (climb, figure-eights, racetracks) with the NovAtel model,
  200 Hz IMU + 20 Hz fix, the 2000-particle UPF and the interpolated KF at 3 kHz (Figs. 5.8, 5.26, T10-T13);
* the campaigns of the kinds ``multi-imu-path1``, ``multi-imu`` and ``upf-flight``: their parameters
  (:class:`Path1Params`, :class:`MultiImuParams`, :class:`UpfParams`) and runs to records
  (:func:`run_path1_records`, :func:`run_multi_imu_records`, :func:`run_upf_flight_records`).

The rig, its flights, fixes and aided PFs are ``simulation.imu_rig``; the per-pulse antenna positions of every
navigation source (Figs. 6.5-6.9) are ``simulation.nav_sources`` (both kept importable from here).

Every function takes a ``numpy.random.SeedSequence`` (or int) and spawns one child per run; runs are
independent of how they are batched. Errors are point-estimate position errors in NED metres against the
noise-free truth; "rmse" is the 3-D RMS over runs and epochs after ``settle`` seconds (the source's
"3-dimensional positional accuracy", Fig. 5.24; its eq. 5.22 cloud RMS is reported as ``cloud_rmse`` where a
cloud exists, gap G18). Parameter choices where the source is silent are the module constants and are
discussed in docs/particles.md.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from sarnav.errors import ConfigError
from sarnav.filters.fusion import cloud_mean, draw_sensors, mean_fuse, sensor_log_weights, virtual_imu
from sarnav.filters.grid_kalman import GridKalmanFilter
from sarnav.filters.grid_particle import GridParticleFilter
from sarnav.filters.pulse_grid import FixStream, GridOutput, ImuStream, NavFrame, uniform_times
from sarnav.frames.wgs84 import geodetic_difference_ned
from sarnav.record import RunRecord
from sarnav.simulation.fusion_records import SOURCE_ATTRS, run_records, source_records
# the rig and the per-pulse sources, kept importable from here (their home until sarnav 0.3)
from sarnav.simulation.imu_rig import (ADIS_LEVER_ARMS, FIX_SIGMA, ORIGIN, SPEC_HORIZON, WHITE_BIAS_TAU,
                                       aided_pf, cart_track, climb_and_turn, correlated_fix_errors, gnss_ins_sim_imu,
                                       rig_imu, rngs_for, seed_sequences, simulate_fixes, spec_accel_psd,
                                       survey_flight, truth_native)
from sarnav.simulation.nav_sources import (NAV_SOURCES, NavSources, navigation_sources,
                                           navigation_sources_at_pulses)
from sarnav.trajectory import Maneuvering
from sarnav.trajectory.geodetic import GeodeticFlight

__all__ = ["PATH1_SIGMAS", "FusionResult", "single_step_sir", "path1", "run_path1", "run_multi_imu", "UpfFlightResult",
           "cloud_settle_time", "run_upf_flight", "Path1Params", "MultiImuParams", "UpfParams", "UPF_ATTRS",
           "run_path1_records", "run_multi_imu_records", "run_upf_flight_records",
           # simulation.imu_rig and simulation.nav_sources
           "ADIS_LEVER_ARMS", "FIX_SIGMA", "ORIGIN", "SPEC_HORIZON", "WHITE_BIAS_TAU", "aided_pf", "cart_track",
           "climb_and_turn", "correlated_fix_errors", "gnss_ins_sim_imu", "rig_imu", "rngs_for", "seed_sequences",
           "simulate_fixes", "spec_accel_psd", "survey_flight", "truth_native", "NAV_SOURCES", "NavSources",
           "navigation_sources", "navigation_sources_at_pulses"]

#: Table 5.1 noise standard deviations of the three path-1 sensors [m]
PATH1_SIGMAS = (0.5, 1.0, 0.1)


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
    seqs = seed_sequences(seed, runs)
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
# 3 x ADIS16465 against one NovAtel over the rotating Earth (Figs. 5.10-5.13)

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
    seqs = seed_sequences(seed, runs)
    flight = GeodeticFlight(climb_and_turn(duration, speed), *ORIGIN)
    t_fix = uniform_times(0.0, duration, 20.0)
    truth, _ = truth_native(flight, t_fix)
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
        pos, out = aided_pf(flight, imu, fix_for(s), ADIS_LEVER_ARMS[s], n_particles, psd("adis16465", 100.0),
                            rngs_for(seqs, 20 + s), t_fix, duration)
        est.append(pos)
        covs[f"sensor{s + 1}"] = out.position_cov
        errors[f"sensor{s + 1}"] = geodetic_difference_ned(*np.moveaxis(pos, -1, 0), *np.moveaxis(truth, -1, 0))
        cloud[f"sensor{s + 1}"] = _cloud_rms(out, errors[f"sensor{s + 1}"], t_fix, settle)
    nov = rig_imu(flight, t_nov, np.zeros(3), gnss_ins_sim_imu("novatel-isa-100c", 200.0), rngs_for(seqs, 5))
    pos, out = aided_pf(flight, nov, fixes, np.zeros(3), n_particles, psd("novatel-isa-100c", 200.0), rngs_for(seqs, 6),
                        t_fix, duration)
    errors["novatel"] = geodetic_difference_ned(*np.moveaxis(pos, -1, 0), *np.moveaxis(truth, -1, 0))
    cloud["novatel"] = _cloud_rms(out, errors["novatel"], t_fix, settle)
    covs["novatel"] = out.position_cov
    if virtual:
        f, w = virtual_imu(np.stack([i.specific_force for i in imus]), np.stack([i.angular_rate for i in imus]),
                           ADIS_LEVER_ARMS[:n_adis], 0.01)
        pos, out = aided_pf(flight, ImuStream(t_adis, f, w), fix_for(9), np.zeros(3), n_particles,
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
    seqs = seed_sequences(seed, runs)
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
        truth = (truth_native(geo, t_out)[0], truth_native(geo, fixes.times)[0])  # once for both filters
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
# the campaigns of the kinds multi-imu-path1, multi-imu and upf-flight (scenarios.multi_imu): parameters -> records

def _run_ids(run_ids, seeds) -> list:
    return list(range(len(seeds))) if run_ids is None else list(run_ids)


@dataclass(frozen=True)
class Path1Params:
    """The ``multi-imu-path1`` campaign (arguments of :func:`run_path1`, SI): path ``duration`` [s], one PF per
    sensor of ``sensor_sigmas`` [m] updated at ``rate`` [Hz], ``n_particles``, ``accel_psd`` [m^2/s^3], ``settle``
    [s], the weighting fix ``fix_sigma`` [m], SIR ``n_draws`` and ``per_axis``."""

    runs: int
    duration: float
    sensor_sigmas: tuple
    rate: float
    n_particles: int
    accel_psd: float
    settle: float
    fix_sigma: float
    n_draws: int
    per_axis: bool

    def filters(self) -> list[str]:
        """The filters with a covariance (the records' states)."""
        return [f"sensor{i + 1}" for i in range(len(self.sensor_sigmas))]

    def sources(self) -> list[str]:
        """Every navigation source of the records."""
        return self.filters() + ["mean", "sir", "fix"]


def run_path1_records(prm: Path1Params, seeds, run_ids=None) -> list[RunRecord]:
    """One record per run of ``seeds`` (numbered ``run_ids``, default 0, 1, ...): :func:`run_path1` at the fix
    epochs (the covariances' epochs), ``fusion_records.run_records``."""
    seeds = list(seeds)
    r = run_path1(runs=len(seeds), seed=seeds, duration=prm.duration, sensor_sigmas=prm.sensor_sigmas,
                  fix_sigma=prm.fix_sigma, n_particles=prm.n_particles, accel_psd=prm.accel_psd, rate=prm.rate,
                  n_draws=prm.n_draws, per_axis=prm.per_axis, settle=prm.settle)
    errors = {k: v[:, 1:] for k, v in r.errors.items()}  # the fix epochs (the covariances' epochs)
    rec = source_records(r.times[1:], errors, r.covariances, prm.filters(), prm.sources(), prm.settle)
    return run_records(rec, _run_ids(run_ids, seeds))


@dataclass(frozen=True)
class MultiImuParams:
    """The ``multi-imu`` campaign (arguments of :func:`run_multi_imu`, SI): flight ``duration`` [s] and ``speed``
    [m/s], ``n_adis`` ADIS16465, fix ``fix_sigma`` / ``fix_bias`` (3,) [m] and ``shared_fix``, ``n_particles``,
    ``psd_scale`` (x :func:`spec_accel_psd` of each IMU), ``settle`` [s], SIR ``n_draws`` and ``per_axis``,
    ``virtual`` (the virtual-IMU PF), records every ``stride`` fix epochs."""

    runs: int
    duration: float
    speed: float
    n_adis: int
    fix_sigma: tuple
    fix_bias: tuple
    shared_fix: bool
    n_particles: int
    psd_scale: float
    settle: float
    n_draws: int
    per_axis: bool
    virtual: bool
    stride: int

    def filters(self) -> list[str]:
        """The filters with a covariance (the records' states)."""
        return [f"sensor{i + 1}" for i in range(self.n_adis)] + ["novatel"] + (["vimu"] if self.virtual else [])

    def sources(self) -> list[str]:
        """Every navigation source of the records."""
        return self.filters() + ["mean", "sir", "fix"]


def run_multi_imu_records(prm: MultiImuParams, seeds, run_ids=None) -> list[RunRecord]:
    """One record per run of ``seeds`` (numbered ``run_ids``, default 0, 1, ...): :func:`run_multi_imu` at the fix
    epochs, the time series every ``prm.stride`` epochs (``source_ms`` from all of them)."""
    seeds = list(seeds)
    psd = {n: prm.psd_scale * spec_accel_psd(n, r) for n, r in (("adis16465", 100.0), ("novatel-isa-100c", 200.0))}
    r = run_multi_imu(runs=len(seeds), seed=seeds, duration=prm.duration, n_particles=prm.n_particles,
                      n_adis=prm.n_adis, accel_psd=psd, fix_sigma=prm.fix_sigma, n_draws=prm.n_draws,
                      per_axis=prm.per_axis, settle=prm.settle, virtual=prm.virtual, fix_bias=prm.fix_bias,
                      shared_fix=prm.shared_fix, speed=prm.speed)
    errors = {k: v[:, 1:] for k, v in r.errors.items()}
    rec = source_records(r.times[1:], errors, r.covariances, prm.filters(), prm.sources(), prm.settle,
                         stride=prm.stride)
    return run_records(rec, _run_ids(run_ids, seeds))


@dataclass(frozen=True)
class UpfParams:
    """The ``upf-flight`` campaign (arguments of :func:`run_upf_flight` over :func:`survey_flight`, SI): flight
    ``duration`` [s], ``speed`` and ``climb`` [m/s]; the ``imu`` preset at ``imu_rate`` [Hz]; fixes ``fix_sigma``
    (3,) [m] at ``fix_rate`` [Hz]; ``n_particles``, ``psd_scale`` (x :func:`spec_accel_psd`), ``noise_at``,
    ``settle`` [s]; outputs at ``out_rate`` [Hz], records at ``record_rate`` [Hz]; ``kf_coriolis``."""

    runs: int
    duration: float
    speed: float
    climb: float
    imu: str
    imu_rate: float
    fix_sigma: tuple
    fix_rate: float
    n_particles: int
    psd_scale: float
    noise_at: str
    settle: float
    out_rate: float
    record_rate: float
    kf_coriolis: bool = False

    def filters(self) -> list[str]:
        """The filters with a covariance (the records' states)."""
        return ["upf", "kf-interp"]

    def sources(self) -> list[str]:
        """Every navigation source of the records (``pf`` / ``kf``: the UPF / KF at the fix epochs)."""
        return ["upf", "kf-interp", "pf", "kf", "fix"]


#: attributes of the record variables of :func:`run_upf_flight_records` (results.nc)
UPF_ATTRS = dict(SOURCE_ATTRS)
UPF_ATTRS.update({
    "source_error": {"units": "m", "description": "estimate minus truth after the update at the record epochs (fix "
                                                  "epochs): upf and kf-interp; NaN-free copies for pf (= upf) and kf "
                                                  "(= kf-interp); fix = the fix"},
    "cloud_var": {"units": "m2", "description": "UPF cloud position variance per NED axis after the update (Fig. "
                                                "5.26), at the record epochs"},
    "settle_time": {"units": "s", "description": "T13: time after which the UPF cloud variance (5-s average) stays "
                                                 "within +50 % of its late median"},
    "filter_seconds": {"units": "s", "description": "wall time of each filter over the flight per run (the batch's "
                                                    "time / its runs; T12; one core; not reproducible bit for bit)"},
})


def run_upf_flight_records(prm: UpfParams, seeds, run_ids=None) -> list[RunRecord]:
    """One record per run of ``seeds`` (numbered ``run_ids``, default 0, 1, ...): :func:`run_upf_flight` at the
    record epochs (``source_ms`` accumulated at the output rate), with ``cloud_var``, ``settle_time`` and
    ``filter_seconds`` (:data:`UPF_ATTRS`)."""
    seeds = list(seeds)
    q = prm.psd_scale * spec_accel_psd(prm.imu, prm.imu_rate)
    u = run_upf_flight(runs=len(seeds), seed=seeds, n_particles=prm.n_particles, out_rate=prm.out_rate,
                       imu=prm.imu, imu_rate=prm.imu_rate, accel_psd=q, fix_sigma=prm.fix_sigma,
                       settle=prm.settle, noise_at=prm.noise_at, record_rate=prm.record_rate, fix_rate=prm.fix_rate,
                       flight=survey_flight(prm.duration, prm.speed, prm.climb), kf_coriolis=prm.kf_coriolis)
    e = dict(u.record_errors)
    e["pf"], e["kf"] = e["upf"], e["kf-interp"]
    e["fix"] = u.record_fix_errors
    rec = source_records(u.record_times, e, u.record_covs, prm.filters(), prm.sources(), prm.settle, ms=u.ms)
    R = len(seeds)  # the batch's wall time shared equally by its runs
    secs = np.broadcast_to([u.seconds["upf"] / R, u.seconds["kf-interp"] / R], (R, 2))
    return run_records(rec, _run_ids(run_ids, seeds), {"cloud_var": (("time", "axis"), u.record_cloud_var),
                                                       "settle_time": ((), u.settle_times),
                                                       "filter_seconds": (("filter",), secs)})
