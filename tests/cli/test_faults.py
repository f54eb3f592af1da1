"""Fault injection (issue 31): every fault a campaign meets ends with one line naming the cause (and, where work is
kept, the ``--resume`` command), the documented exit status (2: input, 3: a fault of the machine), nothing outside
``--out`` created or deleted, no process of the campaign left behind, and ``--resume`` gives the results of an
uninterrupted campaign.

Default: the fast cases (in-process faults through patched writers, one real dead worker, the path cases).
``-m slow``: kill -9 of the main process and of a worker at random moments.
"""

from __future__ import annotations

import errno
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from helpers import child_pids
from toy_kind import TESTS, TOY, toy_cfg

from sarnav.cli.main import main
from sarnav.montecarlo import campaign, store
from sarnav.montecarlo.assemble import open_results
from sarnav.montecarlo.campaign import run_campaign
from sarnav.tomlio import dump_toml

VARS = ("error", "sigma", "nees", "residual", "residual_sigma", "nis", "nis_dof", "truth_x_final")
LINUX = Path("/proc/self/stat").exists()


def _one_line(capsys, code: int, want_code: int, *parts: str) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.strip().splitlines() if not ln.startswith("sarnav: notice:")]
    assert code == want_code and len(lines) == 1 and lines[0].startswith("sarnav: error: "), (code, err)
    assert "Traceback" not in err
    for part in parts:
        assert part in lines[0], lines[0]
    return lines[0]


def _tree(root: Path) -> dict:
    """Every path below ``root`` with its size and mtime (files; what 'nothing changed' compares)."""
    out = {}
    for p in sorted(root.rglob("*")):
        try:
            st = p.lstat()
        except OSError:
            continue
        out[str(p.relative_to(root))] = None if p.is_dir() else (st.st_size, st.st_mtime_ns)
    return out


def _outside(tree: dict, out: Path, root: Path) -> dict:
    rel = str(out.relative_to(root))
    return {k: v for k, v in tree.items() if k != rel and not k.startswith(rel + os.sep)}


def _same_results(a: Path, b: Path) -> None:
    da, db = open_results(a / "results.nc"), open_results(b / "results.nc")
    for v in VARS:
        assert np.array_equal(da[v].values, db[v].values, equal_nan=True), v


@pytest.fixture
def toy(tmp_path):
    """A toy scenario file, its uninterrupted results in ``ref``, and the command line of a campaign into ``out``."""
    cfg = toy_cfg(runs=6, steps=20)
    f = tmp_path / "toy.toml"
    f.write_text(dump_toml(cfg))
    run_campaign(cfg, tmp_path / "ref", TOY, executor="serial", quiet=True)
    argv = ["run", str(f), "--out", str(tmp_path / "out"), "--quiet", "--no-figures", "--executor", "serial",
            "--chunk-size", "2"]
    return tmp_path, argv


# ----------------------------------------------------------------------------- what --out may touch
def test_overwrite_keeps_files_sarnav_did_not_write(tmp_path, capsys, toy):
    root, argv = toy
    out = tmp_path / "out"
    (out / "runs").mkdir(parents=True)
    (out / "figures").mkdir()
    (out / "runs" / "mydata.npz").write_bytes(b"user data")
    (out / "figures" / "mine.png").write_bytes(b"user figure")
    before = _tree(root)
    # a folder holding files sarnav did not write: refused without --overwrite, nothing touched
    _one_line(capsys, main(argv), 2, "--out", "--overwrite")
    assert _tree(root) == before
    assert main(argv + ["--overwrite"]) == 0
    err = capsys.readouterr().err
    assert "kept 2 file(s)" in err
    assert (out / "runs" / "mydata.npz").read_bytes() == b"user data"
    assert (out / "figures" / "mine.png").read_bytes() == b"user figure"
    _same_results(root / "ref", out)
    # figures sarnav drew are its own: the next --overwrite removes them, the user's stay
    argv_fig = [a for a in argv if a != "--no-figures"]
    assert main(argv_fig + ["--overwrite"]) == 0
    drawn = sorted(p.name for p in (out / "figures").glob("*.png") if p.name != "mine.png")
    assert drawn
    (out / "figures" / drawn[0]).write_bytes(b"stale")
    assert main(argv + ["--overwrite"]) == 0
    assert not (out / "figures" / drawn[0]).exists() and (out / "figures" / "mine.png").exists()
    assert (out / "runs" / "mydata.npz").exists()
    assert _outside(_tree(root), out, root) == _outside(before, out, root)


def test_the_filesystem_root_and_the_home_folder_are_refused(tmp_path, capsys, toy, monkeypatch):
    _, argv = toy
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    root_before = sorted(os.listdir("/"))
    i = argv.index("--out") + 1
    for where, words in (("/", "filesystem root"), (str(home), "home folder"), ("~", None)):
        a = list(argv)
        a[i] = where if where != "~" else str(Path("~").expanduser())
        _one_line(capsys, main(a), 2, "--out", words or "home folder")
    assert sorted(os.listdir("/")) == root_before and not list(home.iterdir())


def test_a_symlink_inside_out_is_never_written_through(tmp_path, capsys, toy):
    root, argv = toy
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    assert main(argv) == 0
    elsewhere.mkdir()
    shutil.rmtree(out / "runs")
    (out / "runs").symlink_to(elsewhere, target_is_directory=True)
    _one_line(capsys, main(argv + ["--overwrite"]), 2, "symbolic link")
    assert not list(elsewhere.iterdir())


# ----------------------------------------------------------------------------- checksummed results
@pytest.mark.parametrize("command", ["report", "figures", "compare"])
def test_a_corrupted_results_nc_is_refused_by_what_reads_it(tmp_path, capsys, toy, command):
    root, argv = toy
    out = tmp_path / "out"
    assert main(argv) == 0
    data = bytearray((out / "results.nc").read_bytes())
    rng = random.Random(3)
    for k in rng.sample(range(len(data) // 2, len(data)), 40):  # 40 flipped bytes in the data
        data[k] ^= 0xFF
    (out / "results.nc").write_bytes(bytes(data))
    argv2 = {"report": ["report", str(out)], "figures": ["figures", str(out)],
             "compare": ["compare", str(out), str(root / "ref"), "--out", str(tmp_path / "cmp")]}[command]
    _one_line(capsys, main(argv2), 2, "results.nc does not match the SHA-256", "--resume")
    assert main(argv + ["--resume"]) == 0  # the repair the line names
    _same_results(root / "ref", out)
    assert main(argv2) == 0


# ----------------------------------------------------------------------------- one --set parser
@pytest.mark.parametrize("value, words", [
    ('campaign.runs=3\n[imu]\ngrade="consumer"', "exactly one TOML value"),
    ("campaign.runs=3\nx = 1", "exactly one TOML value"),
    ("campaign.runs=3, x=1", "cannot parse"),
    ("campaign.runs=" + "[" * 1000 + "]" * 1000, "nested more than"),
    ("trajectory.speed=1e-300", "trajectory.speed: must be in"),
])
def test_set_is_exactly_one_value_and_show_checks_like_run(tmp_path, capsys, value, words):
    for argv in (["show", "telemetry"], ["run", "telemetry", "--out", str(tmp_path / "o"), "--quiet",
                                         "--executor", "serial"]):
        _one_line(capsys, main(argv + ["--set", value]), 2, words)
    assert not (tmp_path / "o" / "results.nc").exists()


def test_a_scenario_nested_1000_deep_is_one_line(tmp_path, capsys):
    f = tmp_path / "deep.toml"
    f.write_text('[scenario]\nname = "x"\nkind = "telemetry"\n[' + ".".join(["a"] * 1000) + "]\nz = 1\n")
    _one_line(capsys, main(["show", str(f)]), 2, "nested more than")


# ----------------------------------------------------------------------------- a full disk at each stage
def _enospc(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_a_full_disk_while_storing_runs(tmp_path, capsys, toy, monkeypatch):
    root, argv = toy
    out = tmp_path / "out"
    real, calls = store.save_record, []

    def save(out_, rec, stamp=None):
        calls.append(rec.run)
        if len(calls) > 3:
            path = store.run_path(out_, rec.run)
            (path.parent / f".{path.name}.tmp-{os.getpid()}").write_bytes(b"half")  # what a full disk leaves
            _enospc()
        return real(out_, rec, stamp)

    monkeypatch.setattr(store, "save_record", save)
    before = _tree(root)
    _one_line(capsys, main(argv), 3, "No space left on device", "--resume")
    assert len(store.stored_runs(out)) == 3 and not (out / "results.nc").exists()
    assert _outside(_tree(root), out, root) == _outside(before, out, root)
    monkeypatch.setattr(store, "save_record", real)
    assert main(argv + ["--resume"]) == 0
    _same_results(root / "ref", out)
    assert not [p for p in out.rglob("*") if ".tmp-" in p.name]  # the half-written file is gone


def test_a_full_disk_while_writing_results_nc(tmp_path, capsys, toy, monkeypatch):
    """netCDF says only 'NetCDF: HDF error'; the line says the disk is full, the partial file is removed."""
    root, argv = toy
    out = tmp_path / "out"

    def write_results(ds, path):
        Path(path).with_name(f".{Path(path).name}.tmp-{os.getpid()}").write_bytes(b"\x89HDF partial")
        raise RuntimeError("NetCDF: HDF error")

    class Usage:
        free = 1000

    monkeypatch.setattr(campaign, "write_results", write_results)
    monkeypatch.setattr(campaign.shutil, "disk_usage", lambda p: Usage)
    before = _tree(root)
    _one_line(capsys, main(argv), 3, "results.nc: cannot write the results: No space left on device", "--resume")
    assert _outside(_tree(root), out, root) == _outside(before, out, root)
    assert not [p for p in out.rglob("*") if ".tmp-" in p.name]
    assert len(store.stored_runs(out)) == 6 and not (out / "results.nc").exists()
    monkeypatch.undo()
    assert main(argv + ["--resume"]) == 0
    _same_results(root / "ref", out)


def test_a_full_disk_while_drawing_figures(tmp_path, capsys, toy, monkeypatch):
    import sarnav.report.figures as figures

    root, argv = toy
    monkeypatch.setattr(figures, "write_campaign_figures", _enospc)
    before = _tree(root)
    _one_line(capsys, main([a for a in argv if a != "--no-figures"]), 3, "No space left on device", "sarnav figures")
    assert _outside(_tree(root), tmp_path / "out", root) == _outside(before, tmp_path / "out", root)
    _same_results(root / "ref", tmp_path / "out")  # the results are complete


def test_a_full_disk_when_the_folder_or_the_manifest_is_written(tmp_path, capsys, toy, monkeypatch):
    """The two stages left: the output folder's manifest at the start (nothing to resume: the line names the folder)
    and the final manifest (every product written: the line names it and --resume completes the campaign)."""
    root, argv = toy
    out = tmp_path / "out"
    real = store.write_manifest
    before = _tree(root)
    monkeypatch.setattr(store, "write_manifest", _enospc)
    _one_line(capsys, main(argv), 3, "cannot write in the output folder: No space left on device")
    assert _outside(_tree(root), out, root) == _outside(before, out, root)

    def final_fails(out_, manifest):
        if manifest.get("complete"):
            _enospc()
        return real(out_, manifest)

    shutil.rmtree(out)
    monkeypatch.setattr(store, "write_manifest", final_fails)
    _one_line(capsys, main(argv), 3, "cannot write the manifest: No space left on device", "--resume")
    assert len(store.stored_runs(out)) == 6
    monkeypatch.setattr(store, "write_manifest", real)
    assert main(argv + ["--resume"]) == 0
    _same_results(root / "ref", out)
    assert _outside(_tree(root), out, root) == _outside(before, out, root)


def test_a_lost_dask_cluster_is_one_line_and_resume_finishes(tmp_path, capsys, toy, monkeypatch):
    """A dask fault (the scheduler's connection closed) on the second chunk: one line naming the cluster and
    --resume, exit 3, the first chunk's runs kept; --resume on the local processes gives the uninterrupted results."""
    pytest.importorskip("distributed")
    from distributed.comm.core import CommClosedError

    from sarnav.montecarlo import executors

    root, argv = toy
    out = tmp_path / "out"
    real, calls = executors._result, []

    class Lost:
        def result(self):
            raise CommClosedError("in <TCP (closed) ConnectionPool.gather local=tcp://127.0.0.1>: Stream is closed")

    def result(fut, ids, executor):
        calls.append(executor)
        return real(Lost() if len(calls) == 2 else fut, ids, executor)

    monkeypatch.setattr(executors, "_result", result)
    dask_argv = [a for a in argv if a != "serial"]
    dask_argv[dask_argv.index("--executor") + 1:dask_argv.index("--executor") + 1] = ["dask"]
    dask_argv += ["--workers", "1"]
    line = _one_line(capsys, main(dask_argv), 3, "--executor dask: the dask cluster failed", "CommClosedError",
                     "--resume")
    assert calls[:2] == ["dask", "dask"], line
    assert len(store.stored_runs(out)) == 2 and not (out / "results.nc").exists()
    monkeypatch.setattr(executors, "_result", real)
    assert main(argv + ["--resume"]) == 0
    _same_results(root / "ref", out)


def test_stale_temporary_files_are_removed_at_the_next_start(tmp_path, capsys, toy):
    root, argv = toy
    out = tmp_path / "out"
    assert main(argv) == 0
    for p in (out / ".results.nc.tmp-99999", out / "runs" / ".run_000001.npz.tmp-99999"):
        p.write_bytes(b"left by a killed writer")
    assert main(argv + ["--resume"]) == 0
    assert not [p for p in out.rglob("*") if ".tmp-" in p.name]


# ----------------------------------------------------------------------------- dead processes
def _env() -> dict:
    return dict(os.environ, PYTHONPATH=str(TESTS) + os.pathsep + os.environ.get("PYTHONPATH", ""))


def _alive(pids) -> list[int]:
    alive = []
    for p in pids:
        try:
            state = Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            alive.append(p)
    return alive


def _wait_gone(pids, seconds: float = 5.0) -> list[int]:
    deadline = time.time() + seconds
    while time.time() < deadline and _alive(pids):
        time.sleep(0.05)
    return _alive(pids)


def _campaign(tmp_path: Path, runs: int = 24, delay: float = 0.2):
    cfg = toy_cfg(runs=runs, delay=delay)
    f = tmp_path / "toy.toml"
    f.write_text(dump_toml(cfg))
    cmd = [sys.executable, "-m", "sarnav.cli.main", "run", str(f), "--out", str(tmp_path / "out"), "--workers", "2",
           "--chunk-size", "2", "--quiet", "--no-figures"]
    return cfg, cmd


def _start(cmd):
    return subprocess.Popen(cmd, env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _workers(proc, n: int = 2, timeout: float = 120.0) -> list[int]:
    """The pool's worker processes once they compute (their first run stored)."""
    out = Path(proc.args[proc.args.index("--out") + 1])
    deadline = time.time() + timeout
    while time.time() < deadline and proc.poll() is None and not store.stored_runs(out):
        time.sleep(0.02)
    return [w for w in child_pids(proc.pid) if b"spawn_main" in _cmdline(w)]


def _cmdline(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""


def _resume_equals_uninterrupted(tmp_path, cfg, cmd) -> None:
    r = subprocess.run(cmd + ["--resume"], env=_env(), capture_output=True, timeout=300)
    assert r.returncode == 0, r.stderr
    run_campaign(cfg, tmp_path / "ref", TOY, executor="serial", quiet=True)
    _same_results(tmp_path / "ref", tmp_path / "out")


@pytest.mark.skipif(not LINUX, reason="needs Linux /proc")
def test_a_dead_worker_is_one_line_and_resume_finishes(tmp_path):
    cfg, cmd = _campaign(tmp_path)
    proc = _start(cmd)
    try:
        workers = _workers(proc)
        assert workers, "no worker started"
        os.kill(workers[0], signal.SIGKILL)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    lines = err.decode().strip().splitlines()
    assert proc.returncode == 3 and len(lines) == 1, err
    assert lines[0].startswith("sarnav: error: --workers: a worker process died") and "--resume" in lines[0]
    assert not _wait_gone(child_pids(proc.pid) + workers)
    _resume_equals_uninterrupted(tmp_path, cfg, cmd)


def _reap(proc) -> None:
    """Wait for the (killed) main process; kill it if it is still running (a failed test leaves nothing behind)."""
    try:
        proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()


def _kill_main_at(tmp_path, after: float):
    cfg, cmd = _campaign(tmp_path)
    proc = _start(cmd)
    try:
        workers = _workers(proc)
        time.sleep(after)
        family = child_pids(proc.pid)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        _reap(proc)
    left = _wait_gone(family + workers)  # every process of the campaign: workers, resource tracker
    for p in left:  # do not leave them to the next test
        os.kill(p, signal.SIGKILL)
    assert not left, f"alive 5 s after the main process died: {left}"
    assert not (tmp_path / "out" / "results.nc").exists() or store.read_manifest(tmp_path / "out")["complete"]
    _resume_equals_uninterrupted(tmp_path, cfg, cmd)


@pytest.mark.skipif(not LINUX, reason="needs Linux /proc")
def test_kill_9_of_the_main_process_leaves_no_process_and_resume_finishes(tmp_path):
    _kill_main_at(tmp_path, 0.3)


@pytest.mark.slow
@pytest.mark.skipif(not LINUX, reason="needs Linux /proc")
@pytest.mark.parametrize("trial", range(4))
def test_kill_9_of_the_main_process_at_random_moments(tmp_path, trial):
    _kill_main_at(tmp_path, random.Random(trial).uniform(0.0, 2.0))


@pytest.mark.slow
@pytest.mark.skipif(not LINUX, reason="needs Linux /proc")
@pytest.mark.parametrize("trial", range(3))
def test_kill_9_of_a_worker_at_random_moments(tmp_path, trial):
    cfg, cmd = _campaign(tmp_path)
    proc = _start(cmd)
    try:
        workers = _workers(proc)
        time.sleep(random.Random(trial).uniform(0.0, 1.5))
        os.kill(random.Random(trial).choice(workers), signal.SIGKILL)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    lines = err.decode().strip().splitlines()
    if proc.returncode != 0:  # the campaign may have ended before the kill
        assert proc.returncode == 3 and len(lines) == 1 and "a worker process died" in lines[0], err
    assert "Traceback" not in err.decode()
    assert not _wait_gone(workers)
    _resume_equals_uninterrupted(tmp_path, cfg, cmd)


@pytest.mark.skipif(not LINUX, reason="needs Linux /proc")
def test_kill_9_of_the_main_process_of_a_dask_campaign_leaves_no_process(tmp_path):
    """The dask executor's local cluster (its nannies and workers) is gone within 5 s of a kill -9 of the main
    process too, and --resume finishes the campaign."""
    pytest.importorskip("distributed")
    cfg, cmd = _campaign(tmp_path, delay=0.3)
    cmd = cmd + ["--executor", "dask"]
    proc = _start(cmd)
    out = tmp_path / "out"
    try:
        deadline = time.time() + 120
        while time.time() < deadline and proc.poll() is None and not store.stored_runs(out):
            time.sleep(0.05)
        family, todo = [], [proc.pid]
        while todo:  # the nannies and their workers: every descendant
            kids = child_pids(todo.pop())
            family += kids
            todo += kids
        assert family, "no cluster process found"
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        _reap(proc)
    left = _wait_gone(family)
    for p in left:
        os.kill(p, signal.SIGKILL)
    assert not left, f"alive 5 s after the main process died: {left}"
    _resume_equals_uninterrupted(tmp_path, cfg, cmd)
