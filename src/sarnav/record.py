"""What one Monte Carlo run hands to the campaign: the contract between an experiment (``sarnav.simulation``), the
scenario kind that wires it, and the campaign engine (docs/architecture.md §Contracts). A container at the bottom of
the package (``sarnav.montecarlo.record`` re-exports it).

A scenario kind's ``simulate(cfg, run_ids, seeds)`` returns one :class:`RunRecord` per run. The
campaign stores each record as soon as it arrives (``runs/run_NNNNNN.npz``) and assembles them into
the ``results.nc`` Dataset (dims ``run, time, state, update, meas``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class RunRecord:
    """One run's time histories. All arrays float64 unless stated.

    Attributes
    ----------
    run : run index in the campaign (0..N-1).
    time : (T,) output epochs [s]; identical for every run of a scenario.
    error : (T, S) truth minus estimate in error-state coordinates (attitude per
        ``rotations.attitude_error``), at each epoch after any update at that epoch.
    sigma : (T, S) filter 1-sigma, sqrt(diag P), same epochs.
    nees : (T,) normalised estimation error squared e^T P^-1 e (dof = S).
    update_time : (U,) epochs of measurement updates [s]; identical for every run.
    residual : (U, M) z - z_hat, NaN where measurement m was not available at update u.
    residual_sigma : (U, M) sqrt(diag(H P- H^T + R)), NaN where absent.
    nis : (U,) normalised innovation squared r^T S^-1 r over the measurements present.
    nis_dof : (U,) int, number of measurements present at update u.
    extras : further variables, name -> (dims, array); dims drawn from
        ``run``-less names such as ("update", "meas") or ("time",) or new dims of the kind's own.
    """

    run: int
    time: np.ndarray
    error: np.ndarray
    sigma: np.ndarray
    nees: np.ndarray
    update_time: np.ndarray
    residual: np.ndarray
    residual_sigma: np.ndarray
    nis: np.ndarray
    nis_dof: np.ndarray
    extras: dict[str, tuple[tuple[str, ...], np.ndarray]] = field(default_factory=dict)

    def check(self, n_state: int, n_meas: int) -> None:
        """Raise ValueError naming the field whose shape breaks the contract."""
        T, U = len(self.time), len(self.update_time)
        want = {
            "error": (T, n_state),
            "sigma": (T, n_state),
            "nees": (T,),
            "residual": (U, n_meas),
            "residual_sigma": (U, n_meas),
            "nis": (U,),
            "nis_dof": (U,),
        }
        for name, shape in want.items():
            got = np.shape(getattr(self, name))
            if got != shape:
                raise ValueError(f"RunRecord.{name}: shape {got}, expected {shape}")
