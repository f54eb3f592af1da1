"""Linear covariance analysis of the ``rda-nav`` EKF: what the SAR measurements can tell, without echoes or runs.

The error covariance is propagated along the *truth* trajectory with the filter's own model (Van Loan per
``COV_STEP``) and updated at the end of every 1-s sub-aperture with the altimeter and, per reference target, the
range and cross-range Jacobians of ``measurements.image_shift`` evaluated at the truth (no delayed-state mapping,
no second-order terms: a first-order, truth-linearised study). It answers design questions the Monte Carlo
answers only slowly: how the north 3-sigma depends on the range noise, on the cross-range model, and on the
number and spread of the targets per image (docs/scenarios/rda-nav.md §5).

Why the range noise matters for north: the zero-Doppler cross-range is ``dp_N + (y dv_E + h dv_D) / V`` =
``dp_N + (R / V) dRdot`` (LOS = (0, y, h) / R), i.e. the along-track position plus R/V (about 210 s at 10 m/s and
2.1 km) times the range-rate error, which only the sequence of range measurements determines.
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import ConfigError
from sarnav.filters import ErrorStateModel, joseph_update, propagate_covariance
from sarnav.measurements.image_shift import CrossRangeMeasurement, RangeMeasurement
from sarnav.measurements.telemetry import AltimeterMeasurement
from sarnav.rotations import quat_to_dcm
from sarnav.scenarios.rda_nav import COV_STEP, STATE_LAYOUT, RdaNavParams, reference_targets


def covariance_study(prm: RdaNavParams, range_sigma: float, cross_sigma: float, ground_ranges=None,
                     cross_model: str | None = None) -> dict:
    """Filter 1-sigma of every state over the flight of ``prm`` for a given SAR measurement noise.

    Parameters
    ----------
    prm : parsed scenario (``rda_nav.parse``); its IMU, altimeter, biases, initial P0 and trajectory are used.
    range_sigma, cross_sigma : 1-sigma of the range and cross-range measurements [m], > 0.
    ground_ranges : None (the scenario's one reference target per aperture) or a sequence of ground ranges
        [m]: one target per entry in every aperture, at the reference target's along-track position.
    cross_model : ``"zero-doppler"`` or ``"paper"`` (default: the scenario's ``sar.cross_range_model``);
        ``"paper"`` uses eq. 56 with u_c along the truth velocity.

    Returns
    -------
    {"time": (U + 1,) [s], "sigma": (U + 1, 18) filter 1-sigma, "states": the state names}
    """
    for name, v in (("range_sigma", range_sigma), ("cross_sigma", cross_sigma)):
        if not (np.isfinite(v) and v > 0):
            raise ConfigError(name, f"must be finite and > 0 m, got {v!r}")
    model_name = prm.cross_model if cross_model is None else cross_model
    L = STATE_LAYOUT
    g = prm.imu_grade
    model = ErrorStateModel(L, g.vrw, g.arw, g.accel_bias, g.gyro_bias, prm.tau_accel, prm.tau_gyro,
                            prm.bias_sigma, prm.bias_tau)
    alt = AltimeterMeasurement(prm.alt_sigma, L)
    traj = prm.trajectory
    targets = reference_targets(prm)
    if ground_ranges is not None:
        gr = np.asarray(ground_ranges, dtype=np.float64).ravel()
        if gr.size == 0 or not np.all(np.isfinite(gr) & (gr > 0)):
            raise ConfigError("ground_ranges", f"must be a non-empty list of ground ranges > 0 m, got {ground_ranges!r}")
    steps = int(round(1.0 / COV_STEP))
    P = np.diag(prm.p0_sigma**2)[None]
    sig = [np.sqrt(np.diag(P[0]))]
    for u in range(prm.n_updates):
        for s in range(steps):
            st = traj.state(np.array([u + (s + 0.5) * COV_STEP]))
            T = quat_to_dcm(st.quaternion)
            f_n = (T @ traj.specific_force(np.array([u + (s + 0.5) * COV_STEP]))[..., None])[..., 0]
            Phi, Qd = model.discretize(T, f_n, COV_STEP)
            P = propagate_covariance(P, Phi, Qd)
        end = traj.state(np.array([u + 1.0]))
        _, H_alt, R_alt = alt.predict(_nav(end))
        Hs, Rs = [H_alt[0]], [R_alt[0, 0, 0]]
        targ = targets[u]
        toc = targ[0] / traj.speed if abs(traj.heading) < 1e-12 else u + 0.5
        at = traj.state(np.array([toc]))
        p, v = at.position[0], at.velocity[0]
        w = np.array([-np.sin(traj.heading), np.cos(traj.heading), 0.0])
        ground = [targ] if ground_ranges is None else [targ - (targ - p) @ w * w + r * w for r in gr]
        for tg in ground:
            tg = np.array([tg[0], tg[1], 0.0])
            rm = RangeMeasurement(tg, range_sigma, L.n, L.index("b_range"))
            kw = dict(u_c=v, r_orig=tg) if model_name == "paper" else {}
            cm = CrossRangeMeasurement(tg, cross_sigma, L.n, L.index("b_cross"), model_name=model_name, **kw)
            Hs += [rm.predict(p)[1][0], cm.predict(p, v)[1][0]]
            Rs += [range_sigma**2, cross_sigma**2]
        H, R = np.vstack(Hs), np.diag(Rs)
        _, P, _ = joseph_update(P, H[None], R[None], np.zeros((1, H.shape[0])))
        sig.append(np.sqrt(np.diag(P[0])))
    return {"time": np.arange(prm.n_updates + 1, dtype=np.float64), "sigma": np.array(sig),
            "states": L.state_names()}


def _nav(state):
    from sarnav.ins import NavState

    z = np.zeros((1, 3))
    return NavState(p=state.position, v=state.velocity, q=state.quaternion, ba=z, bg=z, bm=z)
