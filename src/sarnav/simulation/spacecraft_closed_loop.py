"""The simulated closed loop of the spacecraft SAR navigation (issue 11; Pogorelsky et al. 2022 §VI.A with simulated
ALOS-like data in place of the real PALSAR pass).

Per run (one at a time: the images are per run anyway), with ``Generator(PCG64(seeds[i]))``: 9 normals for the
initial error (``filters.mekf.disperse``), then per update 1 normal for the added range noise and one integer that
seeds the run's image (receiver noise of its acquisition, RANSAC); in ``oracle`` mode 5 normals per update instead
(geolocation 3, range, velocity), the open loop of §VI.B on the same updates (claim T19). The MEKF (``filters.mekf``)
propagates at ``mekf.dt`` between the records and updates, the measurement is ``CenterPixelMeasurement`` with the
effective velocity (G9) built on the image's r_f, the update ``filters.underweighting.underweighted_update``
(beta = 0: Joseph). An image without a match (fewer than the minimum inliers, T11) skips the update: the run goes on,
its residual is NaN, ``skipped`` = 1. As campaign records (``sarnav.record.RunRecord``, the ``spacecraft-closed-loop``
kind): :func:`run_closed_loop_records`, :func:`closed_loop_records`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from sarnav.filters.ekf import normalized_squared
from sarnav.filters.mekf import disperse, error_state, propagate, reset
from sarnav.navigation import fuse
from sarnav.ins.orbital import OrbitalNavState
from sarnav.measurements.spacecraft import CenterPixelMeasurement, effective_velocity
from sarnav.measurements.spacecraft_image import STAGES, ImagingConfig, SpacecraftImager
from sarnav.record import RunRecord
from sarnav.simulation.spacecraft import OPEN_LOOP_ATTRS, OpenLoopParams, orbit_frame_dcm, steps_of
from sarnav.trajectory.orbit import OrbitTruth, antenna_dcm, body_dcm

__all__ = ["ClosedLoopParams", "ClosedLoopRun", "run_closed_loop", "first_measurement_statistics", "imager_for",
           "MODES", "closed_loop_records", "run_closed_loop_records", "CLOSED_LOOP_ATTRS"]

MODES = ("image", "oracle")
#: attributes of the record variables of :func:`closed_loop_records` (results.nc)
CLOSED_LOOP_ATTRS = {k: v for k, v in OPEN_LOOP_ATTRS.items() if k != "beta"}
CLOSED_LOOP_ATTRS.update({
    "vic_error": {"units": "m/s", "description": "autofocus in-track (effective) velocity v_ic minus the true V_r "
                                                "(oracle: the drawn noise)"},
    "geolocation_error": {"units": "m", "description": "geolocated centre pixel r_f minus the true one (ECEF x, y, z; "
                                                      "NaN where the image gave no match)"},
    "v0_error": {"units": "m/s", "description": "processor starting velocity (from the estimate) minus the true V_r"},
    "n_inliers": {"units": "1", "description": "RANSAC inliers of the affine registration (correlation: 1 = peak "
                                               "accepted)"},
    "skipped": {"units": "1", "description": "1 where the image gave no match (fewer than min_inliers): no update"},
    "stage_seconds": {"units": "s", "description": "wall time per image and stage (echoes: the shared world of the "
                                                   "update, both passes and the reference)"},
    "autofocus_evaluations": {"units": "1", "description": "images formed by the hill climb"},
})


@dataclass(frozen=True)
class ClosedLoopParams:
    """``base``: orbit, antenna, timing, initial sigmas, noise (sigma_range, sigma_vic and D, measured from images),
    MEKF and underweighting (``simulation.spacecraft.OpenLoopParams``, steering "zero-doppler"); ``imaging``: the image
    chain; ``mode``: "image" (from echoes) or "oracle" (the open loop of §VI.B on the same updates)."""

    base: OpenLoopParams
    imaging: ImagingConfig = field(default_factory=ImagingConfig)
    mode: str = "image"


@dataclass
class ClosedLoopRun:
    """One run: time (T,), error, sigma (T, 9), nees (T,), nees_blocks (T, 3), error_ric, sigma_ric (T, 6);
    update_time (U,); residual, residual_sigma (U, 4); nis (U,); nis_dof (U,); vic_error (U,) v_ic - true V_r [m/s];
    geolocation_error (U, 3) r_f - true centre pixel [m]; v0_error (U,) starting velocity - V_r [m/s];
    n_inliers (U,); skipped (U,) 1 = no update; stage_seconds (U, len(STAGES)); autofocus_evaluations (U,)."""

    time: np.ndarray
    error: np.ndarray
    sigma: np.ndarray
    nees: np.ndarray
    nees_blocks: np.ndarray
    error_ric: np.ndarray
    sigma_ric: np.ndarray
    update_time: np.ndarray
    residual: np.ndarray
    residual_sigma: np.ndarray
    nis: np.ndarray
    nis_dof: np.ndarray
    vic_error: np.ndarray
    geolocation_error: np.ndarray
    v0_error: np.ndarray
    n_inliers: np.ndarray
    skipped: np.ndarray
    stage_seconds: np.ndarray
    autofocus_evaluations: np.ndarray


class _Record:
    def __init__(self, n_rec: int, n_upd: int):
        f = lambda *s: np.full(s, np.nan)  # noqa: E731
        self.error, self.sigma, self.nees, self.blocks = f(n_rec, 9), f(n_rec, 9), f(n_rec), f(n_rec, 3)
        self.e_ric, self.s_ric = f(n_rec, 6), f(n_rec, 6)
        self.res, self.res_sig, self.nis = f(n_upd, 4), f(n_upd, 4), f(n_upd)
        self.vic, self.geo, self.v0 = f(n_upd), f(n_upd, 3), f(n_upd)
        self.inl, self.skip = np.zeros(n_upd), np.zeros(n_upd)
        self.sec, self.evals = np.zeros((n_upd, len(STAGES))), np.zeros(n_upd)

    def state(self, i, truth, est, P):
        e = error_state(truth, est)[0]
        self.error[i], self.sigma[i] = e, np.sqrt(np.diag(P[0]))
        self.nees[i] = normalized_squared(e[None], P)[0]
        for b in range(3):
            s = slice(3 * b, 3 * b + 3)
            self.blocks[i, b] = normalized_squared(e[None, s], P[:, s, s])[0]
        C = orbit_frame_dcm(truth.r[0], truth.v[0])
        for b in range(2):
            s = slice(3 * b, 3 * b + 3)
            self.e_ric[i, s] = C @ e[s]
            self.s_ric[i, s] = np.sqrt(np.diag(C @ P[0, s, s] @ C.T))


#: the worlds (terrain, echoes, references) of recent scenarios, keyed by what they depend on: a campaign's chunks in
#: one process share them (they are pure functions of the scenario)
_IMAGERS: dict = {}


def imager_for(params: ClosedLoopParams) -> SpacecraftImager:
    """The (cached) image chain of a scenario: the same world for every run."""
    b = params.base
    key = (params.imaging, b.elements, b.duration, b.truth_dt, b.look_angle, b.squint, b.steering)
    if key not in _IMAGERS:
        if len(_IMAGERS) >= 2:
            _IMAGERS.pop(next(iter(_IMAGERS)))
        orbit = OrbitTruth(b.elements, b.duration, b.truth_dt)
        _IMAGERS[key] = SpacecraftImager(params.imaging, orbit, antenna_dcm(b.look_angle, b.squint), b.steering)
    return _IMAGERS[key]


def run_closed_loop(params: ClosedLoopParams, seeds: Sequence[np.random.SeedSequence],
                    imager: SpacecraftImager | None = None) -> list[ClosedLoopRun]:
    """The closed loop (module docstring) for each seed; the oracle mode uses the imager's world too (its true
    centre pixels on the terrain)."""
    b = params.base
    imager = imager_for(params) if imager is None else imager
    T_bs = antenna_dcm(b.look_angle, b.squint)
    return [_one_run(params, s, imager.orbit, T_bs, imager) for s in seeds]


def closed_loop_records(runs: Sequence[ClosedLoopRun], run_ids) -> list[RunRecord]:
    """One :class:`RunRecord` per :class:`ClosedLoopRun`, numbered ``run_ids`` (extras: :data:`CLOSED_LOOP_ATTRS`)."""
    return [_run_record(int(i), r) for i, r in zip(run_ids, runs)]


def run_closed_loop_records(params: ClosedLoopParams, seeds: Sequence[np.random.SeedSequence],
                            run_ids=None) -> list[RunRecord]:
    """:func:`run_closed_loop` as one record per run of ``seeds`` (numbered ``run_ids``, default 0, 1, ...)."""
    seeds = list(seeds)
    runs = run_closed_loop(params, seeds) if len(seeds) else []
    return closed_loop_records(runs, range(len(seeds)) if run_ids is None else run_ids)


def _run_record(run: int, r: ClosedLoopRun) -> RunRecord:
    ex = {"error_ric": (("time", "ric"), r.error_ric), "sigma_ric": (("time", "ric"), r.sigma_ric),
          "nees_block": (("time", "block"), r.nees_blocks), "vic_error": (("update",), r.vic_error),
          "geolocation_error": (("update", "xyz"), r.geolocation_error), "v0_error": (("update",), r.v0_error),
          "n_inliers": (("update",), r.n_inliers), "skipped": (("update",), r.skipped),
          "stage_seconds": (("update", "stage"), r.stage_seconds),
          "autofocus_evaluations": (("update",), r.autofocus_evaluations)}
    return RunRecord(run=run, time=r.time, error=r.error, sigma=r.sigma, nees=r.nees, update_time=r.update_time,
                     residual=r.residual, residual_sigma=r.residual_sigma, nis=r.nis, nis_dof=r.nis_dof.astype(int),
                     extras=ex)


def first_measurement_statistics(params: ClosedLoopParams, seeds) -> dict:
    """The paper's calibration (L510, L512): a Monte Carlo of the first image measurement over ``seeds`` (each run's
    initial error dispersed as in the campaign, its own receiver noise) -> statistics of v_ic - V_r [m/s] and of
    r_f - true centre pixel [m]: mean, std, rms (v_ic); mean (3,), covariance (3, 3), rms per axis (r_f); the number
    of images without a match."""
    b = params.base
    imager = imager_for(params)
    t_m = float(b.update_steps()[0] * b.mekf.dt)
    k0 = imager.orbit.index(0.0)
    truth0 = OrbitalNavState(imager.orbit.r[k0:k0 + 1], imager.orbit.v[k0:k0 + 1], np.array([[1.0, 0, 0, 0]]))
    vic, geo, skipped = [], [], 0
    for s in seeds:
        rng = np.random.Generator(np.random.PCG64(s))
        est, _ = disperse(truth0, b.sigma0, [rng])
        est, _ = propagate(est, np.diag(b.sigma0**2)[None], int(round(t_m / b.mekf.dt)), b.mekf)
        rng.standard_normal()
        chip = imager.chip(0, t_m)
        m = imager.measure(chip, est.r[0], est.v[0], est.q_mu[0], np.random.default_rng(int(rng.integers(2**63))))
        vic.append(m.v_ic - chip.v_r)
        if m.ok:
            geo.append(m.r_f - chip.r_b)
        else:
            skipped += 1
    vic, geo = np.asarray(vic), np.asarray(geo).reshape(-1, 3)
    return {"vic_mean": float(vic.mean()), "vic_std": float(vic.std(ddof=1)), "vic_rms": float(np.sqrt(np.mean(vic**2))),
            "geo_mean": geo.mean(axis=0), "geo_cov": np.cov(geo.T), "geo_rms": np.sqrt(np.mean(geo**2, axis=0)),
            "n": int(vic.size), "skipped": skipped}


def _one_run(params, seed, truth_orbit, T_bs, imager) -> ClosedLoopRun:
    b = params.base
    rng = np.random.Generator(np.random.PCG64(seed))
    dt = b.mekf.dt
    every = steps_of("truth_dt", b.truth_dt, dt)
    q_true = np.array([[1.0, 0.0, 0.0, 0.0]])

    def truth_at(step):
        k = step // every
        return OrbitalNavState(truth_orbit.r[k:k + 1], truth_orbit.v[k:k + 1], q_true)

    upd = b.update_steps()
    rec_steps = np.arange(0, steps_of("duration", b.duration, dt) + 1, steps_of("record", b.record_interval, dt))
    events = np.union1d(rec_steps, upd)
    out = _Record(events.size, upd.size)
    est, _ = disperse(truth_at(0), b.sigma0, [rng])
    P = np.diag(b.sigma0**2)[None]
    out.state(0, truth_at(0), est, P)
    u = 0
    for i in range(1, events.size):
        est, P = propagate(est, P, int(events[i] - events[i - 1]), b.mekf)
        truth = truth_at(int(events[i]))
        if u < upd.size and events[i] == upd[u]:
            est, P = _update(params, u, float(upd[u] * dt), truth, est, P, T_bs, rng, imager, out)
            u += 1
        out.state(i, truth, est, P)
    dof = np.where(out.skip > 0, 0, 4)
    return ClosedLoopRun(events * dt, out.error, out.sigma, out.nees, out.blocks, out.e_ric, out.s_ric, upd * dt,
                         out.res, out.res_sig, out.nis, dof, out.vic, out.geo, out.v0, out.inl, out.skip, out.sec,
                         out.evals)


def _measure(params, u, t_m, truth, est, T_bs, rng, imager, out):
    """(r_f, y) of update u, or None when the image gives no match; records the errors against the truth."""
    b = params.base
    noise = b.noise
    if params.mode == "oracle":
        d = noise.draw([rng])[0]  # geolocation (3) ~ N(0, D), range, velocity errors
        chip = imager.chip(u, t_m)
        r_f = chip.r_b + d[:3]
        v_r = effective_velocity(truth.r, truth.v, chip.r_b[None])[0][0]
        y = np.array([0.0, 0.0, chip.rho_c + d[3], v_r + d[4]])
        out.vic[u], out.geo[u] = y[3] - v_r, r_f - chip.r_b
        return r_f, y
    n_range = rng.standard_normal()
    img_rng = np.random.default_rng(int(rng.integers(2**63)))
    chip = imager.chip(u, t_m)
    m = imager.measure(chip, est.r[0], est.v[0], est.q_mu[0], img_rng)
    out.sec[u], out.evals[u], out.inl[u] = m.seconds, len(m.visited), m.n_inliers
    out.vic[u], out.v0[u] = m.v_ic - chip.v_r, m.v0 - chip.v_r
    if not m.ok:
        out.skip[u] = 1
        return None
    out.geo[u] = m.r_f - chip.r_b
    return m.r_f, np.array([0.0, 0.0, m.rho + noise.sigma_range * n_range, m.v_ic])


def _update(params, u, t_m, truth, est, P, T_bs, rng, imager, out):
    got = _measure(params, u, t_m, truth, est, T_bs, rng, imager, out)
    if got is None:  # T11: no update, propagate only
        return est, P
    r_f, y = got
    b = params.base
    T_eb = body_dcm(truth.r, truth.v, b.steering)  # perfect ADS
    meas = CenterPixelMeasurement(T_eb, T_bs, r_f[None], b.noise, velocity_model="effective")
    pred = meas.predict(est)
    beta = np.zeros(1) if b.underweighting is None else b.underweighting.beta_for(u, P)
    fused = fuse(P, pred, y[None], beta=beta)  # the navigator's update (Lear's underweighting), the MEKF's reset
    out.res[u], out.res_sig[u] = fused.residual[0], fused.residual_sigma[0]
    out.nis[u] = fused.nis[0]
    return reset(est, fused.update.dx), fused.update.P
