"""The campaign directory: one ``runs/run_NNNNNN.npz`` per finished run, the manifest
``campaign.json``, the ``INCOMPLETE`` marker. Every file is written atomically (temporary file in the
same directory, then ``os.replace``), so a killed campaign leaves whole files or none.

Every run file carries the campaign's stamp (scenario fingerprint, seed, sarnav version, run index) and a SHA-256
checksum of its arrays; :func:`load_record` verifies both against what the campaign expects, so a file of another
campaign, of another run, truncated or altered is named in one line with the command that repairs it.

Layout (docs/results.md)::

    OUT/campaign.json     manifest: scenario TOML text, seed, runs, complete flag
    OUT/INCOMPLETE        present from the start of a campaign until it is complete
    OUT/runs/run_000123.npz
    OUT/results.nc, OUT/summary.json   written only when every run is stored
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import zipfile
from pathlib import Path

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.montecarlo.record import RunRecord

__all__ = [
    "atomic_write_bytes",
    "atomic_write_text",
    "run_path",
    "StoredRunError",
    "save_record",
    "load_record",
    "stored_runs",
    "read_manifest",
    "write_manifest",
    "file_sha256",
    "product_checksums",
    "verify_products",
    "MANIFEST",
    "MARKER",
    "RESULTS",
    "SUMMARY",
]

MANIFEST = "campaign.json"
MARKER = "INCOMPLETE"
RESULTS = "results.nc"
SUMMARY = "summary.json"
_RUN_RE = re.compile(r"^run_(\d{6,})\.npz$")
_FIELDS = ("time", "error", "sigma", "nees", "update_time", "residual", "residual_sigma", "nis", "nis_dof")


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` via a temporary file in the same directory and ``os.replace``."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    with open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def run_path(out: str | os.PathLike, run: int) -> Path:
    return Path(out) / "runs" / f"run_{run:06d}.npz"


class StoredRunError(InputDataError):
    """A stored run file that cannot be used (unreadable, altered, or of another campaign or run); the message
    says how to repair it."""

    def __init__(self, path, problem: str, run: int | None = None):
        hint = (f"; repair with the same command and --resume --redo-run {run}" if run is not None
                else "; delete it and rerun with --resume")
        super().__init__(str(path), problem + hint)


def _checksum(arrays: dict) -> str:
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(name.encode())
        h.update(str(a.dtype).encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def save_record(out: str | os.PathLike, rec: RunRecord, stamp: dict | None = None) -> Path:
    """Store one run (atomic); extras as ``extra.<name>`` with their dims in ``dims.<name>``; the campaign's
    ``stamp`` (fingerprint, seed, sarnav_version) with the run index, and a checksum of every array."""
    arrays = {name: np.asarray(getattr(rec, name)) for name in _FIELDS}
    arrays["run"] = np.asarray(rec.run, dtype=np.int64)
    for name, (dims, arr) in rec.extras.items():
        arrays[f"extra.{name}"] = np.asarray(arr)
        arrays[f"dims.{name}"] = np.asarray(list(dims), dtype=str)
    arrays["stamp"] = np.asarray(json.dumps(dict(stamp or {}, run=int(rec.run)), sort_keys=True))
    arrays["checksum"] = np.asarray(_checksum(arrays))
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    path = run_path(out, rec.run)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, buf.getvalue())
    return path


def _run_of(path: Path) -> int | None:
    m = _RUN_RE.match(Path(path).name)
    return int(m.group(1)) if m else None


def load_record(path: str | os.PathLike, expect: dict | None = None) -> RunRecord:
    """Read a run stored by :func:`save_record`, verifying its checksum and, when ``expect`` (a stamp: fingerprint,
    seed, sarnav_version) is given, that it is this campaign's run of the index its name says.

    Raises :class:`StoredRunError` naming the file."""
    run = _run_of(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as err:
        raise StoredRunError(path, f"unreadable run file ({type(err).__name__}: truncated or corrupt)", run) from None
    if "checksum" not in arrays or "stamp" not in arrays:
        raise StoredRunError(path, "run file without a campaign stamp (written by another sarnav version?)", run)
    body = {k: v for k, v in arrays.items() if k != "checksum"}
    if _checksum(body) != str(arrays["checksum"]):
        raise StoredRunError(path, "run file altered: its checksum does not match its contents", run)
    stamp = json.loads(str(arrays["stamp"]))
    if run is not None and stamp.get("run") != run:
        raise StoredRunError(path, f"holds run {stamp.get('run')}, not run {run}", run)
    if expect is not None:
        for key in ("fingerprint", "seed", "sarnav_version"):
            if stamp.get(key) != expect.get(key):
                raise StoredRunError(path, f"belongs to another campaign ({key} {stamp.get(key)!r}, this campaign's "
                                     f"{expect.get(key)!r})", run)
    try:
        kw = {name: arrays[name] for name in _FIELDS}
    except KeyError as err:
        raise StoredRunError(path, f"run file without {err}", run) from None
    extras = {}
    for key in arrays:
        if key.startswith("extra."):
            name = key[len("extra."):]
            extras[name] = (tuple(str(d) for d in arrays[f"dims.{name}"]), arrays[key])
    return RunRecord(run=int(arrays["run"]), extras=extras, **kw)


def stored_runs(out: str | os.PathLike) -> set[int]:
    """Run indices with a stored file (atomic writes: a file that exists is whole)."""
    d = Path(out) / "runs"
    if not d.is_dir():
        return set()
    found = set()
    for p in d.iterdir():
        m = _RUN_RE.match(p.name)
        if m:
            found.add(int(m.group(1)))
    return found


def read_manifest(out: str | os.PathLike) -> dict | None:
    """The manifest, or None when there is none; an unreadable one is a ConfigError naming the file."""
    p = Path(out) / MANIFEST
    if not p.is_file():
        return None
    try:
        with open(p, encoding="utf-8") as fh:
            manifest = json.load(fh)
    except (OSError, ValueError) as err:
        raise ConfigError(str(p), f"unreadable campaign manifest ({type(err).__name__}); run without --resume "
                          "(with --overwrite if the folder holds another scenario) or choose another --out") from None
    if not isinstance(manifest, dict):
        raise ConfigError(str(p), "is not a campaign manifest (a JSON object)")
    return manifest


#: the manifest's table of the finished products' SHA-256 (``{"results.nc": "...", "summary.json": "..."}``)
CHECKSUMS = "checksums"


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def product_checksums(out: str | os.PathLike, names=(RESULTS, SUMMARY)) -> dict:
    """``{name: SHA-256}`` of the finished products, computed on the files as written (recorded in the manifest)."""
    return {name: file_sha256(Path(out) / name) for name in names}


def verify_products(out: str | os.PathLike, field: str | None = None) -> None:
    """Check every product the manifest of ``out`` lists under ``checksums`` against its file; a mismatch (40 flipped
    bytes in results.nc gave errors off by 1e8 m that went straight into report, figures and compare) is an
    :class:`InputDataError` naming the file and the repair. Folders written before checksums were recorded pass."""
    manifest = read_manifest(out) or {}
    sums = manifest.get(CHECKSUMS)
    if not isinstance(sums, dict):
        return
    for name, digest in sorted(sums.items()):
        path = Path(out) / str(name)
        try:
            actual = file_sha256(path)
        except OSError as err:
            raise InputDataError(field or str(path), f"{name} cannot be read ({err.strerror})") from None
        if actual != digest:
            raise InputDataError(field or str(path), f"{name} does not match the SHA-256 recorded in {MANIFEST} "
                                 "(altered or damaged since it was written); write it again with the same "
                                 "`sarnav run` command and --resume")


def write_manifest(out: str | os.PathLike, manifest: dict) -> None:
    atomic_write_text(Path(out) / MANIFEST, json.dumps(manifest, indent=2) + "\n")
