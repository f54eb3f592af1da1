"""The rda-nav figure extras (issue 4 items 3, 4, 7): the first run's sub-aperture images and the
position 3-sigma with and without SAR. Capturing images must not change the run."""

import numpy as np
import xarray as xr

from sarnav.cli.main import main
from sarnav.montecarlo.seeding import run_seeds
from sarnav.scenarios import rda_nav as rn
from sarnav.scenarios.rda_nav import RdaNavKind
from sarnav.scenarios.registry import get_scenario
from sarnav.simulation import rda_nav as rda_sim


def _short_cfg():
    cfg = get_scenario("rda-nav")
    cfg["campaign"]["runs"] = 2
    cfg["trajectory"]["duration"] = 6.0
    return cfg


def test_capture_keeps_the_run_bit_identical_and_holds_the_images():
    cfg = _short_cfg()
    seed0 = run_seeds(cfg["campaign"]["seed"], 2)[0]
    plain = RdaNavKind().simulate(cfg, [0], [seed0])[0]
    records, rec = rda_sim._simulate(rn.parse(cfg), [0], [seed0], capture_aperture=3)
    np.testing.assert_array_equal(plain.error, records[0].error)
    np.testing.assert_array_equal(plain.residual, records[0].residual)
    cap = rec["capture"]
    assert cap["aperture"] == 3 and cap["used"] in ("mapdrift", "estimate")
    for key in ("reference", "before", "after"):
        assert cap[key].data.ndim == 2 and np.all(np.isfinite(cap[key].data))
    surface, ly, lx = cap["correlation"]
    assert surface.shape == (ly.size, lx.size)


def test_campaign_writes_image_and_ablation_figures(tmp_path):
    cfg_path = tmp_path / "short.toml"
    from sarnav.tomlio import dump_toml

    cfg_path.write_text(dump_toml(_short_cfg()))
    out = tmp_path / "out"
    assert main(["run", str(cfg_path), "--out", str(out), "--executor", "serial", "--quiet"]) == 0
    figs = out / "figures"
    assert (figs / "sar_images_run0.png").stat().st_size > 10_000
    assert (figs / "position_3sigma_with_without_sar.png").stat().st_size > 10_000
    ds = xr.open_dataset(out / "results.nc")
    assert ds.attrs["complete"] in (1, True, "true", "True")


def test_the_figure_functions_draw_their_inputs(tmp_path, monkeypatch):
    """``report.rda_nav_figures`` on its own: the ablation plot's curves are 3 sigma of the input, the image grid
    shows each image in dB re its peak (floor -40 dB); both write a PNG."""
    from sarnav.report import rda_nav_figures as rf
    from sarnav.signal.data import SarImage

    saved = {}
    real = rf.save_png
    monkeypatch.setattr(rf, "save_png", lambda fig, path: saved.setdefault("fig", fig) and real(fig, path))
    t = np.linspace(0.0, 5.0, 6)
    s_with, s_without = np.full((6, 3), 0.5), np.outer(np.arange(1, 7), [1.0, 2.0, 3.0])
    out = rf.plot_sar_ablation(t, s_with, t, s_without, tmp_path / "ablation.png")
    assert (tmp_path / "ablation.png").stat().st_size > 1000 and str(out).endswith("ablation.png")
    for i, ax in enumerate(saved.pop("fig").axes):
        a, b = ax.get_lines()[:2]
        np.testing.assert_allclose(a.get_ydata(), 3 * s_with[:, i])
        np.testing.assert_allclose(b.get_ydata(), 3 * s_without[:, i])
    amp = np.zeros((4, 5), complex)
    amp[1, 2], amp[3, 4] = 10.0, 1e-4  # 0 dB and -100 dB (floored at -40)
    img = SarImage(amp, np.arange(4.0), 100.0 + np.arange(5.0))
    cap = {"reference": img, "before": img, "after": img, "correlation": (np.ones((3, 3)), np.arange(3.0),
           np.arange(3.0)), "run": 0, "aperture": 2, "speed_hat": 10.0, "autofocus_speed": 10.01, "used": "mapdrift"}
    rf.plot_aperture_images(cap, tmp_path / "images.png")
    shown = saved["fig"].axes[0].get_images()[0].get_array()
    assert shown[1, 2] == 0.0 and shown[3, 4] == -40.0 and shown.min() == -40.0
