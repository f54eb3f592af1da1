"""Error-state filtering: layouts, the INS error model (F, B, Q), Van Loan, the Prediction contract, update
strategies (``update``: Joseph, correlated noise; ``second_order``; ``delayed``), feedback."""

from sarnav.filters.discretization import van_loan
from sarnav.filters.ekf import correlated_update, joseph_update, normalized_squared, propagate_covariance, symmetrize
from sarnav.filters.error_model import ErrorStateModel, fogm_kernels
from sarnav.filters.feedback import apply_feedback, corrupt_state, error_state
from sarnav.filters.layout import ErrorStateLayout
from sarnav.filters.prediction import Prediction, stack_predictions
from sarnav.filters import delayed, second_order, update  # noqa: E402  (strategy modules)

__all__ = [
    "ErrorStateLayout",
    "Prediction",
    "stack_predictions",
    "update",
    "delayed",
    "second_order",
    "ErrorStateModel",
    "fogm_kernels",
    "van_loan",
    "propagate_covariance",
    "joseph_update",
    "correlated_update",
    "normalized_squared",
    "symmetrize",
    "apply_feedback",
    "error_state",
    "corrupt_state",
]
