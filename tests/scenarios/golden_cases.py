"""Golden results of every scenario, recorded on the pre-restructure main (issue 8) and compared to 1e-7 (test_golden.py).

Each case runs a small version of a registered scenario through the public interface (the registry, the kind's
``simulate``, the ``sarnav`` command) and returns a flat dict name -> numpy array. ``tests/data/golden_<case>.npz``
holds what the code at commit af837a1 (before the restructuring) returned; ``test_golden.py`` checks that the
code today returns the same arrays.

Re-recorded since, each for an algorithm change its issue asked for (the other cases are still the pre-restructure
arrays):

* ``rda_nav_image``, ``rda_nav_image_fixed_scene_added_noise``, ``rda_nav_flexsar_image`` (issue 10): R from each
  image's predicted registration sigma, least-squares sub-pixel registration, the image focused with the estimated
  speed and its focusing shift modelled, innovation gate, receive window following the geometry.
  Again for issue 29 (f6cb414): the predicted registration sigma uses the gradient energy both images share and
  Rice-distributed magnitudes near the noise floor (R changes, the shifts do not; errors move by < 1e-3 relative).
  ``rda_nav_image`` again for issue 29 (2026-12-07): the mismatch test's gain is corrected for the template's noise
  (``imaging.registration.corrected_gain``); one update's kappa changed, its R with it (errors move by < 4e-5
  relative).
* ``image_point_target_bpa_hamming`` (issue 28, 2026-12-06): FFT upsampling of pulses whose length the FFT does
  slowly runs at ``next_fast_len`` with a cubic Hermite bridge from the last samples to the first
  (``imaging.kernels.upsample_pulses``): its 1e-5 relative change is the old wrap's interpolation error near the ends.
* ``telemetry``, ``telemetry_maneuver_consumer`` (issue 10, 8da02ea): the Gaussian-sum update with second-order terms
  is the telemetry default (at most 4e-4 m from the EKF where nothing is split).

Regenerate only when a result is *meant* to change (an algorithm change, stated in the commit):

    python tests/scenarios/golden_cases.py --write
"""

from __future__ import annotations

import hashlib
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parent.parent / "data"
#: result variables that measure wall time, not numbers (never compared)
TIMING = ("stage_seconds",)


def _records(cfg: dict, n: int, seed: int) -> dict:
    from sarnav.scenarios.registry import get_kind

    kind = get_kind(cfg["scenario"]["kind"])
    seeds = np.random.SeedSequence(seed).spawn(n)
    recs = kind.simulate(cfg, list(range(n)), seeds)
    out = {}
    for name in ("time", "error", "sigma", "nees", "update_time", "residual", "residual_sigma", "nis", "nis_dof"):
        out[name] = np.stack([np.asarray(getattr(r, name)) for r in recs])
    for name in recs[0].extras:
        if name not in TIMING:
            out[f"extra.{name}"] = np.stack([np.asarray(r.extras[name][1]) for r in recs])
    return out


def _scenario(name: str, **sets) -> dict:
    from sarnav.scenarios.registry import get_scenario

    cfg = get_scenario(name)
    for key, value in sets.items():
        table, _, leaf = key.partition("__")
        cfg[table][leaf] = value
    return cfg


def telemetry() -> dict:
    return _records(_scenario("telemetry", trajectory__duration=5.0), 3, 11)


def telemetry_maneuver_consumer() -> dict:
    return _records(_scenario("telemetry", trajectory__duration=5.0, trajectory__type="maneuver",
                              imu__grade="consumer"), 2, 12)


def rda_nav_oracle() -> dict:
    return _records(_scenario("rda-nav", trajectory__duration=4.0, sar__measurement="oracle"), 2, 13)


def rda_nav_oracle_paper_model() -> dict:
    return _records(_scenario("rda-nav", trajectory__duration=3.0, sar__measurement="oracle",
                              sar__cross_range_model="paper", sar__second_order=False), 2, 14)


def rda_nav_altimeter_only() -> dict:
    return _records(_scenario("rda-nav", trajectory__duration=4.0, sar__enabled=False), 2, 15)


def rda_nav_image() -> dict:
    return _records(_scenario("rda-nav", trajectory__duration=3.0), 2, 16)


def rda_nav_image_fixed_scene_added_noise() -> dict:
    return _records(_scenario("rda-nav", trajectory__duration=2.0, scene__clutter_per_run=False,
                              sar__image_added_noise=True, sar__delayed_state=False), 2, 17)


def rda_nav_flexsar_image() -> dict:
    return _records(_scenario("rda-nav-flexsar", trajectory__duration=2.0), 1, 18)


def rda_nav_covariance() -> dict:
    from sarnav.scenarios import rda_nav as rn
    from sarnav.scenarios.rda_nav import covariance_study

    prm = rn.parse(_scenario("rda-nav", trajectory__duration=5.0))
    a = covariance_study(prm, 0.25, 0.25)
    b = covariance_study(prm, 0.01, 0.03, ground_ranges=[1700.0, 1900.0], cross_model="paper")
    return {"time": a["time"], "sigma": a["sigma"], "sigma_two_targets_paper": b["sigma"]}


def _cli(argv: list[str]) -> int:
    from sarnav.cli.main import main

    return main(argv)


def _image(name: str, *sets: str) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        argv = ["image", name, "--out", tmp]
        for s in sets:
            argv += ["--set", s]
        assert _cli(argv) == 0
        z = np.load(Path(tmp) / "image.npz")
        out = {f"image.{k}": z[k] for k in ("data", "y", "x")}
        metrics = json.loads((Path(tmp) / "metrics.json").read_text())
    out["metrics_json"] = np.frombuffer(json.dumps(metrics, sort_keys=True).encode(), dtype=np.uint8)
    return out


def image_point_target_rda() -> dict:
    return _image("point-target", "image.margin_m=2.0")


def image_point_target_bpa_hamming() -> dict:
    return _image("point-target", "image.margin_m=2.0", "image.algorithm=\"bpa\"", "image.window=\"hamming\"",
                  "scene.target_slant_range_m=1995.0")


def image_scatterers_mapdrift() -> dict:
    return _image("scatterers", "image.autofocus=\"mapdrift\"", "image.speed_error_mps=0.5", "radar.snr_db=10.0")


def image_point_target_contrast() -> dict:
    return _image("point-target", "image.margin_m=2.0", "image.autofocus=\"contrast\"", "image.speed_error_mps=-0.4")


def bpa_sensitivity() -> dict:
    from sarnav.analysis.bpa_sensitivity import CSV_FIELDS
    from sarnav.scenarios import bpa_sensitivity as bs

    cfg = _scenario("bpa-sensitivity")
    cfg["errors"] = {k: cfg["errors"][k] for k in ("position_cross", "velocity_along", "yaw")}
    results, ref = bs.study(cfg)
    out = {"reference": ref.data}
    for r in results:
        for f in CSV_FIELDS[1:]:
            if f != "unit":
                out[f"{r.name}.{f}"] = np.asarray(getattr(r, f))
        out[f"{r.name}.image"] = r.image.data
    return out


CASES = {f.__name__: f for f in (
    telemetry, telemetry_maneuver_consumer, rda_nav_oracle, rda_nav_oracle_paper_model, rda_nav_altimeter_only,
    rda_nav_image, rda_nav_image_fixed_scene_added_noise, rda_nav_flexsar_image, rda_nav_covariance,
    image_point_target_rda, image_point_target_bpa_hamming, image_scatterers_mapdrift, image_point_target_contrast,
    bpa_sensitivity,
)}


def path(case: str) -> Path:
    return DATA / f"golden_{case}.npz"


def platform() -> dict:
    """The numerical environment the goldens were made in (exact comparison needs the same one)."""
    import platform as pf

    import numba
    import scipy
    from threadpoolctl import threadpool_info

    blas = sorted({f"{i.get('internal_api')}:{i.get('version')}:{i.get('architecture')}" for i in threadpool_info()
                   if i.get("user_api") == "blas"})
    return {"numpy": np.__version__, "scipy": scipy.__version__, "numba": numba.__version__,
            "machine": pf.machine(), "blas": blas}


def digest(arrays: dict) -> str:
    h = hashlib.sha256()
    for k in sorted(arrays):
        h.update(k.encode())
        h.update(np.ascontiguousarray(arrays[k]).tobytes())
    return h.hexdigest()


#: arrays with more elements than this are stored as a SHA-256 digest plus a chip around their peak
LARGE = 20000
CHIP = 24


def _chip(a: np.ndarray) -> np.ndarray:
    """The (2 CHIP + 1)^2 chip of a 2-D array around its largest magnitude (the chip is clipped at the edges)."""
    i, j = np.unravel_index(int(np.argmax(np.abs(a))), a.shape)
    return a[max(i - CHIP, 0):i + CHIP + 1, max(j - CHIP, 0):j + CHIP + 1]


def compact(arrays: dict) -> dict:
    """What is stored: small arrays whole; a large one as ``NAME.sha256`` (bytes of its digest), ``NAME.chip``
    (around its peak) and ``NAME.abs_sum``."""
    out = {}
    for k, a in arrays.items():
        a = np.asarray(a)
        if a.size <= LARGE:
            out[k] = a
            continue
        out[f"{k}.sha256"] = np.frombuffer(hashlib.sha256(np.ascontiguousarray(a).tobytes()).digest(), np.uint8)
        out[f"{k}.chip"] = _chip(a) if a.ndim == 2 else a.ravel()[:CHIP]
        out[f"{k}.abs_sum"] = np.asarray(np.sum(np.abs(a)))
    return out


def write(cases=None) -> None:
    DATA.mkdir(exist_ok=True)
    for name in cases or CASES:
        arrays = CASES[name]()
        np.savez_compressed(path(name), **compact(arrays))
        print(f"{name}: {len(arrays)} arrays, sha256 {digest(arrays)[:16]}")
    (DATA / "golden_platform.json").write_text(json.dumps(platform(), indent=2) + "\n")


if __name__ == "__main__":
    if "--write" not in sys.argv:
        sys.exit("usage: python tests/scenarios/golden_cases.py --write [CASE ...]")
    write([a for a in sys.argv[1:] if a != "--write"])
