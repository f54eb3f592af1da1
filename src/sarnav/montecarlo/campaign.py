"""Run a Monte Carlo campaign of a scenario into a directory, resumably.

Sequence (docs/results.md): write ``INCOMPLETE`` and ``campaign.json`` with ``complete: false``;
simulate the runs not yet stored, chunk by chunk, storing every record at once; when all N runs are
stored, write ``results.nc`` and ``summary.json`` atomically, flip the manifest to
``complete: true`` and remove ``INCOMPLETE``. A campaign killed at any point leaves no
``results.nc``/``summary.json`` and a manifest saying ``complete: false``; ``resume=True`` finishes it.
The engine knows nothing of the kind beyond the :class:`~sarnav.montecarlo.kind.ScenarioKind` contract and
looks nothing up: the caller passes the kind instance.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import signal
import sys
import threading
from dataclasses import dataclass
from pathlib import Path

import xarray as xr
from tqdm import tqdm

import sarnav
from sarnav.analysis.consistency import summarize
from sarnav.errors import ConfigError
from sarnav.montecarlo import store
from sarnav.montecarlo.assemble import assemble_results, write_results
from sarnav.montecarlo.executors import ChunkRunner
from sarnav.montecarlo.seeding import default_chunk_size, make_chunks, run_seeds
from sarnav.montecarlo.kind import ScenarioKind, validate_common
from sarnav.tomlio import dump_toml, parse_toml

__all__ = ["CampaignResult", "CampaignInterrupted", "run_campaign"]

FORMAT = "sarnav-campaign-1"


class CampaignInterrupted(KeyboardInterrupt):
    """SIGTERM/SIGINT arrived; the stored runs are kept and ``--resume`` finishes the campaign."""

    def __init__(self, signum: int):
        super().__init__(f"interrupted by signal {signum}")
        self.signum = signum


@dataclass
class CampaignResult:
    """What :func:`run_campaign` produced."""

    out: Path
    results_path: Path
    summary_path: Path
    dataset: xr.Dataset
    summary: dict
    n_simulated: int  #: runs simulated by this call (the others were already stored)


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def _diff_path(a, b, path="") -> str | None:
    """Dotted path of the first difference between two nested dicts (None if equal)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                return f"{path}.{k}" if path else str(k)
            d = _diff_path(a[k], b[k], f"{path}.{k}" if path else str(k))
            if d:
                return d
        return None
    return None if a == b else (path or "<scenario>")


def _clear_outputs(out: Path, keep_runs: bool) -> None:
    for name in (store.RESULTS, store.SUMMARY):
        p = out / name
        if p.exists():
            p.unlink()
    runs = out / "runs"
    if runs.is_dir():
        for p in runs.iterdir():
            stale_tmp = p.name.startswith(".") and ".tmp-" in p.name
            if stale_tmp or (not keep_runs and p.name.startswith("run_") and p.suffix == ".npz"):
                p.unlink()


class _SignalsToException:
    """Turn SIGTERM/SIGINT into :class:`CampaignInterrupted` while a campaign runs (main thread only)."""

    def __enter__(self):
        self.saved = {}
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGTERM, signal.SIGINT):
                self.saved[sig] = signal.signal(sig, self._raise)
        return self

    @staticmethod
    def _raise(signum, frame):
        raise CampaignInterrupted(signum)

    def __exit__(self, *exc):
        for sig, handler in self.saved.items():
            signal.signal(sig, handler)
        return False


def run_campaign(
    cfg: dict,
    out: str | os.PathLike,
    kind: ScenarioKind,
    executor: "str | ChunkRunner" = "processes",
    workers: int | None = None,
    scheduler: str | None = None,
    resume: bool = False,
    quiet: bool = False,
    chunk_size: int | None = None,
) -> CampaignResult:
    """Run ``cfg['campaign']['runs']`` runs of the scenario ``cfg`` into ``out``.

    Parameters
    ----------
    cfg : scenario dict (``[campaign] runs, seed`` plus the kind's tables); validated here again.
    out : output directory (created).
    kind : the :class:`~sarnav.montecarlo.kind.ScenarioKind` instance that simulates the runs.
    executor : ``"serial"``, ``"processes"`` (default) or ``"dask"``; or a :class:`ChunkRunner`
        to share its workers between campaigns (it is then left open).
    workers : worker processes (default: number of cores); for dask without ``scheduler``, the
        size of the LocalCluster started.
    scheduler : dask scheduler address (``tcp://host:port``).
    resume : keep the runs stored in ``out`` by an earlier call with the same scenario and simulate
        only the missing ones; a different stored scenario is a :class:`ConfigError`.
        Without ``resume`` an earlier campaign's files in ``out`` are replaced.
    quiet : no progress bar (it is also off when stderr is not a terminal).
    chunk_size : runs per task (default about two tasks per worker, at most 50).

    Returns
    -------
    CampaignResult

    Notes
    -----
    The ``processes`` and ``dask`` executors start fresh interpreters (``spawn``), which import the
    calling script's main module: a script calling this function must do so under
    ``if __name__ == "__main__":``. The kind instance and ``cfg`` are pickled to the workers, so a
    kind defined outside sarnav must live in an importable module.
    """
    validate_common(cfg)
    kind.validate(cfg)
    text = dump_toml(cfg)
    canonical = parse_toml(text)
    n_runs, seed = int(cfg["campaign"]["runs"]), int(cfg["campaign"]["seed"])
    if isinstance(executor, ChunkRunner):
        runner, own_runner = executor, False
    else:  # checks executor, workers, scheduler before anything is written
        runner, own_runner = ChunkRunner(executor, workers, scheduler), True
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ConfigError("--out", f"cannot create output directory {str(out)!r}: {err.strerror}") from None
    manifest, keep = _open_store(out, cfg, text, canonical, resume)
    seeds = run_seeds(seed, n_runs)
    done = {i for i in store.stored_runs(out) if i < n_runs} if keep else set()
    todo = [i for i in range(n_runs) if i not in done]
    chunks = make_chunks(todo, chunk_size or default_chunk_size(len(todo), runner.workers))
    _simulate_missing(out, runner, own_runner, kind, canonical, chunks, seeds, n_runs, len(done),
                      cfg["scenario"]["name"], quiet)
    ds, summary = _assemble(out, kind, cfg, canonical, text, n_runs, seed)
    manifest.update(complete=True, finished=_now())
    store.write_manifest(out, manifest)
    (out / store.MARKER).unlink(missing_ok=True)
    return CampaignResult(out, out / store.RESULTS, out / store.SUMMARY, ds, summary, len(todo))


def _open_store(out: Path, cfg: dict, text: str, canonical: dict, resume: bool) -> tuple[dict, bool]:
    """Check a resumed store, mark the campaign incomplete, clear stale outputs and write the manifest.
    Returns (manifest, whether stored runs are kept)."""
    old = store.read_manifest(out) if (out / store.MANIFEST).exists() else None
    if resume and old is not None:
        stored_cfg = parse_toml(old.get("scenario_toml", ""), origin=str(out / store.MANIFEST))
        where = _diff_path(stored_cfg, canonical)
        if where is not None:
            raise ConfigError(
                "--resume",
                f"{out / store.MANIFEST} holds a different scenario (first difference at {where}); "
                "run without --resume or choose another --out",
            )
        if old.get("sarnav_version") != sarnav.__version__:  # runs by other code must not be mixed in
            raise ConfigError(
                "--resume",
                f"{out / store.MANIFEST} was written by sarnav {old.get('sarnav_version')!r}, this is "
                f"{sarnav.__version__!r}; run without --resume or choose another --out",
            )
    keep = resume and old is not None
    # Mark incomplete before anything else can be half-written.
    store.atomic_write_text(out / store.MARKER, "campaign in progress or interrupted; rerun with --resume\n")
    _clear_outputs(out, keep_runs=keep)
    manifest = {
        "format": FORMAT,
        "scenario": cfg["scenario"]["name"],
        "kind": cfg["scenario"]["kind"],
        "seed": int(cfg["campaign"]["seed"]),
        "runs": int(cfg["campaign"]["runs"]),
        "sarnav_version": sarnav.__version__,
        "complete": False,
        "started": (old or {}).get("started", _now()) if keep else _now(),
        "scenario_toml": text,
    }
    store.write_manifest(out, manifest)
    return manifest, keep


def _simulate_missing(out, runner, own_runner, kind, canonical, chunks, seeds, n_runs, n_done, name, quiet) -> None:
    """Run the chunks, storing every record as it arrives; signals become :class:`CampaignInterrupted`."""
    bar = tqdm(total=n_runs, initial=n_done, unit="run", desc=name, file=sys.stderr,
               disable=quiet or not sys.stderr.isatty())
    clean = False
    try:
        with _SignalsToException():
            if chunks:
                for ids, records in runner.run(kind, canonical, chunks, seeds):
                    for rec in records:
                        store.save_record(out, rec)
                    bar.update(len(ids))
            clean = True
    finally:
        bar.close()
        if own_runner:
            runner.close(abort=not clean)


def _assemble(out: Path, kind, cfg, canonical, text, n_runs, seed):
    """Read every stored run and write ``results.nc`` and ``summary.json``; returns (dataset, summary)."""
    missing = sorted(set(range(n_runs)) - store.stored_runs(out))
    if missing:  # cannot happen unless files were removed underneath us
        raise RuntimeError(f"runs missing after the campaign: {missing[:10]}")
    records = [store.load_record(store.run_path(out, i)) for i in range(n_runs)]
    attrs = {
        "scenario": text,
        "scenario_name": cfg["scenario"]["name"],
        "kind": cfg["scenario"]["kind"],
        "sarnav_version": sarnav.__version__,
        "seed": seed,
        "runs": n_runs,
        "complete": 1,
    }
    ds = assemble_results(records, kind.state_names(canonical), kind.meas_names(canonical),
                          kind.state_units(canonical), kind.meas_units(canonical), attrs)
    summary = {"scenario": cfg["scenario"]["name"], "seed": seed, "complete": True, **summarize(ds)}
    write_results(ds, out / store.RESULTS)
    store.atomic_write_text(out / store.SUMMARY, json.dumps(summary, indent=2) + "\n")
    return ds, summary
