"""Structure rules that keep experiment code out of ``scenarios/`` (issue 25), read from the source with ``ast``.

Each rule is checked per module. The modules that break a rule today are listed below and marked
``xfail(strict=True)``: when a module is cleaned its test passes, the strict xfail fails, and the module must be taken
off its list (so a list only ever shrinks). A module that starts breaking a rule fails at once.

Rule 1, imports (``scenarios/*`` only): configuration and wiring only. A scenario parses configuration into the
parameters of the library and calls its entry points; it computes nothing itself. Every ``sarnav`` import (module
level or lazy, in a function) must be
* anything from a package of ``WIRING_PACKAGES``: ``errors``, ``units``, ``tomlio``, ``record``, the engine
  ``montecarlo``, the writers ``report``, the statistics ``analysis`` it wires, and ``scenarios`` itself;
* from any other sarnav package (simulation, navigation, measurements, filters, imaging, io, signal, radar,
  trajectory, sensors, ins, frames, rotations), a name that is
  - a class (CapWords, ``RdaNavParams``, ``ImuGrade``, ``StraightLevel``: parameter types, settings, models the parser
    builds),
  - an UPPER_CASE constant (``SEARCH_METHODS``, ``WGS84_A``: the vocabularies a parser validates against), or
  - an entry point: a function named ``run``, ``run_*``, ``simulate_runs``, ``read_*``, ``write_*`` or ``check_*``
    (``ENTRY_NAMES``, ``ENTRY_PREFIXES``);
  never a module object (``from sarnav.simulation import rda_nav_world as world``, ``import sarnav.imaging.rda``)
  and never another function (``from sarnav.signal.windows import as_window``): computations belong to the library.
The kind of a name is read from its spelling; a CapWords or UPPER_CASE name that the module it is imported from
defines with ``def`` is a function all the same. Imports of other packages (numpy, math, ...) are not checked here
(tests/test_architecture.py bans numerics).

Rule 2, loops (``scenarios/*`` only). No ``for`` / ``while`` loop or comprehension inside a function that walks time,
updates, apertures, pulses, epochs or runs: a loop is flagged when an identifier of its target or iterable (split at
``_`` and ``.``) is one of ``LOOP_WORDS`` (``for u in range(n_upd)``, ``for i in range(fl.R)``,
``[g.standard_normal() for g in fl.rngs]``, ``enumerate(run_ids)``, ``while time_s < end``); a loop over a literal
tuple / list / set is never flagged (``for k, unit, hi in (("sigma_r0", "m", 1e7), ...)``). Loops over configuration
(keys, tables, dict items) name none of these words and pass. A name-based rule is blunt on purpose: a loop over
runs or updates written with neutral names would pass, a loop over models of aperture ``u`` is flagged; the word
list is the one place to change.

Rule 3, length. No module in ``src/sarnav`` longer than ``MAX_MODULE_LINES`` lines.

Rule 4, a test module per public module (issue 25, Build 6). Every module of ``src/sarnav`` whose name does not start
with ``_`` has a test module ``test_<its name>.py`` or ``test_<its package>_<its name>.py`` (where two packages hold
modules of one name: ``trajectory/base.py`` -> ``test_trajectory_base.py``) somewhere under ``tests/`` that imports
it, by its path or a name it defines (``from sarnav.navigation import Navigator`` counts for
``navigation/navigator.py``), or, where its tests carry another name, the test module ``TESTED_UNDER`` names for it,
which must import it the same way. ``UNTESTED`` lists the modules without one today (strict xfail: the list only
shrinks). Test file names are unique across ``tests/`` (the folders are not packages: pytest imports each file by its
base name, and two of one name stop the collection).
"""

from __future__ import annotations

import ast
import importlib
import re
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "sarnav"
SCENARIOS = SRC / "scenarios"

ISSUE = "issue 25: experiment code still in scenarios/"
LONG = "issue 25: module still over 600 lines"
#: scenarios modules that import more than rule 1 allows, today
IMPORT_OFFENDERS: set[str] = set()
#: scenarios modules with a loop over time, updates, apertures, pulses, epochs or runs, today
LOOP_OFFENDERS: set[str] = set()
#: modules of src/sarnav (relative paths) over MAX_MODULE_LINES lines, today
LENGTH_OFFENDERS: set[str] = set()

#: packages a scenario may import anything from (the wiring: engine, writers, statistics, configuration)
WIRING_PACKAGES = ("sarnav.errors", "sarnav.units", "sarnav.tomlio", "sarnav.record", "sarnav.montecarlo",
                   "sarnav.report", "sarnav.analysis", "sarnav.scenarios")
#: the entry points of the library a scenario may call, besides classes and constants
ENTRY_NAMES = ("run", "simulate_runs")
ENTRY_PREFIXES = ("run_", "read_", "write_", "check_")
CLASS_NAME = re.compile(r"[A-Z][A-Za-z0-9]*[a-z][A-Za-z0-9]*")
CONSTANT_NAME = re.compile(r"[A-Z][A-Z0-9]*(?:_[A-Z0-9]+)*")
LOOP_WORDS = {
    "u", "upd", "update", "updates", "aperture", "apertures", "time", "times", "epoch", "epochs", "pulse", "pulses",
    "run", "runs", "rid", "R", "rngs", "seeds", "step", "steps",
}
MAX_MODULE_LINES = 600
TESTS = SRC.parents[1] / "tests"
UNTESTED_REASON = "issue 25: no test module of its own yet"
#: public modules whose tests live in a test module of another name (module -> test module, both relative)
TESTED_UNDER: dict[str, str] = {
    "cli/image_cmd.py": "cli/test_image_cli.py",
    "cli/main.py": "cli/test_cli.py",
    "cli/run_cmd.py": "cli/test_cli.py",
    "filters/grid_kalman.py": "filters/test_pulse_grid.py",
    "filters/grid_particle.py": "filters/test_particles.py",
    "filters/layout.py": "filters/test_ekf.py",
    "filters/update.py": "filters/test_update_strategies.py",
    "frames/earth.py": "frames/test_earth_gravity.py",
    "frames/gravity.py": "frames/test_earth_gravity.py",
    "imaging/collect_image.py": "simulation/test_image_scene.py",
    "imaging/interpolation_choice.py": "imaging/test_interpolation_default.py",
    "imaging/interpolation_error.py": "imaging/test_interpolation_default.py",
    "imaging/kernels.py": "imaging/test_backprojection.py",
    "ins/state.py": "ins/test_geodetic.py",
    "io/cphd_read.py": "io/test_cphd_formats.py",
    "io/sicd_product.py": "io/test_sicd_reader.py",
    "measurements/gnss.py": "measurements/test_contract.py",
    "measurements/sar_aperture.py": "measurements/test_sar_image.py",
    "measurements/search_tracks.py": "measurements/test_focus_search.py",
    "measurements/spacecraft_image.py": "measurements/test_spacecraft_imager.py",
    "measurements/sar_product.py": "recording/test_reference_product.py",
    "measurements/spacecraft.py": "measurements/test_spacecraft_sar.py",
    "montecarlo/assemble.py": "montecarlo/test_results.py",
    "montecarlo/kind.py": "scenarios/test_config.py",
    "montecarlo/outdir.py": "montecarlo/test_store_integrity.py",
    "montecarlo/record.py": "montecarlo/test_results.py",
    "montecarlo/store.py": "montecarlo/test_campaign.py",
    "radar/params.py": "radar/test_radar_params.py",
    "radar/presets.py": "radar/test_radar_params.py",
    "radar/quality_scenes.py": "analysis/test_quality_sweep.py",
    "radar/terrain.py": "imaging/test_geocode.py",
    "record.py": "montecarlo/test_results.py",
    "recording/apertures.py": "measurements/test_read_ahead.py",
    "recording/imu_formats.py": "recording/test_imu_log_formats.py",
    "recording/logs.py": "recording/test_imu_formats.py",
    "recording/ortho.py": "recording/test_reference_product.py",
    "recording/recording.py": "recording/test_read_recording.py",
    "recording/timeline.py": "recording/test_navigate.py",
    "report/html_parts.py": "report/test_html.py",
    "report/navigate_figures.py": "report/test_navigate_report.py",
    "report/navigate_files.py": "report/test_navigate_report.py",
    "report/navigate_html.py": "report/test_navigate_report.py",
    "report/overlays.py": "report/test_figures.py",
    "report/study_figure.py": "report/test_figures.py",
    "scenarios/cphd_image.py": "cli/test_image_cphd_cli.py",
    "scenarios/imaging.py": "cli/test_image_cli.py",
    "scenarios/quality_sweep.py": "scenarios/test_quality_scenarios.py",
    "scenarios/registry.py": "scenarios/test_defaults.py",
    "scenarios/study.py": "scenarios/test_studies.py",
    "scenarios/telemetry.py": "scenarios/test_telemetry_kind.py",
    "sensors/gauss_markov.py": "sensors/test_imu.py",
    "simulation/export.py": "simulation/test_export_recording.py",
    "simulation/imu_rig.py": "simulation/test_multi_imu.py",
    "simulation/nav_sources.py": "simulation/test_multi_imu.py",
    "simulation/rda_nav_world.py": "scenarios/test_rda_nav.py",
    "simulation/spacecraft.py": "simulation/test_spacecraft_open_loop.py",
    "trajectory/maneuver.py": "trajectory/test_trajectory.py",
    "trajectory/rate_profile.py": "trajectory/test_trajectory.py",
    "trajectory/straight.py": "trajectory/test_trajectory.py",
    "version.py": "test_packaging.py",
}
#: public modules without a test module of their own, today
UNTESTED: set[str] = set()


def _is_module(name: str) -> bool:
    path = SRC.parent.joinpath(*name.split("."))
    return path.with_suffix(".py").exists() or (path / "__init__.py").exists()


def _sarnav_imports(tree: ast.AST):
    """(module, name or None) of every ``sarnav`` import; ``from a import b`` with a module ``a.b`` is (``a.b``,
    None); relative imports are resolved within ``sarnav.scenarios``."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from ((a.name, None) for a in node.names if a.name.split(".")[0] == "sarnav")
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = ["sarnav", "scenarios"][: 3 - node.level]
                base = ".".join(parts + ([base] if base else []))
            if base.split(".")[0] != "sarnav":
                continue
            for a in node.names:
                sub = f"{base}.{a.name}"
                yield (sub, None) if _is_module(sub) else (base, a.name)


def _module_functions(module: str) -> set[str]:
    """Names the source of ``module`` binds with a top-level ``def``."""
    path = SRC.parent.joinpath(*module.split("."))
    path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
    if not path.exists():
        return set()
    return {n.name for n in ast.parse(path.read_text()).body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))}


def _allowed(module: str, name: str | None) -> bool:
    if any(module == p or module.startswith(p + ".") for p in WIRING_PACKAGES):
        return True
    if name is None:  # a module object of a library package
        return False
    if name in ENTRY_NAMES or name.startswith(ENTRY_PREFIXES):
        return True
    is_type = CLASS_NAME.fullmatch(name) or CONSTANT_NAME.fullmatch(name)
    return bool(is_type) and name not in _module_functions(module)


def import_violations(path: Path) -> list[str]:
    tree = ast.parse(path.read_text())
    return sorted({f"{m}:{n}" if n else m for m, n in _sarnav_imports(tree) if not _allowed(m, n)})


def _words(node: ast.AST) -> set[str]:
    out = set()
    for sub in ast.walk(node):
        if isinstance(sub, ast.Name):
            out.update(sub.id.split("_"))
        elif isinstance(sub, ast.Attribute):
            out.update(sub.attr.split("_"))
    return out


def _loops(fn: ast.AST):
    """(line, target node or None, iterable / test node) of every loop and comprehension in a function."""
    for node in ast.walk(fn):
        if isinstance(node, (ast.For, ast.AsyncFor)):
            yield node.lineno, node.target, node.iter
        elif isinstance(node, ast.While):
            yield node.lineno, None, node.test
        elif isinstance(node, (ast.ListComp, ast.SetComp, ast.DictComp, ast.GeneratorExp)):
            for gen in node.generators:
                yield node.lineno, gen.target, gen.iter


def loop_violations(path: Path) -> list[str]:
    tree = ast.parse(path.read_text())
    hits = set()
    for fn in ast.walk(tree):
        if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        for line, target, it in _loops(fn):
            if isinstance(it, (ast.Tuple, ast.List, ast.Set)):  # a literal: configuration keys, never a time axis
                continue
            words = _words(it) | (_words(target) if target is not None else set())
            if words & LOOP_WORDS:
                hits.add(f"{path.name}:{line} {ast.unparse(target) + ' in ' if target is not None else 'while '}"
                         f"{ast.unparse(it)[:60]}")
    return sorted(hits)


def _marked(values, offenders, reason=ISSUE):
    return [pytest.param(v, id=v, marks=pytest.mark.xfail(strict=True, reason=reason) if v in offenders else ())
            for v in values]


SCENARIO_MODULES = sorted(p.stem for p in SCENARIOS.glob("*.py") if p.name != "__init__.py")
ALL_MODULES = sorted(p.relative_to(SRC).as_posix() for p in SRC.rglob("*.py"))


def test_the_offender_lists_name_existing_modules():
    """A renamed or deleted module must leave the lists too (else its strict xfail would never run)."""
    assert IMPORT_OFFENDERS <= set(SCENARIO_MODULES) and LOOP_OFFENDERS <= set(SCENARIO_MODULES)
    assert LENGTH_OFFENDERS <= set(ALL_MODULES)


@pytest.mark.parametrize("module", _marked(SCENARIO_MODULES, IMPORT_OFFENDERS))
def test_scenarios_import_only_configuration_and_wiring(module):
    bad = import_violations(SCENARIOS / f"{module}.py")
    assert not bad, f"scenarios/{module}.py imports beyond rule 1: {bad}"


@pytest.mark.parametrize("module", _marked(SCENARIO_MODULES, LOOP_OFFENDERS))
def test_scenarios_do_not_loop_over_time_updates_apertures_or_runs(module):
    bad = loop_violations(SCENARIOS / f"{module}.py")
    assert not bad, f"loops of rule 2: {bad}"


@pytest.mark.parametrize("module", _marked(ALL_MODULES, LENGTH_OFFENDERS, LONG))
def test_module_is_at_most_600_lines(module):
    n = len((SRC / module).read_text().splitlines())
    assert n <= MAX_MODULE_LINES, f"{module}: {n} lines"


#: issue 25's bound on the configuration and wiring layer (was 5,941 lines before it)
MAX_SCENARIOS_LINES = 3500


def test_scenarios_stay_configuration_sized():
    """The Python of ``scenarios/`` (not its packaged TOML) stays within issue 25's bound: experiments go elsewhere."""
    n = sum(len(p.read_text().splitlines()) for p in (SRC / "scenarios").glob("*.py"))
    assert n <= MAX_SCENARIOS_LINES, f"scenarios/: {n} lines"


# --- the rules themselves catch what they are meant to (small sources, independent of today's modules) -------------

@pytest.mark.parametrize("source, bad", [
    ("from sarnav.errors import ConfigError\nfrom sarnav import units\nfrom sarnav.radar.presets import PRESETS", []),
    ("from sarnav.simulation.flight import FlightSpec, run_flight\nfrom sarnav.scenarios.fields import x", []),
    ("from sarnav.simulation.flight import ErrorStateFlight", []),  # a class
    ("from sarnav.trajectory import StraightLevel\nfrom sarnav.frames.earth import WGS84_A", []),
    ("from sarnav.io.cphd import read_collect\nfrom sarnav.simulation.x import simulate_runs, check_geometry", []),
    ("from sarnav.analysis.consistency import nees\nfrom sarnav.montecarlo import store\nimport sarnav.report.figures", []),
    ("def f():\n    from sarnav.filters import update", ["sarnav.filters.update"]),  # a module object
    ("import sarnav.imaging.rda", ["sarnav.imaging.rda"]),
    ("from sarnav.simulation import rda_nav_world as world", ["sarnav.simulation.rda_nav_world"]),
    ("from sarnav.signal.windows import as_window", ["sarnav.signal.windows:as_window"]),  # another function
    ("from sarnav.simulation.x import runner, simulate", ["sarnav.simulation.x:runner", "sarnav.simulation.x:simulate"]),
    ("from sarnav.radar.params import window_over", ["sarnav.radar.params:window_over"]),
])
def test_import_rule_on_examples(tmp_path, source, bad):
    f = tmp_path / "m.py"
    f.write_text(source)
    assert import_violations(f) == bad



def test_import_rule_reads_a_def_as_a_function_whatever_its_spelling(tmp_path, monkeypatch):
    lib = tmp_path / "sarnav" / "signal"
    lib.mkdir(parents=True)
    (lib / "windows.py").write_text("def Hann(n):\n    return n\n\n\nclass Taylor:\n    pass\n\n\nKINDS = ('hann',)\n")
    monkeypatch.setattr(sys.modules[__name__], "SRC", tmp_path / "sarnav")
    f = tmp_path / "m.py"
    f.write_text("from sarnav.signal.windows import Hann, Taylor, KINDS")
    assert import_violations(f) == ["sarnav.signal.windows:Hann"]

@pytest.mark.parametrize("source, flagged", [
    ("def f(n_upd):\n    for u in range(n_upd):\n        pass", True),
    ("def f(fl):\n    return [g.standard_normal() for g in fl.rngs]", True),
    ("def f(fl):\n    for i in range(fl.R):\n        pass", True),
    ("def f(t, t_end):\n    while t < t_end:\n        t += 1", False),  # "t" alone is not a word of the list
    ("def f(time_s, end):\n    while time_s < end:\n        time_s += 1", True),
    ("def f(cfg):\n    for key, value in cfg['radar'].items():\n        pass", False),
    ("def f():\n    return [k for k in ('a', 'b')]", False),
    ("def f():\n    for k, u, hi in (('sigma_r0', 'm', 1e7),):\n        pass", False),  # literal: config keys
    ("for u in range(3):\n    pass", False),  # module level: not a function body
])
def test_loop_rule_on_examples(tmp_path, source, flagged):
    f = tmp_path / "m.py"
    f.write_text(source)
    assert bool(loop_violations(f)) == flagged


def _public_modules() -> list[str]:
    return sorted(p.relative_to(SRC).as_posix() for p in SRC.rglob("*.py")
                  if not p.name.startswith("_") and "defaults" not in p.parts)


def _test_files() -> dict[str, list[Path]]:
    out: dict[str, list[Path]] = {}
    for f in sorted(TESTS.rglob("test_*.py")):
        out.setdefault(f.stem, []).append(f)
    return out


def _dotted(module: str) -> str:
    return "sarnav." + module.removesuffix(".py").replace("/", ".")


def modules_imported_by(path: Path) -> set[str]:
    """The sarnav modules a test file imports: each imported module, and the module that defines each imported name
    (a class or function re-exported by its package counts for the module it lives in)."""
    out = set()
    for mod, name in _sarnav_imports(ast.parse(path.read_text())):
        out.add(mod)
        if name is None:
            continue
        try:
            owner = getattr(getattr(importlib.import_module(mod), name), "__module__", None)
        except (ImportError, AttributeError):
            continue
        if isinstance(owner, str):
            out.add(owner)
    return out


PUBLIC_MODULES = _public_modules()
TEST_FILES = _test_files()


def test_the_test_module_lists_name_existing_modules():
    """A renamed or deleted module leaves ``UNTESTED`` and ``TESTED_UNDER``; their test modules exist."""
    assert UNTESTED <= set(PUBLIC_MODULES) and set(TESTED_UNDER) <= set(PUBLIC_MODULES)
    assert all((TESTS / t).is_file() for t in TESTED_UNDER.values())


@pytest.mark.parametrize("module", _marked(PUBLIC_MODULES, UNTESTED, UNTESTED_REASON))
def test_every_public_module_has_a_test_module_of_its_own(module):
    stem, package = Path(module).stem, Path(module).parent.name
    files = TEST_FILES.get(f"test_{stem}", []) + (TEST_FILES.get(f"test_{package}_{stem}", []) if package else [])
    if module in TESTED_UNDER:
        files = files + [TESTS / TESTED_UNDER[module]]
    assert files, f"no tests/**/test_{Path(module).stem}.py"
    assert any(_dotted(module) in modules_imported_by(f) for f in files), \
        f"{', '.join(str(f.relative_to(TESTS)) for f in files)} do not import {_dotted(module)}"


def test_test_file_names_are_unique():
    """pytest imports each test file by its base name (no packages under tests/): two files of one name stop the
    whole collection ("import file mismatch")."""
    twice = sorted(name for name, files in TEST_FILES.items() if len(files) > 1)
    assert not twice, twice


def test_the_test_module_rule_reads_re_exports(tmp_path):
    """A name imported through its package counts for the module that defines it; a module object by its path."""
    f = tmp_path / "test_x.py"
    f.write_text("from sarnav.navigation import Navigator\nimport sarnav.recording.tables\n")
    got = modules_imported_by(f)
    assert "sarnav.navigation.navigator" in got and "sarnav.recording.tables" in got
    assert "sarnav.navigation.sar_navigator" not in got
