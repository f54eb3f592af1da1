"""The documentation site (mkdocs.yml, issue 30): every page of docs/ and every notebook is in its navigation, the
notebooks are stored without outputs (the build executes them), and (slow) the build itself passes in strict mode."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
CONFIG = (ROOT / "mkdocs.yml").read_text()


def _nav_pages() -> set[str]:
    return set(re.findall(r":\s+(\S+\.(?:md|ipynb))\s*$", CONFIG, flags=re.M))


def test_every_page_and_notebook_is_in_the_navigation():
    pages = {str(p.relative_to(DOCS)) for p in DOCS.rglob("*") if p.suffix in (".md", ".ipynb")
             and ".ipynb_checkpoints" not in p.parts}
    assert pages == _nav_pages()
    assert len([p for p in pages if p.endswith(".ipynb")]) == 3


@pytest.mark.parametrize("notebook", sorted(p.name for p in (DOCS / "notebooks").glob("*.ipynb")))
def test_notebooks_are_stored_without_outputs(notebook):
    nb = json.loads((DOCS / "notebooks" / notebook).read_text())
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    assert code and all(not c.get("outputs") and c.get("execution_count") is None for c in code)


@pytest.mark.slow
def test_the_site_builds_in_strict_mode(tmp_path):
    """What .ci/run does: the notebooks executed, warnings as errors."""
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocs_jupyter")
    shutil.rmtree(ROOT / ".cache", ignore_errors=True)  # mkdocs-jupyter's cache of executed notebooks
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "s")],
                          cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    for name in ("rda_nav_campaign", "cphd_image_sicd", "navigate_recording"):
        assert "image/png;base64" in (tmp_path / "s" / "notebooks" / name / "index.html").read_text()
