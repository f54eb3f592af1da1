"""Open-loop Monte Carlo of the spacecraft SAR navigation (Pogorelsky et al. 2022, §VI.B-VII; extraction seed-002).

Truth: the Table 2 orbit (G1 filled, ``trajectory.orbit.table2_elements``) integrated with RK4 (point mass + J2);
exact LVLH attitude (G4), perfect ADS; true misalignment = identity (G17). Filter: the MEKF of ``filters.mekf``
mechanized at 100 Hz (eqs. 8-15). Every ``update_interval`` (8.2 s) an image: the true boresight meets WGS-84 at r_f;
the filter gets r_f,geo = r_f + N(0, D), y = [0, 0, rho + N(0, 1 m^2), |v| + N(0, 0.54^2)] (``measurements.spacecraft``)
and updates with Lear underweighting (``filters.underweighting``) or the plain Joseph form (beta = 0).

Updates (gap G11): at t_k = 8.2 k s, k = 1, 2, ... while t_k <= duration: 73 updates in 600 s (the last at
598.6 s); the paper says 72 (``n_updates=72`` reproduces that count by dropping the last).

Random numbers: run i uses only ``Generator(PCG64(seeds[i]))``: 9 normals for its initial error, then at each record
or update time 3 for the true misalignment's random walk (only when ``truth_misalignment_psd`` > 0), then 5 per update
(geolocation 3, range, speed). A run's numbers do not depend on which runs share the batch.

Output: :class:`OpenLoopResult` with per-run arrays; errors are truth - estimate in ECEF (rX rY rZ vX vY vZ) and
about the antenna axes (muX muY muZ; z = boresight). Records are at multiples of ``record_interval`` and at the
updates (posterior there; the prior 1-sigma at each update is in ``sigma_prior``); as campaign records
(``sarnav.record.RunRecord``, the ``spacecraft`` kind): :func:`run_open_loop_records`, :func:`open_loop_records`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from sarnav.errors import ConfigError, require_positive
from sarnav.filters.ekf import normalized_squared
from sarnav.filters.mekf import STATE_NAMES, MekfModel, disperse, error_state, propagate, reset
from sarnav.filters.underweighting import LearUnderweighting
from sarnav.ins.orbital import OrbitalNavState
from sarnav.navigation import fuse
from sarnav.record import RunRecord
from sarnav.measurements.spacecraft import MEASUREMENT_NAMES, SarMeasurementNoise, boresight_intersection, simulate_image
from sarnav.rotations import quat_multiply, quat_normalize, rotvec_to_quat
from sarnav.trajectory.orbit import STEERING, KeplerElements, OrbitTruth, antenna_dcm, body_dcm, lvlh_dcm, table2_elements

__all__ = ["OpenLoopParams", "OpenLoopResult", "run_open_loop", "check_geometry", "radial_intrack_crosstrack", "orbit_frame_dcm",
           "open_loop_records", "run_open_loop_records", "OPEN_LOOP_ATTRS", "STATE_UNITS", "MEAS_UNITS", "RIC_NAMES",
           "RIC_UNITS", "BLOCK_NAMES"]

#: units of the records' states (``filters.mekf.STATE_NAMES``) and measurements (``MEASUREMENT_NAMES``)
STATE_UNITS = ("m", "m", "m", "m/s", "m/s", "m/s", "rad", "rad", "rad")
MEAS_UNITS = ("1", "1", "m", "m/s")
#: the ``ric`` and ``block`` coordinates of the records' extras
RIC_NAMES = ("pR", "pI", "pC", "vR", "vI", "vC")
RIC_UNITS = ("m", "m", "m", "m/s", "m/s", "m/s")
BLOCK_NAMES = ("position", "velocity", "misalignment")
#: attributes of the record variables of :func:`open_loop_records` (results.nc)
OPEN_LOOP_ATTRS = {
    "error_ric": {"units_coordinate": "ric_units", "description": "position / velocity error in the radial, "
                  "in-track, cross-track frame of the true orbit (truth - estimate)"},
    "sigma_ric": {"units_coordinate": "ric_units", "description": "filter 1-sigma in the radial, in-track, "
                  "cross-track frame (the ECEF covariance blocks rotated)"},
    "nees_block": {"units": "1", "description": "NEES of the position, velocity and misalignment blocks (3 dof each)"},
    "beta": {"units": "1", "description": "Lear underweighting factor beta applied at each update (0: none)"},
}


def steps_of(field_name: str, value: float, dt: float) -> int:
    """``value`` [s] as a whole number >= 1 of steps ``dt`` [s] (ConfigError naming ``field_name`` otherwise)."""
    n = int(round(value / dt))
    if n < 1 or abs(n * dt - value) > 1e-9 * max(1.0, value):
        raise ConfigError(field_name, f"must be a positive multiple of the mechanization step {dt} s, got {value!r}")
    return n


@dataclass(frozen=True)
class OpenLoopParams:
    """All parameters of the open-loop campaign, SI units (angles in rad). Defaults: paper TC-2 (:meth:`tc2`).

    elements : truth orbit at t = 0; duration [s]; update_interval [s] (8.2); n_updates : None for every
    t_k = k * interval <= duration (73), or fewer (72 as the paper counts); record_interval [s];
    truth_dt : RK4 step [s]; look_angle, squint [rad] (34.3 deg right, 0: G3); sigma_r0 [m], sigma_v0 [m/s],
    sigma_mu0 [rad] initial 1-sigma per axis (Table 4); noise : range/speed sigmas and D (G8: 5^2 I m^2);
    mekf : Q_PSD, dt (0.01 s) and the G6/G7 switches; underweighting : None or a :class:`LearUnderweighting`;
    truth_misalignment_psd [rad^2/s] : 0 (default, G17/G18: the true misalignment is constant, as the paper states,
    while the filter still adds Q_mu) or a random-walk PSD of the true misalignment (the filter's own model when
    equal to ``mekf.q_misalignment``); steering : body attitude law (``trajectory.orbit.STEERING``: "lvlh", the
    paper's, or "zero-doppler", the closed loop's).
    """

    elements: KeplerElements = field(default_factory=table2_elements)
    duration: float = 600.0
    update_interval: float = 8.2
    n_updates: int | None = None
    record_interval: float = 1.0
    truth_dt: float = 0.1
    look_angle: float = math.radians(34.3)
    squint: float = 0.0
    sigma_r0: float = 1000.0
    sigma_v0: float = 10.0
    sigma_mu0: float = math.radians(0.01)
    noise: SarMeasurementNoise = field(default_factory=SarMeasurementNoise)
    mekf: MekfModel = field(default_factory=MekfModel)
    underweighting: LearUnderweighting | None = None
    truth_misalignment_psd: float = 0.0
    steering: str = "lvlh"

    def __post_init__(self):
        if self.steering not in STEERING:
            raise ConfigError("antenna.steering", f"must be one of {tuple(STEERING)}, got {self.steering!r}")
        for name, unit in (("sigma_r0", "m"), ("sigma_v0", "m/s"), ("sigma_mu0", "rad")):
            require_positive(f"initial.{name}", getattr(self, name), unit)
        if not (math.isfinite(self.truth_misalignment_psd) and self.truth_misalignment_psd >= 0):
            raise ConfigError("truth.misalignment_psd", f"must be finite and >= 0 rad^2/s, got "
                              f"{self.truth_misalignment_psd!r}")
        dt = self.mekf.dt
        steps_of("simulation.duration", self.duration, dt)
        steps_of("simulation.update_interval", self.update_interval, dt)
        steps_of("simulation.record_interval", self.record_interval, dt)
        every = steps_of("simulation.truth_dt", self.truth_dt, dt)
        for name in ("update_interval", "record_interval"):
            if steps_of(name, getattr(self, name), dt) % every:
                raise ConfigError(f"simulation.{name}", f"must be a multiple of truth_dt = {self.truth_dt} s")
        if self.n_updates is not None and not (isinstance(self.n_updates, int) and self.n_updates >= 0):
            raise ConfigError("simulation.n_updates", f"must be an integer >= 0 or None, got {self.n_updates!r}")
        antenna_dcm(self.look_angle, self.squint)  # validates the angles

    @classmethod
    def tc1(cls, **changes) -> "OpenLoopParams":
        """Test case 1: misalignment 0.1 deg 1-sigma, beta_bar = 0.2 on the first 10 updates (Table 4, L514)."""
        kw = dict(sigma_mu0=math.radians(0.1), underweighting=LearUnderweighting(beta=0.2, first_updates=10))
        kw.update(changes)
        return cls(**kw)

    @classmethod
    def tc2(cls, **changes) -> "OpenLoopParams":
        """Test case 2: misalignment 0.01 deg 1-sigma, no underweighting (Table 4, L514)."""
        kw = dict(sigma_mu0=math.radians(0.01), underweighting=None)
        kw.update(changes)
        return cls(**kw)

    @property
    def sigma0(self) -> np.ndarray:
        return np.repeat([self.sigma_r0, self.sigma_v0, self.sigma_mu0], 3)

    def update_steps(self) -> np.ndarray:
        dt = self.mekf.dt
        every = steps_of("update_interval", self.update_interval, dt)
        total = steps_of("duration", self.duration, dt)
        steps = np.arange(every, total + 1, every)
        return steps if self.n_updates is None else steps[: self.n_updates]


@dataclass
class OpenLoopResult:
    """Per-run arrays of an open-loop campaign (R runs, T records, U updates); SI units.

    time (T,) [s]; error, sigma (R, T, 9) truth - estimate and filter 1-sigma (STATE_NAMES); nees (R, T) (9 dof);
    nees_blocks (R, T, 3): NEES of the position, velocity and misalignment blocks (3 dof each);
    cov_blocks (R, T, 3, 3, 3): the three diagonal 3 x 3 blocks of P; update_time (U,) [s];
    residual, residual_sigma (R, U, 4) y - z_hat and sqrt(diag S) (MEASUREMENT_NAMES); nis (R, U) (4 dof, with the
    underweighted S where beta > 0); beta (R, U); sigma_prior (R, U, 9) 1-sigma before each update;
    truth_r, truth_v (T, 3) ECEF truth at the records.
    """

    time: np.ndarray
    error: np.ndarray
    sigma: np.ndarray
    nees: np.ndarray
    nees_blocks: np.ndarray
    cov_blocks: np.ndarray
    update_time: np.ndarray
    residual: np.ndarray
    residual_sigma: np.ndarray
    nis: np.ndarray
    beta: np.ndarray
    sigma_prior: np.ndarray
    truth_r: np.ndarray
    truth_v: np.ndarray
    state_names: tuple = STATE_NAMES
    measurement_names: tuple = MEASUREMENT_NAMES


class _Recorder:
    def __init__(self, runs: int, n_rec: int, n_upd: int):
        self.error = np.empty((runs, n_rec, 9))
        self.sigma = np.empty((runs, n_rec, 9))
        self.nees = np.empty((runs, n_rec))
        self.nees_blocks = np.empty((runs, n_rec, 3))
        self.cov_blocks = np.empty((runs, n_rec, 3, 3, 3))
        self.residual = np.empty((runs, n_upd, 4))
        self.residual_sigma = np.empty((runs, n_upd, 4))
        self.nis = np.empty((runs, n_upd))
        self.beta = np.empty((runs, n_upd))
        self.sigma_prior = np.empty((runs, n_upd, 9))

    def record(self, i: int, truth: OrbitalNavState, est: OrbitalNavState, P):
        e = error_state(truth, est)
        self.error[:, i] = e
        self.sigma[:, i] = np.sqrt(np.diagonal(P, axis1=1, axis2=2))
        self.nees[:, i] = normalized_squared(e, P)
        for b in range(3):
            blk = slice(3 * b, 3 * b + 3)
            self.cov_blocks[:, i, b] = P[:, blk, blk]
            self.nees_blocks[:, i, b] = normalized_squared(e[:, blk], P[:, blk, blk])


def run_open_loop(params: OpenLoopParams, seeds: Sequence[np.random.SeedSequence]) -> OpenLoopResult:
    """The open-loop campaign of paper §VI.B for ``len(seeds)`` runs, batched (module docstring)."""
    rngs = [np.random.Generator(np.random.PCG64(s)) for s in seeds]
    runs, dt = len(rngs), params.mekf.dt
    truth_orbit = OrbitTruth(params.elements, params.duration, params.truth_dt)
    every = steps_of("truth_dt", params.truth_dt, dt)
    q_true = np.tile([1.0, 0.0, 0.0, 0.0], (runs, 1))  # G17: the true misalignment is the identity

    def truth_at(step: int) -> OrbitalNavState:
        k = step // every
        return OrbitalNavState(np.repeat(truth_orbit.r[k:k + 1], runs, 0), np.repeat(truth_orbit.v[k:k + 1], runs, 0),
                               q_true)

    def walk(q, n_steps: int):  # optional random walk of the true misalignment: 3 normals per run and event
        if params.truth_misalignment_psd == 0.0:
            return q
        d = np.stack([g.standard_normal(3) for g in rngs]) * math.sqrt(params.truth_misalignment_psd * n_steps * dt)
        return quat_normalize(quat_multiply(rotvec_to_quat(-d), q))

    upd = params.update_steps()
    rec = np.arange(0, steps_of("duration", params.duration, dt) + 1, steps_of("record", params.record_interval, dt))
    events = np.union1d(rec, upd)
    out = _Recorder(runs, events.size, upd.size)
    est, _ = disperse(truth_at(0), params.sigma0, rngs)
    P = np.tile(np.diag(params.sigma0**2), (runs, 1, 1))
    T_bs = antenna_dcm(params.look_angle, params.squint)
    out.record(0, truth_at(0), est, P)
    u = 0
    for i in range(1, events.size):
        est, P = propagate(est, P, int(events[i] - events[i - 1]), params.mekf)
        q_true = walk(q_true, int(events[i] - events[i - 1]))
        truth = truth_at(int(events[i]))
        if u < upd.size and events[i] == upd[u]:
            est, P = _update(u, truth, est, P, T_bs, params, rngs, out)
            u += 1
        out.record(i, truth, est, P)
    idx = events // every
    return OpenLoopResult(events * dt, out.error, out.sigma, out.nees, out.nees_blocks, out.cov_blocks, upd * dt,
                          out.residual, out.residual_sigma, out.nis, out.beta, out.sigma_prior,
                          truth_orbit.r[idx], truth_orbit.v[idx])


def check_geometry(params: OpenLoopParams) -> None:
    """Raise ConfigError("antenna.look_angle_deg") when the true boresight misses the WGS-84 ellipsoid at t = 0 or at
    any update time of the flight (the truth orbit is integrated once, RK4 at ``truth_dt``)."""
    truth = OrbitTruth(params.elements, params.duration, params.truth_dt)
    k = np.unique(np.r_[0, np.rint(params.update_steps() * params.mekf.dt / params.truth_dt).astype(int)])
    r, v = truth.r[k], truth.v[k]
    T_es = antenna_dcm(params.look_angle, params.squint) @ body_dcm(r, v, params.steering)
    try:
        boresight_intersection(r, T_es)
    except ConfigError as err:
        raise ConfigError("antenna.look_angle_deg", err.message) from None


def _update(u, truth, est, P, T_bs, params, rngs, out):
    """One image: simulate it from the truth, predict from the estimate, underweighted Joseph update, reset."""
    T_eb = body_dcm(truth.r, truth.v, params.steering)  # perfect ADS (G4)
    meas, y, _ = simulate_image(truth, T_eb, T_bs, params.noise, rngs)
    pred = meas.predict(est)
    beta = np.zeros(est.runs) if params.underweighting is None else params.underweighting.beta_for(u, P)
    out.sigma_prior[:, u] = np.sqrt(np.diagonal(P, axis1=1, axis2=2))
    fused = fuse(P, pred, y, beta=beta)  # the navigator's update (Lear's underweighting), the MEKF's own reset
    out.residual[:, u] = fused.residual
    out.residual_sigma[:, u] = fused.residual_sigma
    out.nis[:, u] = fused.nis
    out.beta[:, u] = beta
    return reset(est, fused.update.dx), fused.update.P


def orbit_frame_dcm(r, v):
    """C (..., 3, 3): ECEF -> radial / in-track / cross-track of the orbit (rows r^, h^ x r^, h^; h = r x v_inertial,
    v_inertial = v + w x r). Equals LVLH up to axis signs/order: radial = -z_b, in-track = x_b, cross = -y_b."""
    T = lvlh_dcm(r, v)
    return np.stack([-T[..., 2, :], T[..., 0, :], -T[..., 1, :]], axis=-2)


def radial_intrack_crosstrack(result: OpenLoopResult):
    """Position and velocity errors and 1-sigma in the radial / in-track / cross-track frame of the true orbit.

    Returns (error (R, T, 6), sigma (R, T, 6)): [r_R, r_I, r_C, v_R, v_I, v_C] [m, m/s].
    """
    C = orbit_frame_dcm(result.truth_r, result.truth_v)  # (T, 3, 3)
    err = np.concatenate([np.einsum("tij,rtj->rti", C, result.error[..., 0:3]),
                          np.einsum("tij,rtj->rti", C, result.error[..., 3:6])], axis=-1)
    sig = []
    for b in range(2):
        cov = np.einsum("tij,rtjk,tlk->rtil", C, result.cov_blocks[:, :, b], C)
        sig.append(np.sqrt(np.diagonal(cov, axis1=-2, axis2=-1)))
    return err, np.concatenate(sig, axis=-1)


def open_loop_records(res: OpenLoopResult, run_ids) -> list[RunRecord]:
    """One :class:`RunRecord` per run of an ``OpenLoopResult`` (extras: RIC errors and sigmas, block NEES, beta)."""
    err_ric, sig_ric = radial_intrack_crosstrack(res)
    out = []
    for i, rid in enumerate(run_ids):
        out.append(RunRecord(
            run=int(rid), time=res.time.copy(), error=res.error[i], sigma=res.sigma[i], nees=res.nees[i],
            update_time=res.update_time.copy(), residual=res.residual[i], residual_sigma=res.residual_sigma[i],
            nis=res.nis[i], nis_dof=np.full(res.update_time.size, 4, dtype=int),
            extras={"error_ric": (("time", "ric"), err_ric[i]), "sigma_ric": (("time", "ric"), sig_ric[i]),
                    "nees_block": (("time", "block"), res.nees_blocks[i]), "beta": (("update",), res.beta[i])}))
    return out


def run_open_loop_records(params: OpenLoopParams, seeds: Sequence[np.random.SeedSequence],
                          run_ids=None) -> list[RunRecord]:
    """:func:`run_open_loop` as one record per run of ``seeds`` (numbered ``run_ids``, default 0, 1, ...)."""
    seeds = list(seeds)
    return open_loop_records(run_open_loop(params, seeds), range(len(seeds)) if run_ids is None else run_ids)
