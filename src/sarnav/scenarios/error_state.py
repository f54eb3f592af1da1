"""Base class of the kinds that run one error-state filter over one state layout (``telemetry``, ``rda-nav``).

The contract itself, :class:`~sarnav.montecarlo.kind.ScenarioKind`, lives beside the run record in
``sarnav.montecarlo``.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from sarnav.montecarlo.kind import ScenarioKind
from sarnav.montecarlo.record import RunRecord


class ErrorStateKind(ScenarioKind):
    """A kind whose runs are an error-state filter over one state layout (``telemetry``, ``rda-nav``).

    Subclasses set ``layout`` (an ``ErrorStateLayout``), ``measurement_names`` / ``measurement_units``,
    ``parse`` (cfg -> validated parameters in SI; raises ConfigError) and ``simulate_runs`` (parameters,
    run_ids, seeds -> records); validation, names and the ``simulate`` checks are shared here.
    """

    layout = None
    measurement_names: tuple[str, ...] = ()
    measurement_units: tuple[str, ...] = ()

    def parse(self, cfg: dict):  # pragma: no cover - replaced by subclasses
        raise NotImplementedError

    def simulate_runs(self, prm, run_ids, seeds):  # pragma: no cover - replaced by subclasses
        raise NotImplementedError

    def validate(self, cfg: dict) -> None:
        self.parse(cfg)

    def state_names(self, cfg: dict) -> list[str]:
        return self.layout.state_names()

    def state_units(self, cfg: dict) -> list[str]:
        return self.layout.state_units()

    def meas_names(self, cfg: dict) -> list[str]:
        return list(self.measurement_names)

    def meas_units(self, cfg: dict) -> list[str]:
        return list(self.measurement_units)

    def simulate(self, cfg: dict, run_ids: Sequence[int], seeds: Sequence[np.random.SeedSequence]) -> list[RunRecord]:
        """Simulate the runs as one batch; run i depends only on cfg and seeds[i]."""
        from sarnav.errors import ConfigError

        if len(run_ids) != len(seeds):
            raise ConfigError("seeds", f"need one seed per run, got {len(seeds)} for {len(run_ids)} runs")
        if len(run_ids) == 0:
            return []
        return self.simulate_runs(self.parse(cfg), run_ids, seeds)
