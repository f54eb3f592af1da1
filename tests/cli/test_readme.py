"""Every command of the README's CLI block runs (issue 9: its --resume example failed as written). Commands are run
in order in a fresh folder, shortened (2-s flights, 2 runs, serial) so that the suite stays fast; the dask example
connects to a LocalCluster started here; ``my_scenario.toml`` comes from the block's own ``sarnav show``."""

from __future__ import annotations

import re
import shlex
from pathlib import Path


from sarnav.cli.main import main

README = Path(__file__).resolve().parents[2] / "README.md"


def _commands() -> list[str]:
    text = README.read_text()
    block = text[text.index("## CLI"):].split("```sh", 1)[1].split("```", 1)[0]
    return [ln.split("  #")[0].strip() for ln in block.splitlines() if ln.startswith("sarnav ")]


def _shorten(argv: list[str], scheduler: str) -> list[str]:
    out, i = [], 0
    while i < len(argv):
        if argv[i] == "--runs":
            out += ["--runs", "2"]
            i += 2
            continue
        if argv[i] == "--scheduler":
            out += ["--scheduler", scheduler]
            i += 2
            continue
        out.append(argv[i])
        i += 1
    if out[0] == "run":
        target = out[1]
        if "--runs" not in out:
            out += ["--runs", "2"]
        if target == "telemetry-imu-grade":
            out += ["--set", "base.trajectory.duration=1.0"]
        else:
            out += ["--set", "trajectory.duration=2.0"]
        if "--executor" not in out:
            out += ["--executor", "serial"]
        out += ["--quiet"]
    if out[0] == "export":
        out += ["--set", "trajectory.duration=2.0", "--quiet"]
    return out


def test_the_readme_cli_block_has_the_commands_it_documents():
    cmds = _commands()
    assert len(cmds) >= 12 and any("--resume" in c for c in cmds) and any(c.startswith("sarnav compare") for c in cmds)


def test_every_readme_command_runs(tmp_path, monkeypatch, capsys):
    from dask.distributed import LocalCluster

    monkeypatch.chdir(tmp_path)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        for line in _commands():
            redirect = None
            if ">" in line:
                line, redirect = (part.strip() for part in line.split(">", 1))
            argv = _shorten(shlex.split(line)[1:], cluster.scheduler_address)
            code = main(argv)
            out = capsys.readouterr()
            assert code == 0, f"{line}: exit {code}: {out.err}"
            if redirect:
                Path(redirect).write_text(out.out)
    assert (tmp_path / "out" / "r50" / "report.html").exists() and (tmp_path / "out" / "cmp" / "compare.csv").exists()
    assert re.search(r"runs", (tmp_path / "out" / "r50" / "campaign.json").read_text())
