"""The output folder of a scenario: one writer at a time, and one scenario's results at a time.

* **Lock.** ``OUT/.sarnav.lock`` is held with an exclusive ``flock`` while a campaign (or study, image, sweep) writes
  into ``OUT`` and removed when it ends; a second writer is refused with one line naming the holder (pid, host,
  scenario, start). The lock dies with its process, so a killed campaign never leaves ``OUT`` locked (the file it
  may leave behind is taken by the next run). The file is removed while still locked, and a writer that locked a
  file since removed retries with a new one, so two writers never both hold "the" lock.
* **Identity.** ``OUT/sarnav.json`` says whose results the folder holds: kind, scenario name, the SHA-256
  fingerprint of the scenario text (without ``campaign.runs``, so a campaign can be extended) and the seed. A run
  into a folder holding *another* scenario's results (or results of unknown origin) is refused unless
  ``overwrite``, which first removes the files sarnav wrote there (below) and keeps every other file, saying so.
  Figures sarnav drew are always cleared at the start: a folder never shows figures of earlier results.
* **What sarnav wrote.** ``sarnav.json`` also lists (``files``) every file written while the folder was claimed
  (found by comparing the folder before and after) and those the CLI adds afterwards (:func:`record_files`:
  figures, reports); besides these, only sarnav's own names are its: the top-level :data:`OUTPUT_FILES`,
  ``runs/run_NNNNNN.npz``, ``study_*.png``, temporary ``.NAME.tmp-PID`` files (removed at every start: what a
  killed writer left) and the case folders of a study. Nothing else is ever removed.
* **Where sarnav writes.** Never into the filesystem root or the home folder; into a folder holding files sarnav
  did not write only with ``overwrite`` (they are kept); never through a symbolic link inside the folder (``runs``
  or ``figures`` as a link is refused).
"""

from __future__ import annotations

import copy
import datetime as _dt
import hashlib
import json
import os
import re
import socket
import sys
from pathlib import Path

from sarnav.errors import ConfigError
from sarnav.tomlio import dump_toml, parse_toml

__all__ = ["IDENTITY", "LOCK", "fingerprint", "identity", "OutputFolder", "clear_outputs", "record_files"]

IDENTITY = "sarnav.json"
LOCK = ".sarnav.lock"
#: files sarnav writes at the top of an output folder (removed by ``overwrite``)
OUTPUT_FILES = ("results.nc", "summary.json", "campaign.json", "INCOMPLETE", "study.json", "sensitivity.csv",
                "sensitivity.png", "image.npz", "image.png", "metrics.json", "report.html", "compare.html",
                "compare.csv", "collect.cphd", "image.nitf", "rho.csv", "rho.csv.partial", "rho_diagnostics.csv",
                "rho_diagnostics.csv.partial", "sweep.nc", "sweep.nc.partial", "claims.json", "search.json", IDENTITY)
OUTPUT_DIRS = ("runs", "figures")
#: names sarnav writes below the top level: run files, and the temporary files of atomic writes
_RUN_FILE = re.compile(r"^run_\d{6,}\.npz$")
_TEMP_FILE = re.compile(r"^\..+\.tmp-\d+$")
#: list of the files sarnav wrote, in sarnav.json
FILES_KEY = "files"


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


def _ledger(out: Path) -> set[str]:
    """The files ``sarnav.json`` lists as written by sarnav (relative POSIX paths)."""
    ident = _read_json(out / IDENTITY)
    files = ident.get(FILES_KEY) if isinstance(ident, dict) else None
    return {f for f in files if isinstance(f, str)} if isinstance(files, list) else set()


def _ours_by_name(rel: str) -> bool:
    parts = rel.split("/")
    if _TEMP_FILE.match(parts[-1]):
        return True
    if len(parts) == 1:
        return parts[0] in OUTPUT_FILES or parts[0] == LOCK or (parts[0].startswith("study_") and
                                                                  parts[0].endswith(".png"))
    return len(parts) == 2 and parts[0] == "runs" and bool(_RUN_FILE.match(parts[1]))


def _is_case_folder(path: Path) -> bool:
    return path.is_dir() and not path.is_symlink() and ((path / IDENTITY).exists() or (path / "campaign.json").exists())


def _files(out: Path):
    """(relative path, path) of every regular file below ``out``, symbolic links neither followed nor listed."""
    for root, dirs, files in os.walk(out):
        base = Path(root)
        dirs[:] = [d for d in dirs if not (base / d).is_symlink()]
        for name in files:
            p = base / name
            if not p.is_symlink():
                yield p.relative_to(out).as_posix(), p


def clear_outputs(out: Path, only_temporary: bool = False) -> list[str]:
    """Remove what sarnav wrote in ``out`` (module docstring: the files ``sarnav.json`` lists, sarnav's own names,
    study case folders) and the folders this empties; with ``only_temporary``, only temporary files of atomic writes.
    Returns the files kept (relative paths)."""
    out = Path(out)
    ledger, kept = _ledger(out), []
    for sub in sorted(p for p in out.iterdir() if _is_case_folder(p)) if not only_temporary else ():
        kept += [f"{sub.name}/{k}" for k in clear_outputs(sub)]
        _remove_empty_dirs(sub)
    for rel, p in list(_files(out)):
        temporary = _TEMP_FILE.match(p.name) is not None
        if rel in (IDENTITY, LOCK) or (only_temporary and not temporary) or not p.exists():
            continue
        if temporary or _ours_by_name(rel) or rel in ledger:
            p.unlink(missing_ok=True)
        else:
            kept.append(rel)
    if not only_temporary:
        (out / IDENTITY).unlink(missing_ok=True)
        for d in OUTPUT_DIRS:
            _remove_empty_dirs(out / d)
    return kept


def _remove_empty_dirs(top: Path) -> None:
    if not top.is_dir() or top.is_symlink():
        return
    for root, dirs, files in os.walk(top, topdown=False):
        try:
            os.rmdir(root)
        except OSError:  # not empty: something sarnav did not write is in it
            pass


def record_files(out, paths) -> None:
    """Add ``paths`` (files just written into ``out``, e.g. figures drawn after a campaign) to the list of files
    sarnav wrote there (``sarnav.json``), so that ``--overwrite`` may remove them later."""
    from sarnav.montecarlo.store import atomic_write_text

    out = Path(out)
    ident = _read_json(out / IDENTITY)
    if not isinstance(ident, dict):
        return
    root = out.resolve()
    added = set()
    for p in paths:
        try:
            added.add(Path(p).resolve().relative_to(root).as_posix())
        except ValueError:  # not inside out
            continue
    ident[FILES_KEY] = sorted(_ledger(out) | added)
    atomic_write_text(out / IDENTITY, json.dumps(ident, indent=2) + "\n")


def _signature(p: Path):
    st = p.stat()
    return st.st_ino, st.st_mtime_ns, st.st_size


def _check_place(out: Path) -> None:
    """Refuse the filesystem root and the home folder, and a ``runs``/``figures`` that is a symbolic link."""
    resolved = out.resolve()
    try:
        home = Path.home().resolve()
    except (RuntimeError, KeyError):  # no home folder known
        home = None
    if resolved == Path(resolved.anchor) or resolved == home:
        raise ConfigError("--out", f"{str(out)!r} is {'the filesystem root' if resolved == Path(resolved.anchor) else 'your home folder'}; "
                          "sarnav writes only into a folder of its own (e.g. --out sarnav-out/NAME)")
    for name in OUTPUT_DIRS + OUTPUT_FILES:
        if (out / name).is_symlink():
            raise ConfigError("--out", f"{str(out / name)!r} is a symbolic link; sarnav never writes through links: "
                              "remove it or choose another --out")


class OutputFolder:
    """``with OutputFolder(out, identity(cfg), resume=..., overwrite=...)``: lock ``out`` and claim it (module doc).

    ``resume``: the folder may hold results of the same scenario (to be finished or extended); with neither
    ``resume`` nor ``overwrite`` it may also hold them (a rerun replaces them), but not another scenario's.
    """

    def __init__(self, out, ident: dict, resume: bool = False, overwrite: bool = False):
        self.out, self.ident, self.resume, self.overwrite = Path(out), ident, resume, overwrite
        self._fh = None
        self._before: dict | None = None  # file signatures when claimed (to find what was written)
        self._ledger: set[str] = set()

    def __enter__(self) -> "OutputFolder":
        out = self.out
        if out.exists() or out.is_symlink():
            _check_place(out)
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise self._unwritable(err) from None
        _check_place(out)
        self._lock()
        try:
            self._claim()
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def _claim(self) -> None:
        out = self.out
        held = _held_identity(out)
        foreign = [rel for rel, _ in _files(out) if rel not in (LOCK,)] if held is None else []
        if held is not None and not _same(held, self.ident) and not self.overwrite:
            what = (f"the results of scenario {held.get('scenario')!r} (kind {held.get('kind')!r}, "
                    f"seed {held.get('seed')})" if held else "sarnav results of unknown origin")
            raise ConfigError("--out", f"{str(out)!r} holds {what}; use --overwrite to replace them or choose "
                              "another --out")
        if foreign and not self.overwrite:
            raise ConfigError("--out", f"{str(out)!r} holds {len(foreign)} file(s) sarnav did not write (e.g. "
                              f"{sorted(foreign)[0]}); choose an empty or new folder, or --overwrite to write beside "
                              "them (they are kept)")
        ledger = _ledger(out)
        if (held is not None and not _same(held, self.ident)) or self.overwrite:
            kept = clear_outputs(out)
            ledger = set()
            if kept:
                print(f"sarnav: notice: --overwrite kept {len(kept)} file(s) in {str(out)!r} that sarnav did not "
                      f"write (e.g. {sorted(kept)[0]})", file=sys.stderr)
        else:
            clear_outputs(out, only_temporary=True)  # what a killed writer left half-written
        for rel in sorted(r for r in ledger if r.startswith("figures/")):
            (out / rel).unlink(missing_ok=True)
            ledger.discard(rel)
        _remove_empty_dirs(out / "figures")
        self._before = {rel: _signature(p) for rel, p in _files(out)}
        self._ledger = ledger
        self._write_identity()

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

        files = sorted(r for r in self._ledger  # run files (also a study case's) are sarnav's by their names
                       if not _ours_by_name(r) and not (r.count("/") >= 1 and r.split("/")[-2] == "runs"
                                                         and _RUN_FILE.match(r.split("/")[-1])))
        try:
            atomic_write_text(self.out / IDENTITY, json.dumps(dict(self.ident, written=_now(), **{FILES_KEY: files}),
                                                              indent=2) + "\n")
        except OSError as err:
            (self.out / f".{IDENTITY}.tmp-{os.getpid()}").unlink(missing_ok=True)
            raise self._unwritable(err) from None

    def _record_written(self) -> None:
        """Add the files written while the folder was claimed to its list of sarnav's files."""
        written = set()
        for rel, p in _files(self.out):
            try:
                if rel not in (IDENTITY, LOCK) and self._before.get(rel) != _signature(p):
                    written.add(rel)
            except OSError:
                continue
        self._ledger = {r for r in self._ledger | written if (self.out / r).exists()}
        self._write_identity()

    def __exit__(self, *exc) -> bool:
        if self._before is not None:
            try:
                self._record_written()
            except OSError:  # e.g. the disk is full: the error being raised says so; the list stays as it was
                pass
            self._before = None
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
