"""Base class of the kinds that run one error-state filter over one state layout (``telemetry``, ``rda-nav``).

The contract itself, :class:`~sarnav.montecarlo.kind.ScenarioKind`, lives beside the run record in
``sarnav.montecarlo``.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from numpy.linalg import LinAlgError  # the exception only (a filter's singular matrix); the algebra is in filters/

from sarnav.errors import ConfigError
from sarnav.montecarlo.kind import ScenarioKind
from sarnav.montecarlo.record import RunRecord
from sarnav.scenarios.kind_base import one_seed_per_run
from sarnav.scenarios.vocabulary import doppler_prf_check


class ErrorStateKind(ScenarioKind):
    """A kind whose runs are an error-state filter over one state layout (``telemetry``, ``rda-nav``).

    Subclasses set ``layout`` (an ``ErrorStateLayout``), ``measurement_names`` / ``measurement_units``,
    ``parse`` (cfg -> validated parameters in SI; raises ConfigError), ``simulate_runs`` (parameters, run_ids, seeds
    -> records: the experiment's, ``staticmethod`` of the function in ``sarnav.simulation``) and ``extra`` (the
    results.nc attributes of the kind's extra variables); validation, names and the ``simulate`` checks are shared
    here.
    """

    layout = None
    measurement_names: tuple[str, ...] = ()
    measurement_units: tuple[str, ...] = ()
    extra: dict = {}

    def extra_attrs(self, cfg: dict) -> dict[str, dict]:
        return self.extra

    def parse(self, cfg: dict):  # pragma: no cover - replaced by subclasses
        raise NotImplementedError

    def simulate_runs(self, prm, run_ids, seeds):  # pragma: no cover - replaced by subclasses
        raise NotImplementedError

    def validate(self, cfg: dict) -> None:
        _check_radar(self.parse(cfg))

    def state_names(self, cfg: dict) -> list[str]:
        return self.layout.state_names()

    def state_units(self, cfg: dict) -> list[str]:
        return self.layout.state_units()

    def meas_names(self, cfg: dict) -> list[str]:
        return list(self.measurement_names)

    def meas_units(self, cfg: dict) -> list[str]:
        return list(self.measurement_units)

    def simulate(self, cfg: dict, run_ids: Sequence[int], seeds: Sequence[np.random.SeedSequence]) -> list[RunRecord]:
        """Simulate the runs as one batch; run i depends only on cfg and seeds[i]. A covariance that lost positive
        definiteness (NaN sigma, a singular innovation covariance) is a ConfigError naming ``initial``, never NaN in
        the results."""
        one_seed_per_run(run_ids, seeds)
        if len(run_ids) == 0:
            return []
        prm = self.parse(cfg)
        _check_radar(prm)
        try:
            with np.errstate(invalid="ignore"):  # a NaN sigma is reported below, in one line
                records = self.simulate_runs(prm, run_ids, seeds)
        except LinAlgError as err:
            raise _not_positive_definite(f"({err})") from None
        for rec in records:
            _check_finite_covariance(rec)
        return records


def _check_radar(prm) -> None:
    """Parameters that carry a radar and a trajectory and form images (rda-nav: ``sar_enabled`` and ``measurement ==
    "image"``): the PRF covers the Doppler band at the flight's speed, named ``radar.prf_hz`` — checked by validation,
    so ``show`` refuses what the imaging would (it was found only while simulating, naming ``radar.prf``)."""
    radar, traj = getattr(prm, "radar", None), getattr(prm, "trajectory", None)
    images = getattr(prm, "sar_enabled", True) and getattr(prm, "measurement", "image") == "image"
    if radar is not None and traj is not None and images:
        doppler_prf_check(radar, traj.speed)


#: the keys a covariance that is not positive definite comes from (the error names the first, the message the rest)
_COVARIANCE_KEYS = "the [initial] 3-sigma values and the noise figures ([imu], [measurements], [altimeter], [sar])"


def _not_positive_definite(where: str) -> ConfigError:
    return ConfigError("initial", f"the filter's covariance is not positive definite {where}: {_COVARIANCE_KEYS} span "
                       "more orders of magnitude than float64 resolves; bring them closer (docs/scenarios/vocabulary.md)")


def _check_finite_covariance(rec: RunRecord) -> None:
    """A safety net behind the documented ranges: a record with NaN sigma or NEES, or a residual without its sigma,
    is never stored (results are finite or the campaign ends with one line)."""
    bad_state = ~np.all(np.isfinite(rec.sigma), axis=1) | ~np.isfinite(rec.nees)
    bad_update = np.any(np.isfinite(rec.residual) & ~np.isfinite(rec.residual_sigma), axis=1)
    if bad_state.any():
        raise _not_positive_definite(f"at t = {rec.time[np.argmax(bad_state)]:g} s of run {rec.run}")
    if bad_update.any():
        raise _not_positive_definite(f"at the update at t = {rec.update_time[np.argmax(bad_update)]:g} s of run {rec.run}")
