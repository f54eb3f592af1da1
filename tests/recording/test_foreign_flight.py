"""``sarnav navigate`` on recordings written by other software (``foreign_flight``: numpy, sarkit and csv only,
following docs/recording.md): a jittered IMU with dropped samples and a 0.5-s gap, clocks offset from the recording
time, GNSS for the first 5 s, CPHD apertures and an earlier pass as reference (a) or a GeoTIFF orthoimage as (b).

Issue 26's claim: NEES and NIS inside their 95 % bands over 20 recordings of different seeds, final position errors
inside 3 sigma (``-m slow``: ``pytest -m slow tests/recording/test_foreign_flight.py``, ~10 min on 2 cores; the
default run navigates one recording and checks its timeline, its gap, its GNSS start and its consistency), with
reference (a), the reference pass as CPHD, and reference (b), a GeoTIFF orthoimage tile per aperture.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from foreign_flight import GNSS_SIGMA, IMU_RATE, ForeignFlight  # noqa: E402

from sarnav.analysis.consistency import nees_statistics, nis_statistics  # noqa: E402
from sarnav.cli.main import main  # noqa: E402
from sarnav.errors import InputDataError  # noqa: E402
from sarnav.recording import read_recording  # noqa: E402
from sarnav.recording.navigate import navigate  # noqa: E402
from sarnav.recording.timeline import gap_noise, plan_flight  # noqa: E402
from sarnav.report.navigate_files import truth_errors  # noqa: E402
from sarnav.scenarios.navigate import read_navigate_settings  # noqa: E402


@pytest.fixture(scope="module")
def one(tmp_path_factory):
    root = tmp_path_factory.mktemp("foreign")
    flight = ForeignFlight(7, duration=10)
    flight.write(root / "rec")
    assert main(["navigate", str(root / "rec"), "--out", str(root / "out"), "--quiet"]) == 0
    rec = read_recording(root / "rec")
    nav = navigate(rec, read_navigate_settings(rec))
    return root, flight, rec, nav


def test_timeline_follows_time_through_jitter_drops_and_the_gap(one):
    _, flight, rec, nav = one
    plan = nav.plan
    t, _, _ = rec.imu.rates()
    assert plan.n_updates == 10 and not plan.uniform
    ends = np.array([t[b[-1]] for b in plan.bounds])
    # each update at the sample of its whole second (+- 10 % jitter of a 10-ms interval; the IMU clock's offset is
    # taken out by the reader), whatever the drops before it
    np.testing.assert_allclose(ends, np.arange(1, 11), atol=0.1 / IMU_RATE + 1e-12)
    assert len(plan.gaps) == 1 and abs(plan.gaps[0].time - 7.2) < 0.02 and 0.49 < plan.gaps[0].seconds < 0.53
    assert any("IMU gap of" in n for n in nav.notices)
    # every aperture planned and imaged, GNSS fixed at 1..5 s, the altimeter at every update
    assert list(plan.aperture) == list(range(10)) and not plan.skipped
    assert [g["time"] for g in nav.gnss] == pytest.approx([1, 2, 3, 4, 5], abs=1e-3)
    assert np.all(plan.altimeter >= 0)


def test_gnss_start_and_update(one):
    """The initial position and velocity are the GNSS fix at t = 0 with its 1-sigma (the manifest leaves them out);
    each GNSS update's residual sigma is at least the fix's own."""
    _, flight, rec, nav = one
    est = nav.estimate()
    np.testing.assert_array_equal(est["p"][0], flight.gnss_p[0])
    np.testing.assert_array_equal(est["v"][0], flight.gnss_v[0])
    np.testing.assert_allclose(est["sigma"][0, 0:3], GNSS_SIGMA, rtol=1e-12)
    for g in nav.gnss:
        assert np.all(g["residual_sigma"][:3] >= GNSS_SIGMA) and g["nis_dof"] == 6


def test_the_gap_grows_the_covariance_by_its_model(one):
    """Across the gap's step the velocity variance grows by at least the bridged Q's (the rest is the IMU noise over
    the span, which the covariance propagation adds as on any step)."""
    _, _, rec, nav = one
    gap = nav.plan.gaps[0]
    est = nav.estimate()
    k = int(np.searchsorted(est["time"], gap.time + gap.seconds))  # the first epoch after the gap
    grow = est["P"][k, 3:6, 3:6].diagonal() - est["P"][k - 1, 3:6, 3:6].diagonal()
    assert np.all(grow >= gap.Q[3:6, 3:6].diagonal() * (1 - 1e-9))


def test_gap_noise_against_its_closed_form():
    """A log whose specific force is a straight line plus white noise of 1-sigma s: the spread is s (within the
    sampling error of ~100 samples), and Q is the constant-error model of the docstring."""
    rng = np.random.default_rng(3)
    dt, s, w = 0.01, 0.02, 3e-4
    t = np.concatenate([np.arange(0, 2.0, dt), np.arange(2.5, 4.5, dt)])
    nu = np.stack([0.1 * t, 0 * t, -9.81 + 0 * t], axis=1) + s * rng.standard_normal((t.size, 3))
    om = w * rng.standard_normal((t.size, 3))
    k = int(np.flatnonzero(np.diff(t) > 0.1)[0])
    sf, sw, Q = gap_noise(t, nu, om, k)
    T = t[k + 1] - t[k]
    assert sf == pytest.approx(s, rel=0.35) and sw == pytest.approx(w, rel=0.35)
    tilt = np.linalg.norm(0.5 * (nu[k] + nu[k + 1])) * sw * T * T / 2
    assert Q[3, 3] == pytest.approx(sf**2 * T**2 + tilt**2, rel=1e-12)
    assert Q[0, 3] == pytest.approx(sf**2 * T**3 / 2 + tilt * tilt * T / 3, rel=1e-12)
    assert Q[6, 6] == pytest.approx(sw**2 * T**2, rel=1e-12)
    assert np.all(np.linalg.eigvalsh(Q) >= -1e-18)


def test_a_gap_longer_than_the_limit_is_refused_naming_the_line(one, capsys):
    root, _, rec, _ = one
    with pytest.raises(InputDataError, match=r"imu\.csv:\d+:time_s: a gap of 0\.5\d* s after t = 7\.\d+ s "
                                             r"\(line \d+; recording time\) is longer than the navigator bridges"):
        plan_flight(rec, max_gap=0.3)
    code = main(["navigate", str(root / "rec"), "--out", str(root / "refused"), "--set", "ins.max_gap_s=0.3"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "ins.max_gap_s = 0.3 s" in err[0]


def test_an_orthoimage_recording_navigates_consistently(tmp_path):
    """Reference (b) written by other software (a GeoTIFF tile per aperture, rasterio): every aperture fused or
    screened (none skipped), NIS per dof inside its one-run band, the final position inside 3 sigma."""
    rec = read_recording(ForeignFlight(11, duration=8, reference="orthoimage").write(tmp_path / "rec"))
    nav = navigate(rec, read_navigate_settings(rec))
    est = nav.estimate()
    errors = truth_errors(rec, est, nav.layout)
    assert rec.manifest.reference.kind == "orthoimage"
    assert all(p["code"] >= 0 for p in nav.pairs) and sum(p["code"] == 0 for p in nav.pairs) >= 6
    st = nis_statistics(np.array([[u["nis"] for u in nav.updates]]), np.array([[u["nis_dof"] for u in nav.updates]]))
    assert st["per_dof_band"][0] <= st["per_dof"] <= st["per_dof_band"][1]
    assert np.all(np.abs(errors["error"][-1, 0:3]) <= 3 * est["sigma"][-1, 0:3])


def test_one_foreign_recording_is_consistent(one):
    """One recording (seed 7): NIS per dof of its SAR/altimeter and GNSS updates inside the one-run 95 % bands, the
    final position inside 3 sigma on each axis."""
    _, _, rec, nav = one
    est = nav.estimate()
    errors = truth_errors(rec, est, nav.layout)
    nis = nis_statistics(np.array([[u["nis"] for u in nav.updates]]), np.array([[u["nis_dof"] for u in nav.updates]]))
    lo, hi = nis["per_dof_band"]
    assert lo <= nis["per_dof"] <= hi
    assert np.all(np.abs(errors["error"][-1, 0:3]) <= 3 * est["sigma"][-1, 0:3])


#: the error states this world realises: all but the SAR range and cross-range biases, which the navigator models
#: (sar.bias_*_3sigma) but the foreign radar does not have (truth.csv states them 0); NEES over the marginal
REALISED = [i for i in range(18) if i not in (16, 17)]


def _nees(est, err) -> np.ndarray:
    e = err["error"][:, REALISED]
    P = est["P"][:, REALISED][:, :, REALISED]
    return np.einsum("ki,ki->k", e, np.linalg.solve(P, e[..., None])[..., 0])


@pytest.fixture(scope="module", params=["cphd-pass", "orthoimage"])
def twenty(request, tmp_path_factory):
    """Issue 26's 20 recordings (seeds 100-119, 12 s each) with reference (a) or (b), navigated: NEES over the
    realised states, NIS and final errors of each."""
    root = tmp_path_factory.mktemp("twenty")
    out = {"nees": [], "nis": [], "dof": [], "gnis": [], "gdof": [], "outside": 0}
    for seed in range(100, 120):
        rec = read_recording(ForeignFlight(seed, duration=12, reference=request.param).write(root / str(seed)))
        nav = navigate(rec, read_navigate_settings(rec))
        est = nav.estimate()
        err = truth_errors(rec, est, nav.layout)
        out["nees"].append(_nees(est, err))
        out["nis"].append([u["nis"] for u in nav.updates])
        out["dof"].append([u["nis_dof"] for u in nav.updates])
        out["gnis"].append([g["nis"] for g in nav.gnss])
        out["gdof"].append([g["nis_dof"] for g in nav.gnss])
        out["outside"] += int(np.sum(np.abs(err["error"][-1, 0:3]) > 3 * est["sigma"][-1, 0:3]))
    return out


@pytest.mark.slow
def test_twenty_foreign_recordings_are_consistent(twenty):
    """Issue 26 over 20 recordings, each reference kind: the mean NEES (the 16 realised states) inside its 95 % band,
    the pooled NIS per dof of the SAR/altimeter updates and of the GNSS updates inside theirs, final position errors
    inside 3 sigma (all but at most 1 of the 60 axis values: 0.16 expected outside for a consistent filter).
    Measured (2026-12-04, band [13.62, 18.57] for NEES, [0.90, 1.11] SAR NIS/dof, [0.89, 1.12] GNSS NIS/dof):
    cphd-pass NEES 13.74, SAR NIS/dof 1.003, GNSS 1.087, 0 of 60 outside 3 sigma; orthoimage NEES 14.37, 1.006,
    1.084, 0 of 60."""
    n = min(len(x) for x in twenty["nees"])  # epochs differ by a step where a sample sits on an epoch's edge
    ne = nees_statistics(np.array([x[:n] for x in twenty["nees"]]), len(REALISED))
    print(f"NEES {ne['time_average']:.2f} in {ne['band']}, final errors outside 3 sigma: {twenty['outside']}")
    lo, hi = ne["band"]
    assert lo <= ne["time_average"] <= hi, ne
    for nis, dof in ((twenty["nis"], twenty["dof"]), (twenty["gnis"], twenty["gdof"])):
        st = nis_statistics(np.array(nis), np.array(dof))
        print(f"NIS per dof {st['per_dof']:.3f} in {st['per_dof_band']}")
        assert st["per_dof_band"][0] <= st["per_dof"] <= st["per_dof_band"][1], st
    assert twenty["outside"] <= 1

def test_a_wrong_radar_clock_offset_skips_the_apertures_and_flies_on(one, tmp_path):
    """A radar clock offset misstated by half a second puts every aperture across two navigation intervals: each is
    skipped and recorded with its reason, the flight goes on with the INS, the altimeter and GNSS (never an abort)."""
    import shutil
    root, _, _, _ = one
    folder = tmp_path / "rec"
    shutil.copytree(root / "rec", folder)
    text = (folder / "flight.toml").read_text()
    (folder / "flight.toml").write_text(text.replace("radar_clock_offset_s = 0.25", "radar_clock_offset_s = 0.75"))
    code = main(["navigate", str(folder), "--out", str(tmp_path / "out"), "--quiet", "--no-report"])
    assert code == 0
    rows = (tmp_path / "out" / "updates.csv").read_text().splitlines()[1:]
    assert len(rows) == 10 and all("skipped: its pulses [" in r and "not inside one navigation interval" in r
                                   for r in rows)
