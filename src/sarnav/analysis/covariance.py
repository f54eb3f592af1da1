"""Linear covariance analysis: what a filter's measurements can tell, without echoes or Monte Carlo runs.

The error covariance is propagated along the *truth* trajectory with the filter's own error model (Van Loan per
step, F from the truth attitude and specific force at mid-step) and updated (Joseph) at every update epoch with
the Jacobians of the measurements evaluated at the truth: a first-order, truth-linearised study. It answers design
questions the Monte Carlo answers only slowly, e.g. how the north 3-sigma of the image-aided flight depends on the
range noise, on the cross-range model and on the number of targets per image (docs/scenarios/rda-nav.md §5).

Why the range noise matters for north there: the zero-Doppler cross-range is ``dp_N + (y dv_E + h dv_D) / V`` =
``dp_N + (R / V) dRdot`` (LOS = (0, y, h) / R), the along-track position plus R/V (about 210 s at 10 m/s and
2.1 km) times the range-rate error, which only the sequence of range measurements determines.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from sarnav.errors import ConfigError
from sarnav.filters import propagate_covariance
from sarnav.filters.prediction import Prediction, stack_predictions
from sarnav.filters.update import fuse
from sarnav.ins import NavState
from sarnav.measurements.sar import SarCrossRangeMeasurement, SarRangeMeasurement
from sarnav.measurements.telemetry import AltimeterMeasurement
from sarnav.navigation import error_model
from sarnav.rotations import quat_to_dcm
from sarnav.simulation.rda_nav import COV_STEP, STATE_LAYOUT, RdaNavParams, reference_targets

__all__ = ["truth_linearised_covariance", "sar_covariance_study", "rda_nav_covariance_study"]


def _nav(state, n_bias: int = 3) -> NavState:
    """A one-run NavState at a truth state (biases zero: the Jacobians do not depend on them)."""
    z = np.zeros((1, 3))
    return NavState(p=state.position, v=state.velocity, q=state.quaternion, ba=z, bg=z, bm=np.zeros((1, n_bias)))


def truth_linearised_covariance(model, trajectory, p0_sigma, n_updates: int, steps: int, step: float,
                                predict: Callable[[int, object], Prediction]) -> np.ndarray:
    """(n_updates + 1, n) filter 1-sigma at t = 0 and after each update (every ``steps * step`` s).

    ``model``: an ``ErrorStateModel``; ``trajectory``: the truth; ``predict(u, truth_state)``: the stacked
    prediction (one run) of the measurements of update u from the truth state at its epoch.
    """
    P = np.diag(np.asarray(p0_sigma, dtype=np.float64) ** 2)[None]
    sig = [np.sqrt(np.diag(P[0]))]
    interval = steps * step
    for u in range(n_updates):
        for s in range(steps):
            t = np.array([u * interval + (s + 0.5) * step])
            st = trajectory.state(t)
            T = quat_to_dcm(st.quaternion)
            f_n = (T @ trajectory.specific_force(t)[..., None])[..., 0]
            Phi, Qd = model.discretize(T, f_n, step)
            P = propagate_covariance(P, Phi, Qd)
        pred = predict(u, trajectory.state(np.array([(u + 1) * interval])))
        P = fuse(P, pred, pred.z_hat).update.P  # the filters' one update; the covariance does not see z
        sig.append(np.sqrt(np.diag(P[0])))
    return np.array(sig)


def sar_covariance_study(model, trajectory, p0_sigma, alt_sigma: float, targets, range_sigma: float,
                         cross_sigma: float, ground_ranges=None, cross_model: str = "zero-doppler",
                         step: float = 0.1) -> dict:
    """Filter 1-sigma of the image-aided flight (altimeter + SAR range and cross-range every second).

    Parameters
    ----------
    model : the filter's ``ErrorStateModel`` (layout with scalar biases b_alt, b_range, b_cross).
    trajectory : the truth (straight, level); p0_sigma : (n,) initial 1-sigma; alt_sigma : altimeter 1-sigma [m].
    targets : (U, 3) the reference target of each one-second sub-aperture.
    range_sigma, cross_sigma : 1-sigma of the range and cross-range measurements [m], > 0.
    ground_ranges : None (one target per aperture) or ground ranges [m]: one target per entry in every aperture,
        at the reference target's along-track position.
    cross_model : ``"zero-doppler"`` or ``"paper"`` (eq. 56 with u_c along the truth velocity).

    Returns
    -------
    {"time": (U + 1,) [s], "sigma": (U + 1, n) filter 1-sigma, "states": the state names}
    """
    for name, v in (("range_sigma", range_sigma), ("cross_sigma", cross_sigma)):
        if not (np.isfinite(v) and v > 0):
            raise ConfigError(name, f"must be finite and > 0 m, got {v!r}")
    if ground_ranges is not None:
        gr = np.asarray(ground_ranges, dtype=np.float64).ravel()
        if gr.size == 0 or not np.all(np.isfinite(gr) & (gr > 0)):
            raise ConfigError("ground_ranges", f"must be a non-empty list of ground ranges > 0 m, got {ground_ranges!r}")
    L = model.layout
    alt = AltimeterMeasurement(alt_sigma, L)
    targets = np.asarray(targets, dtype=np.float64)
    w = np.array([-np.sin(trajectory.heading), np.cos(trajectory.heading), 0.0])

    def predict(u, end):
        parts = [alt.predict(_nav(end))]
        targ = targets[u]
        toc = targ[0] / trajectory.speed if abs(trajectory.heading) < 1e-12 else u + 0.5
        at = _nav(trajectory.state(np.array([toc])))
        p, v = at.p[0], at.v[0]
        ground = [targ] if ground_ranges is None else [targ - (targ - p) @ w * w + r * w for r in gr]
        for tg in ground:
            tg = np.array([tg[0], tg[1], 0.0])
            kw = dict(u_c=v[None], r_orig=tg[None]) if cross_model == "paper" else {}
            parts += [SarRangeMeasurement(tg, range_sigma, L).predict(at),
                      SarCrossRangeMeasurement(tg, cross_sigma, L, model=cross_model, **kw).predict(at)]
        return stack_predictions(parts)

    n_upd = targets.shape[0]
    steps = int(round(1.0 / step))
    sig = truth_linearised_covariance(model, trajectory, p0_sigma, n_upd, steps, step, predict)
    return {"time": np.arange(n_upd + 1, dtype=np.float64), "sigma": sig, "states": L.state_names()}


def rda_nav_covariance_study(prm: RdaNavParams, range_sigma: float, cross_sigma: float, ground_ranges=None,
                             cross_model: str | None = None) -> dict:
    """:func:`sar_covariance_study` of an rda-nav scenario's filter for a given SAR noise: its IMU model, altimeter,
    biases, P0, trajectory and (first) reference targets; ``cross_model`` defaults to the scenario's
    ``sar.cross_range_model``; ``ground_ranges``: several targets per aperture (``scenarios.rda_nav`` names it
    ``covariance_study``)."""
    model = error_model(STATE_LAYOUT, prm.imu_filter, prm.bias_sigma, prm.bias_tau)
    return sar_covariance_study(model, prm.trajectory, prm.p0_sigma, prm.alt_sigma, reference_targets(prm),
                                range_sigma, cross_sigma, ground_ranges=ground_ranges,
                                cross_model=prm.cross_model if cross_model is None else cross_model, step=COV_STEP)
