"""The Python entry point (docs/api.md): ``sarnav.run(scenario, runs=..., seed=..., **overrides)`` runs a scenario's
Monte Carlo campaign exactly as ``sarnav run`` does and returns its ``results.nc`` as an :class:`xarray.Dataset`;
:func:`figures` draws the campaign figures as matplotlib figures (the CLI saves the same figures as PNG).

Overrides are the CLI's ``--set`` in Python: a keyword per table with a dict (``imu={"grade": "consumer"}``), or a
dotted key spelled with double underscores (``imu__grade="consumer"``, ``filter__imu__grade="navigation"``). Each
value goes through the same TOML text and checks as ``--set``, so a bad key or value is the same one-line
:class:`~sarnav.errors.ConfigError`.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

__all__ = ["run", "run_result", "figures", "override_strings"]


def override_strings(overrides: dict) -> list[str]:
    """``{"imu": {"grade": "consumer"}, "trajectory__duration": 20}`` -> ``["imu.grade=\\"consumer\\"",
    "trajectory.duration=20"]``: the ``--set`` strings of keyword overrides (values written as TOML)."""
    import tomli_w

    out: list[str] = []

    def walk(prefix: str, value) -> None:
        if isinstance(value, dict):
            for k, v in value.items():
                walk(f"{prefix}.{k}", v)
            return
        try:
            text = toml_value(value)
        except TypeError:
            from sarnav.errors import ConfigError

            raise ConfigError(prefix, f"must be a TOML value (number, string, boolean, list), got "
                              f"{type(value).__name__} {value!r}") from None
        out.append(f"{prefix}={text}")

    def toml_value(value) -> str:  # one line, as typed after --set
        if isinstance(value, (list, tuple)):
            return "[" + ", ".join(toml_value(v) for v in value) + "]"
        return tomli_w.dumps({"v": value}).partition("=")[2].strip()

    for key, value in overrides.items():
        walk(key.replace("__", "."), value)
    return out


def run_result(scenario: str | os.PathLike = "rda-nav", runs: int | None = None, seed: int | None = None, *,
               out: str | os.PathLike | None = None, executor: str = "processes", workers: int | None = None,
               resume: bool = False, overwrite: bool = False, quiet: bool = True, **overrides):
    """:func:`run`, returning the whole :class:`~sarnav.montecarlo.campaign.CampaignResult` (out folder, summary,
    the number of runs simulated) with its ``dataset`` read back from ``results.nc``; ``out`` is required."""
    from sarnav.errors import ConfigError
    from sarnav.montecarlo.assemble import open_results
    from sarnav.montecarlo.campaign import run_campaign
    from sarnav.scenarios.config import load_scenario
    from sarnav.scenarios.registry import get_kind

    if out is None:
        raise ConfigError("out", "run_result needs an output folder (sarnav.run uses a temporary one)")
    notices: list[str] = []
    cfg = load_scenario(scenario, override_strings(overrides), runs=runs, seed=seed, notices=notices)
    for line in notices:
        import warnings

        warnings.warn(line, FutureWarning, stacklevel=2)
    kind = get_kind(cfg["scenario"]["kind"])
    if callable(getattr(kind, "run_scenario", None)):
        name = cfg["scenario"]["name"]
        raise ConfigError("scenario", f"{name} (kind {cfg['scenario']['kind']}) writes its own files, not one "
                          f"results Dataset: run `sarnav run {name} --out DIR` and read the files in DIR")
    res = run_campaign(cfg, out, kind=kind, executor=executor, workers=workers, resume=resume, quiet=quiet,
                       overwrite=overwrite)
    res.dataset = open_results(res.results_path)
    return res


def run(scenario: str | os.PathLike = "rda-nav", runs: int | None = None, seed: int | None = None, *,
        out: str | os.PathLike | None = None, executor: str = "processes", workers: int | None = None,
        quiet: bool = True, **overrides):
    """Run a scenario's Monte Carlo campaign; return its results (``results.nc``, docs/results.md) as a Dataset.

    Parameters
    ----------
    scenario : a registered name (``sarnav scenarios``) or a TOML file, as for ``sarnav run``.
    runs, seed : ``campaign.runs`` and ``campaign.seed`` (default: the scenario's).
    out : keep the campaign's folder (``results.nc``, ``summary.json``, ``campaign.json``, the run files) there;
        default: a temporary folder, removed on return.
    executor, workers : as ``--executor`` / ``--workers`` (``"serial"``, ``"processes"``, ``"dask"``). The
        ``processes`` and ``dask`` executors start fresh interpreters: a script calling this must do so under
        ``if __name__ == "__main__":`` (a notebook needs nothing).
    quiet : no progress bar (default; ``False`` shows it on stderr when that is a terminal).
    **overrides : scenario values, as ``--set`` (module docstring): ``imu={"grade": "consumer"}`` or
        ``imu__grade="consumer"``.

    Returns
    -------
    xarray.Dataset
        equal to the file ``sarnav run`` writes for the same scenario, runs, seed and overrides (the results do not
        depend on the executor).

    Notes
    -----
    Kinds that write their own files instead of one campaign (studies, sweeps, images) are a
    :class:`~sarnav.errors.ConfigError` naming the command that runs them.
    """
    if out is not None:
        return run_result(scenario, runs, seed, out=out, executor=executor, workers=workers, quiet=quiet,
                          **overrides).dataset
    with tempfile.TemporaryDirectory(prefix="sarnav-run-") as tmp:
        return run_result(scenario, runs, seed, out=Path(tmp) / "campaign", executor=executor, workers=workers,
                          quiet=quiet, **overrides).dataset


def figures(results, max_runs: int = 50) -> dict:
    """The standard campaign figures of a results Dataset as ``{name: matplotlib.figure.Figure}`` (``position``,
    ``velocity``, ``attitude``, ... and ``residuals``): the figures ``sarnav run`` saves as ``figures/<name>.png``.
    In a notebook, show one by evaluating it; save one with ``fig.savefig(path)``."""
    from sarnav.report.figures import campaign_figures

    return campaign_figures(results, max_runs=max_runs)
