"""A study's campaigns: one base scenario run as one Monte Carlo campaign per case (``OUT/<label>/``, resumable like
any campaign), all on one set of workers, and each case's statistics (``analysis.consistency``: the filter 3-sigma
averaged over runs, final and time-averaged sigma per state).

The study's tables (``[base]``, ``[[cases]]``, ``[[figures]]``, ``[[sweeps]]``) are read by ``scenarios.study``,
which hands :func:`run` each case's complete scenario and writes the figures and ``study.json`` from what it returns
(docs/scenarios/studies.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from sarnav.analysis.consistency import case_statistics, mean_three_sigma
from sarnav.montecarlo.campaign import CampaignResult, run_campaign
from sarnav.montecarlo.executors import ChunkRunner
from sarnav.montecarlo.kind import ScenarioKind

__all__ = ["StudyCase", "StudyParams", "CaseOutcome", "run"]


@dataclass(frozen=True)
class StudyCase:
    """One case: its ``label`` (the name of its folder) and its complete scenario ``config`` (the base with the
    case's values and the study's ``[campaign]``)."""

    label: str
    config: dict


@dataclass(frozen=True)
class StudyParams:
    """The cases of a study and the kind that simulates them (the base scenario's)."""

    kind: ScenarioKind
    cases: tuple[StudyCase, ...]


@dataclass(frozen=True)
class CaseOutcome:
    """A case's campaign (``result``), its mean filter 3-sigma (``curves``: time, 3-sigma (T, S), state names;
    ``analysis.consistency.mean_three_sigma``) and per-state statistics (``states``:
    ``analysis.consistency.case_statistics``)."""

    label: str
    result: CampaignResult
    curves: tuple
    states: dict


def run(prm: StudyParams, out, executor: str = "processes", workers: int | None = None, scheduler: str | None = None,
        **campaign_options) -> list[CaseOutcome]:
    """Run every case's campaign into ``out/<label>/`` with one :class:`ChunkRunner` (``executor``, ``workers``,
    ``scheduler``) for all of them; ``campaign_options`` go to :func:`run_campaign` (resume, quiet, chunk_size,
    overwrite). Returns the outcomes in the order of the cases."""
    out = Path(out)
    with ChunkRunner(executor, workers, scheduler) as runner:  # one set of workers for all cases
        results = [run_campaign(case.config, out / case.label, executor=runner, kind=prm.kind, **campaign_options)
                   for case in prm.cases]
    outcomes = []
    for case, res in zip(prm.cases, results):
        curves = mean_three_sigma(res.dataset)
        outcomes.append(CaseOutcome(case.label, res, curves, case_statistics(res.summary, curves)))
    return outcomes
