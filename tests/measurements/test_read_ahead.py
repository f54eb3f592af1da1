"""Reading the next aperture on a second thread (``measurements.read_ahead``) changes no number of ``navigate``, hands a
failed read to the aperture it belongs to, and drops a read-ahead of an aperture that is not asked for next."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.measurements import sar_image
from sarnav.measurements.read_ahead import ReadAhead
from sarnav.montecarlo.seeding import run_seeds
from sarnav.recording import read_recording
from sarnav.recording.apertures import RecordedApertures
from sarnav.recording.navigate import navigate
from sarnav.scenarios import rda_nav as rn
from sarnav.scenarios.config import load_scenario
from sarnav.scenarios.navigate import read_navigate_settings
from sarnav.simulation.export import export_rda_nav
from sarnav.tomlio import dump_toml


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    folder = tmp_path_factory.mktemp("read-ahead") / "rec"
    cfg = load_scenario("rda-nav", ["trajectory.duration=3.0"], runs=2)
    seed = run_seeds(cfg["campaign"]["seed"], 2)[1]
    export_rda_nav(rn.parse(cfg), folder, seed, run=1, runs=2, campaign_seed=cfg["campaign"]["seed"],
                   scenario_name="rda-nav", scenario_text=dump_toml(cfg))
    return folder


def _arrays(nav) -> dict:
    out = {f"estimate_{k}": np.asarray(v) for k, v in nav.estimate().items()}
    for i, u in enumerate(nav.updates):
        out.update({f"update{i}_{k}": np.asarray(v) for k, v in u.items() if k != "seconds"})
    for i, p in enumerate(nav.pairs):
        out.update({f"pair{i}_{k}": np.asarray(v) for k, v in p.items() if not isinstance(v, str)})
    return out


def test_reading_ahead_changes_no_bit(recording, monkeypatch):
    started = []
    monkeypatch.setattr(sar_image, "ReadAhead", lambda prepare, u, r: started.append(u) or ReadAhead(prepare, u, r))
    rec = read_recording(recording)
    ahead = _arrays(navigate(rec, read_navigate_settings(rec)))
    assert started == [1, 2]  # apertures 1 and 2 were read while the navigator worked on 0 and 1
    monkeypatch.setattr(RecordedApertures, "read_ahead", False)
    rec = read_recording(recording)
    serial = _arrays(navigate(rec, read_navigate_settings(rec)))
    assert started == [1, 2]
    assert ahead.keys() == serial.keys() and len(serial) > 50
    for key in serial:
        assert np.array_equal(ahead[key], serial[key], equal_nan=True), key


def test_a_failed_read_ahead_raises_in_the_caller():
    def prepare(u, r):
        raise InputDataError(f"aperture{u}.cphd", "missing file")

    job = ReadAhead(prepare, 3, 0)
    with pytest.raises(InputDataError, match="aperture3.cphd"):
        job.take()
    assert ReadAhead(lambda u, r: (u, r, threading.current_thread().name), 4, 1).take() == (4, 1, "sarnav-read-ahead-4")


def test_a_read_ahead_of_another_aperture_is_dropped(recording):
    """The navigator asks for aperture 2 while aperture 1 is being read ahead (it skipped 1): the extractor waits for
    that read to end, drops it and prepares aperture 2 itself; a read-ahead of the aperture asked for is taken."""
    rec = read_recording(recording)
    imager = rec.imager(read_navigate_settings(rec).imaging)
    calls = []

    def prepare(u, r):
        time.sleep(0.05)
        calls.append((u, threading.current_thread().name))
        return u

    imager._prepare = prepare
    imager._ahead = {(1, 0): ReadAhead(imager._prepare, 1, 0)}
    assert imager._fetch(2, 0) == 2
    assert calls == [(1, "sarnav-read-ahead-1"), (2, threading.current_thread().name)] and not imager._ahead
    imager._ahead = {(3, 0): ReadAhead(imager._prepare, 3, 0), (4, 0): ReadAhead(imager._prepare, 4, 0)}
    assert imager._fetch(3, 0) == 3 and list(imager._ahead) == [(4, 0)]  # the one ahead of 3 is kept


def test_the_source_reads_two_apertures_at_once_and_keeps_each_its_own(recording):
    """Two read-ahead threads load different apertures of one recording at the same time: each gets its own pulses
    (the same arrays as a serial read), and the source keeps only the last few apertures."""
    rec = read_recording(recording)
    src = rec.source(1)
    serial = {u: src.flight(u, 0)[0].data.copy() for u in range(3)}
    src = rec.source(1)
    jobs = [ReadAhead(lambda u, r: src.flight(u, r)[0].data, u, 0) for u in (0, 1, 2)]
    for u, job in zip((0, 1, 2), jobs):
        assert np.array_equal(job.take(), serial[u])
    assert len(src._loaded) <= src.read_ahead + 2


def test_depth_two_starts_the_next_two_apertures(recording, monkeypatch):
    """At aperture 0 the extractor starts reading apertures 1 and 2 (``RecordedApertures.read_ahead`` = 2), none
    past the last aperture, and none at all when the source reads no aperture ahead."""
    rec = read_recording(recording)
    imager = rec.imager(read_navigate_settings(rec).imaging)
    started = []
    monkeypatch.setattr(sar_image, "ReadAhead", lambda prepare, u, r: started.append(u) or (u, r))
    imager._read_ahead_from(0)
    imager._read_ahead_from(1)
    assert started == [1, 2]
    monkeypatch.setattr(RecordedApertures, "read_ahead", 0)
    imager._ahead.clear()
    imager._read_ahead_from(0)
    assert started == [1, 2]
