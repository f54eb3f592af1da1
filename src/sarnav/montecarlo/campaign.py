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
import shutil
import signal
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import xarray as xr
from tqdm import tqdm

import sarnav
from sarnav.analysis.consistency import strict, summarize
from sarnav.errors import ConfigError, Interrupted, RunFault, disk_message, raise_interrupted
from sarnav.montecarlo import store
from sarnav.montecarlo.assemble import assemble_results, write_results
from sarnav.montecarlo.executors import RESUME_HINT, ChunkRunner
from sarnav.montecarlo.seeding import ChunkPlan, run_seeds
from sarnav.montecarlo.kind import ScenarioKind, validate_common
from sarnav.montecarlo.outdir import OutputFolder, fingerprint, identity
from sarnav.tomlio import dump_toml, parse_toml

__all__ = ["CampaignResult", "CampaignInterrupted", "run_campaign"]

FORMAT = "sarnav-campaign-1"


#: SIGTERM/SIGINT arrived; the stored runs are kept and ``--resume`` finishes the campaign
CampaignInterrupted = Interrupted


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
                self.saved[sig] = signal.signal(sig, raise_interrupted)
        return self

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
    redo_runs=(),
    overwrite: bool = False,
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
        only the missing ones (also to extend a finished campaign to more runs: ``campaign.runs`` may grow);
        a different stored scenario is a :class:`ConfigError`. Every kept run file is verified (stamp and
        checksum). Without ``resume`` an earlier campaign of the same scenario is replaced.
    redo_runs : with ``resume``: run indices whose stored files are discarded and simulated again (the repair a
        damaged run file's error message names).
    overwrite : replace whatever another scenario left in ``out`` (otherwise refused, ``montecarlo.outdir``).
    quiet : no progress (a bar on stderr when it is a terminal, else one line per chunk at most every
        :data:`PROGRESS_EVERY` seconds).
    chunk_size : runs per task (default: sized by work, :class:`~sarnav.montecarlo.seeding.ChunkPlan`: each chunk
        about 20 s once the per-run cost is measured on the first ones).

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
    redo = _redo_runs(redo_runs, n_runs, resume)
    stamp = {"fingerprint": fingerprint(canonical), "seed": seed, "sarnav_version": sarnav.__version__}
    if resume and (out / store.MANIFEST).exists():
        _check_resumable(out, canonical)
    with OutputFolder(out, identity(canonical), resume=resume, overwrite=overwrite):
        try:
            manifest, keep = _open_store(out, cfg, text, resume)
        except OSError as err:
            raise RunFault(str(out), f"cannot write in the output folder: {disk_message(err)}") from None
        for i in redo:
            store.run_path(out, i).unlink(missing_ok=True)
        done = _verified_runs(out, n_runs, stamp) if keep else set()
        seeds = run_seeds(seed, n_runs)
        todo = [i for i in range(n_runs) if i not in done]
        chunks = ChunkPlan(todo, runner.workers, size=chunk_size, probe=kind.probe_chunk)
        _simulate_missing(out, runner, own_runner, kind, canonical, chunks, seeds, n_runs, len(done),
                          cfg["scenario"]["name"], quiet, stamp)
        ds, summary = _assemble(out, kind, cfg, canonical, text, n_runs, seed, stamp)
        manifest.update(complete=True, finished=_now(), **{store.CHECKSUMS: store.product_checksums(out)})
        try:
            store.write_manifest(out, manifest)
        except OSError as err:
            raise RunFault(str(out / store.MANIFEST), f"cannot write the manifest: {disk_message(err)}; "
                           f"{RESUME_HINT}") from None
        (out / store.MARKER).unlink(missing_ok=True)
    return CampaignResult(out, out / store.RESULTS, out / store.SUMMARY, ds, summary, len(todo))


def _redo_runs(redo_runs, n_runs: int, resume: bool) -> list[int]:
    redo = sorted({int(i) for i in redo_runs})
    if redo and not resume:
        raise ConfigError("--redo-run", "needs --resume (without it every run is simulated anyway)")
    bad = [i for i in redo if not 0 <= i < n_runs]
    if bad:
        raise ConfigError("--redo-run", f"must be run indices in [0, {n_runs - 1}], got {bad[0]}")
    return redo


def _check_resumable(out: Path, canonical: dict) -> None:
    """The stored scenario must equal the requested one (``campaign.runs`` aside: a campaign may be extended)."""
    old = store.read_manifest(out)
    stored_cfg = parse_toml(old.get("scenario_toml", ""), origin=str(out / store.MANIFEST))
    a, b = (dict(c, campaign={k: v for k, v in c.get("campaign", {}).items() if k != "runs"})
            for c in (stored_cfg, canonical))
    where = _diff_path(a, b)
    if where is not None:
        raise ConfigError(
            "--resume",
            f"{out / store.MANIFEST} holds a different scenario (first difference at {where}); "
            "run without --resume (with --overwrite to replace it) or choose another --out",
        )
    if old.get("sarnav_version") != sarnav.__version__:  # runs by other code must not be mixed in
        raise ConfigError(
            "--resume",
            f"{out / store.MANIFEST} was written by sarnav {old.get('sarnav_version')!r}, this is "
            f"{sarnav.__version__!r}; run without --resume or choose another --out",
        )


def _verified_runs(out: Path, n_runs: int, stamp: dict) -> set[int]:
    """Indices < n_runs of the stored runs, each verified (stamp, checksum); a bad file raises StoredRunError."""
    done = {i for i in store.stored_runs(out) if i < n_runs}
    for i in sorted(done):
        store.load_record(store.run_path(out, i), expect=stamp)
    return done


def _open_store(out: Path, cfg: dict, text: str, resume: bool) -> tuple[dict, bool]:
    """Mark the campaign incomplete, clear stale outputs and write the manifest. Returns (manifest, whether stored
    runs are kept)."""
    old = store.read_manifest(out) if resume else None
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


#: a non-terminal stderr gets a progress line when a chunk ends and at least this many seconds passed since the last
PROGRESS_EVERY = 5.0


def _clock(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


class _Progress:
    """Runs done, elapsed time and an estimate of the time left, per finished chunk: a tqdm bar when stderr is a
    terminal, else a line at most every :data:`PROGRESS_EVERY` s (a log file shows a long campaign moving without
    filling up); nothing when ``quiet``."""

    def __init__(self, name: str, total: int, done: int, quiet: bool):
        self.name, self.total, self.start_done, self.done = name, total, done, done
        self.t0 = self.last = time.monotonic()
        tty = sys.stderr.isatty()
        self.lines = not quiet and not tty
        self.bar = tqdm(total=total, initial=done, unit="run", desc=name, file=sys.stderr, disable=quiet or not tty)

    def update(self, n: int) -> None:
        self.done += n
        self.bar.update(n)
        now = time.monotonic()
        if self.lines and now - self.last >= PROGRESS_EVERY:
            self.last = now
            elapsed = now - self.t0
            rate = (self.done - self.start_done) / max(elapsed, 1e-9)
            left = (self.total - self.done) / rate if rate > 0 else float("nan")
            print(f"sarnav: {self.name}: {self.done}/{self.total} runs, {_clock(elapsed)} elapsed, about "
                  f"{_clock(left)} left", file=sys.stderr, flush=True)

    def close(self) -> None:
        self.bar.close()


def _simulate_missing(out, runner, own_runner, kind, canonical, chunks, seeds, n_runs, n_done, name, quiet,
                      stamp) -> None:
    """Run the chunks, storing every record as its chunk ends; signals become :class:`CampaignInterrupted`."""
    progress = _Progress(name, n_runs, n_done, quiet)
    clean = False
    try:
        with _SignalsToException():
            if chunks.remaining:
                for ids, records in runner.run(kind, canonical, chunks, seeds):
                    for rec in records:
                        try:
                            store.save_record(out, rec, stamp)
                        except OSError as err:  # a full disk, a folder made read-only
                            raise RunFault(str(store.run_path(out, rec.run)), f"cannot store the run: "
                                           f"{disk_message(err)}; {RESUME_HINT}") from None
                    progress.update(len(ids))
            clean = True
    finally:
        progress.close()
        if own_runner:
            runner.close(abort=not clean)


def _assemble(out: Path, kind, cfg, canonical, text, n_runs, seed, stamp):
    """Read every stored run and write ``results.nc`` and ``summary.json``; returns (dataset, summary)."""
    missing = sorted(set(range(n_runs)) - store.stored_runs(out))
    if missing:  # cannot happen unless files were removed underneath us
        raise RuntimeError(f"runs missing after the campaign: {missing[:10]}")
    records = [store.load_record(store.run_path(out, i), expect=stamp) for i in range(n_runs)]
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
                          kind.state_units(canonical), kind.meas_units(canonical), attrs,
                          extra_attrs=kind.extra_attrs(canonical), extra_coords=kind.extra_coords(canonical))
    summary = {"scenario": cfg["scenario"]["name"], "seed": seed, "complete": True, **summarize(ds),
               **strict(kind.summary_extras(ds))}
    _write_products(out, ds, summary)
    return ds, summary


def _write_products(out: Path, ds, summary: dict) -> None:
    """``results.nc`` and ``summary.json``; a full disk (netCDF says only ``NetCDF: HDF error``) or another write
    failure is one :class:`RunFault` line, with the temporary file removed."""
    path = out / store.RESULTS
    try:
        write_results(ds, path)
        store.atomic_write_text(out / store.SUMMARY, json.dumps(summary, indent=2, allow_nan=False) + "\n")
    except (OSError, RuntimeError) as err:
        for name in (store.RESULTS, store.SUMMARY):
            (out / f".{name}.tmp-{os.getpid()}").unlink(missing_ok=True)
        if isinstance(err, OSError):
            cause = disk_message(err)
        else:  # the netCDF library's words; say what the disk has left
            free = shutil.disk_usage(out).free
            cause = (f"No space left on device (ENOSPC: {free} bytes free, the results need about {ds.nbytes})"
                     if free < 2 * ds.nbytes + 2**20 else f"{type(err).__name__}: {err}")
        raise RunFault(str(path), f"cannot write the results: {cause}; the runs are stored: write them with the "
                       "same command and --resume") from None
