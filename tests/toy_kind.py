"""A toy scenario kind for the campaign engine's tests (and the CLI's): importable as ``toy_kind:ToyKind``
with the tests folder on the path (tests/conftest.py puts it there; subprocesses get it through PYTHONPATH).

``ToyKind`` knows nothing of sarnav's navigation code: a scalar random walk x[k+1] = x[k] + w, w ~ N(0, q),
observed by z1 = x + v1 at every step and by z2 = x + v2 at every second step, estimated by an exact scalar
Kalman filter. Its NEES and NIS are exactly chi-square distributed, so summary statistics can be checked against
theory.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.montecarlo.kind import ScenarioKind
from sarnav.montecarlo.record import RunRecord

#: the tests folder (on PYTHONPATH for subprocesses that load the toy kind)
TESTS = Path(__file__).resolve().parent
TOY_KIND = "toy_kind:ToyKind"


class ToyKind(ScenarioKind):
    """1-D random walk + scalar KF (see module docstring). Config table ``[toy] steps, q, r1, r2, p0, delay``
    (and ``chunk_log``: a file that gets one line of run ids per chunk simulated)."""

    kind = TOY_KIND

    def validate(self, cfg):
        toy = cfg.get("toy", {})
        for key in ("q", "r1", "r2", "p0"):
            if not (isinstance(toy.get(key), (int, float)) and toy[key] > 0):
                raise ConfigError(f"toy.{key}", f"must be > 0, got {toy.get(key)!r}")
        if not (isinstance(toy.get("steps"), int) and toy["steps"] >= 2):
            raise ConfigError("toy.steps", f"must be an integer >= 2, got {toy.get('steps')!r}")

    def state_names(self, cfg):
        return ["x"]

    def state_units(self, cfg):
        return ["m"]

    def meas_names(self, cfg):
        return ["z1", "z2"]

    def meas_units(self, cfg):
        return ["m", "m"]

    def simulate(self, cfg, run_ids, seeds):
        toy = cfg["toy"]
        delay = float(toy.get("delay", 0.0))
        records = [self._one(toy, rid, ss, delay) for rid, ss in zip(run_ids, seeds)]
        if toy.get("chunk_log"):  # one line per chunk simulated: its run ids (tests of what a kill loses)
            with open(toy["chunk_log"], "a", encoding="utf-8") as fh:
                fh.write(" ".join(str(r) for r in run_ids) + "\n")
        return records

    @staticmethod
    def _one(toy, rid, ss, delay):
        if delay:
            time.sleep(delay)
        if toy.get("fail_run") == rid:
            raise InputDataError("toy.samples", f"NaN in run {rid}")
        rng = np.random.default_rng(ss)
        n, q, r1, r2, p0 = toy["steps"], toy["q"], toy["r1"], toy["r2"], toy["p0"]
        x = rng.normal(0.0, np.sqrt(p0))
        xh, P = 0.0, p0
        err, sig = np.empty((n + 1, 1)), np.empty((n + 1, 1))
        err[0, 0], sig[0, 0] = x - xh, np.sqrt(P)
        res = np.full((n, 2), np.nan)
        rsig = np.full((n, 2), np.nan)
        nis, dof = np.empty(n), np.empty(n, dtype=np.int64)
        for k in range(n):
            x += rng.normal(0.0, np.sqrt(q))
            P += q
            both = k % 2 == 1
            H = np.ones((2, 1)) if both else np.ones((1, 1))
            R = np.diag([r1, r2]) if both else np.array([[r1]])
            z = x + rng.normal(0.0, np.sqrt(np.diag(R)))
            r = z - xh
            S = P * (H @ H.T) + R
            K = P * H.T @ np.linalg.inv(S)
            res[k, : len(r)] = r
            rsig[k, : len(r)] = np.sqrt(np.diag(S))
            nis[k] = r @ np.linalg.solve(S, r)
            dof[k] = len(r)
            xh = xh + (K @ r).item()
            P = ((1.0 - (K @ H).item()) * P)
            err[k + 1, 0], sig[k + 1, 0] = x - xh, np.sqrt(P)
        t = np.arange(n + 1, dtype=float)
        return RunRecord(
            run=rid,
            time=t,
            error=err,
            sigma=sig,
            nees=(err[:, 0] / sig[:, 0]) ** 2,
            update_time=t[1:],
            residual=res,
            residual_sigma=rsig,
            nis=nis,
            nis_dof=dof,
            extras={"truth_x_final": ((), np.float64(x))},
        )


TOY = ToyKind()


def toy_cfg(runs=12, seed=7, steps=40, delay=0.0):
    return {
        "scenario": {"name": "toy", "kind": TOY_KIND, "description": "1-D random walk"},
        "campaign": {"runs": runs, "seed": seed},
        "toy": {"steps": steps, "q": 0.5, "r1": 1.0, "r2": 4.0, "p0": 10.0, "delay": delay},
    }
