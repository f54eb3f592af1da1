"""The contract every scenario kind implements (docs/architecture.md §Contracts).

A *scenario* is a nested dict that round-trips through TOML. Its top level always has::

    [scenario]  name, kind, description
    [campaign]  runs (int >= 1), seed (int >= 0)

plus tables that belong to its kind (``[trajectory]``, ``[imu]``, ``[radar]``, ...). The campaign
engine (``sarnav.montecarlo``) knows nothing of the kind except this interface.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Sequence

import numpy as np

from sarnav.montecarlo.record import RunRecord


class ScenarioKind(ABC):
    """One family of experiments (``telemetry``, ``rda-nav``, ...).

    Implementations must make ``simulate`` a pure function of (cfg, run_ids, seeds): the record of
    run i depends only on cfg and seeds[i], never on which other runs share the batch, so that
    results are bit-identical whatever the executor or number of workers.
    """

    #: the value of ``scenario.kind`` this class handles
    kind: str = ""

    @abstractmethod
    def validate(self, cfg: dict) -> None:
        """Raise :class:`sarnav.errors.ConfigError` naming the first bad field and its valid range."""

    @abstractmethod
    def state_names(self, cfg: dict) -> list[str]:
        """Names of the error states (the ``state`` coordinate), e.g. pN, pE, pD, vN, ..."""

    def state_units(self, cfg: dict) -> list[str]:
        return ["" for _ in self.state_names(cfg)]

    @abstractmethod
    def meas_names(self, cfg: dict) -> list[str]:
        """Names of the measurement components (the ``meas`` coordinate), e.g. alt, range, rate."""

    def meas_units(self, cfg: dict) -> list[str]:
        return ["" for _ in self.meas_names(cfg)]

    @abstractmethod
    def simulate(self, cfg: dict, run_ids: Sequence[int], seeds: Sequence[np.random.SeedSequence]) -> list[RunRecord]:
        """Simulate the given runs (batched as the kind likes) and return one record per run."""

    def figures(self, results, outdir) -> list[str]:
        """Optional kind-specific figures beyond the standard ones; returns written paths."""
        return []


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
