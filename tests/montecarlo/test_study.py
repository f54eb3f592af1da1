"""A study's campaigns (``sarnav.montecarlo.study.run``) with the toy kind (tests/toy_kind.py): one campaign per case
in ``out/<label>/`` in the cases' order, all on one ChunkRunner, and each case's curves and statistics checked
against the dataset and against the toy filter's Riccati recursion written out here."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from toy_kind import TOY, toy_cfg

from sarnav.errors import ConfigError
from sarnav.montecarlo import study
from sarnav.montecarlo.study import CaseOutcome, StudyCase, StudyParams


def _final_sigma(steps, q, r1, r2, p0):
    """The toy's scalar filter in information form (its own code uses the gain form): sqrt(P) after ``steps``."""
    P = p0
    for k in range(steps):
        P = 1.0 / (1.0 / (P + q) + 1.0 / r1 + (1.0 / r2 if k % 2 else 0.0))
    return math.sqrt(P)


def _cases():
    quiet, noisy = toy_cfg(runs=3, steps=12), toy_cfg(runs=3, steps=12)
    noisy["toy"].update(r1=9.0, r2=36.0)
    return (StudyCase("quiet", quiet), StudyCase("noisy", noisy))


def test_each_case_is_a_campaign_in_its_folder_with_its_statistics(tmp_path):
    """Outcomes in case order; each campaign in out/<label>; final sigma = the Riccati recursion; curves = 3 x the
    run-mean sigma of the case's dataset; the per-state statistics name the toy's state."""
    cases = _cases()
    outcomes = study.run(StudyParams(TOY, cases), tmp_path, executor="serial", quiet=True)
    assert [o.label for o in outcomes] == ["quiet", "noisy"] and all(isinstance(o, CaseOutcome) for o in outcomes)
    finals = []
    for case, o in zip(cases, outcomes):
        assert o.result.out == tmp_path / case.label and (tmp_path / case.label / "results.nc").is_file()
        assert o.result.n_simulated == 3
        t, sig3, names = o.curves
        ds = o.result.dataset
        np.testing.assert_array_equal(t, ds["time"].values)
        np.testing.assert_allclose(sig3, 3.0 * ds["sigma"].values.mean(axis=0), rtol=1e-15)
        assert names == ["x"] and list(o.states) == ["x"]
        toy = case.config["toy"]
        want = _final_sigma(toy["steps"], toy["q"], toy["r1"], toy["r2"], toy["p0"])
        st = o.states["x"]
        assert st["final_sigma"] == pytest.approx(want, rel=1e-12)
        assert st["final_3sigma"] == pytest.approx(3 * want, rel=1e-12)
        assert st["mean_3sigma"] == pytest.approx(float(np.mean(sig3[:, 0])), rel=1e-12)
        assert 0.0 <= st["fraction_inside_3sigma"] <= 1.0
        finals.append(st["final_sigma"])
    assert finals[0] < finals[1]  # noisier measurements leave a larger sigma


def test_all_cases_share_one_chunk_runner_and_the_options_reach_run_campaign(tmp_path, monkeypatch):
    """One set of workers for every case (the same ChunkRunner object), each case's config,
    folder and the kind handed to run_campaign with the campaign options passed through unchanged."""
    calls = []

    def fake_campaign(cfg, out, executor, kind, **options):
        calls.append({"cfg": cfg, "out": out, "executor": executor, "kind": kind, "options": options})
        return SimpleNamespace(dataset=None, summary={})

    monkeypatch.setattr(study, "run_campaign", fake_campaign)
    monkeypatch.setattr(study, "mean_three_sigma", lambda ds: ("curves",))
    monkeypatch.setattr(study, "case_statistics", lambda summary, curves: {"curves": curves})
    cases = _cases()
    out = study.run(StudyParams(TOY, cases), tmp_path, executor="serial", quiet=True, chunk_size=2, resume=True)
    assert [c["cfg"] for c in calls] == [c.config for c in cases]
    assert [c["out"] for c in calls] == [tmp_path / "quiet", tmp_path / "noisy"]
    assert calls[0]["executor"] is calls[1]["executor"] and isinstance(calls[0]["executor"], study.ChunkRunner)
    assert all(c["kind"] is TOY and c["options"] == {"quiet": True, "chunk_size": 2, "resume": True} for c in calls)
    assert [(o.label, o.curves, o.states) for o in out] == [(c.label, ("curves",), {"curves": ("curves",)})
                                                            for c in cases]


def test_a_bad_executor_is_refused_before_anything_is_written(tmp_path):
    """The ChunkRunner's one-line error naming --executor; no case folder is created."""
    with pytest.raises(ConfigError, match="^--executor: "):
        study.run(StudyParams(TOY, _cases()), tmp_path / "s", executor="threads")
    assert not (tmp_path / "s").exists()
