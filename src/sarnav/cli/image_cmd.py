"""``sarnav image SCENARIO|FILE.toml``: simulate one block of echoes, focus it (RDA or BPA, optional autofocus) and
write ``image.npz``, ``image.png`` and ``metrics.json`` to ``--out`` (default ``./sarnav-out/image-<scenario>/``).
Parses and prints only: the work is ``sarnav.scenarios.imaging.run_image``."""

from __future__ import annotations

import sys
from pathlib import Path

NAME = "image"
DEFAULT_OUT_ROOT = "sarnav-out"
DESCRIPTION = ("Simulate one block of echoes, focus it (RDA or BPA, optional autofocus) and write image.npz, "
               "image.png and metrics.json to --out (default ./sarnav-out/image-<scenario>/).")
ALGORITHMS = ("rda", "bpa")  # == sarnav.imaging.straight_block.ALGORITHMS (tested)
IMAGE_SCENARIOS = ("point-target", "scatterers")  # the registered scenarios of kind "image" (tested)


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(NAME, help="form one SAR image of a simulated scene", description=DESCRIPTION)
    p.add_argument("scenario", metavar="SCENARIO", help=f"{' | '.join(IMAGE_SCENARIOS)} or FILE.toml")
    p.add_argument("--algorithm", choices=ALGORITHMS, help="image formation (image.algorithm)")
    p.add_argument("--window", metavar="NAME", help="azimuth window: none, hamming, taylor, kaiser (image.window)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value (dotted key, TOML value), repeatable")
    p.add_argument("--out", help=f"output directory (default: ./{DEFAULT_OUT_ROOT}/image-<scenario>)")
    p.set_defaults(handler=run)


def run(args) -> int:
    from sarnav.errors import ConfigError
    from sarnav.scenarios.config import load_scenario
    from sarnav.scenarios.imaging import run_image

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
    report = run_image(cfg, out)
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
    return 0


def _fmt(value, spec: str, unit: str) -> str:
    """A measured figure, or ``n/a`` where it is undefined (None / NaN: metrics.json says why)."""
    import math

    if value is None or not math.isfinite(value):
        return "n/a"
    return f"{value:{spec}}{unit}"
