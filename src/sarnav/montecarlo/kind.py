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

import re
from abc import ABC, abstractmethod
from typing import Sequence

import numpy as np

from sarnav.errors import ConfigError
from sarnav.montecarlo.record import RunRecord
from sarnav.tomlio import check_finite

__all__ = ["ScenarioKind", "validate_campaign", "validate_common", "validate_name", "MAX_RUNS", "MAX_SEED"]


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
    #: runs in each worker's first chunk (``seeding.ChunkPlan``): 1 by default; a kind whose chunk costs about the
    #: same for 1 or 50 runs (one vectorised pass over the runs) states more, so that its probe is not a whole pass
    #: spent on one run
    probe_chunk: int = 1

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

    def extra_attrs(self, cfg: dict) -> dict[str, dict]:
        """``units`` and ``description`` of each extra variable the kind's records carry (results.nc attributes)."""
        return {}

    def extra_coords(self, cfg: dict) -> dict[str, tuple[list, dict]]:
        """Labels of the kind's own dimensions: dim -> (values, attributes), e.g. the names of the ``stage`` axis."""
        return {}

    def figures(self, results, outdir) -> list[str]:
        """Optional kind-specific figures beyond the standard ones; returns written paths."""
        return []

    def summary_extras(self, results) -> dict:
        """Optional kind-specific statistics of the assembled results, merged into ``summary.json`` (finite
        numbers; e.g. the ``rmse`` per navigation source of the multi-IMU kinds)."""
        return {}


#: largest campaign (runs) and seed accepted: seeds are stored as signed 64-bit integers (netCDF attributes)
MAX_RUNS = 100_000
MAX_SEED = 2**63 - 1
#: a scenario name is an identifier: it names the output folder ``sarnav-out/<name>``
NAME_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


def validate_campaign(cfg: dict) -> tuple[int, int]:
    """``(runs, seed)`` of the ``[campaign]`` table: integers, 1 <= runs <= MAX_RUNS, 0 <= seed < 2^63."""
    camp = _require_table(cfg, "campaign")
    runs = camp.get("runs")
    if isinstance(runs, bool) or not isinstance(runs, int) or not 1 <= runs <= MAX_RUNS:
        raise ConfigError("campaign.runs", f"must be an integer in [1, {MAX_RUNS}], got {runs!r}")
    seed = camp.get("seed")
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
        raise ConfigError("campaign.seed", f"must be an integer in [0, 2^63 - 1], got {seed!r}")
    return runs, seed


def validate_name(name, field: str = "scenario.name") -> str:
    """A scenario name: letters, digits and ``_.-``, starting with a letter or digit, no ``..`` (it becomes a folder
    name: never a path)."""
    if not isinstance(name, str) or not NAME_PATTERN.match(name) or ".." in name or len(name) > 128:
        raise ConfigError(field, f"must be a name of letters, digits and '_.-' (no path, no '..', at most 128 "
                          f"characters), got {name!r}")
    return name


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
    if not isinstance(scen.get("kind"), str) or not scen.get("kind"):
        raise ConfigError("scenario.kind", f"must be a non-empty string, got {scen.get('kind')!r}")
    validate_name(scen.get("name"))
    if not isinstance(scen.get("description", ""), str):
        raise ConfigError("scenario.description", "must be a string")
    if needs_campaign:
        validate_campaign(cfg)
