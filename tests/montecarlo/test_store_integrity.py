"""A campaign's store can be trusted (issue 9): one writer per folder, run files that carry their campaign's stamp
and a checksum, another scenario's results never silently replaced, stale figures never left, a finished campaign
extended bit for bit. Each test reproduces a finding of the issue that the 0.1 store accepted."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from toy_kind import TESTS, TOY, toy_cfg

from sarnav.cli.main import main
from sarnav.errors import ConfigError, InputDataError
from sarnav.montecarlo import store
from sarnav.montecarlo.assemble import open_results
from sarnav.montecarlo.campaign import run_campaign
from sarnav.montecarlo.outdir import OutputFolder, identity, record_files
from sarnav.tomlio import dump_toml

VARS = ("error", "sigma", "nees", "residual", "residual_sigma", "nis", "nis_dof")


def _same(a: Path, b: Path):
    da, db = open_results(a / "results.nc"), open_results(b / "results.nc")
    for v in VARS:
        np.testing.assert_array_equal(da[v].values, db[v].values, err_msg=v)


def _run(cfg, out, **kw):
    return run_campaign(cfg, out, TOY, executor="serial", quiet=True, **kw)


def test_a_second_writer_is_refused_naming_the_holder(tmp_path):
    cfg = toy_cfg(runs=2)
    with OutputFolder(tmp_path, identity(cfg)):
        with pytest.raises(ConfigError, match=r"^--out: .* is in use by another sarnav run \(pid \d+ on .*scenario 'toy'"):
            _run(toy_cfg(runs=2, seed=99), tmp_path)
    _run(cfg, tmp_path)  # the lock went with its holder


def test_the_lock_file_exists_only_while_a_run_writes(tmp_path):
    # docs/results.md: "while a run writes"; 0.1 left .sarnav.lock in every folder
    cfg = toy_cfg(runs=2)
    lock = tmp_path / ".sarnav.lock"
    with OutputFolder(tmp_path, identity(cfg)):
        assert lock.read_text().startswith("pid ")
    assert not lock.exists()
    _run(cfg, tmp_path)
    assert not lock.exists() and (tmp_path / "results.nc").exists()
    lock.write_text("pid 1 on elsewhere, scenario 'toy', started long ago")  # left by a killed run: not held
    _run(cfg, tmp_path)
    assert not lock.exists()


def test_a_writer_whose_lock_file_was_removed_retries_with_the_current_one(tmp_path, monkeypatch):
    # the writer that ends removes the file while it still holds the lock; one that opened that file just before
    # locks the removed file: it must notice and lock the file now at the path, or two writers would hold "the" lock
    import fcntl

    cfg = toy_cfg(runs=2)
    lock = tmp_path / ".sarnav.lock"
    lock.write_text("")
    real, calls = fcntl.flock, []

    def flock(fh, op):
        if op & fcntl.LOCK_EX and not calls:  # between our open and our flock, the previous writer ends
            lock.unlink()
        calls.append(op)
        return real(fh, op)

    monkeypatch.setattr(fcntl, "flock", flock)
    with OutputFolder(tmp_path, identity(cfg)) as folder:
        assert sum(1 for op in calls if op & fcntl.LOCK_EX) == 2  # locked twice: the removed file, then the current
        assert os.fstat(folder._fh.fileno()).st_ino == os.stat(lock).st_ino
    assert not lock.exists()


def test_two_concurrent_campaigns_into_one_folder_one_is_refused(tmp_path):
    """The 0.1 store let seeds 3 and 99 write into one folder and mixed their runs; now the second one stops."""
    files = []
    for seed in (3, 99):
        f = tmp_path / f"toy{seed}.toml"
        f.write_text(dump_toml(toy_cfg(runs=30, seed=seed, delay=0.5)))
        files.append(f)
    env = {"PYTHONPATH": str(TESTS), "PATH": "/usr/bin:/bin"}
    cmd = [sys.executable, "-m", "sarnav.cli.main", "run", "--out", str(tmp_path / "out"), "--executor", "serial",
           "--chunk-size", "1", "--quiet", "--no-figures"]
    first = subprocess.Popen(cmd[:3] + [cmd[3], str(files[0])] + cmd[4:], env=env, stderr=subprocess.PIPE)
    deadline = time.time() + 30
    while time.time() < deadline and not store.stored_runs(tmp_path / "out"):
        time.sleep(0.05)
    second = subprocess.run(cmd[:3] + [cmd[3], str(files[1])] + cmd[4:], env=env, capture_output=True, timeout=60)
    _, err1 = first.communicate(timeout=60)
    assert first.returncode == 0, err1
    assert second.returncode == 2 and b"is in use by another sarnav run" in second.stderr
    assert open_results(tmp_path / "out" / "results.nc").attrs["seed"] == 3


@pytest.fixture
def finished(tmp_path):
    cfg = toy_cfg(runs=10)
    out = tmp_path / "c"
    _run(cfg, out)
    return cfg, out


@pytest.mark.parametrize("damage,problem", [
    ("swap", "holds run 8, not run 7"),
    ("foreign", "belongs to another campaign"),
    ("truncate", "unreadable run file"),
    ("corrupt", "unreadable run file|checksum does not match"),
    ("edit", "checksum does not match"),
    ("legacy", "without a campaign stamp"),
])
def test_a_damaged_run_file_is_named_with_its_repair_and_the_repair_works(finished, tmp_path, damage, problem):
    cfg, out = finished
    path = store.run_path(out, 7)
    if damage == "swap":
        shutil.copy(store.run_path(out, 8), path)
    elif damage == "foreign":
        other = tmp_path / "other"
        _run(toy_cfg(runs=10, seed=8), other)
        shutil.copy(store.run_path(other, 7), path)
    elif damage == "truncate":
        path.write_bytes(path.read_bytes()[:200])
    elif damage == "corrupt":
        data = bytearray(path.read_bytes())
        data[len(data) // 2] ^= 0xFF
        path.write_bytes(bytes(data))
    elif damage == "edit":
        with np.load(path) as z:
            arrays = {k: z[k] for k in z.files}
        arrays["error"] = arrays["error"] + 1.0
        np.savez(path.with_suffix(""), **arrays)
    else:
        with np.load(path) as z:
            arrays = {k: z[k] for k in z.files if k not in ("stamp", "checksum")}
        np.savez(path.with_suffix(""), **arrays)
    with pytest.raises(InputDataError) as err:
        _run(cfg, out, resume=True)
    assert err.value.field == str(path)
    import re

    assert re.search(problem, err.value.message) and "--resume --redo-run 7" in err.value.message
    ref = tmp_path / "ref"
    _run(cfg, ref)
    _run(cfg, out, resume=True, redo_runs=[7])
    _same(ref, out)


def test_resume_with_more_runs_extends_bit_for_bit(tmp_path):
    """``sarnav run telemetry --runs 20 --out A && sarnav run telemetry --runs 40 --out A --resume`` == 40 runs."""
    common = ["--executor", "serial", "--quiet", "--no-figures", "--set", "trajectory.duration=2.0"]
    a, b = tmp_path / "A", tmp_path / "B"
    assert main(["run", "telemetry", "--runs", "20", "--out", str(a), *common]) == 0
    assert main(["run", "telemetry", "--runs", "40", "--out", str(a), "--resume", *common]) == 0
    assert main(["run", "telemetry", "--runs", "40", "--out", str(b), *common]) == 0
    _same(a, b)
    assert json.loads((a / "campaign.json").read_text())["runs"] == 40


def test_another_scenarios_results_are_refused_unless_overwrite_which_clears_them(tmp_path, capsys):
    out = tmp_path / "o"
    _run(toy_cfg(runs=3, seed=3), out)
    (out / "figures").mkdir()
    (out / "figures" / "old.png").write_bytes(b"x")
    (out / "notes.txt").write_text("mine")
    with pytest.raises(ConfigError, match=r"^--out: .* holds the results of scenario 'toy' \(kind .*seed 3\).*--overwrite"):
        _run(toy_cfg(runs=3, seed=99), out)
    res = _run(toy_cfg(runs=3, seed=99), out, overwrite=True)
    assert res.dataset.attrs["seed"] == 99
    # not written by sarnav: kept (issue 31: --overwrite deleted a user's figures/mine.png)
    assert (out / "notes.txt").read_text() == "mine" and (out / "figures" / "old.png").exists()
    # a rerun of the same scenario replaces its own results without --overwrite; stale figures sarnav drew go
    (out / "figures" / "drawn.png").write_bytes(b"x")
    record_files(out, [out / "figures" / "drawn.png"])
    _run(toy_cfg(runs=4, seed=99), out)
    assert not (out / "figures" / "drawn.png").exists() and (out / "figures" / "old.png").exists()
    # the CLI: one line naming --out
    f = tmp_path / "t.toml"
    f.write_text(dump_toml(toy_cfg(runs=2, seed=5)))
    assert "kept 2 file(s)" in capsys.readouterr().err  # the notice of the --overwrite above
    assert main(["run", str(f), "--out", str(out), "--executor", "serial", "--quiet", "--no-figures"]) == 2
    assert capsys.readouterr().err.startswith("sarnav: error: --out: ")


def test_no_figures_leaves_no_stale_figures(tmp_path):
    f = tmp_path / "t.toml"
    f.write_text(dump_toml(toy_cfg(runs=2)))
    out = tmp_path / "o"
    common = ["run", str(f), "--out", str(out), "--executor", "serial", "--quiet"]
    assert main(common) == 0 and any((out / "figures").glob("*.png"))
    assert main(common + ["--no-figures"]) == 0
    assert not (out / "figures").exists()


@pytest.mark.parametrize("name", ["../x", "/abs/x", "a/b", "..", ".hidden", "x" * 129, ""])
def test_scenario_names_are_identifiers_never_paths(tmp_path, capsys, name, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "telemetry", "--set", f"scenario.name={json.dumps(name)}", "--runs", "1", "--quiet"]) == 2
    assert capsys.readouterr().err.startswith("sarnav: error: scenario.name: must be a name")
    assert not (tmp_path.parent / "x").exists() and not Path("/abs/x").exists()


def test_unreadable_manifest_and_read_only_out_are_one_line_errors(tmp_path, capsys):
    out = tmp_path / "o"
    _run(toy_cfg(runs=2), out)
    (out / "campaign.json").write_text("{not json")
    with pytest.raises(ConfigError, match="unreadable campaign manifest"):
        _run(toy_cfg(runs=2), out, resume=True)
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        if (ro / "probe").exists() or _writable(ro):
            pytest.skip("running as a user who can write in read-only folders (root)")
        with pytest.raises(ConfigError, match=r"^--out: cannot create or write"):
            _run(toy_cfg(runs=2), ro)
    finally:
        ro.chmod(0o700)


def _writable(d: Path) -> bool:
    try:
        (d / "probe").write_text("")
        (d / "probe").unlink()
        return True
    except OSError:
        return False
