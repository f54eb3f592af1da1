"""``sarnav navigate DIR --out OUT``: the SAR-aided navigator on a flight recording (docs/navigate.md). Parses and
prints only: the settings are ``scenarios.navigate.read_navigate_settings``, the run and its files
``report.navigate_files.run_navigate``."""

from __future__ import annotations

import sys

NAME = "navigate"
DESCRIPTION = ("Run the SAR-aided navigator on a flight recording (docs/recording.md): the initial state of the "
               "manifest, then INS + altimeter + image-derived range and cross-range updates, each image formed along "
               "the navigator's own estimated track. Writes trajectory.nc, trajectory.csv, trajectory.geojson, "
               "trajectory.kml, updates.csv, with truth errors.csv, report.html, navigate.json, and images/ (a PNG of "
               "every in-flight image formed; with --sicd its SICD too) (docs/navigate.md).")


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(NAME, help="navigate a flight recording (INS + altimeter + SAR)", description=DESCRIPTION)
    p.add_argument("recording", metavar="DIR", help="the recording's folder (holding flight.toml)")
    p.add_argument("--out", required=True, help="output folder (created; must be empty unless --overwrite)")
    p.add_argument("--config", metavar="NAV.toml", help="the navigator's settings: [sar], [filter.imu], "
                   "[earth] modelled (defaults: the recording's scenario.toml, else rda-nav's)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a setting (e.g. sar.gate_probability=1e-3), repeatable")
    p.add_argument("--overwrite", action="store_true", help="replace navigate's outputs found in --out")
    p.add_argument("--quiet", action="store_true", help="no summary line")
    p.add_argument("--no-report", action="store_true", help="do not draw report.html (its figures take seconds)")
    p.add_argument("--sicd", action="store_true", help="also write each in-flight image as OUT/images/"
                   "aperture_NNN.sicd (SICD NITF on the navigator's estimated track; docs/navigate.md)")
    p.set_defaults(handler=run)


def _progress(u: int, n: int, nav) -> None:
    up = nav.updates[-1] if nav.updates else None
    what = "" if up is None else (f" aperture {up['aperture']}: {up['pairs_fused']} pair(s) fused"
                                  if up["aperture"] >= 0 else " altimeter only")
    print(f"\rnavigate: update {u + 1}/{n} t={nav.time[-1]:.1f} s{what}\033[K", end="", file=sys.stderr, flush=True)


def run(args) -> int:
    from sarnav.recording import read_recording
    from sarnav.report.navigate_files import run_navigate
    from sarnav.scenarios.navigate import read_navigate_settings

    rec = read_recording(args.recording)
    settings = read_navigate_settings(rec, args.config, args.overrides)
    tty = sys.stderr.isatty()
    try:
        doc = run_navigate(rec, args.out, settings, progress=_progress if tty else None, overwrite=args.overwrite,
                           describe={"config": args.config, "set": list(args.overrides), "sicd": args.sicd},
                           report=not args.no_report, sicd=args.sicd)
    finally:
        if tty:
            print(file=sys.stderr)
    for line in doc.get("notices", []):
        print(f"sarnav: notice: {line}", file=sys.stderr)
    if not args.quiet:
        c = doc.get("consistency", {})
        nees = c.get("nees", {})
        extra = f", NEES {nees['time_average']:.3g} (95 % band {nees['band_95'][0]:.3g}-{nees['band_95'][1]:.3g})" \
            if nees else ""
        print(f"{args.recording}: {doc['updates']} updates, {doc['pairs_fused']} SAR pairs fused, "
              f"{doc['pairs_rejected']} rejected, {doc['pairs_skipped']} skipped{extra} -> {args.out} "
              f"({doc['real_time_factor']:.3g}x real time)")
    return 0
