"""``sarnav image SCENARIO|FILE.toml|FILE.cphd``: simulate one block of echoes and focus it (RDA or BPA, optional
autofocus), or form an image from a CPHD file (BPA, FFBP, or by default the faster of the two within -60 dB of exact); write ``image.npz``, ``image.png`` and ``metrics.json``
to ``--out`` (default ``./sarnav-out/image-<name>/``), with ``--cphd`` the simulated collect as ``collect.cphd``, with
``--sicd`` the back-projected image as ``image.nitf``, with ``--geotiff`` (FILE.cphd) the image geocoded as
``image.tif``. Parses and prints only: the work is
``sarnav.scenarios.imaging.run_image`` and ``sarnav.scenarios.cphd_image.run_cphd_image``."""

from __future__ import annotations

import sys
from pathlib import Path

NAME = "image"
DEFAULT_OUT_ROOT = "sarnav-out"
DESCRIPTION = ("Simulate one block of echoes and focus it (RDA or BPA, optional autofocus), or form an image from a "
               "CPHD file (BPA, FFBP, or by default the faster within -60 dB of exact); write image.npz, image.png and metrics.json to --out (default "
               "./sarnav-out/image-<name>/), with --cphd the collect as collect.cphd, with --sicd the image as image.nitf.")
ALGORITHMS = ("rda", "bpa")  # == sarnav.imaging.straight_block.ALGORITHMS (tested)
CPHD_ALGORITHMS = ("auto", "bpa", "ffbp")  # == sarnav.scenarios.cphd_image.ALGORITHMS (tested)
IMAGE_SCENARIOS = ("point-target", "scatterers")  # the registered scenarios of kind "image" (tested)


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(NAME, help="form one SAR image of a simulated scene or of a CPHD file",
                              description=DESCRIPTION)
    p.add_argument("scenario", metavar="SCENARIO", help=f"{' | '.join(IMAGE_SCENARIOS)}, FILE.toml or FILE.cphd")
    p.add_argument("--algorithm", choices=ALGORITHMS + ("ffbp", "auto"),
                   help="image formation: rda | bpa for a scenario (image.algorithm); auto (default: FFBP where it is "
                   "within -60 dB of exact and faster, else bpa) | bpa | ffbp for a CPHD")
    p.add_argument("--window", metavar="NAME", help="azimuth window: none, hamming, taylor, kaiser (image.window)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value (dotted key, TOML value), repeatable")
    p.add_argument("--out", help=f"output directory (default: ./{DEFAULT_OUT_ROOT}/image-<name>)")
    p.add_argument("--cphd", action="store_true", help="also write the simulated collect as OUT/collect.cphd")
    p.add_argument("--sicd", action="store_true", help="also write the back-projected image as OUT/image.nitf (SICD)")
    p.add_argument("--geotiff", action="store_true", help="FILE.cphd: also write the image geocoded as OUT/image.tif "
                   "(GeoTIFF: |image| on a UTM map, nodata NaN; needs sarnav[geo])")
    p.add_argument("--spacing", metavar="M", help="FILE.cphd: pixel spacing [m] on the file's image plane "
                   "(default: its image grid)")
    p.add_argument("--extent", metavar="X[,Y]", help="FILE.cphd: image size [m] along the file's uIAX, uIAY about "
                   "its image grid's centre (default: its image grid)")
    p.add_argument("--filter", metavar="FILE.npy", help="FILE.cphd: weights of the frequency samples (1-D .npy)")
    p.add_argument("--channel", metavar="ID", help="FILE.cphd: the channel's identifier (default: the first)")
    p.add_argument("--pulses", metavar="START:STOP", help="FILE.cphd: the vectors imaged, STOP exclusive, either may "
                   "be empty (default: all); only these are read")
    p.add_argument("--tropo", choices=("in-data", "compensated"), help="FILE.cphd: TDTropoSRP is a delay left in the "
                   "data and removed (in-data, default) or already compensated and ignored (compensated)")
    p.add_argument("--budget", metavar="SIZE", help="FILE.cphd: memory of the image formation, e.g. 512M, 2G "
                   "(default 1G); the vectors are read and imaged in blocks that fit")
    p.add_argument("--error-db", metavar="DB", help="FILE.cphd with --algorithm ffbp or auto: the FFBP image's predicted "
                   "error against exact back-projection [dB], e.g. -70 (the cheapest plan within it; default: os 2, "
                   "kaiser6 under ffbp, -75 under auto)")
    p.add_argument("--overwrite", action="store_true", help="replace another scenario's results in --out")
    p.set_defaults(handler=run)


def _cphd(args) -> int:
    from sarnav.errors import ConfigError
    from sarnav.scenarios.cphd_image import run_cphd_image

    for flag, given in (("--set", args.overrides), ("--cphd", args.cphd)):
        if given:
            raise ConfigError(flag, f"applies to simulated scenarios, not to the CPHD file {args.scenario!r}")
    path = Path(args.scenario)
    out = Path(args.out) if args.out else Path(DEFAULT_OUT_ROOT) / f"image-{path.stem}"
    _progress(f"{path.name}: forming the {args.algorithm or 'auto'} image")
    report = run_cphd_image(path, out, algorithm=args.algorithm or "auto", spacing=args.spacing, extent=args.extent,
                            window=args.window, filter_path=args.filter, sicd=args.sicd, overwrite=args.overwrite,
                            channel=args.channel, pulses=args.pulses, tropo=args.tropo or "in-data",
                            budget=args.budget, geotiff=args.geotiff, error_db=args.error_db)
    shape = report["image_shape"]
    st = report["stream"]
    formed = report.get("formed_by", report["algorithm"])
    print(f"{path.name}: {formed} image {shape[0]}x{shape[1]} from {report['n_pulses']} pulses of channel "
          f"{report['channel']} ({st['blocks']} block(s) of <= {st['pulses_per_block']}) -> {out}")
    return 0


def run(args) -> int:
    from sarnav.errors import ConfigError
    from sarnav.scenarios.cphd_image import is_cphd
    from sarnav.scenarios.config import load_scenario
    from sarnav.scenarios.imaging import run_image

    if is_cphd(args.scenario):
        return _cphd(args)
    for flag, given in (("--spacing", args.spacing), ("--extent", args.extent), ("--filter", args.filter),
                        ("--channel", args.channel), ("--pulses", args.pulses), ("--tropo", args.tropo),
                        ("--budget", args.budget), ("--geotiff", args.geotiff or None), ("--error-db", args.error_db)):
        if given is not None:
            raise ConfigError(flag, "applies to a CPHD file (sarnav image FILE.cphd), not to a simulated scenario")
    if args.algorithm in CPHD_ALGORITHMS and args.algorithm not in ALGORITHMS:
        raise ConfigError("--algorithm", f"{args.algorithm} forms images of a CPHD file; a scenario takes one of "
                                         f"{ALGORITHMS}")
    overrides = list(args.overrides)
    if args.algorithm:
        overrides.append(f"image.algorithm={args.algorithm}")
    if args.window:
        overrides.append(f"image.window={args.window}")
    notices: list[str] = []
    cfg = load_scenario(args.scenario, overrides, notices=notices)
    for line in notices:
        print(f"sarnav: notice: {line}", file=sys.stderr)
    if cfg["scenario"]["kind"] != "image":
        raise ConfigError("scenario", f"{args.scenario!r} is a {cfg['scenario']['kind']!r} scenario, not an image: "
                          f"run it with `sarnav run {args.scenario}`")
    name = cfg["scenario"]["name"] or Path(str(args.scenario)).stem
    out = Path(args.out) if args.out else Path(DEFAULT_OUT_ROOT) / f"image-{name}"
    _progress(f"{name}: simulating the echoes and forming the {cfg['image']['algorithm']} image")
    report = run_image(cfg, out, overwrite=args.overwrite, cphd=args.cphd, sicd=args.sicd)
    shape = report["image_shape"]
    print(f"{name}: {cfg['image']['algorithm']} image {shape[0]}x{shape[1]} -> {out}")
    if "point_target" in report:
        pt = report["point_target"]
        for axis in ("slant_range", "along_track"):
            d = pt[axis]
            print(f"  {axis:>11}: IRW {_fmt(d['irw_m']['measured'], '.4g', ' m')} (theory {d['irw_m']['theory']:.4g}), "
                  f"PSLR {_fmt(d['pslr_db']['measured'], '.2f', ' dB')} ({d['pslr_db']['theory']:.2f}), "
                  f"ISLR {_fmt(d['islr_db']['measured'], '.2f', ' dB')} ({d['islr_db']['theory']:.2f})")
        if pt.get("measured_undefined"):
            print(f"  not measured ({pt['measured_undefined']}); metrics.json holds null")
    for f in report.get("files", []):
        print(f"  wrote {out / f}")
    return 0


def _progress(text: str) -> None:
    """What the command is doing, on stderr when that is a terminal (the results go to stdout)."""
    if sys.stderr.isatty():
        print(f"sarnav image: {text} ...", file=sys.stderr, flush=True)


def _fmt(value, spec: str, unit: str) -> str:
    """A measured figure, or ``n/a`` where it is undefined (None / NaN: metrics.json says why)."""
    import math

    if value is None or not math.isfinite(value):
        return "n/a"
    return f"{value:{spec}}{unit}"
