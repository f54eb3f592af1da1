"""``sarnav image SCENARIO|FILE.toml``: simulate one block of echoes, focus it (RDA or BPA, optional
autofocus) and write ``image.npz``, ``image.png`` and ``metrics.json`` to ``--out``
(default ``./sarnav-out/image-<scenario>/``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

NAME = "image"
DEFAULT_OUT_ROOT = "sarnav-out"
DESCRIPTION = ("Simulate one block of echoes, focus it (RDA or BPA, optional autofocus) and write image.npz, "
               "image.png and metrics.json to --out (default ./sarnav-out/image-<scenario>/).")
#: dynamic range of the PNG [dB below the peak]
PNG_DYNAMIC_RANGE_DB = 50.0


def add_parser(subparsers) -> None:
    from sarnav.scenarios.imaging import ALGORITHMS, IMAGE_SCENARIOS

    p = subparsers.add_parser(NAME, help="form one SAR image of a simulated scene", description=DESCRIPTION)
    p.add_argument("scenario", metavar="SCENARIO", help=f"{' | '.join(IMAGE_SCENARIOS)} or FILE.toml")
    p.add_argument("--algorithm", choices=ALGORITHMS, help="image formation (image.algorithm)")
    p.add_argument("--window", metavar="NAME", help="azimuth window: none, hamming, taylor, kaiser (image.window)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value (dotted key, TOML value), repeatable")
    p.add_argument("--out", help=f"output directory (default: ./{DEFAULT_OUT_ROOT}/image-<scenario>)")
    p.set_defaults(handler=run)


def _form_image(cfg, rc, sc, params):
    """Focus ``rc`` as the configuration says; returns (SarImage, autofocus dict or None)."""
    from sarnav.imaging.autofocus import contrast_autofocus, mapdrift
    from sarnav.imaging.rda import range_doppler
    from sarnav.signal.windows import as_window

    im = cfg["image"]
    v_true = float(cfg["trajectory"]["speed_mps"])
    v_hat = v_true + float(im["speed_error_mps"])
    centre = np.array([0.0, 0.0, -float(cfg["trajectory"]["altitude_m"])])
    # the processor's trajectory: the true straight line flown at the (possibly wrong) speed estimate
    est = rc.with_positions(centre + np.outer(rc.pulse_times, [v_hat, 0.0, 0.0]))
    if im["algorithm"] == "bpa":
        from sarnav.imaging.backprojection import backproject
        from sarnav.imaging.grid import SlantGrid

        w = as_window(im["window"], "image.window")
        if w.name != "none":  # same slow-time weighting as the RDA (rda module docstring)
            est = est.__class__(**{**est.__dict__, "data": est.data * w.samples(est.n_pulses)[:, None]})
        side = 1.0 if cfg["radar"]["look_side"] == "right" else -1.0
        grid = SlantGrid(origin=centre, direction=[1.0, 0.0, 0.0], look_point=[0.0, side * 1e3, 0.0],
                         along_track=v_hat * rc.pulse_times, slant_range=rc.slant_range)
        img = backproject(est, grid, interpolation=im["bpa_interpolation"])
        img.metadata.update({"window": w.label, "speed": v_hat, "prf": params.prf,
                             "carrier_frequency": params.carrier_frequency, "bandwidth": params.bandwidth,
                             "aperture_length": v_hat * rc.n_pulses / params.prf,
                             "closest_approach_range": float(0.5 * (rc.slant_range[0] + rc.slant_range[-1]))})
        return img, None
    kw = dict(window=im["window"], rcmc_kernel=im["rcmc_kernel"], azimuth_model=im["azimuth_model"],
              along_track_origin=centre)
    if im["autofocus"] == "mapdrift":
        res = mapdrift(est, v_hat, **kw)
        af = {"method": "mapdrift", "speed_in": v_hat, "speed_estimate": res.speed,
              "fm_rate_error_hz_per_s": res.fm_rate_error, "iterations": res.iterations,
              "misregistration_s": res.misregistration}
        return res.image, af
    if im["autofocus"] == "contrast":
        res = contrast_autofocus(est, v_hat, **kw)
        af = {"method": "contrast(normalised_variance)", "speed_in": v_hat, "speed_estimate": res.speed,
              "fm_rate_error_hz_per_s": res.fm_rate_error, "evaluations": len(res.evaluations[0])}
        return res.image, af
    return range_doppler(est, v_hat, **kw), None


def _point_metrics(cfg, img, params) -> dict:
    """Measured point-target figures beside their theoretical values."""
    from sarnav.signal import metrics
    from sarnav.signal.metrics import irf_theory
    from sarnav.units import C

    s = cfg["scene"]
    y_t, r0 = float(s["target_along_track_m"]), float(s["target_slant_range_m"])
    m = metrics.point_target_metrics(img, near=(y_t, r0), half_width=48, n_sidelobes=10)
    v = float(cfg["trajectory"]["speed_mps"])
    aperture = v * float(cfg["trajectory"]["duration_s"])
    th_r = irf_theory(cfg["radar"]["range_window"])
    th_a = irf_theory(cfg["image"]["window"])
    theory = {
        "x": {"irw_m": th_r.irw_factor * C / (2.0 * params.bandwidth), "pslr_db": th_r.pslr_db, "islr_db": th_r.islr_db},
        "y": {"irw_m": th_a.irw_factor * params.wavelength * r0 / (2.0 * aperture), "pslr_db": th_a.pslr_db,
              "islr_db": th_a.islr_db},
    }
    out = {"target": {"along_track_m": y_t, "slant_range_m": r0},
           "note": "theory: uniform illumination over the whole block (0.886 c/2B, 0.886 lambda R0 / 2L, L = V T) "
                   "with the window factors of sarnav.signal.metrics.irf_theory; ISLR with 10 sidelobes"}
    for ax, name in (("x", "slant_range"), ("y", "along_track")):
        out[name] = {k: {"measured": m[ax][k], "theory": theory[ax][k]} for k in ("irw_m", "pslr_db", "islr_db")}
    out["peak_position_m"] = {"measured": list(m["peak_position"]), "true": [y_t, r0]}
    out["peak_error_cells"] = [(m["peak_position"][0] - y_t) / img.dy, (m["peak_position"][1] - r0) / img.dx]
    return out


def _write_png(img, path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sarnav.units import amplitude_to_db

    mag = np.abs(img.data)
    db = amplitude_to_db(np.maximum(mag, mag.max() * 10 ** (-PNG_DYNAMIC_RANGE_DB / 20) * 1e-3) / mag.max())
    fig, ax = plt.subplots(figsize=(7, 5), dpi=110)
    extent = [img.x[0], img.x[-1], img.y[0], img.y[-1]]
    h = ax.imshow(db, origin="lower", aspect="auto", extent=extent, cmap="gray", vmin=-PNG_DYNAMIC_RANGE_DB, vmax=0)
    ax.set_xlabel(f"{img.x_name.replace('_', ' ')} [m]")
    ax.set_ylabel(f"{img.y_name.replace('_', ' ')} [m]")
    ax.set_title(title)
    fig.colorbar(h, ax=ax, label="amplitude [dB re peak]")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _json_safe(obj):
    if isinstance(obj, dict):
        return {str(k): _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


def run(args) -> int:
    from sarnav.errors import ConfigError
    from sarnav.imaging import quality
    from sarnav.scenarios.imaging import build_pulses, load_image_scenario

    overrides = list(args.overrides)
    if args.algorithm:
        overrides.append(f"image.algorithm={args.algorithm}")
    if args.window:
        overrides.append(f"image.window={args.window}")
    cfg = load_image_scenario(args.scenario, overrides)
    name = cfg["scenario"]["name"] or Path(str(args.scenario)).stem
    out = Path(args.out) if args.out else Path(DEFAULT_OUT_ROOT) / f"image-{name}"
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:  # one line like ``sarnav run --out``
        raise ConfigError("--out", f"cannot create output directory {str(out)!r}: {err.strerror}") from None

    rc, sc, params = build_pulses(cfg)
    img, af = _form_image(cfg, rc, sc, params)
    meta = _json_safe(dict(img.metadata))
    meta.setdefault("wavelength", params.wavelength)
    np.savez_compressed(
        out / "image.npz", data=img.data, y=img.y, x=img.x, y_name=img.y_name, x_name=img.x_name,
        carrier_frequency=params.carrier_frequency, bandwidth=params.bandwidth, prf=params.prf,
        speed=float(meta.get("speed", cfg["trajectory"]["speed_mps"])),
        closest_approach_range=float(meta.get("closest_approach_range", np.nan)),
        aperture_length=float(meta.get("aperture_length", np.nan)),
        metadata_json=json.dumps(meta), scenario_toml=_toml(cfg),
    )
    report = {"scenario": cfg["scenario"]["name"], "algorithm": cfg["image"]["algorithm"],
              "n_targets": int(sc.n_targets), "image_shape": list(img.shape),
              "pixel_spacing_m": {"along_track": img.dy, "slant_range": img.dx},
              "quality": {"normalised_kurtosis": quality.normalised_complex_kurtosis(img.data),
                          "entropy_magnitude_100": quality.entropy_magnitude(img.data, 100),
                          "normalised_variance": quality.normalised_variance(img.data)}}
    if af is not None:
        af["speed_true"] = float(cfg["trajectory"]["speed_mps"])
        report["autofocus"] = af
    if cfg["scene"]["type"] == "point":
        report["point_target"] = _point_metrics(cfg, img, params)
    (out / "metrics.json").write_text(json.dumps(_json_safe(report), indent=2) + "\n")
    _write_png(img, out / "image.png", f"{name}: {cfg['image']['algorithm'].upper()}, window {meta.get('window', '')}")
    print(f"{name}: {cfg['image']['algorithm']} image {img.shape[0]}x{img.shape[1]} -> {out}")
    if "point_target" in report:
        pt = report["point_target"]
        for axis in ("slant_range", "along_track"):
            d = pt[axis]
            print(f"  {axis:>11}: IRW {d['irw_m']['measured']:.4g} m (theory {d['irw_m']['theory']:.4g}), "
                  f"PSLR {d['pslr_db']['measured']:.2f} dB ({d['pslr_db']['theory']:.2f}), "
                  f"ISLR {d['islr_db']['measured']:.2f} dB ({d['islr_db']['theory']:.2f})")
    return 0


def _toml(cfg) -> str:
    from sarnav.tomlio import dump_toml

    return dump_toml(cfg)
