"""GPS-denied multi-IMU fusion (beyond Sun 2022; extraction gap G29): the absolute fix that aids each IMU's particle
filter and weights the SIR fusion is made by the image-aided machinery of rda-nav instead of GPS.

The flight is rda-nav's (straight and level, 10 m/s, 1000 m, flat non-rotating Earth, nav-paper-sim radar at PRF
100 Hz, one geolocated reference reflector plus clutter per 1-s sub-aperture). The rig carries ``n_adis``
ADIS16465 (100 Hz, lever arms ``imu_rig.ADIS_LEVER_ARMS``) and one NovAtel IMU-ISA-100C (200 Hz) at the
reference point, which is the antenna phase centre. Each IMU has its own aided PF (``filters.grid_particle``,
linear model in the flat frame, process noise from the IMU's specs). Per sub-aperture u (pulses u .. u + 1 s):

1. every PF is propagated over the aperture (a copy, so the real filters are untouched) and the mean of the
   sensors' estimated antenna tracks is handed to ``measurements.sar_image.SubApertureImager``: echoes along the
   *true* track, RDA + mapdrift with the estimated speed, registration against the geolocated reference chip ->
   the reference target's time of closest approach eta0 and range R0 (radar timing only);
2. the SAR fix is the pair of rda-nav (``measurements.sar``): slant range ``|p_targ - p(eta0)| = R0`` (eq. 47) and
   the zero-Doppler cross-range ``v/|v| . (p(eta0) - p_targ) = 0``, with R from the measured registration errors
   (``sar_sigma``), plus a barometric altitude ``-p_D(eta0)`` (``AltimeterMeasurement``); no measurement biases;
3. the real PFs are propagated to eta0 and updated there (``update``): ``"gaussian"`` (default), the Gaussian
   particle filter update (``GridParticleFilter.update_gaussian``, Kotecha & Djuric 2003: Kalman update of the
   cloud's mean and covariance with the models' Jacobians, ``Measurement.predict``, a new cloud drawn from it and
   importance-weighted by the exact likelihood), or ``"tempered"``, the bootstrap SIR update applied by adaptive
   tempering (``update_tempered``); the exact likelihood of the three values at every particle comes from the
   models' value, Jacobian and Hessian at the prior mean (third-order accurate). A 1.25-mm range and a
   cross-range whose velocity lever is ground range / speed = 180 s make the likelihood thousands of times
   narrower than the cloud: one bootstrap SIR step keeps a few particles and even the tempered one leaves the
   filters inconsistent (docs/particles.md);
4. the SIR sensor weights (Algorithm 1, G13) are the likelihood of each sensor's estimate at eta0 given the same
   measurement, per component: the cross-range weights the along-track axis, the range the cross-track axis and
   the altitude the down axis (``per_axis``), or the product for a joint draw; the drawn indices are held until
   the next fix (G15);
5. the PFs continue to u + 1.

``fix_source = "oracle"``: the same pair synthesised from the truth at the true TOC plus N(0, sar_sigma^2)
(``Measurement.simulate``: the only mode in which truth enters a SAR measurement). ``fix_source = "gps"``: the
source's setting on the same flight, 20 Hz GPS fixes (truth + N(0, gps_sigma^2) per NED axis) aid every PF and
weight the SIR, for the comparison of the fusion gain.

Records at the ends of the sub-apertures (1 Hz; ``simulation.fusion_records``): each PF's antenna position error
against its cloud covariance; every source's error (sensors, novatel, mean, sir).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters.fusion import cloud_mean, draw_sensors, normalize_log_weights
from sarnav.filters.grid_particle import GridParticleFilter
from sarnav.filters.layout import ErrorStateLayout
from sarnav.filters.pulse_grid import FixStream, ImuStream, NavFrame, uniform_times
from sarnav.ins.state import NavState
from sarnav.measurements.sar import SarCrossRangeMeasurement, SarRangeMeasurement
from sarnav.measurements.telemetry import AltimeterMeasurement
from sarnav.radar.params import RadarParams
from sarnav.radar.presets import nav_paper_sim
from sarnav.rotations import quat_to_dcm
from sarnav.sensors.lever_arm import lever_arm_specific_force, rate_derivative
from sarnav.simulation import rda_nav_world
from sarnav.simulation.sar_echoes import simulated_imager
from sarnav.record import RunRecord
from sarnav.simulation.fusion_records import SOURCE_ATTRS, SourceRecords, run_records, source_records
from sarnav.simulation.imu_rig import ADIS_LEVER_ARMS, gnss_ins_sim_imu, rngs_for, spec_accel_psd
from sarnav.trajectory import StraightLevel
from sarnav.trajectory.sampled import closest_approach

__all__ = ["FIX_SOURCES", "SAR_UPDATES", "SAR_FIX_ATTRS", "SarFixSetup", "run_sar_fix", "run_sar_fix_records",
           "reference_targets"]

FIX_SOURCES = ("sar", "oracle", "gps")
#: how each PF takes a SAR fix: Gaussian particle filter update (default) or adaptive tempering of the bootstrap SIR
SAR_UPDATES = ("gaussian", "tempered")
#: the measurement layout of the SAR fix (position/velocity blocks of the error state; scalar biases unused: 0)
LAYOUT = ErrorStateLayout(("b_alt", "b_range", "b_cross"), scalar_units=("m", "m", "m"))
#: estimated-track epochs per second handed to the imager (the INS history of rda-nav is 10 Hz)
TRACK_RATE = 10.0
#: attributes of the record variables of :func:`run_sar_fix_records` (results.nc)
SAR_FIX_ATTRS = dict(SOURCE_ATTRS)
SAR_FIX_ATTRS.update({
    "sar_registration_error": {"units": "m", "description": "image-derived minus geometric truth per sub-aperture: "
                               "range of closest approach, along-track V x TOC error (NaN unless fix.source = 'sar')"},
    "fix_time": {"units": "s", "description": "epoch of each SAR fix (the TOC used; NaN for GPS)"},
})


@dataclass(frozen=True)
class SarFixSetup:
    """Everything a run needs (defaults: rda-nav's flight and scene, docs/particles.md "multi-imu-sar-fix")."""

    duration: float = 50.0
    speed: float = 10.0
    altitude: float = 1000.0
    radar: RadarParams = field(default_factory=nav_paper_sim)
    snr_db: float = -10.0
    scene_seed: int = 7
    ground_range: tuple = (1760.0, 1940.0)
    toc_jitter: float = 0.25
    clutter: int = 4
    clutter_per_run: bool = True
    reflector_amplitude: float = 3.16
    sar_sigma: tuple = (0.00125, 0.0315)
    alt_sigma: float = 4.0 / 3.0
    fix_source: str = "sar"
    gps_sigma: tuple = (0.3, 0.3, 0.5)
    gps_rate: float = 20.0
    n_adis: int = 3
    n_particles: int = 1000
    psd_scale: float = 1.0
    n_draws: int = 50
    per_axis: bool = True
    p0_sigma: tuple = (1.9 / 3, 1.9 / 3, 4.4 / 3, 0.1, 0.1, 0.5 / 3)
    update: str = "gaussian"

    def __post_init__(self):
        if self.update not in SAR_UPDATES:
            raise ConfigError("filter.sar_update", f"must be one of {list(SAR_UPDATES)}, got {self.update!r}")
        if self.fix_source not in FIX_SOURCES:
            raise ConfigError("fix.source", f"must be one of {list(FIX_SOURCES)}, got {self.fix_source!r}")
        if not 1 <= self.n_adis <= len(ADIS_LEVER_ARMS):
            raise ConfigError("imu.n_adis", f"must be in [1, {len(ADIS_LEVER_ARMS)}], got {self.n_adis}")

    @property
    def n_apertures(self) -> int:
        return int(np.floor(self.duration + 1e-9))

    @property
    def world(self) -> rda_nav_world.WorldFlight:
        """rda-nav's world for this flight (``simulation.rda_nav_world``): point targets, one reference reflector
        per sub-aperture, ``clutter`` Rayleigh scatterers, the reference pass the same pass (rda-nav's default)."""
        scene = {"type": "points", "seed": self.scene_seed, "ground_range": tuple(self.ground_range),
                 "toc_jitter": self.toc_jitter, "targets_per_image": 1, "clutter": self.clutter,
                 "reflector_amplitude": self.reflector_amplitude, "clutter_per_run": self.clutter_per_run,
                 "reference_offset": (0.0, 0.0), "geolocation_sigma": (0.0, 0.0, 0.0)}
        return rda_nav_world.WorldFlight(self.trajectory(), scene, self.radar, self.n_apertures)

    @property
    def sensor_names(self) -> list[str]:
        """The filters' names: ``sensor1`` .. ``sensor<n_adis>`` (the ADIS units), then ``novatel``."""
        return [f"sensor{s + 1}" for s in range(self.n_adis)] + ["novatel"]

    def trajectory(self) -> StraightLevel:
        # one second longer than the record: the last aperture's pulses and the IMU samples after it
        return StraightLevel([0.0, 0.0, -self.altitude], self.speed, 0.0, self.duration + 1.0)


def reference_targets(setup: SarFixSetup) -> np.ndarray:
    """(U, 3) one geolocated reference target per sub-aperture on the ground right of the track, TOC at the
    aperture centre +- ``toc_jitter``: rda-nav's world (``rda_nav_world.reference_targets``, ``scene_seed``)."""
    return rda_nav_world.reference_targets(setup.world)[:, 0]


def _rig_imu(traj, times, lever, model, rngs) -> ImuStream:
    """Measured samples of an IMU at body offset ``lever`` on the flat trajectory (Euler + centripetal terms)."""
    f, w = traj.specific_force(times), traj.angular_rate(times)
    f = lever_arm_specific_force(f, w, rate_derivative(w, float(times[1] - times[0])), lever)
    ba, bg = model.initial_biases(rngs)
    nu, om, *_ = model.measure(f, w, ba, bg, rngs)
    return ImuStream(times, nu, om)


@dataclass
class _Sensor:
    name: str
    lever: np.ndarray
    imu: ImuStream
    pf: GridParticleFilter

    def antenna(self, pos, q):
        """Antenna (reference point) positions of IMU positions ``pos`` (1, ..., 3) at attitudes q (1, ..., 4)."""
        return pos - np.einsum("...ij,j->...i", quat_to_dcm(q), self.lever)


def _sensors(setup: SarFixSetup, traj, seq) -> list[_Sensor]:
    """The rig's IMUs and their PFs, initialised at one common estimate drawn from P0 (per run)."""
    s0 = traj.state(0.0)
    C0 = quat_to_dcm(s0.quaternion)
    e0 = np.asarray(setup.p0_sigma) * rngs_for([seq], 90)[0].standard_normal(6)
    p0 = np.diag(np.asarray(setup.p0_sigma) ** 2)
    frame = NavFrame()
    out = []
    t_end = traj.duration
    for s, name in enumerate(setup.sensor_names):
        adis = name != "novatel"
        lever = ADIS_LEVER_ARMS[s] if adis else np.zeros(3)
        preset, rate = ("adis16465", 100.0) if adis else ("novatel-isa-100c", 200.0)
        imu = _rig_imu(traj, uniform_times(0.0, t_end, rate), lever, gnss_ins_sim_imu(preset, rate), rngs_for([seq], 10 + s))
        pf = GridParticleFilter(frame, setup.n_particles, setup.psd_scale * spec_accel_psd(preset, rate),
                                noise_at="fix", ess_threshold=0.5, kernel_h=0.3, fix_lever_arm=-lever)
        pf.initialize(0.0, (s0.position + e0[:3] + C0 @ lever)[None], (s0.velocity + e0[3:])[None], s0.quaternion,
                      p0, rngs_for([seq], 20 + s))
        out.append(_Sensor(name, lever, imu, pf))
    return out


def _antenna_now(sensor, pf):
    """(antenna position (3,), velocity (3,)) of ``pf``'s current weighted mean (run 0 of a one-run filter)."""
    pos, vel = pf.particle_states()
    w = np.exp(pf.logw[0])
    return w @ sensor.antenna(pos, pf.q[:, None, :])[0], w @ vel[0]


def _estimates(sensors, out_list):
    """(S, 1, K, 3) antenna positions and velocities of the sensors' outputs ``out_list`` (GridOutput each)."""
    pos = np.stack([s.antenna(o.position, o.quaternion) for s, o in zip(sensors, out_list)])
    vel = np.stack([o.velocity for o in out_list])
    return pos, vel


def _sar_models(target, sigma, alt_sigma):
    return (SarRangeMeasurement(target, sigma[0], LAYOUT), SarCrossRangeMeasurement(target, sigma[1], LAYOUT),
            AltimeterMeasurement(alt_sigma, LAYOUT))


def _nav(p, v):
    n = p.shape[0]
    return NavState(p=p, v=v, q=np.tile([1.0, 0, 0, 0], (n, 1)), ba=np.zeros((n, 3)), bg=np.zeros((n, 3)),
                    bm=np.zeros((n, 3)))


def _predicted(models, p, v, p_mean, v_mean):
    """(N, 3) predicted [range, cross, alt] at points (p, v) (N, 3): each model's value, Jacobian and Hessian at
    the cloud mean (``predict``), expanded to second order (exact to < 1e-7 m for clouds of metres at 2 km)."""
    L = LAYOUT
    d = np.zeros((p.shape[0], L.n))
    d[:, L.slice("p")] = p - p_mean
    d[:, L.slice("v")] = v - v_mean
    out = []
    for m in models:
        pred = m.predict(_nav(p_mean[None], v_mean[None]))
        H = pred.H[0, 0]
        A = pred.hessians[0, 0] if pred.hessians is not None else np.zeros((L.n, L.n))
        out.append(pred.z_hat[0, 0] + d @ H + 0.5 * np.einsum("ni,ij,nj->n", d, A, d))
    return np.stack(out, -1)


def _linearized(models, p, v):
    """(z_hat (1, 3), H (1, 3, 6)) of the models at the antenna point (p, v) for the state [p, v] (the lever arm
    is a constant offset of the position: the same Jacobian)."""
    L = LAYOUT
    zh, H = [], []
    for m in models:
        pred = m.predict(_nav(p[None], v[None]))
        zh.append(pred.z_hat[0, 0])
        H.append(np.r_[pred.H[0, 0, L.slice("p")], pred.H[0, 0, L.slice("v")]])
    return np.array(zh)[None], np.array(H)[None]


def _measure_sar(setup, imager, models, u, sensors, truth_traj, noise_rng):
    """(z (3,), eta0, registration errors (range, along-track) or NaN) of sub-aperture u."""
    targ = models[0].target
    t_ap = setup.radar.pulse_times(int(round(setup.radar.prf)), u)
    eta_true, r_true, _ = closest_approach(targ, t_ap, truth_traj.state(t_ap).position)
    if setup.fix_source == "oracle":
        st = truth_traj.state(np.array([eta_true]))
        nav = _nav(st.position, st.velocity)
        z = np.array([m.simulate(nav, noise=noise_rng.standard_normal((1, 1)))[0, 0] for m in models[:2]])
        return z, float(eta_true), (np.nan, np.nan)
    ap_t = u + np.arange(int(TRACK_RATE) + 1) / TRACK_RATE
    trial = [copy.deepcopy(s.pf) for s in sensors]  # the real filters are propagated to the TOC afterwards
    now = [_antenna_now(s, f) for s, f in zip(sensors, trial)]
    outs = [f.run(s.imu, u + 1.0, None, ap_t[1:]) for f, s in zip(trial, sensors)]
    pos, vel = _estimates(sensors, outs)
    pos = np.concatenate([np.stack([n[0] for n in now])[:, None, None], pos], axis=2)
    vel = np.concatenate([np.stack([n[1] for n in now])[:, None, None], vel], axis=2)
    speed_sigma = np.array([_speed_sigma(trial)])
    am = imager.measure(u, ap_t, pos.mean(axis=0), vel.mean(axis=0), speed_sigma)
    if am.status[0, 0] != 0:  # a failed image or a refused match: no fix this second
        return np.full(2, np.nan), float("nan"), (np.nan, np.nan)
    z = np.array([am.range[0, 0], 0.0])  # cross-range: 0 at zero Doppler
    return z, float(am.toc[0, 0]), (float(am.range[0, 0] - r_true), setup.speed * float(am.toc[0, 0] - eta_true))


def _speed_sigma(filters) -> float:
    """1-sigma of the forward speed of the sensors' mean estimate (the imager's mapdrift gate): the clouds' spread
    along the mean velocity, averaged over the sensors and divided by sqrt(S)."""
    sig = []
    for f in filters:
        _, v = f.particle_states()
        w = np.exp(f.logw[0])
        m = w @ v[0]
        u = m / np.linalg.norm(m)
        sig.append(np.sqrt(w @ ((v[0] - m) @ u) ** 2))
    return float(np.mean(sig) / np.sqrt(len(sig)))


def _sar_update(setup, sensors, models, z_sar, z_alt, sigma):
    """Update each PF at the TOC with the likelihood of (range, cross, alt); returns the sensors' estimates
    (S, 3) antenna positions and (S, 3) velocities after the update and the per-component log-weights of SIR."""
    z = np.r_[z_sar, z_alt]
    est_p, est_v = [], []
    for s in sensors:
        w0 = np.exp(s.pf.logw[0])
        pos0, vel0 = s.pf.particle_states()
        ref = (w0 @ s.antenna(pos0, s.pf.q[:, None, :])[0], w0 @ vel0[0])  # expansion point: the prior mean

        def loglik(pos, vel, s=s, ref=ref):
            zh = _predicted(models, s.antenna(pos, s.pf.q[:, None, :])[0], vel[0], *ref)
            return (-0.5 * np.sum(((z - zh) / sigma) ** 2, axis=-1))[None]

        def linearize(p, v, s=s):
            return _linearized(models, s.antenna(p[:, None], s.pf.q[:, None, :])[0, 0], v[0])

        if setup.update == "gaussian":
            s.pf.update_gaussian(linearize, loglik, z[None], np.diag(sigma**2))
        else:
            s.pf.update_tempered(loglik)
        p, v = _antenna_now(s, s.pf)
        est_p.append(p)
        est_v.append(v)
    est_p, est_v = np.array(est_p), np.array(est_v)
    zh = np.concatenate([_predicted(models, est_p[i:i + 1], est_v[i:i + 1], est_p[i], est_v[i]) for i in
                         range(len(sensors))])
    ll = -0.5 * ((z - zh) / sigma) ** 2  # (S, 3): cross -> along-track (N), range -> cross-track (E), alt -> D
    return est_p, est_v, ll[:, [1, 0, 2]]


def _draw(ll, setup, rng):
    """SIR indices (1, n_draws, 3) from per-axis log-likelihoods (S, 3), or jointly from their sum."""
    if setup.per_axis:
        lw, _ = normalize_log_weights(ll.T)  # (3, S): per axis over sensors
        return draw_sensors(lw.T[None], setup.n_draws, [rng])
    lw, _ = normalize_log_weights(ll.sum(-1)[None])
    return draw_sensors(lw, setup.n_draws, [rng])


def run_sar_fix(setup: SarFixSetup, seeds, settle: float = 5.0) -> tuple[SourceRecords, dict]:
    """The experiment of the module docstring for the runs of ``seeds`` (one SeedSequence each; every run is
    simulated on its own: its TOCs are its own): (records at the aperture ends, extras name -> (R, ...):
    ``registration_error`` (U, 2) [m] image-derived minus geometric range and along-track position (NaN unless
    ``fix_source == "sar"``), ``fix_time`` (U,) [s] the epochs of the SAR fixes (NaN for GPS))."""
    runs = [_one_run(setup, s) for s in seeds]
    names = setup.sensor_names
    errors = {k: np.concatenate([r[0][k] for r in runs]) for k in runs[0][0]}
    covs = {k: np.concatenate([r[1][k] for r in runs]) for k in names}
    extras = {k: np.stack([r[3][k] for r in runs]) for k in runs[0][3]}
    return source_records(runs[0][2], errors, covs, names, names + ["mean", "sir"], settle), extras


def run_sar_fix_records(setup: SarFixSetup, seeds, run_ids=None, settle: float = 5.0) -> list[RunRecord]:
    """One record per run of ``seeds`` (numbered ``run_ids``, default 0, 1, ...): :func:`run_sar_fix` as
    ``fusion_records.run_records`` with ``sar_registration_error (aperture, sar_axis)`` and ``fix_time (aperture)``
    (:data:`SAR_FIX_ATTRS`)."""
    seeds = list(seeds)
    rec, ex = run_sar_fix(setup, seeds, settle)
    return run_records(rec, list(range(len(seeds))) if run_ids is None else list(run_ids),
                       {"sar_registration_error": (("aperture", "sar_axis"), ex["registration_error"]),
                        "fix_time": (("aperture",), ex["fix_time"])})


def _one_run(setup: SarFixSetup, seed):
    if not isinstance(seed, np.random.SeedSequence):
        raise InputDataError("seed", "must be a numpy SeedSequence (one per run)")
    traj = setup.trajectory()
    sensors = _sensors(setup, traj, seed)
    U = setup.n_apertures
    targets = reference_targets(setup)
    rng_meas, rng_fuse, rng_alt = (rngs_for([seed], k)[0] for k in (30, 40, 41))
    imager = None
    if setup.fix_source == "sar":
        cseed = int(rngs_for([seed], 50)[0].integers(2**63))
        imager = simulated_imager(radar=setup.radar, truth=traj, targets=targets,
                                   scene_for=rda_nav_world.scene_factory(setup.world, targets[:, None]),
                                   reflector_amplitude=setup.reflector_amplitude, snr_db=setup.snr_db,
                                   reference_seed=setup.scene_seed, noise_seeds=[cseed],
                                   clutter_seeds=[cseed] if setup.clutter_per_run else None)
    sigma = np.r_[setup.sar_sigma, setup.alt_sigma]
    idx = np.zeros((1, setup.n_draws, 3), dtype=np.int64)
    idx[:] = (np.arange(setup.n_draws) % len(sensors))[None, :, None]  # equal draws before the first fix
    rec = {k: [] for k in setup.sensor_names + ["mean", "sir"]}
    covs = {k: [] for k in setup.sensor_names}
    reg, eta = np.full((U, 2), np.nan), np.full(U, np.nan)
    for u in range(U):
        if setup.fix_source == "gps":
            idx = _gps_second(setup, sensors, traj, u, rng_meas, rng_fuse, idx)
        else:
            models = _sar_models(targets[u], setup.sar_sigma, setup.alt_sigma)
            z, eta[u], reg[u] = _measure_sar(setup, imager, models, u, sensors, traj, rng_meas)
            if not np.all(np.isfinite(z)):  # no fix: fly the second on the IMUs alone
                for s in sensors:
                    s.pf.run(s.imu, u + 1.0)
                _record(sensors, traj, u + 1.0, idx, rec, covs)
                continue
            for s in sensors:
                if eta[u] > s.pf.t + 1e-9:  # the TOC lies inside the aperture (u, u + 1)
                    s.pf.run(s.imu, eta[u])
            z_alt = models[2].simulate(_nav(traj.state(np.array([eta[u]])).position,
                                            np.zeros((1, 3))), noise=rng_alt.standard_normal((1, 1)))[0, 0]
            _, _, ll = _sar_update(setup, sensors, models, z, z_alt, sigma)
            idx = _draw(ll, setup, rng_fuse)
            for s in sensors:
                s.pf.run(s.imu, u + 1.0)
        _record(sensors, traj, u + 1.0, idx, rec, covs)
    t = np.arange(1, U + 1, dtype=float)
    errors = {k: np.stack(v, 1) for k, v in rec.items()}
    covs = {k: np.stack(v, 1) for k, v in covs.items()}
    return errors, covs, t, {"registration_error": reg, "fix_time": eta}


def _record(sensors, traj, t, idx, rec, covs):
    """Errors (1, 3) of every sensor's antenna estimate and of the fused ones at time t, covariances (1, 3, 3)."""
    truth = traj.state(np.array([t])).position
    est = []
    for s in sensors:
        p, _ = _antenna_now(s, s.pf)
        est.append(p)
        rec[s.name].append(p[None] - truth)
        covs[s.name].append(s.pf.position_covariance())
    est = np.array(est)[None]  # (1, S, 3)
    rec["mean"].append(est.mean(axis=1) - truth)
    rec["sir"].append(cloud_mean(est, idx) - truth)


def _gps_second(setup, sensors, traj, u, rng_meas, rng_fuse, idx):
    """The GPS-aided comparison: fixes in (u, u + 1] aid every PF and weight the SIR (per NED axis)."""
    t_fix = uniform_times(u, u + 1.0, setup.gps_rate)[1:]
    truth = traj.state(t_fix).position
    sig = np.asarray(setup.gps_sigma, dtype=float)
    fixes = FixStream(t_fix, (truth + sig * rng_meas.standard_normal(truth.shape))[None], sig)
    est = []
    for s in sensors:
        if setup.update == "gaussian":  # the same update as for the SAR fixes, at every GPS fix
            for k, t in enumerate(t_fix):
                s.pf.run(s.imu, t)
                _gps_gaussian_update(s, fixes.position[0, k], sig)
        else:
            s.pf.run(s.imu, u + 1.0, fixes)
        est.append(_antenna_now(s, s.pf)[0])
    ll = -0.5 * ((fixes.position[0, -1] - np.array(est)) / sig) ** 2  # (S, 3) at the last fix (u + 1)
    return _draw(ll, setup, rng_fuse)


def _gps_gaussian_update(sensor, z, sigma):
    """Gaussian PF update of one sensor with a GPS fix ``z`` (3,) of the antenna (reference point)."""
    off = sensor.antenna(np.zeros((1, 3)), sensor.pf.q)[0]  # -C a: antenna = IMU position + off

    def linearize(p, v):
        return p + off, np.broadcast_to(np.hstack([np.eye(3), np.zeros((3, 3))]), (p.shape[0], 3, 6))

    def loglik(p, v):
        return -0.5 * np.sum(((z - (p + off)) / sigma) ** 2, axis=-1)

    sensor.pf.update_gaussian(linearize, loglik, z[None], np.diag(sigma**2))
