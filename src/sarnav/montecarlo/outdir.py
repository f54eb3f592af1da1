"""The output folder of a scenario: one writer at a time, and one scenario's results at a time.

* **Lock.** ``OUT/.sarnav.lock`` is held with an exclusive ``flock`` while a campaign (or study, image, sweep) writes
  into ``OUT`` and removed when it ends; a second writer is refused with one line naming the holder (pid, host,
  scenario, start). The lock dies with its process, so a killed campaign never leaves ``OUT`` locked (the file it
  may leave behind is taken by the next run). The file is removed while still locked, and a writer that locked a
  file since removed retries with a new one, so two writers never both hold "the" lock.
* **Identity.** ``OUT/sarnav.json`` says whose results the folder holds: kind, scenario name, the SHA-256
  fingerprint of the scenario text (without ``campaign.runs``, so a campaign can be extended) and the seed. A run
  into a folder holding *another* scenario's results (or results of unknown origin) is refused unless
  ``overwrite``, which first removes every file sarnav writes there (results, runs, figures, reports; case
  sub-folders of a study). Figures are always cleared at the start: a folder never shows figures of earlier results.
"""

from __future__ import annotations

import copy
import datetime as _dt
import hashlib
import json
import os
import shutil
import socket
from pathlib import Path

from sarnav.errors import ConfigError
from sarnav.tomlio import dump_toml, parse_toml

__all__ = ["IDENTITY", "LOCK", "fingerprint", "identity", "OutputFolder", "clear_outputs"]

IDENTITY = "sarnav.json"
LOCK = ".sarnav.lock"
#: files sarnav writes at the top of an output folder (removed by ``overwrite``)
OUTPUT_FILES = ("results.nc", "summary.json", "campaign.json", "INCOMPLETE", "study.json", "sensitivity.csv",
                "sensitivity.png", "image.npz", "image.png", "metrics.json", "report.html", "compare.html",
                "compare.csv", "collect.cphd", "image.nitf", "rho.csv", "rho.csv.partial", "rho_diagnostics.csv",
                "rho_diagnostics.csv.partial", "sweep.nc", "sweep.nc.partial", "claims.json", "search.json", IDENTITY)
OUTPUT_DIRS = ("runs", "figures")


def fingerprint(cfg: dict) -> str:
    """SHA-256 of the scenario's canonical TOML text with ``campaign.runs`` removed (its other values, seed
    included, are part of it)."""
    c = copy.deepcopy(cfg)
    if isinstance(c.get("campaign"), dict):
        c["campaign"].pop("runs", None)
    return hashlib.sha256(dump_toml(c).encode("utf-8")).hexdigest()


def identity(cfg: dict) -> dict:
    """What a folder holding this scenario's results says of itself (``sarnav.json``)."""
    camp = cfg.get("campaign") if isinstance(cfg.get("campaign"), dict) else {}
    return {"kind": cfg["scenario"]["kind"], "scenario": cfg["scenario"]["name"], "fingerprint": fingerprint(cfg),
            "seed": camp.get("seed")}


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def _read_json(path: Path):
    try:
        with open(path, encoding="utf-8") as fh:
            return json.load(fh)
    except (OSError, ValueError):
        return None


def _held_identity(out: Path) -> dict | None:
    """The identity of what ``out`` holds: ``sarnav.json``, a 0.1 campaign's manifest, ``{}`` for sarnav outputs of
    unknown origin, None for a folder with no sarnav outputs."""
    ident = _read_json(out / IDENTITY)
    if isinstance(ident, dict):
        return ident
    manifest = _read_json(out / "campaign.json")
    if isinstance(manifest, dict) and isinstance(manifest.get("scenario_toml"), str):
        try:
            return identity(parse_toml(manifest["scenario_toml"]))
        except ConfigError:
            return {}
    if any((out / f).exists() for f in OUTPUT_FILES) or (out / "runs").is_dir():
        return {}
    return None


def _same(a: dict, b: dict) -> bool:
    return all(a.get(k) == b.get(k) for k in ("kind", "fingerprint", "seed"))


def clear_outputs(out: Path) -> None:
    """Remove what sarnav wrote in ``out`` (files of :data:`OUTPUT_FILES`, ``runs/``, ``figures/``, study case
    folders); other files are left alone."""
    for name in OUTPUT_FILES:
        (out / name).unlink(missing_ok=True)
    for p in out.glob("study_*.png"):
        p.unlink()
    for d in OUTPUT_DIRS:
        shutil.rmtree(out / d, ignore_errors=True)
    for sub in out.iterdir():
        if sub.is_dir() and ((sub / IDENTITY).exists() or (sub / "campaign.json").exists()):
            clear_outputs(sub)
            try:
                sub.rmdir()
            except OSError:
                pass


class OutputFolder:
    """``with OutputFolder(out, identity(cfg), resume=..., overwrite=...)``: lock ``out`` and claim it (module doc).

    ``resume``: the folder may hold results of the same scenario (to be finished or extended); with neither
    ``resume`` nor ``overwrite`` it may also hold them (a rerun replaces them), but not another scenario's.
    """

    def __init__(self, out, ident: dict, resume: bool = False, overwrite: bool = False):
        self.out, self.ident, self.resume, self.overwrite = Path(out), ident, resume, overwrite
        self._fh = None

    def __enter__(self) -> "OutputFolder":
        out = self.out
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise self._unwritable(err) from None
        self._lock()
        held = _held_identity(out)
        if held is not None and not _same(held, self.ident):
            if not self.overwrite:
                what = (f"the results of scenario {held.get('scenario')!r} (kind {held.get('kind')!r}, "
                        f"seed {held.get('seed')})" if held else "sarnav results of unknown origin")
                self.__exit__(None, None, None)
                raise ConfigError("--out", f"{str(out)!r} holds {what}; use --overwrite to replace them or choose "
                                  "another --out")
            clear_outputs(out)
        elif self.overwrite:
            clear_outputs(out)
        shutil.rmtree(out / "figures", ignore_errors=True)
        self._write_identity()
        return self

    def _unwritable(self, err: OSError) -> ConfigError:
        return ConfigError("--out", f"cannot create or write in output directory {str(self.out)!r}: {err.strerror}")

    def _lock(self) -> None:
        import fcntl

        path = self.out / LOCK
        for _ in range(100):  # another writer may remove the file we opened (it ends): lock the current file
            try:
                self._fh = open(path, "a+", encoding="utf-8")
            except OSError as err:
                raise self._unwritable(err) from None
            try:
                fcntl.flock(self._fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                self._fh.seek(0)
                holder = self._fh.read().strip() or "another process"
                self._fh.close()
                self._fh = None
                raise ConfigError("--out", f"{str(self.out)!r} is in use by another sarnav run ({holder}); wait for "
                                  "it to finish or choose another --out") from None
            try:
                if os.stat(path).st_ino == os.fstat(self._fh.fileno()).st_ino:
                    break
            except FileNotFoundError:
                pass
            self._fh.close()
            self._fh = None
        else:  # pragma: no cover - a hundred writers ending one after the other
            raise ConfigError("--out", f"{str(self.out)!r}: could not take the lock {LOCK}; try again")
        self._fh.seek(0)
        self._fh.truncate()
        self._fh.write(f"pid {os.getpid()} on {socket.gethostname()}, scenario {self.ident.get('scenario')!r}, "
                       f"started {_now()}")
        self._fh.flush()

    def _write_identity(self) -> None:
        from sarnav.montecarlo.store import atomic_write_text

        atomic_write_text(self.out / IDENTITY, json.dumps(dict(self.ident, written=_now()), indent=2) + "\n")

    def __exit__(self, *exc) -> bool:
        if self._fh is not None:
            import fcntl

            try:  # removed while still locked (see the module docstring)
                (self.out / LOCK).unlink()
            except OSError:
                pass
            fcntl.flock(self._fh, fcntl.LOCK_UN)
            self._fh.close()
            self._fh = None
        return False
