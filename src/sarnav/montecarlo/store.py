"""The campaign directory: one ``runs/run_NNNNNN.npz`` per finished run, the manifest
``campaign.json``, the ``INCOMPLETE`` marker. Every file is written atomically (temporary file in the
same directory, then ``os.replace``), so a killed campaign leaves whole files or none.

Layout (docs/results.md)::

    OUT/campaign.json     manifest: scenario TOML text, seed, runs, complete flag
    OUT/INCOMPLETE        present from the start of a campaign until it is complete
    OUT/runs/run_000123.npz
    OUT/results.nc, OUT/summary.json   written only when every run is stored
"""

from __future__ import annotations

import io
import json
import os
import re
from pathlib import Path

import numpy as np

from sarnav.montecarlo.record import RunRecord

__all__ = [
    "atomic_write_bytes",
    "atomic_write_text",
    "run_path",
    "save_record",
    "load_record",
    "stored_runs",
    "read_manifest",
    "write_manifest",
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


def save_record(out: str | os.PathLike, rec: RunRecord) -> Path:
    """Store one run (atomic); extras as ``extra.<name>`` with their dims in ``dims.<name>``."""
    arrays = {name: np.asarray(getattr(rec, name)) for name in _FIELDS}
    arrays["run"] = np.asarray(rec.run, dtype=np.int64)
    for name, (dims, arr) in rec.extras.items():
        arrays[f"extra.{name}"] = np.asarray(arr)
        arrays[f"dims.{name}"] = np.asarray(list(dims), dtype=str)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    path = run_path(out, rec.run)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, buf.getvalue())
    return path


def load_record(path: str | os.PathLike) -> RunRecord:
    """Read a run stored by :func:`save_record`."""
    with np.load(path, allow_pickle=False) as z:
        kw = {name: z[name] for name in _FIELDS}
        extras = {}
        for key in z.files:
            if key.startswith("extra."):
                name = key[len("extra."):]
                extras[name] = (tuple(str(d) for d in z[f"dims.{name}"]), z[key])
        return RunRecord(run=int(z["run"]), extras=extras, **kw)


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
    p = Path(out) / MANIFEST
    if not p.is_file():
        return None
    with open(p, encoding="utf-8") as fh:
        return json.load(fh)


def write_manifest(out: str | os.PathLike, manifest: dict) -> None:
    atomic_write_text(Path(out) / MANIFEST, json.dumps(manifest, indent=2) + "\n")
