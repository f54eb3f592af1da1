"""Campaign engine: seeding, executors (serial / processes / dask), incremental store, resume,
interruption, results assembly.

The engine is exercised with ``ToyKind`` (defined here; knows nothing of sarnav's navigation code):
a scalar random walk x[k+1] = x[k] + w, w ~ N(0, q), observed by z1 = x + v1 at every step and by
z2 = x + v2 at every second step, estimated by an exact scalar Kalman filter. Its NEES and NIS are
exactly χ² distributed, so the summary statistics can be checked against theory.
"""

from __future__ import annotations

import copy
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

from toy_kind import TESTS, TOY, ToyKind, toy_cfg  # noqa: F401

from sarnav.errors import ConfigError, InputDataError
from sarnav.montecarlo import store
from sarnav.montecarlo.assemble import open_results
from sarnav.montecarlo.campaign import run_campaign
from sarnav.montecarlo.seeding import make_chunks, run_seeds
from sarnav.tomlio import dump_toml
from helpers import child_pids

VARS = ("error", "sigma", "nees", "residual", "residual_sigma", "nis", "nis_dof", "truth_x_final")


def assert_same_results(a: Path, b: Path, variables=VARS):
    da, db = open_results(a / "results.nc"), open_results(b / "results.nc")
    for v in variables:
        assert np.array_equal(da[v].values, db[v].values, equal_nan=True), v
    assert da.attrs["scenario"] == db.attrs["scenario"]


# --------------------------------------------------------------------------- seeding
def test_run_seeds_are_spawn_children_independent_of_n():
    a, b = run_seeds(3, 5), run_seeds(3, 50)
    for i in range(5):
        assert a[i].spawn_key == (i,)
        assert np.array_equal(a[i].generate_state(4), b[i].generate_state(4))
    assert make_chunks(range(7), 3) == [[0, 1, 2], [3, 4, 5], [6]]


# --------------------------------------------------------------------------- engine
def test_serial_campaign_writes_schema_and_summary(tmp_path):
    cfg = toy_cfg(runs=40, steps=60)
    res = run_campaign(cfg, tmp_path, TOY, executor="serial", quiet=True, chunk_size=7)
    ds = open_results(tmp_path / "results.nc")
    assert dict(ds.sizes) == {"run": 40, "time": 61, "state": 1, "update": 60, "meas": 2}
    assert list(ds["state"].values) == ["x"] and list(ds["state_units"].values) == ["m"]
    assert list(ds["meas"].values) == ["z1", "z2"]
    assert ds.attrs["complete"] == 1 and ds.attrs["seed"] == 7
    assert ds.attrs["scenario"] == dump_toml(cfg)
    # z2 present at odd updates only -> nis_dof 1, 2, 1, 2, ...
    assert np.array_equal(ds["nis_dof"].values[0, :4], [1, 2, 1, 2])
    assert np.isnan(ds["residual"].values[:, 0::2, 1]).all()
    # run i comes from SeedSequence(7).spawn(40)[i]: recompute run 13 directly
    one = ToyKind().simulate(cfg, [13], [run_seeds(7, 40)[13]])[0]
    assert np.array_equal(ds["error"].values[13], one.error)
    # summary numbers equal an independent computation from the arrays
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["complete"] is True and s["runs"] == 40
    fin = ds["sigma"].values[:, -1, 0].mean()
    assert s["states"]["x"]["final_3sigma"] == pytest.approx(3 * fin, rel=1e-12)
    lo, hi = chi2.ppf([0.025, 0.975], 40 * 1) / 40
    assert s["nees"]["band"] == pytest.approx([lo, hi], rel=1e-12)
    # exact KF: pooled NIS per dof is chi2(D)/D -> inside its 99.9% band with this seed-independent margin
    D = ds["nis_dof"].values.sum()
    assert s["nis"]["total_dof"] == D
    assert chi2.ppf(0.0005, D) / D < s["nis"]["per_dof"] < chi2.ppf(0.9995, D) / D
    assert not (tmp_path / store.MARKER).exists()
    assert json.loads((tmp_path / "campaign.json").read_text())["complete"] is True
    assert res.n_simulated == 40


def _identity_cfg():
    """The telemetry kind with a few short runs (a real batched kind; an import error must fail,
    not silently fall back to the toy)."""
    from sarnav.scenarios.config import load_scenario

    return load_scenario("telemetry", ["trajectory.duration=8"], runs=4, seed=11), "telemetry"


def test_same_seed_bit_identical_serial_processes_dask(tmp_path):
    cfg, which = _identity_cfg()
    from sarnav.scenarios.registry import get_kind

    kind = get_kind(cfg["scenario"]["kind"])
    n = cfg["campaign"]["runs"]
    run_campaign(cfg, tmp_path / "serial", kind, executor="serial", quiet=True, chunk_size=n)
    run_campaign(cfg, tmp_path / "proc", kind, executor="processes", workers=2, quiet=True, chunk_size=(n + 2) // 3)
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        run_campaign(cfg, tmp_path / "dask", kind, executor="dask", scheduler=cluster.scheduler_address, quiet=True, chunk_size=1)
    variables = VARS if which == "toy" else VARS[:-1]
    assert_same_results(tmp_path / "serial", tmp_path / "proc", variables)
    assert_same_results(tmp_path / "serial", tmp_path / "dask", variables)
    other = copy.deepcopy(cfg)
    other["campaign"]["seed"] += 1
    res = run_campaign(other, tmp_path / "seed+1", kind, executor="serial", quiet=True)
    assert not np.array_equal(res.dataset["error"].values, open_results(tmp_path / "serial/results.nc")["error"].values)


def test_resume_completes_partial_store_and_rejects_other_scenario(tmp_path):
    cfg = toy_cfg(runs=9)
    full = tmp_path / "full"
    run_campaign(cfg, full, TOY, executor="serial", quiet=True)
    part = tmp_path / "part"
    run_campaign(cfg, part, TOY, executor="serial", quiet=True)
    # simulate an interruption: drop results, some runs, mark incomplete
    for i in (2, 5, 8):
        store.run_path(part, i).unlink()
    (part / "results.nc").unlink()
    m = store.read_manifest(part)
    m["complete"] = False
    store.write_manifest(part, m)
    res = run_campaign(cfg, part, TOY, executor="serial", quiet=True, resume=True)
    assert res.n_simulated == 3
    assert_same_results(full, part)
    with pytest.raises(ConfigError, match=r"--resume: .*first difference at toy\.q"):
        bad = toy_cfg(runs=9)
        bad["toy"]["q"] = 0.6
        run_campaign(bad, part, TOY, executor="serial", quiet=True, resume=True)
    # runs stored by another sarnav version are not mixed into this campaign
    m = store.read_manifest(part)
    m["sarnav_version"], m["complete"] = "0.0.0-other", False
    store.write_manifest(part, m)
    with pytest.raises(ConfigError, match=r"--resume: .*sarnav '0\.0\.0-other'"):
        run_campaign(cfg, part, TOY, executor="serial", quiet=True, resume=True)


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_sigterm_midway_leaves_incomplete_then_resume_equals_uninterrupted(tmp_path):
    """A real ``sarnav run`` subprocess, killed with SIGTERM once some runs are stored."""
    cfg = toy_cfg(runs=16, delay=0.25)
    scen = tmp_path / "toy.toml"
    scen.write_text(dump_toml(cfg))
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=str(TESTS) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    cmd = [sys.executable, "-m", "sarnav.cli.main", "run", str(scen), "--out", str(out), "--executor", "processes",
           "--workers", "2", "--chunk-size", "2", "--quiet", "--no-figures"]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.time() + 60
    while time.time() < deadline and len(store.stored_runs(out)) < 3:
        time.sleep(0.05)
    assert len(store.stored_runs(out)) >= 3, proc.stderr.read() if proc.poll() is not None else "no runs stored"
    workers = child_pids(proc.pid)
    assert workers, "expected worker processes"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    deadline = time.time() + 10  # the workers are terminated, not orphaned
    while time.time() < deadline and any(Path(f"/proc/{w}").exists() for w in workers):
        time.sleep(0.1)
    assert not [w for w in workers if Path(f"/proc/{w}").exists()]
    assert proc.returncode != 0, err
    n_stored = len(store.stored_runs(out))
    assert n_stored < 16
    assert not (out / "results.nc").exists() and not (out / "summary.json").exists()
    assert (out / store.MARKER).exists()
    assert json.loads((out / "campaign.json").read_text())["complete"] is False
    assert b"--resume" in err
    # resume through the same command line
    r = subprocess.run(cmd + ["--resume"], env=env, capture_output=True, timeout=120)
    assert r.returncode == 0, r.stderr
    ref = tmp_path / "ref"
    run_campaign(cfg, ref, TOY, executor="serial", quiet=True)
    assert_same_results(ref, out)
    assert json.loads((out / "campaign.json").read_text())["complete"] is True
    assert not (out / store.MARKER).exists()


@pytest.mark.parametrize("executor", ["serial", "processes"])
def test_input_error_in_a_worker_arrives_as_itself(tmp_path, executor):
    """ConfigError/InputDataError do not unpickle by themselves; the engine carries them across."""
    cfg = toy_cfg(runs=4)
    cfg["toy"]["fail_run"] = 2
    with pytest.raises(InputDataError, match=r"^toy\.samples: NaN in run 2$"):
        run_campaign(cfg, tmp_path, TOY, executor=executor, workers=2, chunk_size=1, quiet=True)
    assert json.loads((tmp_path / "campaign.json").read_text())["complete"] is False
    assert not (tmp_path / "results.nc").exists() and (tmp_path / store.MARKER).exists()
