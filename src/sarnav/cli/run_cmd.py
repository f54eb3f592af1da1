"""``sarnav run [SCENARIO|FILE.toml]``: a Monte Carlo campaign (or a study of several) with results
and figures in ``--out`` (default ``./sarnav-out/<scenario>/``)."""

from __future__ import annotations

import sys
from pathlib import Path

from sarnav.scenarios.registry import DEFAULT_RUNS, DEFAULT_SCENARIO

# The heavy modules (xarray, scipy.stats, matplotlib) are imported inside run(): worker processes
# started with ``spawn`` re-import this command's main module and should start fast.
EXECUTORS = ("serial", "processes", "dask")  # == sarnav.montecarlo.executors.EXECUTORS (tested)

DESCRIPTION = "Run a scenario's Monte Carlo campaign (or each case of a study); results, summary and figures go to --out (default ./sarnav-out/<scenario>/)."
NAME = "run"
DEFAULT_OUT_ROOT = "sarnav-out"


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(NAME, help="run a scenario's Monte Carlo campaign", description=DESCRIPTION)
    p.add_argument("scenario", metavar="SCENARIO", nargs="?", default=None,
                   help=f"registered name or FILE.toml (default: {DEFAULT_SCENARIO} with {DEFAULT_RUNS} runs "
                        f"unless --runs is given)")
    p.add_argument("--runs", type=int, help="number of Monte Carlo runs (campaign.runs)")
    p.add_argument("--seed", type=int, help="campaign seed (campaign.seed)")
    p.add_argument("--out", help=f"output directory (default: ./{DEFAULT_OUT_ROOT}/<scenario>)")
    p.add_argument("--executor", choices=EXECUTORS, default=None,
                   help="where runs execute (default: processes; dask when --scheduler is given)")
    p.add_argument("--workers", type=int, help="worker processes (default: number of cores)")
    p.add_argument("--scheduler", metavar="ADDR", help="dask.distributed scheduler address, e.g. tcp://host:8786")
    p.add_argument("--chunk-size", type=int, help="runs per task (default: sized by work, about 20 s per task once the cost of a run is measured)")
    p.add_argument("--resume", action="store_true",
                   help="keep the runs already stored in --out and finish (or extend: a larger --runs)")
    p.add_argument("--redo-run", dest="redo_runs", type=int, action="append", default=[], metavar="K",
                   help="with --resume: simulate run K again (repairs a damaged run file), repeatable")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the results of another scenario found in --out")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value (dotted key, TOML value), repeatable")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no summary lines")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p.set_defaults(handler=run)


def _print_summary(summary: dict, out: Path) -> None:
    print(f"{summary['scenario']}: {summary['runs']} runs -> {out}")
    rows = list(summary["states"].items())[:9]
    for name, s in rows:
        value = f"{s['final_3sigma']:.4g} {s['units']}"
        print(f"  {name:>6}  final 3-sigma {value:<14} inside 3-sigma {100 * s['fraction_inside_3sigma']:6.2f} %")
    n = summary["nees"]
    print(f"  mean NEES (time average) {n['time_average']:.3g}, dof {n['dof']}, 95% band of the run mean [{n['band'][0]:.3g}, {n['band'][1]:.3g}]")


def _import_engine() -> None:
    """The campaign engine's C-extension dependencies, imported while signals are deferred (errors.deferred_signals)."""
    import matplotlib.figure  # noqa: F401
    import netCDF4  # noqa: F401
    import numba  # noqa: F401
    import scipy.linalg  # noqa: F401
    import scipy.stats  # noqa: F401
    import xarray  # noqa: F401

    import sarnav.montecarlo.campaign  # noqa: F401
    import sarnav.report.figures  # noqa: F401
    import sarnav.scenarios.config  # noqa: F401


def _draw_figures(ds, out: Path, kind) -> None:
    """The campaign's figures, listed in the folder's record of what sarnav wrote; a full disk is one line (the
    results are complete: ``sarnav figures OUT`` draws them again)."""
    from sarnav.errors import RunFault, disk_message
    from sarnav.montecarlo.outdir import record_files
    from sarnav.report.figures import write_campaign_figures

    try:
        record_files(out, write_campaign_figures(ds, out, kind=kind))
    except OSError as err:
        raise RunFault(str(out / "figures"), f"cannot draw the figures: {disk_message(err)}; the results are "
                       f"complete: draw the figures again with `sarnav figures {out}`") from None


def run(args) -> int:
    from sarnav.errors import ConfigError, deferred_signals

    with deferred_signals():
        _import_engine()
    from sarnav.montecarlo.campaign import CampaignInterrupted, run_campaign
    from sarnav.montecarlo.store import stored_runs
    from sarnav.scenarios.config import load_scenario

    if args.chunk_size is not None and args.chunk_size < 1:
        raise ConfigError("--chunk-size", f"must be an integer >= 1, got {args.chunk_size}")
    if args.scenario is None:  # the main job: a reduced campaign of the default scenario
        args.scenario = DEFAULT_SCENARIO
        if args.runs is None:
            args.runs = DEFAULT_RUNS
            if not args.quiet:
                print(f"sarnav run: default job {DEFAULT_SCENARIO} with {DEFAULT_RUNS} runs "
                      f"(the full campaign: sarnav run {DEFAULT_SCENARIO})", file=sys.stderr)
    notices: list[str] = []
    cfg = load_scenario(args.scenario, args.overrides, runs=args.runs, seed=args.seed, notices=notices)
    for line in notices:
        print(f"sarnav: notice: {line}", file=sys.stderr)
    name = cfg["scenario"]["name"]
    out = Path(args.out) if args.out else Path(DEFAULT_OUT_ROOT) / name
    executor = args.executor or ("dask" if args.scheduler else "processes")
    if args.scheduler and executor != "dask":
        raise ConfigError("--scheduler", f"needs --executor dask, got --executor {executor}")
    opts = dict(executor=executor, workers=args.workers, scheduler=args.scheduler, resume=args.resume,
                quiet=args.quiet, chunk_size=args.chunk_size, overwrite=args.overwrite)
    if args.redo_runs:
        opts["redo_runs"] = args.redo_runs
    from sarnav.scenarios.registry import get_kind

    kind = get_kind(cfg["scenario"]["kind"])
    custom = getattr(kind, "run_scenario", None)  # kinds that are not one campaign (studies, ...)
    try:
        if callable(custom):
            custom(cfg, out, figures=not args.no_figures, **opts)
            if not args.quiet:
                print(f"{name} -> {out}")
            return 0
        res = run_campaign(cfg, out, kind=kind, **opts)
    except CampaignInterrupted as exc:
        if cfg["scenario"]["kind"] == "study":
            what = f"study {name}: finished cases and stored runs are kept in {out}"
        else:
            what = f"{len(stored_runs(out))} of {cfg['campaign']['runs']} runs stored in {out}"
        print(f"sarnav: interrupted by signal {exc.signum}: {what}; finish with the same command and --resume",
              file=sys.stderr)
        return 128 + exc.signum
    if not args.no_figures:
        _draw_figures(res.dataset, out, kind)
    if not args.quiet:
        _print_summary(res.summary, out)
    if res.summary.get("consistent") is False:  # the run itself succeeded: exit 0
        print(f"sarnav: warning: the filter is inconsistent ({'; '.join(res.summary['inconsistency'])}); "
              f"see {out / 'summary.json'}", file=sys.stderr)
    return 0
