"""``measurements.sar_image.SubApertureImager`` on its own (not through a scenario): one reflector beside a straight,
level track at the rda-nav paper geometry (9.75 GHz, 500 MHz, PRF 100 Hz, 10 m/s, 1000 m altitude, ground range
1800 m; docs/scenarios/rda-nav.md §1), no clutter, so the registration is limited by receiver noise alone.

Every expectation comes from geometry computed here with numpy, not from the imager: on a straight north track
p(t) = (V t, 0, -H) a target at (n, e, 0) has its closest approach at t = n / V and range sqrt(e^2 + H^2). The TOC and
range the imager measures come from radar timing only (the module docstring), so

* (a) along the truth they equal that geometry within a few of the imager's own predicted sigmas;
* (b) a rigid offset of the estimated track (along, across, up) does not move them (what moves is the prediction a
  filter makes from the offset track, i.e. the innovation, by the geometric amount); a speed error of the focusing
  moves the along-track registration of a target off the aperture centre by 2 (eta0 - eta_c) (V - V_hat) (a
  mismatched azimuth FM rate: the deramped chirp's linear term), which is also the slope the imager measures by
  refocusing (docs §2);
* (c) failures carry the status codes of ``FAILURES``;
* (d) the predicted sigma falls as 1 / sqrt(SNR) (6 dB more SNR halves it) with noise as the only error source.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.measurements.sar_image import FAILURES, AperturePasses, ImagingSettings
from sarnav.radar.presets import nav_paper_sim
from sarnav.radar.scene import point_targets
from sarnav.simulation.sar_echoes import simulated_imager
from sarnav.trajectory.straight import StraightLevel

V, H, G = 10.0, 1000.0, 1800.0  # speed [m/s], altitude [m], ground range of the reflector [m]
R0 = float(np.hypot(G, H))  # its range of closest approach [m]
U = 1  # the sub-aperture imaged: pulses 1.00 ... 1.99 s
TOC = 1.3  # the reflector's TOC [s]: 0.2 s before the aperture centre (inside rda-nav's +-0.25 s jitter)
TARGET = np.array([V * TOC, G, 0.0])  # right of a north track
AMPLITUDE, SNR_DB = 3.16, -10.0  # rda-nav's defaults (scene.reflector_amplitude, radar.snr_db)
# a receive window of +-110 m around R0 (the pulse's half-extent c T / 4 = 75 m, the search window and the offsets)
RADAR = nav_paper_sim(near_range=R0 - 110.0, n_range_samples=int(220.0 / 0.15))
TRUTH = StraightLevel([0.0, 0.0, -H], V, 0.0, 3.0)
AP_T = U + np.linspace(0.0, 1.0, 21)  # the epochs of the estimated track over the aperture


def _imager(runs, algorithm="rda", snr_db=SNR_DB, per_run_reference=False, **settings):
    scene = point_targets(TARGET, AMPLITUDE)
    seeds = list(range(100, 100 + runs))
    clutter_seeds = [s + 100 for s in seeds] if per_run_reference else None  # per run: its own reference noise
    return simulated_imager(RADAR, TRUTH, np.broadcast_to(TARGET, (3, 1, 3)),
                             lambda u, s: AperturePasses(scene, scene), AMPLITUDE, snr_db, 7, seeds,
                             clutter_seeds=clutter_seeds, settings=ImagingSettings(algorithm=algorithm, **settings))


def _track(runs, offset=(0.0, 0.0, 0.0), dv=0.0):
    """(p, v) (runs, K, 3) of an estimated track: the truth moved by ``offset`` [m] (NED), its speed V + dv with the
    same position at the aperture centre."""
    s = TRUTH.state(AP_T)
    p = s.position + np.asarray(offset) + dv * (AP_T - (U + 0.5))[:, None] * np.array([1.0, 0.0, 0.0])
    v = s.velocity * (1.0 + dv / V)
    return np.repeat(p[None], runs, 0), np.repeat(v[None], runs, 0)


def _along_error(m):
    """(R,) along-track registration error [m]: V (TOC - TOC_true), less the modelled focusing shift (speed = V)."""
    return V * (m.toc[:, 0] - TOC) - np.nan_to_num(m.focus_offset[:, 0])


@pytest.mark.parametrize("algorithm", ["rda", "bpa"])
def test_truth_track_measures_the_geometric_toc_and_range_within_the_predicted_sigma(algorithm):
    """(a) Estimate = truth, each run its own reference and in-flight noise: every range within 4 sigma of
    sqrt(G^2 + H^2), every TOC within 4 sigma of n / V (times V), and the rms of error / sigma of the runs is of
    order one (not a sigma a hundred times too large either)."""
    runs = 5 if algorithm == "rda" else 3
    m = _imager(runs, algorithm, per_run_reference=True, autofocus=False).measure(U, AP_T, *_track(runs))
    assert np.all(m.status == 0), [FAILURES[s] for s in m.status.ravel()]
    e = np.stack([m.range[:, 0] - R0, _along_error(m)], axis=1) / m.sigma[:, 0]
    assert np.all(np.abs(e) < 4.0), e
    rms = np.sqrt(np.mean(e**2, axis=0))
    assert np.all((rms > 0.3) & (rms < 2.0)), rms
    assert np.all(m.quality[:, 0] > 0.9)  # one clean reflector: the chip matches
    assert np.allclose(m.lever[:, 0], m.toc[:, 0] - (U + 0.495), atol=1e-12)  # TOC minus the centre of pulses 0..99


@pytest.fixture(scope="module", params=["rda", "bpa"])
def offsets(request):
    """(algorithm, imager, measurement along the truth) of one run (the scene's echoes cached)."""
    im = _imager(1, request.param, autofocus=False)
    return request.param, im, im.measure(U, AP_T, *_track(1))


@pytest.mark.parametrize("offset", [(3.0, 0.0, 0.0), (0.0, 4.0, 0.0), (0.0, 0.0, 2.0)],
                         ids=["along 3 m", "across 4 m", "down 2 m"])
def test_rigid_offset_of_the_estimated_track_leaves_toc_and_range_and_shows_in_the_innovation(offsets, offset):
    """(b) The estimated track moved rigidly by ``offset``: the measured TOC and range stay those along the truth
    (within a quarter sigma; the same noise), so the innovations a filter forms from the offset track, range
    measured - |target - p_hat(TOC)| and along-track 0 - (target - p_hat(TOC)) . north, are the geometric ones."""
    algorithm, im, ref = offsets
    m = im.measure(U, AP_T, *_track(1, offset))
    assert np.all(m.status == 0)
    assert np.all(np.abs(m.range - ref.range) < 0.25 * ref.sigma[..., 0])
    assert np.all(np.abs(V * (m.toc - ref.toc)) < 0.25 * ref.sigma[..., 1])
    d = np.asarray(offset)
    p_hat = np.array([[V * t, 0.0, -H] for t in m.toc[:, 0]]) + d
    innovation_range = m.range[:, 0] - np.linalg.norm(TARGET - p_hat, axis=1)
    geometric = R0 - np.linalg.norm(TARGET - (np.array([V * TOC, 0.0, -H]) + d))
    assert np.all(np.abs(innovation_range - geometric) < 4.0 * m.sigma[:, 0, 0])
    innovation_along = -(TARGET - p_hat)[:, 0]
    assert np.all(np.abs(innovation_along - d[0]) < 4.0 * m.sigma[:, 0, 1] + np.abs(m.focus_offset[:, 0]))


def test_speed_error_moves_the_along_track_registration_by_twice_the_toc_lever(offsets):
    """(b) Focused with V_hat = V + dv (same centre position): the along-track registration moves by
    2 (eta0 - eta_c) (V - V_hat) (eta0 - eta_c = -0.2 s: +8 cm for dv = 0.2 m/s, several sigmas) within 15 %, the
    range not at all (within sigma), and the imager's measured sensitivity is -2 (eta0 - eta_c) within 15 %."""
    algorithm, im, ref = offsets
    dv, lever = 0.2, TOC - (U + 0.5)
    m = im.measure(U, AP_T, *_track(1, dv=dv))
    assert np.all(m.status == 0)
    assert np.allclose(m.speed, V + dv)
    shift = V * (m.toc[:, 0] - ref.toc[:, 0])
    assert shift == pytest.approx(np.full(1, 2.0 * lever * -dv), rel=0.15)
    assert m.sensitivity[:, 0] == pytest.approx(np.full(1, -2.0 * lever), rel=0.15)
    assert np.all(np.abs(m.range - ref.range) < ref.sigma[..., 0])


@pytest.fixture(scope="module")
def shared():
    """An RDA imager of one run (the scene's echoes cached), without autofocus."""
    return _imager(1, autofocus=False)


def test_status_weak_and_ambiguous_match(shared):
    """(c) The same match judged by stricter thresholds: its correlation below ``min_correlation`` is status 3, the
    best other match above ``max_ambiguity`` status 4 (the numbers are still reported)."""
    base = shared.measure(U, AP_T, *_track(1))
    assert np.all(base.status == 0)
    weak = _imager(1, autofocus=False, min_correlation=float(base.quality.max()) + 1e-4).measure(U, AP_T, *_track(1))
    assert FAILURES.index("weak match (correlation)") == 3 and np.all(weak.status == 3)
    ambiguous = _imager(1, autofocus=False, max_ambiguity=float(base.ambiguity.min()) - 1e-4).measure(
        U, AP_T, *_track(1))
    assert FAILURES.index("ambiguous match") == 4 and np.all(ambiguous.status == 4)
    assert np.allclose(weak.toc, base.toc) and np.allclose(ambiguous.range, base.range)


def test_status_target_outside_the_image(shared):
    """(c) The map puts the target 40 m further out (slant range +35 m, beyond the +-12 m search window): the chip is
    not in the image, its correlation falls below 0.5, status 3. 400 m out the window leaves the receive window:
    no image, status 1 and NaN."""
    p, v = _track(1)
    out = shared.measure(U, AP_T, p, v, map_targets=np.broadcast_to(TARGET + [0.0, 40.0, 0.0], (1, 1, 3)))
    assert np.all(out.status == FAILURES.index("weak match (correlation)"))
    assert np.all(out.quality < 0.5)
    gone = shared.measure(U, AP_T, p, v, map_targets=np.broadcast_to(TARGET + [0.0, 400.0, 0.0], (1, 1, 3)))
    assert FAILURES.index("image formation or autofocus failed") == 1 and np.all(gone.status == 1)
    assert np.all(np.isnan(gone.toc) & np.isnan(gone.range))


def test_status_bpa_search_beyond_its_limit():
    """(c) BPA: a filter along-track sigma of 100 m asks for a +-300 m search grid, beyond MAX_BPA_HALF_ALONG_M:
    status 1, no measurement (nothing is formed, so this is fast)."""
    im = _imager(1, "bpa")
    m = im.measure(U, AP_T, *_track(1), along_sigma=np.array([100.0]))
    assert m.status[0, 0] == 1 and np.isnan(m.toc[0, 0])


def test_bad_inputs_are_one_line_errors_naming_the_field(shared):
    p, v = _track(3)
    with pytest.raises(InputDataError, match="^source"):
        shared.measure(U, AP_T, p, v)  # three runs, a source of one
    with pytest.raises(InputDataError, match="targets"):
        simulated_imager(RADAR, TRUTH, np.zeros((2, 1, 2)), None, 1.0, 0.0, 0, [1])
    with pytest.raises(InputDataError, match="clutter_seeds"):
        simulated_imager(RADAR, TRUTH, np.zeros((2, 1, 3)), None, 1.0, 0.0, 0, [1, 2], clutter_seeds=[1])
    with pytest.raises(ConfigError, match="sar.algorithm"):
        ImagingSettings(algorithm="omega-k")
    with pytest.raises(ConfigError, match="sar.focus"):
        ImagingSettings(algorithm="bpa", focus="mapdrift")
    for bad in (0, 9, 1.5, True):
        with pytest.raises(ConfigError, match=r"^range_lattices: must be an integer in \[1, 8\]"):
            ImagingSettings(algorithm="bpa", range_lattices=bad)


@pytest.mark.parametrize("algorithm", ["rda", "bpa"])
def test_predicted_sigma_halves_with_6_db_more_snr(algorithm):
    """(d) Noise the only error source: sigma ~ 1 / sqrt(SNR), so +6 dB gives 10^(-6/20) = 0.50 x (0.42-0.60 for
    both components: a loose bound; RDA without the focus-sensitivity term, which is not noise)."""
    kw = dict(autofocus=False, focus="mapdrift") if algorithm == "rda" else {}
    sig = [_imager(1, algorithm, snr, **kw).measure(U, AP_T, *_track(1)).sigma[:, 0] for snr in (SNR_DB, SNR_DB + 6)]
    ratio = sig[1] / sig[0]
    assert np.all((ratio > 0.42) & (ratio < 0.60)), ratio
