"""Packaging (issue 30): the license and py.typed in the wheel, complete metadata, every import declared, the
optional extras with their one-line errors, the version derived from git (setuptools-scm) and ``python -m sarnav``."""

from __future__ import annotations

import ast
import re
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "sarnav"
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
PROJECT = PYPROJECT["project"]

#: import name -> distribution name, where they differ
DIST_OF = {"PIL": "pillow", "skimage": "scikit-image", "netCDF4": "netcdf4", "dask": "dask", "distributed": "dask",
           "setuptools_scm": "setuptools-scm"}
#: modules that a feature needs only with an extra: module -> extra (setuptools-scm: a checkout's live version)
OPTIONAL = {"skimage": "registration", "dask": "dask", "distributed": "dask", "setuptools_scm": "test", "rasterio": "geo",
            "rosbags": "ros"}


def _dist_name(requirement: str) -> str:
    return re.split(r"[\s\[<>=!~;]", requirement, maxsplit=1)[0].lower().replace("_", "-")


def _third_party_imports() -> set[str]:
    stdlib = set(sys.stdlib_module_names)
    found = set()
    for f in SRC.rglob("*.py"):
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                names = [node.module or ""]
            else:
                continue
            found |= {n.split(".")[0] for n in names}
    return {n for n in found if n and n not in stdlib and n != "sarnav"}


def test_license_is_mit_with_its_holder():
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("MIT License") and "sarnav developers" in text
    assert "THE SOFTWARE IS PROVIDED \"AS IS\"" in text
    assert PROJECT["license"] == "MIT" and PROJECT["license-files"] == ["LICENSE"]


def test_metadata_is_complete():
    assert PROJECT["authors"] == [{"name": "sarnav developers"}]
    classifiers = PROJECT["classifiers"]
    assert "Typing :: Typed" in classifiers
    assert any(c.startswith("Programming Language :: Python :: 3.11") for c in classifiers)
    assert not any(c.startswith("License ::") for c in classifiers)  # PEP 639: the license expression says it
    for label, url in PROJECT["urls"].items():  # no public home yet: every address says it is a placeholder
        assert "placeholder" in label and ".invalid" in url
    assert "version" in PROJECT["dynamic"] and "version" not in PROJECT
    assert (SRC / "py.typed").is_file()


def test_every_import_is_declared():
    """Each third-party package imported by sarnav is a dependency, or in the extra of the feature that needs it."""
    required = {_dist_name(r) for r in PROJECT["dependencies"]}
    extras = {name: {_dist_name(r) for r in reqs} for name, reqs in PROJECT["optional-dependencies"].items()}
    missing = []
    for module in sorted(_third_party_imports()):
        dist = DIST_OF.get(module, module).lower().replace("_", "-")
        if module in OPTIONAL:
            if dist not in extras[OPTIONAL[module]] or dist in required:
                missing.append(f"{module} ({dist}) belongs to the extra {OPTIONAL[module]!r} only")
        elif dist not in required:
            missing.append(f"{module} ({dist}) is not a dependency")
    assert not missing, missing


def test_the_test_extra_pulls_every_extra_the_tests_need():
    test = PROJECT["optional-dependencies"]["test"]
    assert "sarnav[dask,registration,geo,ros]" in test
    assert {"pytest", "pytest-xdist", "cf-units", "setuptools-scm"} <= {_dist_name(r) for r in test}


def test_fallback_version_is_the_one_the_code_reports():
    from sarnav.version import FALLBACK

    assert PYPROJECT["tool"]["setuptools_scm"]["fallback_version"] == FALLBACK


def _git(*args: str) -> str:
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, check=True).stdout.strip()


def _expected_version() -> str:
    """A regular expression of the version by setuptools-scm's default scheme (guess-next-dev, node-and-date), worked
    out here from git: the tag itself on a clean tagged commit, else the next patch's ``.devN+gHASH`` (N commits
    after the tag, or all of them from the fallback version without a tag), ``.dYYYYMMDD`` when modified."""
    from sarnav.version import FALLBACK

    head = _git("rev-parse", "HEAD")
    dirty = bool(_git("status", "--porcelain", "--untracked-files=no"))
    try:
        described = _git("describe", "--tags", "--long", "--match", "*[0-9]*")
    except subprocess.CalledProcessError:  # no tag
        base = None
        next_version, distance = FALLBACK.removesuffix(".dev0"), int(_git("rev-list", "--count", "HEAD"))
    else:
        tag, distance_text, _ = described.rsplit("-", 2)
        base, distance = tag.lstrip("v"), int(distance_text)
        major, minor, patch = (base.split(".") + ["0", "0"])[:3]
        next_version = f"{major}.{minor}.{int(patch) + 1}"
    if base is not None and distance == 0 and not dirty:
        return re.escape(base)
    return re.escape(f"{next_version}.dev{distance}+g{head[:7]}") + r"[0-9a-f]*" + (r"\.d\d{8}" if dirty else "")


@pytest.mark.skipif(not (ROOT / ".git").exists() or shutil.which("git") is None, reason="needs a git checkout")
def test_python_m_sarnav_version_prints_the_git_derived_version():
    pytest.importorskip("setuptools_scm")
    out = subprocess.run([sys.executable, "-m", "sarnav", "--version"], capture_output=True, text=True, timeout=60,
                         cwd=ROOT, env=_env())
    assert out.returncode == 0, out.stderr
    m = re.fullmatch(r"sarnav (\S+) \(commit ([0-9a-f]{40})(-dirty)?\)", out.stdout.strip())
    assert m, out.stdout
    assert re.fullmatch(_expected_version(), m.group(1)), (m.group(1), _expected_version())
    assert m.group(2) == _git("rev-parse", "HEAD")
    assert bool(m.group(3)) == bool(_git("status", "--porcelain", "--untracked-files=no"))


def _env():
    import os

    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT / "src") + os.pathsep + env.get("PYTHONPATH", "")
    return env


def test_results_carry_the_version_and_commit(tmp_path):
    from sarnav.montecarlo.assemble import open_results
    from sarnav.montecarlo.campaign import run_campaign
    from sarnav.scenarios.config import load_scenario
    from sarnav.scenarios.registry import get_kind
    from sarnav.version import commit, version

    cfg = load_scenario("telemetry", ["trajectory.duration=2.0"], runs=1, seed=3)
    run_campaign(cfg, tmp_path / "c", kind=get_kind("telemetry"), executor="serial", quiet=True)
    ds = open_results(tmp_path / "c" / "results.nc")
    assert ds.attrs["sarnav_version"] == version() and ds.attrs["sarnav_commit"] == commit()
    if (ROOT / ".git").exists() and shutil.which("git"):
        assert ds.attrs["sarnav_commit"].startswith(_git("rev-parse", "HEAD"))


# --- optional extras: a missing one is one line naming it -----------------------------------------------------------
def test_executor_dask_without_the_dask_extra_is_one_line(monkeypatch, tmp_path, capsys):
    from sarnav.cli.main import main

    monkeypatch.setitem(sys.modules, "distributed", None)  # as if dask[distributed] were not installed
    code = main(["run", "telemetry", "--runs", "1", "--executor", "dask", "--out", str(tmp_path / "o"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert err[0].startswith("sarnav: error: --executor:") and "pip install 'sarnav[dask]'" in err[0]
    assert not (tmp_path / "o").exists()  # refused before anything was written


def test_closed_loop_without_the_registration_extra_is_one_line(monkeypatch, tmp_path, capsys):
    from sarnav.cli.main import main

    monkeypatch.setitem(sys.modules, "skimage", None)
    code = main(["run", "spacecraft-closed-loop", "--runs", "1", "--out", str(tmp_path / "o"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "measurement.mode" in err[0] and "pip install 'sarnav[registration]'" in err[0]
    # the open loop (oracle measurements) does not register images: no extra needed to validate it
    from sarnav.scenarios.config import load_scenario

    load_scenario("spacecraft-closed-loop", ["measurement.mode=oracle"], runs=1)


def test_registration_functions_name_the_extra(monkeypatch):
    import numpy as np

    from sarnav.errors import MissingExtraError
    from sarnav.imaging.feature_registration import correlation_shift, feature_affine

    monkeypatch.setitem(sys.modules, "skimage", None)
    img = np.ones((40, 40))
    for call in (lambda: correlation_shift(img, img), lambda: feature_affine(img, img)):
        with pytest.raises(MissingExtraError, match=r"sarnav\[registration\]"):
            call()


# --- the wheel -------------------------------------------------------------------------------------------------------
def _tracked_copy(dest: Path) -> Path:
    """The files git tracks (plus this branch's uncommitted ones), copied to ``dest`` without git metadata."""
    files = _git("ls-files", "--cached", "--others", "--exclude-standard").splitlines()
    for name in files:
        src = ROOT / name
        if src.is_file():
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / name)
    return dest


@pytest.mark.skipif(not (ROOT / ".git").exists() or shutil.which("git") is None, reason="needs a git checkout")
def test_wheel_holds_license_and_py_typed_and_builds_without_tags(tmp_path):
    """A clone without tags (here: a fresh repository of the tracked files, one commit) builds, with the version
    counted from the fallback, and its wheel holds LICENSE, py.typed and the recorded version and commit."""
    tree = _tracked_copy(tmp_path / "tree")
    git = ["git", "-C", str(tree), "-c", "user.name=t", "-c", "user.email=t@t", "-c", "commit.gpgsign=false"]
    subprocess.run(git[:3] + ["init", "-q"], check=True)
    subprocess.run(git + ["add", "-A"], check=True)
    subprocess.run(git + ["commit", "-q", "-m", "one"], check=True)
    node = subprocess.run(git[:3] + ["rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    built = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path / "dist"),
                            str(tree)], capture_output=True, text=True, timeout=600)
    if built.returncode and "No matching distribution" in built.stderr + built.stdout:
        pytest.skip("the build requirements (setuptools, setuptools-scm) cannot be downloaded here")
    assert built.returncode == 0, built.stderr[-2000:]
    (wheel,) = (tmp_path / "dist").glob("sarnav-*.whl")
    version = wheel.name.split("-")[1]
    assert re.fullmatch(r"0\.2\.1\.dev1\+g[0-9a-f]{7,}", version), version
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        assert "sarnav/py.typed" in names
        assert f"sarnav-{version}.dist-info/licenses/LICENSE" in names
        assert z.read(f"sarnav-{version}.dist-info/licenses/LICENSE") == (ROOT / "LICENSE").read_bytes()
        stamped = z.read("sarnav/_version.py").decode()
        meta = z.read(f"sarnav-{version}.dist-info/METADATA").decode()
    assert f"version = '{version}'" in stamped and f"node = 'g{node}'" in stamped
    assert "Requires-Dist: lxml" in meta and "Provides-Extra: dask" in meta and "Provides-Extra: registration" in meta
    assert "Requires-Dist: scikit-image>=0.22; extra == \"registration\"" in meta
    assert not any(line.startswith("Requires-Dist: dask") and "extra" not in line for line in meta.splitlines())
