"""The aided bootstrap particle filter of Sun (2022) eqs. 3.16-3.24 on the up-sampled grid (the UPF, §3.5).

Each particle carries ``[position, velocity]``; the attitude is shared by the cloud (propagated with the gyro
as in the KF, gap G9). Two motion models (gap G9: L757 says (3.10), L696 and L1145 the geodetic mechanization):

* ``"linear"``: eq. 3.10 in local metres, ``p += v dt + a dt^2/2, v += a dt`` with ``a = f^n + g^n``;
* ``"geodetic"``: the strapdown translational step of ``sarnav.ins.geodetic`` (eqs. 2.52-2.59 with Earth
  rate, transport rate, Coriolis and WGS-84 gravity; ``translational_step_cloud`` evaluates the latitude
  functions once per step at the cloud mean), particles ``[lat, lon, h, vN, vE, vD]``.

Between epochs the particles move deterministically with the held IMU sample (zero-order hold, L750); white
acceleration noise of PSD ``accel_psd`` is added at every IMU epoch ("each time the particle filter is
propagated, a small amount of process noise is added", L757), drawn exactly for the IMU interval:
``[dp; dv] ~ N(0, q [[dt^3/3, dt^2/2], [dt^2/2, dt]])`` per axis. At a fix: weights by the Gaussian likelihood
of the fix given each particle (eq. 3.24, 3-D product over NED axes with the fix sigma, gap G10), SIR update in
log-weights, resampling when N_eff < ``ess_threshold`` N (1.0: at every fix, as §3.5 L763; Algorithm 1 leaves
N_th open, gap G8), optional roughening of the resampled clouds. The estimate is the weighted mean (eq. 3.23).

A 2000-particle UPF at 3 kHz on one core runs faster than real time (``benchmarks/bench_particles.py``).
"""

from __future__ import annotations

import numba
import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters.grid_kalman import check_three_nonnegative, linear_acceleration, world_parameters
from sarnav.filters.particles import (
    RESAMPLING_METHODS,
    ParticleCloud,
    check_particle_count,
    effective_sample_size,
    gaussian_log_likelihood,
    kernel_shrinkage,
    normalize_log_weights,
    resample,
    roughen,
    sir_update,
    tempering_exponent,
    weighted_covariance,
)
from sarnav.filters.prediction import Prediction
from sarnav.filters.pulse_grid import GridFilter, ImuStream, NavFrame
from sarnav.filters.update import fuse
from sarnav.frames.earth import WGS84_A, WGS84_E2
from sarnav.frames.wgs84 import geodetic_difference_ned, ned_offset_to_geodetic
from sarnav.rotations import quat_to_dcm
from sarnav.ins.geodetic import attitude_step_inplace, navigation_rate_inplace, rotate_to_nav, translational_step_cloud

MOTION_MODELS = ("linear", "geodetic")
#: a fix whose one SIR step leaves N_eff below this is applied by tempering: the 6-D [p, v] cloud needs >= 7
#: distinct particles for a non-singular covariance (the same bound as ``scenarios.multi_imu.MIN_PARTICLES``)
DEGENERATE_ESS = 7.0


@numba.njit(cache=True)
def _weighted_mean(parts, w, out):
    out[:] = 0.0
    for i in range(parts.shape[0]):
        for j in range(6):
            out[j] += w[i] * parts[i, j]


@numba.njit(cache=True)
def _particle_block(parts, w, q, mean, t, held, imu_new, f_b, w_b, noise, chol, geodetic_model, world, out_mean,
                    out_q):
    """Propagate the clouds of all runs over t[0..S]; at the c-th noise epoch (an IMU arrival, or the block's
    last epoch) the unit normals noise[r, c] (N, 6) are scaled by the per-axis factors chol (3, 3) and added.
    ``world``: ``grid_kalman.world_parameters`` (7 values; numba caches the inlined ``linear_acceleration`` with this
    file, so a change there needs a change here to refresh the cache)."""
    n = parts.shape[1]
    a = np.empty(3)
    w_n = np.empty(3)
    fn = np.empty(3)
    omega_e = world[4]
    for r in range(parts.shape[0]):
        out_mean[r, 0] = mean[r]
        out_q[r, 0] = q[r]
        c = 0
        for k in range(t.size - 1):
            dt = t[k + 1] - t[k]
            j = held[k]
            if geodetic_model:
                navigation_rate_inplace(mean[r], omega_e, w_n)
                fn[:] = 0.0
                rotate_to_nav(q[r], f_b[r, j], fn)
                attitude_step_inplace(q[r], w_b[r, j], w_n, dt)
                rotate_to_nav(q[r], f_b[r, j], fn)
                translational_step_cloud(parts[r], 0.5 * fn[0], 0.5 * fn[1], 0.5 * fn[2], dt, omega_e, mean[r, 0],
                                         mean[r, 2])
            else:
                linear_acceleration(mean[r], q[r], f_b[r, j], w_b[r, j], dt, world, a)
                for i in range(n):
                    for d in range(3):
                        parts[r, i, d] += parts[r, i, d + 3] * dt + 0.5 * a[d] * dt * dt
                        parts[r, i, d + 3] += a[d] * dt
            if imu_new[k + 1]:
                # noise[r, c, i] are unit normals; [dp; dv] per axis = [[l11, 0], [l21, l22]] [z_d; z_d+3]
                sp = np.ones(3)
                if geodetic_model:
                    s = np.sin(mean[r, 0])
                    wq = 1.0 - WGS84_E2 * s * s
                    sp[0] = 1.0 / (WGS84_A * (1.0 - WGS84_E2) / (wq * np.sqrt(wq)) + mean[r, 2])
                    sp[1] = 1.0 / ((WGS84_A / np.sqrt(wq) + mean[r, 2]) * np.cos(mean[r, 0]))
                    sp[2] = -1.0
                for i in range(n):
                    for d in range(3):
                        z0, z1 = noise[r, c, i, d], noise[r, c, i, d + 3]
                        parts[r, i, d] += sp[d] * chol[d, 0] * z0
                        parts[r, i, d + 3] += chol[d, 1] * z0 + chol[d, 2] * z1
                c += 1
            _weighted_mean(parts[r], w[r], mean[r])
            out_mean[r, k + 1] = mean[r]
            out_q[r, k + 1] = q[r]


def _noise_factor(psd, dt):
    """Per axis (l11, l21, l22): the lower Cholesky factor of q [[dt^3/3, dt^2/2], [dt^2/2, dt]] (3, 3)."""
    psd = np.asarray(psd, dtype=float)
    return np.stack([np.sqrt(psd * dt**3 / 3.0), np.sqrt(3.0 * psd * dt) / 2.0, np.sqrt(psd * dt) / 2.0], -1)


class GridParticleFilter(GridFilter):
    """The aided PF / UPF on the up-sampled grid, batched over runs (module docstring).

    Parameters
    ----------
    frame : the world; ``model="geodetic"`` needs a geodetic frame.
    n_particles : N >= 1 (the source: 2000 for the UPF, 1000 per IMU in the multi-IMU fusion).
    accel_psd : white-acceleration PSD per axis [m^2/s^3] (the "small amount of process noise").
    model : ``"linear"`` or ``"geodetic"``.
    resampling : one of ``sarnav.filters.particles.RESAMPLING_METHODS`` (default multinomial, L761).
    ess_threshold : resample when N_eff < threshold N; 1.0 resamples at every fix.
    roughening : Gordon's K for the resampled clouds (0 = none).
    kernel_h : Liu-West kernel shrinkage bandwidth for the resampled clouds (0 = none): diversity without
        inflating the cloud's covariance (``sarnav.filters.particles.kernel_shrinkage``).
    fix_lever_arm : body-frame vector [m] from the IMU (the point the particles track) to the point the fix
        measures (gap G12: zero in the source; multi-IMU rigs need it).
    on_collapse : what to do when every particle misses the fix (``sarnav.filters.particles.sir_update``).
    noise_at : ``"imu"`` adds the process noise at every IMU epoch (L757); ``"fix"`` adds the same exact
        white-acceleration noise once per fix interval, just before the update (the same law at the fix
        epochs, 10-20x fewer random numbers; the IMU-to-fix rate ratio).
    """

    def __init__(self, frame: NavFrame, n_particles: int, accel_psd=1e-2, model: str = "linear",
                 resampling: str = "multinomial", ess_threshold: float = 1.0, roughening: float = 0.0,
                 on_collapse: str = "raise", noise_at: str = "imu", kernel_h: float = 0.0, fix_lever_arm=(0, 0, 0)):
        if model not in MOTION_MODELS:
            raise ConfigError("pf.model", f"must be one of {list(MOTION_MODELS)}, got {model!r}")
        if model == "geodetic" and not frame.geodetic:
            raise ConfigError("pf.model", "the geodetic motion model needs a geodetic NavFrame")
        if resampling not in RESAMPLING_METHODS:
            raise ConfigError("pf.resampling", f"must be one of {list(RESAMPLING_METHODS)}, got {resampling!r}")
        if not 0.0 <= ess_threshold <= 1.0:
            raise ConfigError("pf.ess_threshold", f"must be in [0, 1], got {ess_threshold!r}")
        if not 0.0 <= kernel_h < 1.0:
            raise ConfigError("pf.kernel_h", f"must be in [0, 1), got {kernel_h!r}")
        if not 0.0 <= roughening < 10.0:
            raise ConfigError("pf.roughening", f"must be in [0, 10), got {roughening!r}")
        if noise_at not in ("imu", "fix"):
            raise ConfigError("pf.noise_at", f"must be 'imu' or 'fix', got {noise_at!r}")
        self.frame, self.model, self.noise_at = frame, model, noise_at
        self.n = check_particle_count(n_particles, "pf.n_particles")
        self.accel_psd = check_three_nonnegative("pf.accel_psd", accel_psd)
        self.resampling, self.ess_threshold, self.roughening = resampling, float(ess_threshold), float(roughening)
        self.kernel_h = float(kernel_h)
        self.fix_lever_arm = np.asarray(fix_lever_arm, dtype=float)
        if self.fix_lever_arm.shape != (3,) or not np.all(np.isfinite(self.fix_lever_arm)):
            raise ConfigError("pf.fix_lever_arm", f"must be 3 finite body-frame metres, got {fix_lever_arm!r}")
        self.on_collapse = on_collapse
        self._world = world_parameters(frame)
        self.collapsed = None

    def initialize(self, t0, position, velocity, quaternion, cov, rngs):
        """Cloud at ``t0`` ~ N([position, velocity], cov): ``position`` (R, 3) native, ``velocity`` (R, 3),
        ``cov`` (6, 6) or (R, 6, 6) in NED metres and m/s (the source: GPS variance for position, L757);
        ``rngs`` one Generator per run, kept for the whole run."""
        position = np.atleast_2d(np.asarray(position, dtype=float))
        runs = position.shape[0]
        if len(rngs) != runs:
            raise InputDataError("rngs", f"need one Generator per run ({runs}), got {len(rngs)}")
        self.rngs = rngs
        zero = np.zeros((runs, 3))
        cloud = ParticleCloud.from_gaussian(np.concatenate([zero, np.atleast_2d(velocity)], -1), cov, self.n, rngs)
        off = cloud.particles[..., :3]
        if self.model == "geodetic":
            lat, lon, h = ned_offset_to_geodetic(position[:, None, 0], position[:, None, 1], position[:, None, 2], off)
            pos = np.stack([lat, lon, h], -1)
        else:
            pos = self.frame.to_local(position)[:, None, :] + off
        self.parts = np.ascontiguousarray(np.concatenate([pos, cloud.particles[..., 3:]], -1))
        self.logw = cloud.log_weights
        self.q = np.array(np.broadcast_to(quaternion, (runs, 4)), dtype=float)
        self.mean = np.einsum("rn,rnd->rd", np.exp(self.logw), self.parts)
        self.collapsed = np.zeros(runs, dtype=bool)
        self._start(t0)
        return self

    def _propagate(self, grid, a, b, imu: ImuStream):
        runs, n = self.parts.shape[0], b - a + 1
        if imu.specific_force.shape[0] != runs:
            raise InputDataError("imu.specific_force", f"has {imu.specific_force.shape[0]} runs, filter has {runs}")
        if self.noise_at == "imu":
            when = grid.imu_new[a:b + 1].copy()
            when[0] = False
            dt_noise = float(np.median(np.diff(imu.times)))
        else:  # one exact draw for the whole block, at its last epoch (the next fix)
            when = np.zeros(n, dtype=bool)
            when[-1] = n > 1
            dt_noise = float(grid.t[b] - grid.t[a])
        draws = int(np.count_nonzero(when))
        noise = np.stack([g.standard_normal((draws, self.n, 6)) for g in self.rngs])
        out_m, out_q = np.empty((runs, n, 6)), np.empty((runs, n, 4))
        _particle_block(self.parts, np.exp(self.logw), self.q, self.mean, grid.t[a:b + 1], grid.imu[a:b + 1],
                        when, imu.specific_force, imu.angular_rate, noise, _noise_factor(self.accel_psd, dt_noise),
                        self.model == "geodetic", self._world, out_m, out_q)
        return self._native(out_m[..., :3]), out_m[..., 3:], out_q

    def _native(self, pos):
        return pos.copy() if self.model == "geodetic" else self.frame.to_native(pos)

    def _offsets_from(self, z):
        """Particle positions relative to the native points ``z`` (R, 3), in NED metres (R, N, 3)."""
        if self.model == "geodetic":
            p = self.parts
            return geodetic_difference_ned(p[..., 0], p[..., 1], p[..., 2], z[:, None, 0], z[:, None, 1], z[:, None, 2])
        return self.parts[..., :3] - self.frame.to_local(z)[:, None, :]

    def _fix_log_likelihood(self, z, sigma):
        off = self._offsets_from(np.asarray(z, dtype=float))
        if np.any(self.fix_lever_arm):  # the fix is taken at particle + C_b^n r (lever arm IMU -> antenna)
            off = off + np.einsum("rij,j->ri", quat_to_dcm(self.q), self.fix_lever_arm)[:, None, :]
        return gaussian_log_likelihood(off, np.zeros((off.shape[0], 3)), np.diag(np.asarray(sigma, dtype=float) ** 2))

    def _update(self, z, sigma):
        """A position fix. Runs whose one SIR step would leave fewer than :data:`DEGENERATE_ESS` effective particles
        (a fix far sharper than the cloud: a low fix rate, few particles) are updated by tempering instead
        (:meth:`update_tempered`): after one such step the resampled cloud has fewer distinct particles than the
        state has dimensions + 1, its covariance is singular, and the Liu-West move cannot restore it (the cloud
        collapses for good: multi-imu-path1 at 1-2 Hz with 50 particles, NEES 1e12). Other runs are updated as
        before (per run, so a run's numbers do not depend on the batch)."""
        ll = self._fix_log_likelihood(z, sigma)
        x = self.logw + ll
        m = np.max(x, axis=1)
        alive = np.isfinite(m)  # a run whose every particle misses is on_collapse's case, not this one
        w = np.exp(x - np.where(alive, m, 0.0)[:, None])
        s1, s2 = np.sum(w, axis=1), np.sum(w * w, axis=1)
        degenerate = alive & (s1 * s1 < DEGENERATE_ESS * s2)  # N_eff = (sum w)^2 / sum w^2 < DEGENERATE_ESS
        if not degenerate.any():
            self.update_log_likelihood(ll)
            return
        self.update_log_likelihood(np.where(degenerate[:, None], 0.0, ll))
        self.update_tempered(lambda *_: self._fix_log_likelihood(z, sigma), runs=degenerate)

    def particle_states(self) -> tuple[np.ndarray, np.ndarray]:
        """(positions (R, N, 3) in the frame's local metres, NED velocities (R, N, 3)) of the particles (the point
        the filter tracks), copies: for measurements other than a position fix (``update_log_likelihood``)."""
        pos = self.parts[..., :3] if self.model == "linear" else self.frame.to_local(self.parts[..., :3])
        return np.array(pos, dtype=float), np.array(self.parts[..., 3:], dtype=float)

    def update_log_likelihood(self, log_likelihood) -> None:
        """Bayes update at the current time with any measurement: per-particle log-likelihoods (R, N) (eq. 3.22
        with the bootstrap proposal), then the filter's resampling and regularisation, as at a fix."""
        ll = np.asarray(log_likelihood, dtype=float)
        if ll.shape != self.logw.shape:
            raise InputDataError("log_likelihood", f"must have shape {self.logw.shape} (runs, particles), got {ll.shape}")
        self.logw, _, collapsed = sir_update(self.logw, ll, self.on_collapse)
        self.collapsed |= collapsed
        cloud, mask = resample(ParticleCloud(self.parts, self.logw), self.rngs, self.resampling, self.ess_threshold)
        if self.roughening > 0 and mask.any():
            cloud.particles = roughen(cloud.particles, self.rngs, self.roughening, mask)
        if self.kernel_h > 0 and mask.any():
            cloud.particles = self._shrink(cloud.particles, mask)
        self.parts, self.logw = np.ascontiguousarray(cloud.particles), cloud.log_weights
        self.mean = np.einsum("rn,rnd->rd", np.exp(self.logw), self.parts)

    def _shrink(self, parts, mask, h=None):
        """Liu-West kernel shrinkage in NED metres (geodetic particles are mapped to offsets from the mean)."""
        h = self.kernel_h if h is None else h
        if self.model != "geodetic":
            return kernel_shrinkage(parts, self.rngs, h, mask)
        m = parts.mean(axis=1)
        off = geodetic_difference_ned(parts[..., 0], parts[..., 1], parts[..., 2], m[:, None, 0], m[:, None, 1], m[:, None, 2])
        x = kernel_shrinkage(np.concatenate([off, parts[..., 3:]], -1), self.rngs, h, mask)
        lat, lon, h = ned_offset_to_geodetic(m[:, None, 0], m[:, None, 1], m[:, None, 2], x[..., :3])
        return np.concatenate([np.stack([lat, lon, h], -1), x[..., 3:]], -1)

    def _current(self):
        return self._native(self.mean[:, :3]), self.mean[:, 3:].copy(), self.q.copy()

    def update_tempered(self, log_likelihood_fn, target_ess: float = 0.5, max_stages: int = 200, runs=None) -> int:
        """Bayes update with a likelihood too informative for one SIR step (a SAR range of 1 mm against a cloud of
        centimetres): adaptive tempering / progressive correction (``particles.tempering_exponent``). The
        likelihood is applied in stages L^lambda_1, L^lambda_2, ... with sum lambda = 1, each the largest that
        keeps N_eff >= ``target_ess`` N, every stage followed by resampling and the Liu-West move
        (``kernel_h``, 0.3 when the filter has none), which restores distinct particles with the cloud's mean and
        covariance; ``log_likelihood_fn(positions (R, N, 3) local, velocities (R, N, 3)) -> (R, N)`` is
        evaluated again at every stage. After ``max_stages`` the rest is applied at once. ``runs`` (R,) bool
        selects the runs updated (default all; the others keep their cloud). Returns the number of stages (a plain
        SIR update is one stage)."""
        remaining = np.ones(self.parts.shape[0]) if runs is None else np.asarray(runs, dtype=bool).astype(float)
        h = self.kernel_h if self.kernel_h > 0 else 0.3
        stages = 0
        while np.any(remaining > 1e-9):
            ll = np.asarray(log_likelihood_fn(*self.particle_states()), dtype=float)
            if ll.shape != self.logw.shape:
                raise InputDataError("log_likelihood", f"must have shape {self.logw.shape}, got {ll.shape}")
            lam = remaining if stages + 1 >= max_stages else tempering_exponent(self.logw, ll, remaining, target_ess)
            part = np.where(np.isneginf(ll), -np.inf, lam[:, None] * np.where(np.isneginf(ll), 0.0, ll))
            part[lam <= 0] = 0.0
            self.logw, _, collapsed = sir_update(self.logw, part, self.on_collapse)
            self.collapsed |= collapsed
            rows = np.flatnonzero(lam > 0)  # only these runs draw random numbers (batch independence)
            sub, _ = resample(ParticleCloud(self.parts[rows], self.logw[rows]), [self.rngs[r] for r in rows],
                              self.resampling, 1.0)
            parts, logw = self.parts.copy(), self.logw.copy()
            parts[rows], logw[rows] = sub.particles, sub.log_weights
            self.parts = np.ascontiguousarray(self._shrink(parts, lam > 0, h))
            self.logw = logw
            remaining = np.maximum(remaining - lam, 0.0)
            stages += 1
        self.mean = np.einsum("rn,rnd->rd", np.exp(self.logw), self.parts)
        return stages

    def update_gaussian(self, linearize, log_likelihood_fn, z, meas_cov) -> np.ndarray:
        """Gaussian particle filter update (Kotecha & Djuric 2003) for a measurement too informative for the
        bootstrap proposal: the cloud's weighted mean m and covariance P, the Kalman update with the measurement
        linearised at m, ``linearize(p (R, 3), v (R, 3)) -> (z_hat (R, M), H (R, M, 6))`` for the state [p, v]
        (local metres, m/s), a new cloud drawn from that Gaussian posterior N(m1, P1), importance-weighted by
        ``exp(log_likelihood_fn(p, v)) N(x; m, P) / N(x; m1, P1)`` (exact for a linear measurement: equal weights),
        then the filter's resampling rule. Linear motion model only. ``z`` (R, M), ``meas_cov`` (M, M) or
        (R, M, M). Returns the importance weights' N_eff / N (R,)."""
        if self.model != "linear":
            raise ConfigError("pf.model", "the Gaussian update needs the linear motion model")
        pos, vel = self.particle_states()
        x = np.concatenate([pos, vel], -1)
        w = np.exp(self.logw)
        m = np.einsum("rn,rnd->rd", w, x)
        d = x - m[:, None]
        P = np.einsum("rn,rni,rnj->rij", w, d, d)
        zh, H = linearize(m[:, :3], m[:, 3:])
        Rm = np.broadcast_to(np.asarray(meas_cov, dtype=float), (x.shape[0],) + np.shape(meas_cov)[-2:])
        up = fuse(P, Prediction(zh, H, Rm), z).update  # the one Kalman update (Joseph form), state [p, v]
        m1, P1 = m + up.dx, up.P
        jitter = lambda C: C + (1e-12 * np.trace(C, axis1=-2, axis2=-1)[:, None, None] + 1e-300) * np.eye(6)  # noqa: E731
        L1 = np.linalg.cholesky(jitter(0.5 * (P1 + np.swapaxes(P1, -1, -2))))
        e = np.stack([g.standard_normal((self.n, 6)) for g in self.rngs])
        new = m1[:, None] + np.einsum("rij,rnj->rni", L1, e)
        L0 = np.linalg.cholesky(jitter(P))
        u = np.linalg.solve(L0[:, None], (new - m[:, None])[..., None])[..., 0]
        log_prior_over_proposal = -0.5 * np.sum(u**2, -1) + 0.5 * np.sum(e**2, -1) \
            - np.log(np.abs(np.diagonal(L0, axis1=-2, axis2=-1))).sum(-1)[:, None] \
            + np.log(np.abs(np.diagonal(L1, axis1=-2, axis2=-1))).sum(-1)[:, None]
        self.parts = np.ascontiguousarray(new)
        self.logw = np.full_like(self.logw, -np.log(self.n))
        ll = np.asarray(log_likelihood_fn(new[..., :3], new[..., 3:]), dtype=float) + log_prior_over_proposal
        ll = ll - np.max(ll, axis=1, keepdims=True)
        ess = effective_sample_size_ratio(normalize_log_weights(ll)[0])
        self.update_log_likelihood(ll)
        return ess

    def position_covariance(self) -> np.ndarray:
        """(R, 3, 3) weighted sample covariance of the particle positions now, NED metres [m^2]."""
        return self._position_cov()

    def _position_cov(self):
        return weighted_covariance(self._offsets_from(self._native(self.mean[:, :3])), self.logw)

    def cloud_positions(self) -> np.ndarray:
        """(R, N, 3) particle positions as NED metres from the cloud mean (the cloud of eq. 5.22)."""
        return self._offsets_from(self._native(self.mean[:, :3]))


def effective_sample_size_ratio(log_weights) -> np.ndarray:
    return effective_sample_size(log_weights) / np.shape(log_weights)[-1]


__all__ = ["GridParticleFilter", "MOTION_MODELS"]
