"""What the scenario kinds share beyond their tables: the base of the kinds that write their own files instead of a
Monte Carlo campaign (:class:`FileKind`: ``bpa-sensitivity``, ``image``, ``quality-sweep``, ``gpsd-search``), the
claim of their output folder (:func:`writing`) and the check of a batch's seeds (:func:`one_seed_per_run`).
"""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Callable, Sequence

from sarnav.errors import ConfigError
from sarnav.montecarlo.kind import ScenarioKind
from sarnav.montecarlo.record import RunRecord

__all__ = ["FileKind", "one_seed_per_run", "writing"]


def one_seed_per_run(run_ids: Sequence[int], seeds: Sequence) -> None:
    """Refuse a batch whose seeds do not match its runs one to one (``ScenarioKind.simulate``'s contract)."""
    if len(run_ids) != len(seeds):
        raise ConfigError("seeds", f"need one seed per run, got {len(seeds)} for {len(run_ids)} runs")


@contextlib.contextmanager
def writing(cfg: dict, out, overwrite: bool, what: str):
    """``out`` claimed for the scenario ``cfg`` (``montecarlo.outdir.OutputFolder``; ``overwrite`` replaces another
    scenario's results) with a file ``INCOMPLETE`` ("<what> running") that only a block run to its end removes."""
    from sarnav.montecarlo.outdir import OutputFolder, identity

    with OutputFolder(out, identity(cfg), overwrite=overwrite):
        marker = Path(out) / "INCOMPLETE"
        marker.write_text(f"{what} running\n")
        yield
        marker.unlink()


class FileKind(ScenarioKind):
    """A kind that ``sarnav run`` hands to one writer, ``write(cfg, out, **options)``, instead of the campaign engine
    (executor options do not apply: the writer runs in this process, its compiled kernels on the cores).

    Subclasses set ``kind``, ``needs_campaign`` and, as ``staticmethod``: ``config()`` (the default configuration),
    ``check(cfg)`` (raises ConfigError naming the first bad key) and ``write``; ``options`` names the writer's keyword
    arguments among ``figures``, ``overwrite`` and ``quiet``; ``what`` says what the kind is (in the error of
    :meth:`simulate`).
    """

    config: Callable[[], dict]
    check: Callable[[dict], object]
    write: Callable
    options: tuple[str, ...] = ("figures", "overwrite")
    what: str = "a deterministic study"

    def default_config(self) -> dict:
        return self.config()

    def validate(self, cfg: dict) -> None:
        self.check(cfg)

    def state_names(self, cfg: dict) -> list[str]:
        return []

    def meas_names(self, cfg: dict) -> list[str]:
        return []

    def run_scenario(self, cfg: dict, out, figures: bool = True, **campaign_opts):
        """``sarnav run NAME``: the writer with the options it takes; returns what it returns."""
        given = {"figures": figures, "overwrite": campaign_opts.get("overwrite", False),
                 "quiet": campaign_opts.get("quiet", True)}
        return self.write(cfg, out, **{k: given[k] for k in self.options})

    def simulate(self, cfg, run_ids, seeds) -> list[RunRecord]:
        raise ConfigError("scenario.kind", f"{self.kind} is {self.what}: run it with sarnav run "
                                           f"({self.write.__module__}.{self.write.__name__})")
