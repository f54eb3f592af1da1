"""Per-run arrays of the navigation-source experiments (multi-IMU fusion, UPF flight, per-pulse sources) in the
shape of a campaign record (``sarnav.record.RunRecord``: :func:`run_records`; the scenario kinds name them).

Two kinds of output (docs/particles.md "Scenarios"):

* the **filters with a covariance** (each IMU's aided PF, the NovAtel PF, the UPF, the KF): their position error
  after each update against the 1-sigma of their own covariance (the cloud's sample covariance for a PF, P for the
  KF), as the states ``<filter>_pN, _pE, _pD``; the NEES of the stack is ``sum_f e_f^T P_f^-1 e_f`` with
  ``3 F`` degrees of freedom (its expectation is 3 F for consistent filters whatever their cross-correlation,
  so the mean NEES is a valid check; its spread is that of independent filters only when they are independent);
* every **navigation source** (the filters and the fused outputs, which have no covariance: the mean, SIR, the
  fix): the NED error time series ``source_error`` and, per run, the mean squared 3-D error after the settling
  time ``source_ms``, from which ``summary.json`` -> ``rmse`` is sqrt(mean over runs).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sarnav.errors import InputDataError
from sarnav.record import RunRecord

__all__ = ["SourceRecords", "source_records", "run_records", "stacked_nees", "filter_nees", "mean_square_after", "AXES",
           "SOURCE_ATTRS"]

#: the ``axis`` coordinate of ``source_error``
AXES = ("N", "E", "D")
#: attributes of the record variables of :func:`run_records` (results.nc)
SOURCE_ATTRS = {
    "source_error": {"units": "m", "description": "estimate minus truth of every navigation source, NED [m], at the "
                                                  "output epochs (fused sources included)"},
    "source_ms": {"units": "m2", "description": "per run: mean over the epochs after the settling time of the "
                                                "squared 3-D position error [m^2]; summary.json rmse = sqrt(mean "
                                                "over runs)"},
    "filter_nees": {"units": "1", "description": "NEES of each filter's position, e^T P^-1 e with its own "
                                                 "covariance (cloud sample covariance / KF P), 3 dof"},
}


@dataclass
class SourceRecords:
    """``time`` (K,) [s]; ``filters`` (F names) and ``error`` / ``sigma`` (R, K, 3F) [m], ``nees`` (R, K) of the
    stack and ``filter_nees`` (R, K, F) of each filter (3 dof); ``sources`` (S names), ``source_error``
    (R, K, S, 3) [m], ``source_ms`` (R, S) [m^2]."""

    time: np.ndarray
    filters: list
    error: np.ndarray
    sigma: np.ndarray
    nees: np.ndarray
    sources: list
    source_error: np.ndarray
    source_ms: np.ndarray
    filter_nees: np.ndarray | None = None

    def state_names(self) -> list[str]:
        return [f"{f}_p{a}" for f in self.filters for a in AXES]


def filter_nees(errors, covariances) -> np.ndarray:
    """``e_f^T P_f^-1 e_f`` per filter: errors (F, R, K, 3), covariances (F, R, K, 3, 3) -> (F, R, K)."""
    e = np.asarray(errors, dtype=float)
    P = np.asarray(covariances, dtype=float)
    if P.shape != e.shape + (3,):
        raise InputDataError("covariances", f"need shape {e.shape + (3,)}, got {P.shape}")
    try:
        return np.einsum("frki,frki->frk", e, np.linalg.solve(P, e[..., None])[..., 0])
    except np.linalg.LinAlgError:
        pass
    # a particle cloud collapsed onto fewer than 4 distinct points (resampling faster than its process noise spreads
    # it) has a singular covariance: the NEES is undefined there (NaN), the other epochs keep their values
    out = np.full(e.shape[:-1], np.nan)
    for idx in np.ndindex(*e.shape[:-1]):
        try:
            out[idx] = e[idx] @ np.linalg.solve(P[idx], e[idx])
        except np.linalg.LinAlgError:
            pass
    return out


def stacked_nees(errors, covariances) -> np.ndarray:
    """``sum_f e_f^T P_f^-1 e_f``: errors (F, R, K, 3), covariances (F, R, K, 3, 3) -> (R, K)."""
    return filter_nees(errors, covariances).sum(axis=0)


def mean_square_after(err, times, settle: float) -> np.ndarray:
    """Per run, the mean over epochs ``times >= settle`` of the squared 3-D error: err (R, K, 3) -> (R,) [m^2]."""
    k = np.asarray(times) >= settle
    if not np.any(k):
        raise InputDataError("settle", f"no epoch after the settling time {settle} s (last epoch {times[-1]} s)")
    return np.mean(np.sum(np.asarray(err)[:, k] ** 2, axis=-1), axis=1)


def source_records(times, errors: dict, covariances: dict, filters, sources, settle: float,
                   stride: int = 1, ms: dict | None = None) -> SourceRecords:
    """Records of the sources at ``times`` (K,): ``errors`` name -> (R, K, 3) estimate - truth [m],
    ``covariances`` name -> (R, K, 3, 3) for the ``filters``; ``source_ms`` from the full series (or ``ms`` name ->
    (R,) when the caller accumulated it at a higher rate); the time series are kept every ``stride`` epochs."""
    times = np.asarray(times, dtype=float)
    for name in list(filters) + list(sources):
        if name not in errors or np.shape(errors[name])[1:] != (times.size, 3):
            raise InputDataError(f"errors.{name}", f"need (runs, {times.size}, 3) errors")
    for name in filters:
        if name not in covariances:
            raise InputDataError(f"covariances.{name}", "missing (a filter needs its covariance)")
    sel = slice(None, None, int(stride))
    e = np.stack([errors[f] for f in filters])[:, :, sel]
    P = np.stack([covariances[f] for f in filters])[:, :, sel]
    sigma = np.sqrt(np.diagonal(P, axis1=-2, axis2=-1))
    if ms is None:
        source_ms = np.stack([mean_square_after(errors[s], times, settle) for s in sources], -1)
    else:
        source_ms = np.stack([np.asarray(ms[s], dtype=float) for s in sources], -1)
    per = filter_nees(e, P)
    return SourceRecords(times[sel], list(filters), np.concatenate(list(e), -1), np.concatenate(list(sigma), -1),
                         per.sum(axis=0), list(sources), np.stack([errors[s][:, sel] for s in sources], 2),
                         source_ms, np.moveaxis(per, 0, -1))


def run_records(rec: SourceRecords, run_ids, extras=None, sources: bool = True) -> list[RunRecord]:
    """One RunRecord per run: states = the filters' position errors, no measurement residuals (the filters'
    updates are the fixes; their consistency is the NEES), ``filter_nees``, (``sources``) ``source_error`` /
    ``source_ms`` and ``extras`` name -> (dims, (R, ...) array) as kind variables."""
    out = []
    for i, run in enumerate(run_ids):
        ex = {"filter_nees": (("time", "filter"), rec.filter_nees[i])}
        if sources:
            ex["source_error"] = (("time", "source", "axis"), rec.source_error[i])
            ex["source_ms"] = (("source",), rec.source_ms[i])
        for name, (dims, arr) in (extras or {}).items():
            ex[name] = (dims, arr[i])
        out.append(RunRecord(run=int(run), time=rec.time.copy(), error=rec.error[i], sigma=rec.sigma[i],
                             nees=rec.nees[i], update_time=rec.time[:0].copy(), residual=rec.error[i, :0, :0],
                             residual_sigma=rec.error[i, :0, :0], nis=rec.time[:0].copy(),
                             nis_dof=rec.time[:0].astype(int), extras=ex))
    return out
