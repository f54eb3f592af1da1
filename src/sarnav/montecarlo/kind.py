"""The contract between a scenario kind and the campaign engine (docs/architecture.md §Contracts).

A *scenario* is a nested dict that round-trips through TOML (:mod:`sarnav.tomlio`). Its top level always has::

    [scenario]  name, kind, description
    [campaign]  runs (int >= 1), seed (int >= 0)

plus tables that belong to its kind (``[trajectory]``, ``[imu]``, ``[radar]``, ...). A kind (one family of
experiments: ``telemetry``, ``rda-nav``, ...) implements :class:`ScenarioKind`; the campaign engine
(:func:`sarnav.montecarlo.campaign.run_campaign`) takes a kind instance and a scenario and knows nothing else of
it. Each :meth:`ScenarioKind.simulate` returns one :class:`~sarnav.montecarlo.record.RunRecord` per run.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Sequence

import numpy as np

from sarnav.errors import ConfigError
from sarnav.montecarlo.record import RunRecord
from sarnav.tomlio import check_finite

__all__ = ["ScenarioKind", "validate_campaign", "validate_common"]


class ScenarioKind(ABC):
    """One family of experiments (``telemetry``, ``rda-nav``, ...).

    Implementations must make ``simulate`` a pure function of (cfg, run_ids, seeds): the record of
    run i depends only on cfg and seeds[i], never on which other runs share the batch, so that
    results are bit-identical whatever the executor or number of workers.
    """

    #: the value of ``scenario.kind`` this class handles
    kind: str = ""
    #: whether scenarios of this kind carry the ``[campaign] runs, seed`` table (single-image kinds do not)
    needs_campaign: bool = True

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


def validate_campaign(cfg: dict) -> tuple[int, int]:
    """``(runs, seed)`` of the ``[campaign]`` table; ConfigError unless runs >= 1 and seed >= 0 are integers."""
    camp = _require_table(cfg, "campaign")
    runs = camp.get("runs")
    if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
        raise ConfigError("campaign.runs", f"must be an integer >= 1, got {runs!r}")
    seed = camp.get("seed")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError("campaign.seed", f"must be an integer >= 0, got {seed!r}")
    return runs, seed


def _require_table(cfg: dict, name: str) -> dict:
    table = cfg.get(name)
    if not isinstance(table, dict):
        raise ConfigError(name, f"missing table [{name}]")
    return table


def validate_common(cfg: dict, needs_campaign: bool = True) -> None:
    """Check the keys every scenario has: ``scenario.name``, ``scenario.kind`` and (``needs_campaign``)
    ``campaign.runs/seed``."""
    if not isinstance(cfg, dict):
        raise ConfigError("<scenario>", "must be a table")
    check_finite(cfg)
    scen = _require_table(cfg, "scenario")
    for key in ("name", "kind"):
        if not isinstance(scen.get(key), str) or not scen.get(key):
            raise ConfigError(f"scenario.{key}", f"must be a non-empty string, got {scen.get(key)!r}")
    if not isinstance(scen.get("description", ""), str):
        raise ConfigError("scenario.description", "must be a string")
    if needs_campaign:
        validate_campaign(cfg)
