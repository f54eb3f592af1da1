"""``sarnav export SCENARIO --run K --out DIR``: run K of the campaign ``sarnav run SCENARIO`` would run, written as
a flight recording (docs/recording.md)."""

from __future__ import annotations

import sys

DESCRIPTION = ("Write run K of a scenario's campaign (the rda-nav kind) as a flight recording: the IMU and altimeter "
               "logs, every aperture's pulses and its reference pass as CPHD, the reference points, the initial "
               "estimate, the truth (docs/recording.md).")
NAME = "export"


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(NAME, help="write one run of a campaign as a flight recording", description=DESCRIPTION)
    p.add_argument("scenario", metavar="SCENARIO", help="registered name or FILE.toml (kind rda-nav)")
    p.add_argument("--run", dest="run_id", type=int, required=True, metavar="K",
                   help="the campaign's run to write (0 to campaign.runs - 1)")
    p.add_argument("--out", required=True, help="the recording's folder (created; must be empty unless --overwrite)")
    p.add_argument("--seed", type=int, help="campaign seed (campaign.seed)")
    p.add_argument("--runs", type=int, help="number of runs of the campaign (campaign.runs)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value (dotted key, TOML value), repeatable")
    p.add_argument("--reference", choices=("cphd-pass", "orthoimage"), default="cphd-pass",
                   help="reference (a): the reference passes as CPHD (default); (b): GeoTIFF orthoimages (and a DEM)")
    p.add_argument("--overwrite", action="store_true", help="replace a recording found in --out")
    p.add_argument("--quiet", action="store_true", help="no summary line")
    p.set_defaults(handler=run)


def _progress(u: int, n: int) -> None:
    print(f"\rexport: interval {u + 1}/{n} written\033[K", end="", file=sys.stderr, flush=True)


def run(args) -> int:
    from sarnav.errors import ConfigError
    from sarnav.montecarlo.seeding import run_seeds
    from sarnav.scenarios.config import load_scenario
    from sarnav.scenarios.registry import get_kind
    from sarnav.simulation.export import EXPORT_KINDS, check_exportable, export_rda_nav, prepare_folder
    from sarnav.tomlio import dump_toml

    notices: list[str] = []
    cfg = load_scenario(args.scenario, args.overrides, runs=args.runs, seed=args.seed, notices=notices)
    for line in notices:
        print(f"sarnav: notice: {line}", file=sys.stderr)
    kind, name = cfg["scenario"]["kind"], cfg["scenario"]["name"]
    if kind not in EXPORT_KINDS:
        raise ConfigError("scenario.kind", f"export writes the kinds {list(EXPORT_KINDS)}, got {kind!r} ({name})")
    runs, seed = int(cfg["campaign"]["runs"]), int(cfg["campaign"]["seed"])
    if not 0 <= args.run_id < runs:
        raise ConfigError("--run", f"must be a run of the campaign, 0 to {runs - 1} (campaign.runs = {runs}), "
                          f"got {args.run_id}")
    prm = get_kind(kind).parse(cfg)
    check_exportable(prm)
    out = prepare_folder(args.out, args.overwrite)
    tty = sys.stderr.isatty() and not args.quiet
    try:
        done = export_rda_nav(prm, out, run_seeds(seed, runs)[args.run_id], run=args.run_id, runs=runs,
                              campaign_seed=seed, scenario_name=name, scenario_text=dump_toml(cfg),
                              reference=args.reference, progress=_progress if tty else None)
    finally:
        if tty:
            print(file=sys.stderr)
    if not args.quiet:
        apertures = sum(f.startswith("apertures/") for f in done.files)
        print(f"{name}: run {args.run_id} of seed {seed} -> {out} ({len(done.files)} files, {apertures} apertures)")
    return 0
