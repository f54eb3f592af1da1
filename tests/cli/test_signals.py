"""SIGINT and SIGTERM to ``sarnav run`` — to the main process or to its whole process group (``killpg``, what a
terminal's ^C does), at any moment from start-up to the middle of the campaign, with the processes and the dask
executors — end it within seconds with the one "interrupted" line and exit 130 / 143: no hang, no traceback, no
worker left (issue 9; 0.1 hung in 4 of 46 trials joining the process pool's manager thread, dask printed pages of
CommClosedError tracebacks, a signal in the first ~50 ms gave a KeyboardInterrupt traceback or a silent kill).

    python -m pytest -q -m slow tests/cli/test_signals.py     # 36 + 12 + 16 trials and two dask trials

Start-up: the handlers are installed by the first line of ``sarnav/__init__.py``. A signal that arrives before it —
while the interpreter itself starts (site, encodings: 10-30 ms on a loaded machine) — gets the operating system's
default, which no Python code can change; the early trials therefore check the strict outcome whenever
``/proc/PID/status`` showed the handler installed just before the signal was sent, and count the others.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers import child_pids
from toy_kind import TESTS, toy_cfg

from sarnav.tomlio import dump_toml

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")

#: the console script next to the interpreter (what a user runs), else ``python -m sarnav.cli.main``
_SCRIPT = Path(sys.executable).with_name("sarnav")
COMMAND = [str(_SCRIPT)] if _SCRIPT.exists() else [sys.executable, "-m", "sarnav.cli.main"]


def _env() -> dict:
    return dict(os.environ, PYTHONPATH=str(TESTS) + os.pathsep + os.environ.get("PYTHONPATH", ""))


def _toy_command(tmp: Path, k: int, executor: str = "processes", runs: int = 40) -> list[str]:
    f = tmp / f"toy{k}.toml"
    f.write_text(dump_toml(toy_cfg(runs=runs, seed=k, delay=0.5)))
    return COMMAND + ["run", str(f), "--out", str(tmp / f"out{k}"), "--executor", executor, "--workers", "2",
                      "--chunk-size", "2", "--quiet", "--no-figures"]


def _send(proc, sig: int, group: bool) -> None:
    if group:
        os.killpg(proc.pid, sig)
    else:
        proc.send_signal(sig)


def _trial(cmd, sig: int, after: float, group: bool = False, timeout: float = 30.0):
    """(exit status, stderr, seconds from the signal to the exit, processes the command had started)."""
    proc = subprocess.Popen(cmd, env=_env(), stderr=subprocess.PIPE, stdout=subprocess.DEVNULL,
                            start_new_session=group)
    time.sleep(after)
    workers = child_pids(proc.pid)
    t0 = time.time()
    _send(proc, sig, group)
    try:
        _, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL) if group else proc.kill()
        _, err = proc.communicate()
        return -1, err.decode(), timeout, workers
    return proc.returncode, err.decode(), time.time() - t0, workers


def _assert_clean(code, err, took, workers, sig, where):
    assert code == 128 + sig, f"{where}: exit {code}, stderr {err!r}"
    assert took < 15, f"{where}: took {took:.1f} s"
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"sarnav: interrupted by signal {sig}"), f"{where}: {err!r}"
    assert "Traceback" not in err
    deadline = time.time() + 10
    while time.time() < deadline and any(Path(f"/proc/{w}").exists() for w in workers):
        time.sleep(0.1)
    assert not [w for w in workers if Path(f"/proc/{w}").exists()], f"{where}: workers left"


def _check(trials, tmp_path, group=False, executor="processes"):
    for k, (sig, after) in enumerate(trials):
        code, err, took, workers = _trial(_toy_command(tmp_path, k, executor), sig, after, group)
        _assert_clean(code, err, took, workers, sig, f"trial {k}: signal {sig} after {after} s (group {group})")


def _plan(n: int, seed: int):
    import random

    rnd = random.Random(seed)
    # from start-up (imports) to well inside the campaign
    return [(rnd.choice([signal.SIGINT, signal.SIGTERM]), rnd.choice([0.15, 0.3, 0.6]) if i % 3 == 0
             else rnd.uniform(0.6, 4.0)) for i in range(n)]


def test_signals_to_the_main_process_end_the_campaign_cleanly(tmp_path):
    _check(_plan(8, 1), tmp_path)


def test_signals_to_the_process_group_end_the_campaign_cleanly(tmp_path):
    # the workers get the signal too: none may print a traceback or outlive the command
    _check([(signal.SIGINT, 2.5), (signal.SIGTERM, 1.5)], tmp_path, group=True)


# ----------------------------------------------------------------------------- start-up
_SIGCGT_BIT = {signal.SIGINT: 1 << (signal.SIGINT - 1), signal.SIGTERM: 1 << (signal.SIGTERM - 1)}


def _handles_sigterm(pid: int) -> bool:
    """Whether the process has a handler for SIGTERM (``SigCgt`` of /proc/PID/status): sarnav's is the only one a
    Python process installs, so it shows that the first line of ``sarnav/__init__.py`` has run."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    caught = int(status.split("SigCgt:")[1].split()[0], 16)
    return bool(caught & _SIGCGT_BIT[signal.SIGTERM])


def _early_trial(cmd, sig: int, after: float | None):
    """Signal ``after`` s from the start, or (None) the moment the handler appears; returns (handled before the
    signal, exit status, stderr)."""
    proc = subprocess.Popen(cmd, env=_env(), stderr=subprocess.PIPE, stdout=subprocess.DEVNULL)
    if after is None:
        deadline = time.time() + 20
        while not _handles_sigterm(proc.pid) and time.time() < deadline:
            pass
    else:
        time.sleep(after)
    handled = _handles_sigterm(proc.pid)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=30)
    return handled, proc.returncode, err.decode()


def _install_line() -> int:
    """The line of ``sarnav/__init__.py`` that installs the deferring handlers (the statements before it, a few
    microseconds, are the only sarnav code a signal can interrupt with the operating system's defaults)."""
    import sarnav

    lines = Path(sarnav.__file__).read_text().splitlines()
    return next(i for i, line in enumerate(lines, 1) if "_BEFORE = (_sg.signal(" in line)


def _only_before_the_handlers(err: str) -> bool:
    """No frame of sarnav's code in the traceback ``err`` but the first lines of ``sarnav/__init__.py``, up to the
    handlers' installation."""
    import re

    frames = re.findall(r'File "([^"]*)", line (\d+)', err)
    inside = [(f, int(n)) for f, n in frames if f"{os.sep}sarnav{os.sep}" in f]
    return all(f.endswith(f"sarnav{os.sep}__init__.py") and n <= _install_line() for f, n in inside)


def _check_early(tmp_path, delays, repeat=1):
    cmd = _toy_command(tmp_path, 0, executor="serial", runs=4)
    early = 0
    for k in range(repeat):
        for sig in (signal.SIGINT, signal.SIGTERM):
            for after in delays:
                handled, code, err = _early_trial(cmd, sig, after)
                where = f"signal {sig} {'at the handler' if after is None else f'after {after} s'} (trial {k})"
                if handled or after is None:
                    assert handled, f"{where}: no SIGTERM handler within 20 s"
                    _assert_clean(code, err, 0.0, [], sig, where)
                else:  # still in the interpreter's own start-up: the OS default, never a hang, never a traceback
                    early += 1  # through sarnav's code (a KeyboardInterrupt in site or in the search for the package)
                    assert code in (-sig, 128 + sig, 1), f"{where}: exit {code}, {err!r}"
                    assert _only_before_the_handlers(err), f"{where}: a traceback through sarnav: {err!r}"
    return early


def test_a_signal_at_start_up_gives_the_one_line(tmp_path):
    # None: the moment the first line of sarnav/__init__.py installed the handlers (then come the imports of
    # sarnav.cli, numpy, xarray, ... and the scenario file)
    _check_early(tmp_path, [None, 0.01, 0.02, 0.03, 0.05])


def test_only_the_command_defers_signals():
    import sarnav

    assert sarnav._runs_the_command(["python3", "/venv/bin/sarnav", "run"])
    assert sarnav._runs_the_command(["python", "-X", "dev", "-m", "sarnav.cli.main", "run"])
    assert not sarnav._runs_the_command(["python", "-m", "pytest", "-q"])
    assert not sarnav._runs_the_command(["python", "script_importing_sarnav.py"])
    # a worker process of the pool (spawn) re-imports the console script as __mp_main__: it must die by SIGTERM
    assert not sarnav._runs_the_command(["python", "-B", "-c", "from multiprocessing.spawn import spawn_main; "
                                         "spawn_main(tracker_fd=5, pipe_handle=7)", "--multiprocessing-fork"])


def test_pool_workers_do_not_catch_sigterm(tmp_path):
    # 0.1 installed the command's deferring handlers in every worker started from the console script, so that the
    # pool's terminate() was ignored until the worker's task ended
    proc = subprocess.Popen(_toy_command(tmp_path, 0), env=_env(), stderr=subprocess.PIPE, stdout=subprocess.DEVNULL)
    try:
        deadline, workers = time.time() + 30, []
        while time.time() < deadline and len(workers) < 2:
            time.sleep(0.2)
            workers = [w for w in child_pids(proc.pid)
                       if b"spawn_main" in Path(f"/proc/{w}/cmdline").read_bytes() and _imported_sarnav(w)]
        assert len(workers) == 2, "the pool's workers did not start"
        assert not [w for w in workers if _handles_sigterm(w)], "a worker catches SIGTERM"
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=30)
    assert proc.returncode == 128 + signal.SIGTERM


def _imported_sarnav(pid: int) -> bool:
    """Whether the worker has loaded numpy (it then runs the toy kind's module, after the console script)."""
    try:
        return "numpy" in Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return False


# ----------------------------------------------------------------------------- dask
def test_sigterm_to_a_dask_campaign_gives_the_one_line(tmp_path):
    # a LocalCluster of 2 workers: no worker's CommClosedError or cancelled-task warning on the terminal
    code, err, took, workers = _trial(_toy_command(tmp_path, 0, "dask", runs=40), signal.SIGTERM, 8.0)
    _assert_clean(code, err, took, workers, signal.SIGTERM, "dask SIGTERM after 8 s")


@pytest.mark.slow
def test_signals_to_the_main_process_end_the_campaign_cleanly_36_times(tmp_path):
    _check(_plan(36, 2), tmp_path)


@pytest.mark.slow
def test_signals_to_the_process_group_end_the_campaign_cleanly_12_times(tmp_path):
    _check(_plan(12, 3), tmp_path, group=True)


@pytest.mark.slow
def test_a_signal_at_start_up_gives_the_one_line_16_times(tmp_path):
    early = _check_early(tmp_path, [None, 0.005, 0.01, 0.02, 0.03, 0.04, 0.05, 0.08], repeat=1)
    print(f"{early} of 16 signals arrived in the interpreter's own start-up")


@pytest.mark.slow
def test_group_sigint_to_a_dask_campaign_gives_the_one_line(tmp_path):
    code, err, took, workers = _trial(_toy_command(tmp_path, 0, "dask", runs=40), signal.SIGINT, 8.0, group=True)
    _assert_clean(code, err, took, workers, signal.SIGINT, "dask group SIGINT after 8 s")
