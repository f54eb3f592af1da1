"""Property tests of the scenario reader (issue 9): any file generated from a kind's scenario by changing, removing or
adding keys gives either a valid scenario that runs to a finite campaign, or one line ``sarnav: error: <key>: ...``
naming a key of the file (or a command-line flag) — never a traceback, a hang or a NaN.

Default run: 200 generated files per kind through ``sarnav show`` (validation) and 12 per kind through ``sarnav run``
(one short run). More examples: ``python -m pytest -q -m slow tests/scenarios/test_reader_properties.py``.
"""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path

import numpy as np
import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sarnav.cli.main import main
from sarnav.scenarios.registry import get_scenario

#: one scenario per kind; the run property shortens the flight (unless the mutation is the duration itself)
KINDS = {"telemetry": "telemetry", "rda-nav": "rda-nav", "image": "point-target", "bpa-sensitivity": "bpa-sensitivity",
         "study": "telemetry-imu-grade", "quality-sweep": "quality-sweep", "gpsd-search": "gpsd-search",
         "quality-nav": "quality-nav"}
SHORTEN = {"telemetry": {("trajectory", "duration"): 2.0}, "rda-nav": {("trajectory", "duration"): 2.0},
           "study": {("base", "trajectory", "duration"): 1.0},
           "quality-sweep": {("geometry", "n_pulses"): 200, ("sweep", "sizes"): [6], ("sweep", "steps"): 1,
                             ("sweep", "figure_size"): 6, ("reliability", "scenes"): 0, ("sweep", "bins"): [10]},
           "gpsd-search": {("geometry", "n_pulses"): 400, ("search", "initial_pulses"): 200,
                           ("search", "block_pulses"): [100], ("image", "size"): 8, ("search", "sigmas"): 1,
                           ("search", "spacings"): 1, ("geometry", "scene_extent"): 4.0},
           "quality-nav": {("trajectory", "duration"): 1.0, ("focus", "calibration_apertures"): 2,
                           ("focus", "pixels"): 16, ("focus", "aperture_pulses"): 300, ("scene", "length"): 12.0}}
#: kinds without [campaign] runs (the run property gives them no --runs)
NO_RUNS = ("image", "bpa-sensitivity", "quality-sweep")

NUMBERS = st.one_of(
    st.floats(min_value=-1e300, max_value=1e300, allow_nan=False, allow_infinity=False),
    st.sampled_from([0.0, -1.0, 1e-300, 1e300, 1e9, -1e9, 1e-9, 2.0**63, 0.5, 3600.0, 1e6]),
    st.integers(min_value=-2**63, max_value=2**63 - 1),
)
STRINGS = st.one_of(st.text(max_size=12), st.sampled_from(["", "none", "../x", "/abs", "a/b", "custom", "bpa",
                                                           "straight", "maneuver", "hamming", "left"]))
VALUES = st.one_of(NUMBERS, STRINGS, st.booleans(), st.lists(NUMBERS, max_size=4), st.lists(STRINGS, max_size=2))


def _leaves(node, path=()):
    """Paths (tuples of keys and list indices) of every leaf value."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _leaves(v, path + (k,))
    elif isinstance(node, list) and node and all(isinstance(v, dict) for v in node):
        for i, v in enumerate(node):
            yield from _leaves(v, path + (i,))
    else:
        yield path


def _parent(cfg, path):
    node = cfg
    for p in path[:-1]:
        node = node[p]
    return node, path[-1]


def _dotted(path) -> str:
    return ".".join(str(p) for p in path)


@st.composite
def mutated(draw, name):
    cfg = get_scenario(name)
    leaves = [p for p in _leaves(cfg) if p != ("scenario", "kind")]
    changed = []
    for _ in range(draw(st.integers(1, 2))):
        path = draw(st.sampled_from(leaves))
        node, key = _parent(cfg, path)
        action = draw(st.sampled_from(["replace", "replace", "replace", "scale", "delete", "add"]))
        old = node[key] if isinstance(node, list) else node.get(key)
        if action == "delete" and isinstance(node, dict):
            node.pop(key, None)
        elif action == "add" and isinstance(node, dict):
            node[draw(st.sampled_from(["colour", "extra", "gain_db"]))] = draw(VALUES)
        elif action == "scale" and isinstance(old, (int, float)) and not isinstance(old, bool):
            value = old * draw(st.sampled_from([-1.0, 0.0, 1e-12, 1e-3, 10.0, 1e3, 1e12]))
            node[key] = type(old)(value) if isinstance(old, float) or abs(value) < 2**63 else value
        elif isinstance(node, dict):
            node[key] = draw(VALUES)
        changed.append(_dotted(path))
    return cfg, changed


def _top_keys(cfg) -> set[str]:
    return set(cfg) | {"scenario", "campaign"}


def _check_one_line(code, err, cfg, path):
    if code == 0:
        return
    assert code == 2, f"exit {code}: {err}"
    lines = err.strip().splitlines()
    errors = [ln for ln in lines if not ln.startswith("sarnav: notice:")]
    assert len(errors) == 1 and errors[0].startswith("sarnav: error: "), err
    field = errors[0][len("sarnav: error: "):].split(": ", 1)[0]
    root = field.split(".")[0].split("[")[0].split(" ")[0]
    ok = root in _top_keys(cfg) or field.startswith(str(path)) or field.startswith("--") or root == "cases"
    assert ok, f"error names {field!r}, not a key of the file: {errors[0]}"


def _write(cfg, tmp: Path) -> Path:
    f = tmp / "generated.toml"
    try:
        f.write_text(tomli_w.dumps(cfg))
    except (TypeError, ValueError, OverflowError):
        pytest.skip("value not representable in TOML")
    return f


def _show(cfg, capsys):
    with tempfile.TemporaryDirectory() as tmp:
        f = _write(cfg, Path(tmp))
        code = main(["show", str(f)])
        out = capsys.readouterr()
        _check_one_line(code, out.err, cfg, f)
    return code


@pytest.mark.parametrize("kind", sorted(KINDS))
@settings(max_examples=200, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                 HealthCheck.too_slow])
@given(data=st.data())
def test_any_generated_file_validates_or_names_a_key(kind, data, capsys):
    cfg, _ = data.draw(mutated(KINDS[kind]))
    _show(cfg, capsys)


def _finite_results(out: Path):
    summary = out / "summary.json"
    if summary.exists():
        json.loads(summary.read_text(), parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))
        from sarnav.montecarlo.assemble import open_results

        ds = open_results(out / "results.nc")
        for v in ("error", "sigma", "nees"):
            assert np.all(np.isfinite(ds[v].values)), v
    for csv in out.glob("*.csv"):
        assert "nan" not in csv.read_text().lower()


def _run_property(kind, data, capsys):
    cfg, changed = data.draw(mutated(KINDS[kind]))
    for key, value in SHORTEN.get(kind, {}).items():
        if not any(c.startswith(_dotted(key)) for c in changed):
            try:
                node, leaf = _parent(cfg, key)
            except (KeyError, TypeError):
                continue
            if isinstance(node, dict) and leaf in node:
                node[leaf] = value
    if _show(cfg, capsys) != 0:
        return
    with tempfile.TemporaryDirectory() as tmp:
        f = _write(cfg, Path(tmp))
        out = Path(tmp) / "out"
        argv = ["run", str(f), "--executor", "serial", "--quiet", "--no-figures", "--out", str(out)]
        if kind not in NO_RUNS:
            argv += ["--runs", "1"]
        code = main(argv)
        _check_one_line(code, capsys.readouterr().err, cfg, f)
        if code == 0:
            _finite_results(out)


@pytest.mark.parametrize("kind", sorted(KINDS))
@settings(max_examples=12, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                HealthCheck.too_slow])
@given(data=st.data())
def test_a_valid_generated_file_runs_to_a_finite_campaign_or_names_a_key(kind, data, capsys):
    _run_property(kind, data, capsys)


@pytest.mark.slow
@pytest.mark.parametrize("kind", sorted(KINDS))
@settings(max_examples=120, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                 HealthCheck.too_slow])
@given(data=st.data())
def test_a_valid_generated_file_runs_many(kind, data, capsys):
    _run_property(kind, data, capsys)


assert math  # noqa: used for readability of numbers above
